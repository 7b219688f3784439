"""Streaming fit: one frame in, one coefficient vector out, as Audio2Face-3D's blendshape solver does.

:class:`StreamingSolver` keeps the rig's products (the shape basis on the fitted
vertices, its Gram matrix, the regularised system of :class:`StreamingSolverConfig`)
and solves each frame as it arrives, from that frame and its own previous answer
only: causal, with no look-ahead.  Per frame it solves ::

    minimise   1/2 ||B u - (p_t - n)||^2 + 1/2 u^T R u - w_T u_{t-1} . u
    subject to 0 <= u <= 1   (and, optionally, |u - u_{t-1}| <= rate_bound)

where ``R = w_1 11^T + (w_2 + w_T) I + w_S S^T S`` collects the terms of NVIDIA's
Audio2Face-3D SDK (``blendshape_solver_base.cpp``, ``Prepare``): squared L1 (the
sum of the coefficients, squared), L2, the previous-frame term and symmetry
(``S`` has a row ``e_left - e_right`` per left/right pair).  Each strength is
scaled as in the SDK by its constant and by ``(bbox diagonal of the neutral /
template_bb_size)^2``, so the regularisation is a fixed fraction of the squared
head size whatever the units.  Then, as in the SDK: paired shapes that cancel
(``cancel_pairs``) get a second solve with the weaker of each pair held at 0,
masked shapes are left out (output 0), and every output is ``u * multiplier +
offset``.

``objective="a2f"`` solves the SDK's own problem instead: it hands its regularised
normal matrix ``M`` and right-hand side ``c`` to a bounded-variable least squares,
``min ||M u - c||^2`` over the box, whose unconstrained optimum is the same but whose
bounded one is not; and its previous-frame term scales the right-hand side by
``scaleFactor`` but the matrix by ``100 scaleFactor``.  See ``docs/streaming.md``.

Each frame's box QP is solved exactly by :func:`blendvoca.fit.box_qp.solve_box_qp`,
warm-started from the previous frame's active bounds (``backend="active-set"``),
or by the banded solver of the offline fit frame by frame
(:func:`blendvoca.fit.framewise_coefficients`, ``backend="framewise"``), which is
also the fallback should the active set ever fail to certify its answer.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from blendvoca.assets import load_index_list
from blendvoca.errors import DataError, UserError
from blendvoca.io.arrays import float_array
from blendvoca.io.json_file import read_json
from blendvoca.names import BLENDVOCA_NAMES, arkit_name, mirror_pairs
from blendvoca.runtime.threads import one_blas_thread

from ._checks import as_float_array, vertex_indices
from .banded_qp import solve_banded_qp
from .box_qp import solve_box_qp
from .framewise import framewise_coefficients
from .normal_equations import check_rig
from .pose import FLAME_NUM_VERTICES

__all__ = [
    "A2F_DEFAULTS",
    "BACKENDS",
    "OBJECTIVES",
    "StreamingSolver",
    "StreamingSolverConfig",
    "default_cancel_pairs",
    "default_symmetry_pairs",
]

#: The SDK's defaults (``audio2face/blendshape_solver.h``: kDefaultL1Reg, kDefaultL2Reg,
#: kDefaultSymmetryReg, kDefaultTemporalReg, kDefaultTemplateBBSize).
A2F_DEFAULTS = {"l1": 1.0, "l2": 3.5, "symmetry": 100.0, "temporal": 0.0, "template_bb_size": 54.7}

#: The SDK's fixed scale of each strength (``blendshape_solver_base.cpp``, ``Prepare``):
#: L1RegScale, L2RegScale, TemporalRegScale, SymmetryRegScale (times scaleFactor).
L1_SCALE = 0.25
L2_SCALE = 10.0
TEMPORAL_SCALE = 100.0
SYMMETRY_SCALE = 10.0

#: ``objective``: "mesh" (the regularised fit of the mesh, default) or "a2f" (the SDK's
#: bounded least squares on its normal system).
OBJECTIVES = ("mesh", "a2f")
#: ``backend``: the warm-started active set, or the offline fit's banded solver per frame.
BACKENDS = ("active-set", "framewise")

#: The fields of the SDK's solver configuration file (``parse_helper.cpp``,
#: ``BlendshapeSolverConfigOwner::Init``): under "blendshape_params".
A2F_SECTION = "blendshape_params"
_A2F_STRENGTHS = (
    ("l1", "strengthL1regularization"),
    ("l2", "strengthL2regularization"),
    ("temporal", "strengthTemporalSmoothing"),
    ("symmetry", "strengthSymmetry"),
)
_A2F_ARRAYS = ("bsSolveActivePoses", "bsSolveCancelPoses", "bsSolveSymmetryPoses",
               "bsWeightMultipliers", "bsWeightOffsets")

#: Left/right pairs that move the jaw or the mouth sideways: opposite motions, so a
#: pair that cancels rather than a pair kept symmetric.
_SIDEWAYS = ("jaw", "mouth")


def _side_base(pair) -> str:
    return pair[0][: -len("Left")]


def default_symmetry_pairs(names: Sequence[str]) -> tuple[tuple[str, str], ...]:
    """Left/right mirror pairs among ``names`` (``blendvoca.names.mirror_pairs``), less
    the sideways jaw and mouth pairs: e.g. (mouthSmileLeft, mouthSmileRight)."""
    return tuple(p for p in mirror_pairs(names) if _side_base(p) not in _SIDEWAYS)


def default_cancel_pairs(names: Sequence[str]) -> tuple[tuple[str, str], ...]:
    """The sideways pairs among ``names``: (jawLeft, jawRight) and (mouthLeft, mouthRight)."""
    return tuple(p for p in mirror_pairs(names) if _side_base(p) in _SIDEWAYS)


def _is_number(value) -> bool:
    """A finite real number (a bool is none)."""
    return not isinstance(value, bool) and isinstance(value, numbers.Real) and math.isfinite(float(value))


def _is_count(value) -> bool:
    """An integer >= 0 (a bool is none)."""
    return not isinstance(value, bool) and isinstance(value, numbers.Integral) and int(value) >= 0


def _is_key(value) -> bool:
    return isinstance(value, str) or _is_count(value)


def _strength(value, name: str, where: str, *, positive: bool = False) -> float:
    if not _is_number(value):
        raise UserError(f"{where}: {name} must be a finite number, got {value!r}")
    value = float(value)
    if value < 0.0 or (positive and value == 0.0):
        raise UserError(f"{where}: {name} must be {'> 0' if positive else '>= 0'}, got {value}")
    return value


def _pairs(value, name: str, where: str):
    if value is None:
        return None
    try:
        if isinstance(value, str) or any(isinstance(p, str) for p in value):
            raise TypeError("a string")
        pairs = tuple(tuple(p) for p in value)
    except TypeError:
        raise UserError(f"{where}: {name} must be a list of (shape, shape) pairs, got {value!r}") from None
    for pair in pairs:
        if len(pair) != 2 or not all(_is_key(k) for k in pair) or pair[0] == pair[1]:
            raise UserError(f"{where}: {name} must hold pairs of two different shapes (names, or indices "
                            f">= 0), got {pair!r}")
    return tuple((p[0] if isinstance(p[0], str) else int(p[0]), p[1] if isinstance(p[1], str) else int(p[1]))
                 for p in pairs)


def _per_shape(value, name: str, where: str) -> dict:
    if not isinstance(value, Mapping):
        raise UserError(f"{where}: {name} must map shapes (names or indices) to numbers, got "
                        f"{type(value).__name__}")
    out = {}
    for key, number in value.items():
        if not _is_key(key):
            raise UserError(f"{where}: {name} keys must be shape names or indices >= 0, got {key!r}")
        if not _is_number(number):
            raise UserError(f"{where}: {name}[{key!r}] must be a finite number, got {number!r}")
        out[key if isinstance(key, str) else int(key)] = float(number)
    return out


@dataclass(frozen=True)
class StreamingSolverConfig:
    """Settings of :class:`StreamingSolver`; the defaults are the Audio2Face-3D SDK's.

    Shapes are named (``"mouthSmileLeft"``) or given by their index in the rig's shape
    order; a configuration read from an SDK file without ``names`` uses indices.

    Attributes
    ----------
    l1, l2, symmetry, temporal : float
        The SDK's ``strengthL1regularization`` (1.0), ``strengthL2regularization``
        (3.5), ``strengthSymmetry`` (100) and ``strengthTemporalSmoothing`` (0: off).
    template_bb_size : float
        ``templateBBSize`` (54.7): the bounding-box diagonal at which the strengths
        apply unscaled; each is multiplied by ``(neutral's bbox diagonal / this)^2``.
    symmetry_pairs : sequence of (shape, shape), optional
        Pairs kept equal by the symmetry term; None (default): the left/right pairs of
        the rig's names (:func:`default_symmetry_pairs`), () for none.
    cancel_pairs : sequence of (shape, shape), optional
        Pairs that cancel each other: after the first solve the weaker of each pair is
        held at 0 and the frame solved again. None (default): jawLeft/jawRight and
        mouthLeft/mouthRight where present (:func:`default_cancel_pairs`), () for none.
    inactive : sequence of shapes
        Shapes left out of the solve (the SDK's ``bsSolveActivePoses`` 0): output 0
        (then times its multiplier, plus its offset).
    multipliers, offsets : mapping shape -> float
        Output ``u_k * multipliers[k] + offsets[k]`` (defaults 1 and 0); applied after
        the solve, so they can take the output out of [0, 1], as in the SDK. The
        previous-frame terms use the solved ``u``.
    objective : {"mesh", "a2f"}
        "mesh" (default): the regularised least squares of the mesh above. "a2f": the
        SDK's bounded least squares on its normal system, with its temporal scaling.
    rate_bound : float, optional
        Also bound ``|u_t - u_{t-1}|`` per frame (the offline fit's 0.1 at 60 fps);
        None (default, as the SDK): no such bound.
    backend : {"active-set", "framewise"}
        Per-frame solver (module docstring); both give the same optimum.
    pose_names : tuple of str, optional
        Set by :meth:`from_a2f` with ``names``: the SDK pose order the file's arrays
        follow. Entries for shapes of that list that the rig lacks are then ignored.
    num_poses : int, optional
        Set by :meth:`from_a2f`: the file's ``numPoses``. Without ``pose_names`` the
        rig must have that many shapes (the file's arrays are in the rig's order).
    """

    l1: float = A2F_DEFAULTS["l1"]
    l2: float = A2F_DEFAULTS["l2"]
    symmetry: float = A2F_DEFAULTS["symmetry"]
    temporal: float = A2F_DEFAULTS["temporal"]
    template_bb_size: float = A2F_DEFAULTS["template_bb_size"]
    symmetry_pairs: tuple | None = None
    cancel_pairs: tuple | None = None
    inactive: tuple = ()
    multipliers: Mapping = field(default_factory=dict)
    offsets: Mapping = field(default_factory=dict)
    objective: str = "mesh"
    rate_bound: float | None = None
    backend: str = "active-set"
    pose_names: tuple | None = None
    num_poses: int | None = None

    def __post_init__(self):
        where = "StreamingSolverConfig"
        put = object.__setattr__
        for name in ("l1", "l2", "symmetry", "temporal"):
            put(self, name, _strength(getattr(self, name), name, where))
        put(self, "template_bb_size", _strength(self.template_bb_size, "template_bb_size", where, positive=True))
        put(self, "symmetry_pairs", _pairs(self.symmetry_pairs, "symmetry_pairs", where))
        put(self, "cancel_pairs", _pairs(self.cancel_pairs, "cancel_pairs", where))
        inactive = (self.inactive,) if _is_key(self.inactive) else self.inactive
        inactive = tuple(inactive) if isinstance(inactive, Iterable) else None
        if inactive is None or not all(_is_key(k) for k in inactive):
            raise UserError(f"{where}: inactive must list shape names or indices >= 0, got {self.inactive!r}")
        put(self, "inactive", tuple(k if isinstance(k, str) else int(k) for k in inactive))
        put(self, "multipliers", _per_shape(self.multipliers, "multipliers", where))
        put(self, "offsets", _per_shape(self.offsets, "offsets", where))
        if self.objective not in OBJECTIVES:
            raise UserError(f"{where}: objective must be one of {OBJECTIVES}, got {self.objective!r}")
        if self.backend not in BACKENDS:
            raise UserError(f"{where}: backend must be one of {BACKENDS}, got {self.backend!r}")
        if self.rate_bound is not None:
            if not (_is_number(self.rate_bound) and self.rate_bound > 0):
                raise UserError(f"{where}: rate_bound must be a number > 0 (or None: no rate bound), "
                                f"got {self.rate_bound!r}")
            put(self, "rate_bound", float(self.rate_bound))
        if self.pose_names is not None:
            put(self, "pose_names", tuple(str(n) for n in self.pose_names))
        if self.num_poses is not None and not (_is_count(self.num_poses) and self.num_poses >= 1):
            raise UserError(f"{where}: num_poses must be a positive integer, got {self.num_poses!r}")

    @classmethod
    def bounded_least_squares(cls, **overrides) -> StreamingSolverConfig:
        """No regulariser, no previous-frame term, no cancel pairs: each frame is the plain
        bounded least-squares fit of its mesh (``overrides`` set any other field)."""
        settings = dict(l1=0.0, l2=0.0, symmetry=0.0, temporal=0.0, symmetry_pairs=(), cancel_pairs=())
        settings.update(overrides)
        return cls(**settings)

    @classmethod
    def from_a2f(cls, source, *, names: Sequence[str] | None = None, **overrides) -> StreamingSolverConfig:
        """Read an Audio2Face-3D blendshape solver configuration (e.g. ``bs_skin_config.json``).

        The layout is the SDK's (``parse_helper.cpp``, ``BlendshapeSolverConfigOwner::Init``):
        an object ``"blendshape_params"`` with ``strengthL1regularization``,
        ``strengthL2regularization``, ``strengthTemporalSmoothing``, ``strengthSymmetry``,
        ``templateBBSize`` (optional, 54.7), ``numPoses`` and five arrays of ``numPoses``
        entries: ``bsSolveActivePoses`` (0 leaves a pose out), ``bsSolveCancelPoses`` and
        ``bsSolveSymmetryPoses`` (equal ids >= 0 form a pair, -1 none), ``bsWeightMultipliers``
        and ``bsWeightOffsets``.  Other keys of the file are ignored.

        Parameters
        ----------
        source : str, os.PathLike or dict
            The JSON file, or its parsed content (with or without the outer object).
        names : sequence of str, optional
            The pose names in the order of the file's arrays (the SDK takes them from the
            blendshape ``.npz``'s ``poseNames``, less "neutral"): the arrays then apply by
            name (ARKit names in any case, ``JawOpen`` = ``jawOpen``), to the rig's shapes of
            those names. Without it, by index in the rig's order.
        **overrides
            Other fields of the configuration (e.g. ``rate_bound=0.1``).

        Raises
        ------
        DataError
            The file is not JSON or lacks a field or has a malformed one (naming both).
        UserError
            ``names`` has another length than ``numPoses``.
        """
        if isinstance(source, (str, os.PathLike)):
            where = os.fspath(source)
            data = read_json(source, what="an Audio2Face-3D blendshape solver configuration (JSON)")
        elif isinstance(source, Mapping):
            where, data = "StreamingSolverConfig.from_a2f", source
        else:
            raise UserError(f"StreamingSolverConfig.from_a2f: expected a path or a dict, got {type(source).__name__}")
        if isinstance(data, Mapping) and A2F_SECTION in data:
            data = data[A2F_SECTION]
        if not isinstance(data, Mapping) or "numPoses" not in data:
            got = sorted(data)[:8] if isinstance(data, Mapping) else type(data).__name__
            raise DataError(f"{where}: expected an object {A2F_SECTION!r} holding numPoses, "
                            f"strengthL1regularization, ... (the SDK's blendshape solver configuration), got {got}")

        def number(key, default=None):
            if key not in data:
                if default is not None:
                    return default
                raise DataError(f"{where}: {A2F_SECTION}.{key} is missing")
            value = data[key]
            if not _is_number(value):
                raise DataError(f"{where}: {A2F_SECTION}.{key}: expected a number, got {value!r}")
            return float(value)

        num_poses = data["numPoses"]
        if not (_is_count(num_poses) and num_poses >= 1):
            raise DataError(f"{where}: {A2F_SECTION}.numPoses: expected a positive integer, got {num_poses!r}")
        arrays = {}
        for key in _A2F_ARRAYS:
            if key not in data:
                raise DataError(f"{where}: {A2F_SECTION}.{key} is missing")
            value = data[key]
            integer = not key.startswith("bsWeight")
            ok = isinstance(value, list) and all(
                (not isinstance(v, bool) and isinstance(v, numbers.Integral)) if integer else _is_number(v)
                for v in value)
            if not ok or len(value) != num_poses:
                kind = "integers" if integer else "numbers"
                got = f"{len(value)} entries" if isinstance(value, list) else type(value).__name__
                raise DataError(f"{where}: {A2F_SECTION}.{key}: expected a list of numPoses={num_poses} {kind}, "
                                f"got {got if ok or not isinstance(value, list) else value[:8]}")
            arrays[key] = value
        if names is not None:
            # ARKit names in any case (the SDK's files spell them its own way): camelCase.
            names = tuple(arkit_name(n) or str(n) for n in names)
            if len(names) != num_poses:
                raise UserError(f"{where}: names: expected numPoses={num_poses} pose names (the SDK's pose order), "
                                f"got {len(names)}")
            repeated = sorted({n for n in names if names.count(n) > 1})
            if repeated:
                raise UserError(f"{where}: names: each pose named once (the SDK's pose order), got "
                                + ", ".join(f"{n!r} {names.count(n)} times" for n in repeated))
            keys = names
        else:
            keys = tuple(range(num_poses))

        def pairs(key):
            groups = {}
            for index, group in enumerate(arrays[key]):
                if group != -1:
                    groups.setdefault(int(group), []).append(index)
            for group, members in groups.items():
                if len(members) != 2:
                    raise DataError(f"{where}: {A2F_SECTION}.{key}: id {group} marks {len(members)} poses "
                                    f"({members}); a pair is exactly 2 poses (-1 for none)")
            return tuple((keys[a], keys[b]) for a, b in sorted(groups.values()))

        settings = {name: number(key) for name, key in _A2F_STRENGTHS}
        settings["template_bb_size"] = number("templateBBSize", A2F_DEFAULTS["template_bb_size"])
        if settings["template_bb_size"] <= 0:
            raise DataError(f"{where}: {A2F_SECTION}.templateBBSize: expected a number > 0, "
                            f"got {settings['template_bb_size']}")
        for name, _ in _A2F_STRENGTHS:
            if settings[name] < 0:
                raise DataError(f"{where}: {A2F_SECTION}: strengths must be >= 0, got {name}={settings[name]}")
        settings.update(
            symmetry_pairs=pairs("bsSolveSymmetryPoses"),
            cancel_pairs=pairs("bsSolveCancelPoses"),
            inactive=tuple(keys[i] for i, on in enumerate(arrays["bsSolveActivePoses"]) if not on),
            multipliers=dict(zip(keys, map(float, arrays["bsWeightMultipliers"]))),
            offsets=dict(zip(keys, map(float, arrays["bsWeightOffsets"]))),
            pose_names=names,
            num_poses=int(num_poses),
        )
        settings.update(overrides)
        return cls(**settings)


def _resolve_subset(vertex_subset, num_vertices: int, where: str):
    """The fitted vertices: ``"auto"`` is the FLAME head crop on a 5023-vertex rig (as the
    offline fit of ``blendvoca.build``), else every vertex; None every vertex."""
    if isinstance(vertex_subset, str):
        if vertex_subset != "auto":
            raise UserError(f"{where}: vertex_subset must be 'auto', None or vertex indices, got {vertex_subset!r}")
        if num_vertices != FLAME_NUM_VERTICES:
            return None
        vertex_subset = load_index_list("flame-head-idx")
    if vertex_subset is None:
        return None
    subset = vertex_indices(vertex_subset, num_vertices, where).astype(np.int64)
    return None if subset.size == num_vertices and np.array_equal(subset, np.arange(num_vertices)) else subset


class StreamingSolver:
    """Fit blendshape coefficients one frame at a time (causal, warm-started).

    Parameters
    ----------
    neutral : (V, 3) array_like
        Rig neutral (full topology).
    deltas : (K, V, 3) array_like
        Blendshape offsets from the neutral.
    config : StreamingSolverConfig, optional
        Default: the Audio2Face-3D SDK's settings (:class:`StreamingSolverConfig`).
    names : sequence of K str, optional
        The shapes' names, for the name-keyed settings and the default pairs; default:
        BlendVOCA's 32 names when K = 32 (the column order of every BlendVOCA file),
        else none (then settings must use indices).
    vertex_subset : "auto", None or (S,) array_like of int
        Vertices fitted: "auto" (default) is the 4580-vertex FLAME head crop on a
        5023-vertex rig, as the offline fit of the build, and every vertex otherwise.

    Frames passed to :meth:`solve` are unposed (no head pose is removed) and either of
    the full topology ``(V, 3)`` or already cropped to the fitted vertices ``(S, 3)``,
    in ``vertex_subset`` order; the fit is the same.
    """

    def __init__(self, neutral, deltas, config: StreamingSolverConfig | None = None, *,
                 names: Sequence[str] | None = None, vertex_subset="auto"):
        where = "StreamingSolver"
        if config is None:
            config = StreamingSolverConfig()
        if not isinstance(config, StreamingSolverConfig):
            raise UserError(f"{where}: config must be a StreamingSolverConfig, got {type(config).__name__}")
        neutral, deltas = check_rig(neutral, deltas, where)
        num_shapes, num_vertices = deltas.shape[0], neutral.shape[0]
        if names is None and num_shapes == len(BLENDVOCA_NAMES):
            names = BLENDVOCA_NAMES
        if names is not None:
            names = tuple(str(n) for n in names)
            if len(names) != num_shapes or len(set(names)) != num_shapes:
                raise UserError(f"{where}: names must be {num_shapes} different shape names (one per blendshape), "
                                f"got {len(names)} ({len(set(names))} different)")
        self.config = config
        self.names = names
        self.num_shapes = num_shapes
        self.num_vertices = num_vertices
        self.vertex_subset = _resolve_subset(vertex_subset, num_vertices, where)
        subset = self.vertex_subset
        self.num_fitted = num_vertices if subset is None else subset.size

        # The SDK measures the whole neutral (not its vertex mask) for the scale.
        diagonal = float(np.linalg.norm(neutral.max(axis=0) - neutral.min(axis=0)))
        self.scale_factor = (diagonal / config.template_bb_size) ** 2

        crop = deltas if subset is None else np.take(deltas, subset, axis=1)
        basis = np.ascontiguousarray(crop.reshape(num_shapes, -1))  # (K, 3S)
        self._basis_crop = basis
        if subset is None:
            self._basis_full = basis
        else:
            full = np.zeros_like(deltas)
            full[:, subset] = crop
            self._basis_full = full.reshape(num_shapes, -1)  # zero off the crop: no gather per frame
        crop_neutral = neutral if subset is None else np.take(neutral, subset, axis=0)
        self._neutral_rhs = basis @ crop_neutral.reshape(-1)
        gram = basis @ basis.T
        self.gram = 0.5 * (gram + gram.T)

        self._setup(config)
        self.reset()

    @classmethod
    def from_rig(cls, rig, config: StreamingSolverConfig | None = None, *, vertex_subset="auto") -> StreamingSolver:
        """A solver for a :class:`blendvoca.rig.Rig` (its names and shape order)."""
        return cls(rig.neutral, rig.deltas, config, names=rig.names, vertex_subset=vertex_subset)

    # ----------------------------------------------------------------- set-up

    def _index(self, key, what: str, *, optional: bool) -> int | None:
        """Index of a shape key of the config in the rig's order (None: not in the rig, allowed)."""
        config = self.config
        if isinstance(key, str):
            if self.names is not None and key in self.names:
                return self.names.index(key)
            if optional and config.pose_names is not None and key in config.pose_names:
                return None  # an SDK pose this rig does not have
            have = f"the rig's shapes are {list(self.names)[:6]}..." if self.names else "the rig has no names (pass names=)"
            raise UserError(f"StreamingSolver: {what} names the shape {key!r}, which is not in the rig; {have}")
        if config.num_poses is not None and config.pose_names is None and config.num_poses != self.num_shapes:
            raise UserError(f"StreamingSolver: the Audio2Face-3D configuration describes numPoses="
                            f"{config.num_poses} poses by index, the rig has {self.num_shapes} shapes; pass the "
                            f"SDK's pose names to from_a2f(names=...) to map them by name")
        if key >= self.num_shapes:
            raise UserError(f"StreamingSolver: {what} has the shape index {key}, expected 0..{self.num_shapes - 1}")
        return int(key)

    def _pair_indices(self, pairs, what: str):
        out = []
        for a, b in pairs:
            i, j = self._index(a, what, optional=True), self._index(b, what, optional=True)
            if i is not None and j is not None:
                if i == j:
                    raise UserError(f"StreamingSolver: {what} pairs the shape {a!r} with itself")
                out.append((i, j))
        return tuple(out)

    def _setup(self, config: StreamingSolverConfig) -> None:
        k = self.num_shapes
        if config.pose_names is not None and self.names is not None and not set(config.pose_names) & set(self.names):
            raise UserError(f"StreamingSolver: none of the configuration's {len(config.pose_names)} pose names "
                            f"({list(config.pose_names)[:4]}...) is a shape of the rig ({list(self.names)[:4]}...): "
                            "its settings would apply to nothing; give the pose names of the file's arrays "
                            "(ARKit names in any case)")
        names = self.names or ()
        symmetry = config.symmetry_pairs if config.symmetry_pairs is not None else default_symmetry_pairs(names)
        cancel = config.cancel_pairs if config.cancel_pairs is not None else default_cancel_pairs(names)
        active = np.ones(k, dtype=bool)
        for key in config.inactive:
            index = self._index(key, "inactive", optional=True)
            if index is not None:
                active[index] = False
        if not active.any():
            raise UserError("StreamingSolver: every shape is inactive; at least one must be solved for")
        multipliers, offsets = np.ones(k), np.zeros(k)
        for target, values, what in ((multipliers, config.multipliers, "multipliers"),
                                     (offsets, config.offsets, "offsets")):
            for key, value in values.items():
                index = self._index(key, what, optional=True)
                if index is not None:
                    target[index] = value
        self.multipliers, self.offsets = multipliers, offsets
        self.active = active
        act = np.flatnonzero(active)
        self._act = None if active.all() else act
        position = {int(i): p for p, i in enumerate(act)}
        # As the SDK, pairs with an inactive member are dropped.
        sym = [(position[i], position[j]) for i, j in self._pair_indices(symmetry, "symmetry_pairs")
               if i in position and j in position]
        self._cancel = [(position[i], position[j]) for i, j in self._pair_indices(cancel, "cancel_pairs")
                        if i in position and j in position]
        self.symmetry_pairs = tuple((int(act[i]), int(act[j])) for i, j in sym)
        self.cancel_pairs = tuple((int(act[i]), int(act[j])) for i, j in self._cancel)

        s = self.scale_factor
        w_l1 = config.l1 ** 2 * L1_SCALE * s  # the SDK squares the L1 strength
        w_l2 = config.l2 * L2_SCALE * s
        w_temporal = config.temporal * TEMPORAL_SCALE * s
        w_symmetry = config.symmetry * SYMMETRY_SCALE * s
        n = act.size
        pair_rows = np.zeros((len(sym), n))
        for row, (i, j) in enumerate(sym):
            pair_rows[row, i], pair_rows[row, j] = 1.0, -1.0
        regulariser = (w_l1 * np.ones((n, n)) + (w_l2 + w_temporal) * np.eye(n)
                       + w_symmetry * pair_rows.T @ pair_rows)
        system = self.gram[np.ix_(act, act)] + regulariser  # the SDK's AMat
        self.system = system
        if config.objective == "mesh":
            self.hessian = system
            self._temporal_rhs = w_temporal
        else:
            self.hessian = system @ system
            self._temporal_rhs = config.temporal * s  # the SDK's right-hand side: scaleFactor, not 100x
        self._lower = np.zeros(n)
        self._upper = np.ones(n)

    # --------------------------------------------------------------- stream

    def reset(self, previous=None) -> None:
        """Start a new stream: no previous frame (the previous-frame term then pulls
        towards 0, as the SDK's ``Reset``; the rate bound starts at the next frame), or
        ``previous`` (K,) solved coefficients of the frame before the first one."""
        self._status = None
        self._previous = None
        #: Linear solves of the active set in the last frame; frames that fell back to the banded solver.
        self.iterations = 0
        self.fallbacks = 0
        if previous is not None:
            previous = as_float_array(previous, "previous", 1, "StreamingSolver.reset")
            if previous.shape != (self.num_shapes,):
                raise UserError(f"StreamingSolver.reset: previous must hold {self.num_shapes} coefficients, "
                                f"got shape {previous.shape}")
            self._previous = previous if self._act is None else previous[self._act]

    @property
    def previous(self) -> np.ndarray | None:
        """The last frame's solved coefficients (K,) before multipliers and offsets, or None."""
        if self._previous is None:
            return None
        out = np.zeros(self.num_shapes)
        out[self.active] = self._previous
        return out

    def _offsets_of(self, frame) -> np.ndarray:
        """``B^T (p - n)`` of one frame, full topology or crop."""
        where = "StreamingSolver.solve"
        if not isinstance(frame, np.ndarray) or frame.dtype != np.float64:
            frame = float_array(frame, where=where, name="frame", shape=f"({self.num_vertices}, 3)")
        if frame.ndim != 2 or frame.shape[1] != 3 or frame.shape[0] not in (self.num_vertices, self.num_fitted):
            crop = "" if self.num_fitted == self.num_vertices else f" or ({self.num_fitted}, 3) (its fitted crop)"
            raise UserError(f"{where}: expected a frame of ({self.num_vertices}, 3) (the rig's vertices){crop}, "
                            f"got shape {frame.shape}")
        flat = frame.reshape(-1)
        if not np.isfinite(flat).all():
            bad = int(np.flatnonzero(~np.isfinite(flat))[0]) // 3
            raise UserError(f"{where}: the frame holds a non-finite value at vertex {bad}")
        basis = self._basis_full if frame.shape[0] == self.num_vertices else self._basis_crop
        return basis @ flat - self._neutral_rhs

    def _box(self, linear, lower, upper, status):
        """One box QP: the active set (falling back to the banded solver), or the banded solver."""
        if self.config.backend == "active-set":
            solution = solve_box_qp(self.hessian, linear, lower, upper, status=status)
            self.iterations += solution.iterations
            if solution.certified:
                return solution.x, solution.status
            self.fallbacks += 1
        x = solve_banded_qp(self.hessian, linear[None], lower=lower[None], upper=upper[None], rate_bound=None).coeffs[0]
        return x, _status_of(x, lower, upper)

    def solve(self, frame) -> np.ndarray:
        """Coefficients (K,) of one frame (``(V, 3)`` or the fitted crop ``(S, 3)``, unposed)."""
        rhs = self._offsets_of(frame)
        self.iterations = 0
        if self._act is not None:
            rhs = rhs[self._act]
        config = self.config
        previous = self._previous
        if previous is not None and self._temporal_rhs:
            rhs = rhs + self._temporal_rhs * previous
        linear = rhs if config.objective == "mesh" else self.system @ rhs
        lower, upper = self._lower, self._upper
        if previous is not None and config.rate_bound is not None:
            lower = np.maximum(lower, previous - config.rate_bound)
            upper = np.minimum(upper, previous + config.rate_bound)
            lower = np.minimum(lower, upper)  # a caller's previous may lie outside [0, 1]
        if config.backend == "framewise":
            x = framewise_coefficients(self.hessian, linear[None], rate_bound=config.rate_bound, warm_start=previous)[0]
            status = _status_of(x, lower, upper)
        else:
            x, status = self._box(linear, lower, upper, self._status)
        self._status = status
        if self._cancel:
            held = upper.copy()
            for i, j in self._cancel:
                weaker = j if x[i] >= x[j] else i
                held[weaker] = lower[weaker]
            if np.any(x > held):  # otherwise the second solve would return x itself
                second = status.copy()
                second[held == lower] = -1
                x, _ = self._box(linear, lower, held, second)
        self._previous = x
        out = np.zeros(self.num_shapes)
        out[self.active] = x
        out *= self.multipliers
        out += self.offsets
        return out

    def solve_sequence(self, frames) -> np.ndarray:
        """:meth:`solve` on every frame of ``(T, V, 3)`` (or ``(T, S, 3)``), continuing the
        stream, with BLAS on one thread; returns ``(T, K)``."""
        frames = np.asarray(frames)
        if frames.ndim != 3:
            raise UserError(f"StreamingSolver.solve_sequence: expected frames (T, {self.num_vertices}, 3), "
                            f"got shape {frames.shape}")
        out = np.empty((frames.shape[0], self.num_shapes))
        with one_blas_thread():
            for t in range(frames.shape[0]):
                try:
                    out[t] = self.solve(frames[t])
                except UserError as error:
                    raise UserError(f"frame {t}: {error}") from None
        return out


def _status_of(x, lower, upper) -> np.ndarray:
    return np.where(x <= lower, -1, np.where(x >= upper, 1, 0)).astype(np.int8)

