"""The build's processes and files under signals and hostile output folders: no worker outlives
its build, Ctrl-C is one line, nothing is written through a link, nothing of the user's is deleted
(docs/build.md, "What happens when")."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from blendvoca.builder import build_dataset
from blendvoca.cli import EXIT_INTERRUPTED
from blendvoca.io.atomic import temporary_prefix
from tests.faults.conftest import assert_one_error_line, build_cli, outputs, tree

ROOT = Path(__file__).resolve().parents[2]
#: Enough sentences that the fit stage lasts a couple of seconds with 2 workers.
SIGNAL_CORPUS = dict(speakers=3, sentences=10, seed=1, duration=(2.0, 3.0))


@pytest.fixture(scope="module")
def signal_corpus(tmp_path_factory, assets_dir) -> Path:
    from blendvoca.synthetic import generate_corpus

    return generate_corpus(tmp_path_factory.mktemp("signals") / "S", layout="official",
                           **SIGNAL_CORPUS)


@pytest.fixture(scope="module")
def signal_build(tmp_path_factory, signal_corpus) -> Path:
    """The uninterrupted build of ``signal_corpus`` (2 workers)."""
    out = tmp_path_factory.mktemp("signals") / "B"
    assert build_dataset(out, signal_corpus, workers=2).ok
    return out


def _children(pid: int) -> set[int]:
    """Every descendant of ``pid`` (read from /proc)."""
    parents = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat", encoding="ascii", errors="replace") as f:
                    parents[int(entry)] = int(f.read().rpartition(")")[2].split()[1])
            except (OSError, IndexError, ValueError):
                continue
    found, frontier = set(), {pid}
    while frontier:
        frontier = {child for child, parent in parents.items() if parent in frontier} - found
        found |= frontier
    return found


def _alive(pid: int) -> bool:
    """True for a running process (a zombie waiting for its parent to reap it is dead)."""
    try:
        with open(f"/proc/{pid}/stat", encoding="ascii", errors="replace") as f:
            return f.read().rpartition(")")[2].split()[0] != "Z"
    except (OSError, IndexError):
        return False


def _sigint_as_in_a_terminal() -> None:
    """In a child before it runs: SIGINT's default action, as a command typed at a terminal has it
    (a test session started in the background, nohup or ``&``, would hand its children SIGINT ignored)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start_build(corpus, out, *extra, **popen) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen([sys.executable, "-m", "blendvoca.build", "--vocaset", str(corpus), "--out", str(out),
                             "--workers", "2", "--quiet", *extra], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=_sigint_as_in_a_terminal, **popen)


def _wait_for_fit_stage(process, out, timeout=300.0) -> set[int]:
    """Wait until the first sentence is fitted (the fit stage's pool is running); its workers' pids."""
    deadline = time.monotonic() + timeout
    records = out / ".buildstate" / "sentences"
    while time.monotonic() < deadline and process.poll() is None:
        if records.is_dir() and any(records.rglob("*.json")):
            workers = _children(process.pid)
            if workers:
                return workers
        time.sleep(0.01)
    raise AssertionError(f"the build ended (exit {process.poll()}) or never reached the fit stage")


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["KILL", "TERM"])
def test_killing_the_build_process_alone_ends_its_workers_and_the_rerun_starts(tmp_path, signal_corpus,
                                                                               signal_build, sig):
    out = tmp_path / "B"
    process = _start_build(signal_corpus, out)
    try:
        workers = _wait_for_fit_stage(process, out)
        os.kill(process.pid, sig)  # the main process only, as `timeout`, `docker stop` and systemd do
        process.wait(timeout=30)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and any(map(_alive, workers)):
            time.sleep(0.05)
        assert not any(map(_alive, workers)), f"workers still alive 10 s after the build died: {workers}"
    finally:
        if process.poll() is None:
            process.kill()
        for pid in _children(process.pid):
            os.kill(pid, signal.SIGKILL)
    assert not (out / "manifest.json").exists()
    import fcntl

    fd = os.open(out / ".buildstate" / "lock", os.O_RDWR)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # free at once: nothing of the dead build holds it
    finally:
        os.close(fd)
    clock = time.monotonic()
    summary = build_dataset(out, signal_corpus, workers=2)
    assert summary.ok and summary.skipped["speakers"] == 3 and summary.skipped["sentences"] >= 1
    assert time.monotonic() - clock < 60
    assert outputs(out) == outputs(signal_build)
    assert not [p for p in out.rglob("*.tmp")]  # the killed writes' temporaries are gone


def _interrupted_with_ctrl_c(process) -> str:
    """Send SIGINT to the process group (what the terminal does on Ctrl-C); the stderr, checked to be one line."""
    try:
        os.killpg(process.pid, signal.SIGINT)
        _, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
    assert process.returncode == EXIT_INTERRUPTED, err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("interrupted"), err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err
    return err


@pytest.mark.slow
def test_ctrl_c_during_the_fits_is_one_interrupted_line(tmp_path, signal_corpus):
    out = tmp_path / "B"
    process = _start_build(signal_corpus, out, start_new_session=True)
    _wait_for_fit_stage(process, out)
    _interrupted_with_ctrl_c(process)


@pytest.mark.parametrize("ignored", [False, True])
def test_build_workers_leave_ctrl_c_to_the_parent_unless_the_build_ignores_it(ignored):
    # a build started with SIGINT ignored (nohup, a background job) must not have its workers die of it
    script = ("import signal\n"
              "from blendvoca.runtime.lifetime import leave_interrupts_to_the_parent\n"
              f"signal.signal(signal.SIGINT, signal.SIG_IGN if {ignored} else signal.default_int_handler)\n"
              "leave_interrupts_to_the_parent()\n"
              "print(signal.getsignal(signal.SIGINT).name)\n")
    out = subprocess.run([sys.executable, "-c", script], env=dict(os.environ, PYTHONPATH=str(ROOT)),
                         capture_output=True, text=True, check=True).stdout.strip()
    assert out == ("SIG_IGN" if ignored else "SIG_DFL")


