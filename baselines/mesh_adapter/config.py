"""The per-method YAML file that tells the mesh adapter where the vertex outputs are.

Example (``voca.yaml``)::

    name: VOCA                 # leaderboard label
    vertices: outputs/voca     # relative to this file; <subject>/<sentence>.npy or <subject>/<sentence>/*.ply|obj
    fps: 30                    # frame rate of the outputs (resampled to 60)
    template: absolute         # absolute positions, or "offsets" from the speaker's neutral
    delta: 0.1                 # rate bound of the QP per 60 fps frame
    vertex_subset: null        # null (all vertices), "flame-head" (the 4580-vertex crop) or a list of indices
    max_frame_mismatch: 6      # frames padded/cropped to match the ground-truth length
    reference: false           # true: a reference row (e.g. the corpus meshes), shown but never ranked
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass
from pathlib import Path

from blendvoca.errors import DataError, UserError

__all__ = ["TEMPLATE_MODES", "AdapterConfig", "adapter_config", "read_adapter_config"]

TEMPLATE_MODES = ("absolute", "offsets")
_KEYS = ("name", "vertices", "fps", "template", "delta", "vertex_subset", "max_frame_mismatch", "reference")


@dataclass(frozen=True)
class AdapterConfig:
    """Validated adapter settings (see the module docstring for the fields)."""

    name: str
    vertices: str
    fps: float = 60.0
    template: str = "absolute"
    delta: float | None = 0.1
    vertex_subset: str | list | None = None
    max_frame_mismatch: int = 6
    reference: bool = False

    def to_dict(self) -> dict:
        return asdict(self)


def adapter_config(mapping: dict, *, base_dir: str | os.PathLike | None = None,
                   where: str = "mesh-adapter config") -> AdapterConfig:
    """An :class:`AdapterConfig` from a plain mapping; ``vertices`` (text or ``os.PathLike``) is resolved
    against ``base_dir``.

    Raises
    ------
    UserError
        Unknown keys, missing ``vertices``, a non-positive fps, an unknown template mode.
    """
    if not isinstance(mapping, dict):
        raise TypeError(f"{where}: expected a mapping of settings, got {type(mapping).__name__}")
    unknown = sorted(set(mapping) - set(_KEYS))
    if unknown:
        raise UserError(f"{where}: unknown key(s) {unknown}; expected some of {list(_KEYS)}")
    if not mapping.get("vertices"):
        raise UserError(f"{where}: 'vertices' (folder of vertex outputs) is required")
    raw = mapping["vertices"]
    vertices = Path(os.fspath(raw) if isinstance(raw, os.PathLike) else str(raw)).expanduser()
    if base_dir is not None and not vertices.is_absolute():
        vertices = Path(os.fspath(base_dir)) / vertices
    fps = mapping.get("fps", 60.0)
    if isinstance(fps, bool) or not isinstance(fps, (int, float)) or fps <= 0:
        raise UserError(f"{where}: 'fps' must be a positive number (30 or 60), got {fps!r}")
    template = mapping.get("template", "absolute")
    if template not in TEMPLATE_MODES:
        raise UserError(f"{where}: 'template' must be one of {TEMPLATE_MODES}, got {template!r}")
    subset = mapping.get("vertex_subset")
    if subset is not None and subset != "flame-head" and not isinstance(subset, list):
        raise UserError(f"{where}: 'vertex_subset' must be null, 'flame-head' or a list of indices, got {subset!r}")
    delta = mapping.get("delta", 0.1)
    return AdapterConfig(
        name=str(mapping.get("name") or vertices.name),
        vertices=str(vertices.resolve()),
        fps=float(fps),
        template=template,
        delta=None if delta is None else float(delta),
        vertex_subset=subset,
        max_frame_mismatch=int(mapping.get("max_frame_mismatch", 6)),
        reference=bool(mapping.get("reference", False)),
    )


def read_adapter_config(path: str | os.PathLike) -> AdapterConfig:
    """Read a YAML adapter file (``vertices`` relative to the file's folder).

    Raises
    ------
    UserError
        No file at ``path``, or settings :func:`adapter_config` refuses.
    DataError
        The file is not YAML, or not a mapping.
    """
    import yaml

    path = Path(os.fspath(path))
    if not path.is_file():
        raise UserError(f"mesh-adapter config {path} does not exist")
    with path.open() as handle:
        try:
            mapping = yaml.safe_load(handle)
        except yaml.YAMLError as exc:
            raise DataError(f"mesh-adapter config {path}: not YAML: {exc}") from exc
    if mapping is not None and not isinstance(mapping, dict):
        raise DataError(f"mesh-adapter config {path}: expected a mapping of settings, got {type(mapping).__name__}")
    return adapter_config(mapping or {}, base_dir=path.parent, where=str(path))
