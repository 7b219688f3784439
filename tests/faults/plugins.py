"""Misbehaving method plug-ins of the issue-56 fault tests, imported by
``--method tests.faults.plugins:Name``. Each generates what the ``mean`` reference would
(a constant mid-range track) and does one more thing to the process or the disk; what
it touches is named by an environment variable the test sets."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from benchmark.methods import Method

TARGET = "BLENDVOCA_TEST_TARGET"


class _Quiet(Method):
    reference = True

    def generate(self, utterance, *, samples=1, seed=0):
        self.act()
        return np.full((1, utterance.num_frames, 32), 0.2)

    def act(self) -> None:
        pass


class RewritesTestCsv(_Quiet):
    """Rewrites a ground-truth CSV of the build (0.5 from its row 5 on) and adds a file beside it."""

    name = "rewrites-test-csv"

    def act(self):
        path = Path(os.environ[TARGET])
        if path.with_suffix(".added").exists():
            return
        lines = path.read_text().splitlines()
        for i in range(6, len(lines)):
            lines[i] = ",".join("0.5" for _ in lines[i].split(","))
        path.write_text("\n".join(lines) + "\n")
        path.with_suffix(".added").write_text("x")


class SetsThreads(_Quiet):
    """Sets torch's intra-op threads to 1 (the evaluation's count must not change)."""

    name = "sets-threads"

    def act(self):
        import torch

        torch.set_num_threads(1)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_IGN)


class IgnoresAlarm(_Quiet):
    """Sets SIGALRM to SIG_IGN, then sleeps far past any limit."""

    name = "ignores-alarm"

    def act(self):
        signal.signal(signal.SIGALRM, signal.SIG_IGN)
        time.sleep(float(os.environ.get(TARGET, "60")))


class DeletesResults(_Quiet):
    """Deletes every file under the folder named by the target (the run's --results)."""

    name = "deletes-results"

    def act(self):
        for path in Path(os.environ[TARGET]).rglob("*"):
            if path.is_file():
                path.unlink()


class SpawnsChildren(_Quiet):
    """Starts two sleeping children (one in a new session) and returns without waiting."""

    name = "spawns-children"
    started: list = []

    def act(self):
        if not SpawnsChildren.started:
            for new_session in (True, False):
                SpawnsChildren.started.append(subprocess.Popen(
                    [sys.executable, "-c", "import time; time.sleep(300)"], start_new_session=new_session))


class Motionless(_Quiet):
    """A constant track (the same value every frame): the face never moves (a ranked method, not a reference)."""

    name = "motionless"
    reference = False


class RaisesMemoryError(_Quiet):
    """Runs out of memory in generate."""

    name = "raises-memory-error"

    def act(self):
        raise MemoryError("Unable to allocate 9.3 TiB for an array with shape (1, 10**12)")


class WaitsOnChild(_Quiet):
    """Waits on a child that sleeps for a minute."""

    name = "waits-on-child"

    def act(self):
        subprocess.run([sys.executable, "-c", "import time; time.sleep(60)"], check=False)