def test_a_worker_ends_when_its_parent_dies(tmp_path):
    """The lifetime guard on its own: a child of a SIGKILLed process exits within seconds."""
    script = (
        "import os, sys, time\n"
        "from blendvoca.runtime.lifetime import die_with_parent\n"
        "parent = os.getpid()\n"
        "child = os.fork()\n"
        "if child == 0:\n"
        "    die_with_parent(parent)\n"
        "    time.sleep(120)\n"
        "    os._exit(0)\n"
        "print(child, flush=True)\n"
        "time.sleep(120)\n"
    )
    process = subprocess.Popen([sys.executable, "-c", script], env=dict(os.environ, PYTHONPATH=str(ROOT)),
                               stdout=subprocess.PIPE, text=True)
    child = int(process.stdout.readline())
    try:
        assert _alive(child)
        process.kill()
        process.wait()
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and _alive(child):
            time.sleep(0.02)
        assert not _alive(child)
    finally:
        if _alive(child):
            os.kill(child, signal.SIGKILL)


# ----------------------------------------------------------------------------- links


@pytest.mark.parametrize("linked", ["audio", "blendshape_coeffs/Synth_000_TA", ".buildstate"])
def test_an_output_folder_replaced_by_a_link_is_refused_and_nothing_is_written_through_it(copies, tmp_path,
                                                                                          capsys, linked):
    corpus, out = copies
    elsewhere = tmp_path / "users_folder"
    shutil.copytree(out / linked, elsewhere)
    (elsewhere / "mine.txt").write_text("the user's")
    shutil.rmtree(out / linked)
    (out / linked).symlink_to(elsewhere, target_is_directory=True)
    before, outside = tree(out), tree(elsewhere)
    code, err = build_cli(capsys, "--vocaset", corpus, "--out", out, "--workers", 1, "--delta", 0.2)
    assert code == 2
    assert_one_error_line(err, str(out / linked), "symbolic link")
    assert tree(elsewhere) == outside and tree(out) == before


def test_an_output_file_replaced_by_a_link_is_refused(copies, tmp_path, capsys):
    corpus, out = copies
    users_file = tmp_path / "users.csv"
    users_file.write_text("the user's own data\n")
    target = out / "blendshape_coeffs" / "Synth_001_TA" / "sentence01.csv"
    target.unlink()
    target.symlink_to(users_file)
    code, err = build_cli(capsys, "--vocaset", corpus, "--out", out, "--workers", 1)
    assert code == 2
    assert_one_error_line(err, str(target), "symbolic link")
    assert users_file.read_text() == "the user's own data\n" and target.is_symlink()


# ----------------------------------------------------------------------------- temporaries


def test_only_the_builds_own_temporaries_of_dead_processes_are_removed(copies):
    corpus, out = copies
    folder = out / "blendshape_coeffs" / "Synth_000_TA"
    users = [folder / ".mine.x1.tmp", folder / ".sentence01.csv.abc.tmp", out / "audio" / ".notes.tmp",
             out / ".blendvoca-1-notes.txt.tmp"]  # our prefix, but a name the build never makes
    for path in users:
        path.write_text("the user's")
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True, check=True)
    killed = folder / f"{temporary_prefix('sentence01.csv', int(dead.stdout))}abcd1234.tmp"
    killed.write_text("a killed write")
    running = folder / f"{temporary_prefix('sentence02.csv', os.getppid())}abcd1234.tmp"
    running.write_text("a write of a process still running")
    summary = build_dataset(out, corpus, workers=1, delta=0.2)
    assert summary.ok
    assert all(path.read_text() == "the user's" for path in users)
    assert not killed.exists() and running.exists()


def test_atomic_writes_name_their_temporaries_with_the_prefix_and_the_pid(tmp_path):
    from blendvoca.io.atomic import atomic_write, temporary_owner

    with atomic_write(tmp_path / "sentence01.csv", "w") as f:
        (temporary,) = [p.name for p in tmp_path.iterdir()]
        f.write("x")
    assert temporary.startswith(f".blendvoca-{os.getpid()}-sentence01.csv.") and temporary.endswith(".tmp")
    assert temporary_owner(temporary) == os.getpid()
    assert temporary_owner(".mine.x1.tmp") is None and temporary_owner(".sentence01.csv.abc.tmp") is None
    assert [p.name for p in tmp_path.iterdir()] == ["sentence01.csv"]


def test_a_lock_held_by_what_a_dead_build_left_says_so(copies, capsys):
    """Processes of an older build that outlived it: the message says the named build is gone."""
    corpus, out = copies
    lock = out / ".buildstate" / "lock"
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True,
                          check=True).stdout.strip()
    holder = subprocess.Popen([sys.executable, "-c", (
        "import fcntl, os, sys, time; fd = os.open(sys.argv[1], os.O_RDWR); fcntl.flock(fd, fcntl.LOCK_EX); "
        "os.ftruncate(fd, 0); os.pwrite(fd, (sys.argv[2] + '\\n').encode(), 0); print('locked', flush=True); "
        "time.sleep(60)"), str(lock), dead], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        code, err = build_cli(capsys, "--vocaset", corpus, "--out", out, "--workers", 1)
    finally:
        holder.kill()
        holder.wait()
    assert code == 2
    assert_one_error_line(err, f"pid {dead}", "no longer running", "fuser -v")
