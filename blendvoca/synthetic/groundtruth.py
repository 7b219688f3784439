"""Deterministic ``.npz`` files for the ground-truth sidecar.

``numpy.savez`` stamps each zip member with the current time, so two
generations of the same corpus would differ byte for byte; this writer fixes
the timestamps.
"""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np

from blendvoca.io.atomic import atomic_write

_EPOCH = (1980, 1, 1, 0, 0, 0)


def write_npz(path, arrays: dict[str, np.ndarray]) -> None:
    """Write ``arrays`` as an uncompressed ``.npz`` readable by ``numpy.load``, byte-reproducibly."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression=zipfile.ZIP_STORED) as zf:
        for name in sorted(arrays):
            member = io.BytesIO()
            np.lib.format.write_array(member, np.asanyarray(arrays[name]), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=_EPOCH)
            info.external_attr = 0o644 << 16
            zf.writestr(info, member.getvalue())
    with atomic_write(Path(path), "wb") as f:
        f.write(buffer.getvalue())


def read_npz(path) -> dict[str, np.ndarray]:
    """All arrays of an ``.npz`` file as a dict."""
    with np.load(path, allow_pickle=False) as data:
        return {k: data[k] for k in data.files}
