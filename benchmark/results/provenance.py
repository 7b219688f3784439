"""What a result records of the code and the machine a run ran on (its ``provenance``)."""

from __future__ import annotations

import datetime as _dt
import importlib.metadata
import os
import platform
import subprocess
from pathlib import Path

from blendvoca.runtime.version import blendvoca_version
from blendvoca.format import blas_kernels

__all__ = ["OUTPUT_FOLDERS", "VERSIONED_PACKAGES", "cpu_info", "current_provenance", "git_revision", "hardware_info",
           "package_versions"]

#: Distributions whose versions are recorded when installed.
VERSIONED_PACKAGES = (
    "blendvoca", "numpy", "scipy", "torch", "transformers", "scikit-learn", "trimesh", "libigl",
    "piqp", "clarabel", "osqp", "qpsolvers", "soundfile", "soxr", "pot",
)


def package_versions(packages=VERSIONED_PACKAGES) -> dict:
    """``{distribution: version}`` for those of ``packages`` that are installed."""
    versions = {}
    for name in packages:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            continue
    if "blendvoca" not in versions:  # running from a source checkout
        versions["blendvoca"] = blendvoca_version() + "+source"
    return dict(sorted(versions.items()))


#: Folders of the checkout that hold outputs (the committed results, their archive and the
#: tables), not code: changes there do not make a run's code dirty (rows of one reproduce
#: run are written in turn, after ``--archive`` moved the old ones).
OUTPUT_FOLDERS = ("leaderboard/results", "leaderboard/results-archive", "leaderboard/tables")


def git_revision(directory=None) -> dict:
    """``{"revision": sha or None, "dirty": bool or None}`` of the git checkout at ``directory``;
    ``dirty``: uncommitted changes outside :data:`OUTPUT_FOLDERS`."""
    directory = Path(directory) if directory is not None else Path(__file__).resolve().parent
    try:
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=directory, capture_output=True, text=True,
                             timeout=10, check=False)
        if sha.returncode != 0:
            return {"revision": None, "dirty": None}
        outputs = [f":(top,exclude){folder}" for folder in OUTPUT_FOLDERS]
        status = subprocess.run(["git", "status", "--porcelain", "--", ":/", *outputs], cwd=directory,
                                capture_output=True, text=True, timeout=30, check=False)
        return {"revision": sha.stdout.strip(), "dirty": bool(status.stdout.strip())}
    except (OSError, subprocess.SubprocessError):
        return {"revision": None, "dirty": None}


def cpu_info(field: str) -> str | None:
    """A field of the first CPU in /proc/cpuinfo (``"model name"``, ``"vendor_id"``); None
    where the system has no such file or the CPU no such field."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.split(":", 1)[0].strip() == field:
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return None


def _cpu_name() -> str:
    return cpu_info("model name") or platform.processor() or platform.machine()


def hardware_info() -> dict:
    """CPU model, usable cores, the BLAS kernels in use, and the GPU when torch sees one."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:
        cores = os.cpu_count()
    info = {"cpu": _cpu_name(), "cores": cores, "blas": blas_kernels(), "gpu": None}
    try:
        import torch

        if torch.cuda.is_available():
            info["gpu"] = torch.cuda.get_device_name(0)
        info["torch_threads"] = torch.get_num_threads()
    except ImportError:
        pass
    return info


def current_provenance() -> dict:
    """The date, git revision and state, Python, platform, package versions and hardware now
    (a run takes it when it starts: the code that runs is the code of that moment)."""
    git = git_revision()
    return {
        "date": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "git_revision": git["revision"],
        "git_dirty": git["dirty"],
        "python": platform.python_version(),
        "platform": platform.platform(),
        "versions": package_versions(),
        "hardware": hardware_info(),
    }

