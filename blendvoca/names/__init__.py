"""Blendshape names: the ARKit shapes, BlendVOCA's 32 speech shapes and their left/right
mirror pairs, and every naming convention the project reads or writes, with
:func:`remap` to move a coefficient track from one convention's columns to another's.

`BLENDVOCA_NAMES` is the column order of every BlendVOCA coefficient file; it equals
the asset ``arkit-blendshape-names`` (``tests/test_names.py`` checks that).
The conventions (names, order, count, what each lacks of ARKit's 52, and the source
each was checked against) are data in :mod:`blendvoca.names.conventions`;
``python -m blendvoca.names list`` and ``show NAME`` print them.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from blendvoca.errors import UserError
from blendvoca.names.conventions import (
    ARKIT_FACE_ORDER,
    ARKIT_NAMES,
    BLENDVOCA_NAMES,
    CONVENTIONS,
    Convention,
)
from blendvoca.names.facegood import FACEGOOD116, FACEGOOD_TO_ARKIT, FACEGOOD_UNMAPPED, ControlMapping  # noqa: F401
from blendvoca.registry import Registry

# Live Link Face's CSV export: the same 52 shapes in PascalCase, except that the app
# writes JawRight before JawLeft and MouthRight before MouthLeft; then head and eye
# rotations. Columns: Timecode, BlendShapeCount, these 52, these 9 (63 in all).
LIVELINK_SHAPE_COLUMNS: tuple[str, ...] = CONVENTIONS["livelink"].columns()
LIVELINK_ROTATION_COLUMNS: tuple[str, ...] = (
    "HeadYaw", "HeadPitch", "HeadRoll", "LeftEyeYaw", "LeftEyePitch", "LeftEyeRoll",
    "RightEyeYaw", "RightEyePitch", "RightEyeRoll",
)
LIVELINK_HEADER: tuple[str, ...] = ("Timecode", "BlendShapeCount") + LIVELINK_SHAPE_COLUMNS + LIVELINK_ROTATION_COLUMNS

_BY_LOWER = {n.lower(): n for n in ARKIT_FACE_ORDER}


def arkit_name(name: str) -> str | None:
    """The camelCase ARKit name that ``name`` spells in any case (``JawOpen``,
    ``jawopen`` -> ``jawOpen``), or None when it is no ARKit shape."""
    return _BY_LOWER.get(str(name).strip().lower())


def pascal_name(name: str) -> str:
    """Live Link Face's PascalCase spelling of an ARKit name (``jawOpen`` -> ``JawOpen``)."""
    canonical = arkit_name(name)
    if canonical is None:
        raise UserError(f"pascal_name: {name!r} is not an ARKit blendshape name; expected one of {ARKIT_FACE_ORDER[:3]}...")
    return canonical[0].upper() + canonical[1:]


def _mirror_name(name: str) -> str | None:
    """Name of the left/right partner of ``name``, or None if it has none."""
    for side, other in (("Left", "Right"), ("Right", "Left")):
        if name.endswith(side):
            return name[: -len(side)] + other
    return None


def mirror_pairs(names: Sequence[str]) -> tuple[tuple[str, str], ...]:
    """Left/right pairs among ``names`` as ``(left, right)`` in the order of ``names``.

    jawLeft/jawRight and mouthLeft/mouthRight are pairs too: each moves the jaw or
    mouth sideways, mirror images of one another.
    """
    present = set(names)
    pairs = []
    for name in names:
        if name.endswith("Left") and _mirror_name(name) in present:
            pairs.append((name, _mirror_name(name)))
    return tuple(pairs)


MIRROR_PAIRS: tuple[tuple[str, str], ...] = mirror_pairs(BLENDVOCA_NAMES)


def mirror_permutation(names: Sequence[str]) -> np.ndarray:
    """Index of each name's mirror partner within ``names`` (itself when unpaired).

    Parameters
    ----------
    names : sequence of str, length K

    Returns
    -------
    perm : (K,) int64 ndarray
        ``coeffs[:, perm]`` swaps every left/right pair of a ``(T, K)`` track.
    """
    index = {name: i for i, name in enumerate(names)}
    perm = np.arange(len(names), dtype=np.int64)
    for i, name in enumerate(names):
        partner = _mirror_name(name)
        if partner is not None and partner in index:
            perm[i] = index[partner]
    return perm


def check_names(names: Sequence[str], *, where: str) -> tuple[str, ...]:
    """Return ``names`` as a tuple after checking each is an ARKit name, once.

    Raises
    ------
    UserError
        Naming the unknown or repeated names and ``where`` they came from (a ``ValueError``).
    """
    names = tuple(str(n) for n in names)
    unknown = [n for n in names if n not in ARKIT_NAMES]
    if unknown:
        raise UserError(f"{where}: unknown blendshape names {unknown}; expected ARKit names such as {ARKIT_NAMES[:3]}")
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise UserError(f"{where}: blendshape names repeated: {repeated}")
    return names


# ----------------------------------------------------------------------------- conventions and remap

MISSING_POLICIES = ("zero", "refuse")


class MissingShapesWarning(UserWarning):
    """A remap filled target shapes the source lacks with 0 (``missing="zero"``)."""


#: The convention registry over :data:`CONVENTIONS` (a :class:`~blendvoca.registry.Registry`).
NAMING_CONVENTIONS = Registry("blendshape convention", CONVENTIONS)


def convention(name: str) -> Convention:
    """The registered :class:`Convention` called ``name``.

    Raises
    ------
    UserError
        For an unknown name, listing the close matches and the known ones.
    """
    return NAMING_CONVENTIONS.get(str(name))


def convention_names(name: str) -> tuple[str, ...]:
    """The camelCase shape names of convention ``name`` in its column order.

    Raises
    ------
    UserError
        For an unknown name, or a convention whose files carry their own names
        (``beat``, ``a2f46``): the message says to pass the file's names instead.
    """
    found = convention(name)
    if found.controls is not None:
        raise UserError(f"the {name!r} convention names a rig's controls, not ARKit shapes; form ARKit shapes "
                        f"from them with blendvoca.names.controls_to_arkit(values, controls, {name!r})")
    if found.names is None:
        raise UserError(f"the {name!r} convention has no fixed order: each file lists its own shapes "
                        f"({found.unverified or found.checked}); pass the file's names instead of {name!r}")
    return found.names


def controls_to_arkit(values, controls, convention_name: str, *, where: str = "controls_to_arkit"
                      ) -> tuple[np.ndarray, tuple[str, ...]]:
    """A track of a rig's controls as ARKit shapes, by the rig convention's map (``to_arkit``).

    Each ARKit shape is ``clip(sum(weight * control), 0, 1)`` over its mapping's terms
    (:class:`~blendvoca.names.facegood.ControlMapping`); controls no mapping names are left out
    (the convention's ``FACEGOOD_UNMAPPED``-style list says what they carry).

    Parameters
    ----------
    values : (T, K) array_like of real numbers in [0, 1]
    controls : K control names, in the track's column order (the file's names list)
    convention_name : str
        A convention with ``to_arkit`` (``facegood116``).
    where : str
        What the track is, for messages.

    Returns
    -------
    track : (T, M) float64 ndarray in [0, 1]
    names : M camelCase ARKit names, in ARKit's order

    Raises
    ------
    UserError
        A convention without a map, a control the map needs that ``controls`` lacks,
        controls repeated, or a track whose width is not ``len(controls)``.
    """
    entry = convention(convention_name)
    if not entry.to_arkit:
        raise UserError(f"{where}: the {convention_name!r} convention has no map of rig controls onto ARKit; "
                        f"conventions with one: {', '.join(n for n, c in CONVENTIONS.items() if c.to_arkit)}")
    controls = tuple(str(c) for c in controls)
    repeated = sorted({c for c in controls if controls.count(c) > 1})
    if repeated:
        raise UserError(f"{where}: controls named twice: {repeated[:5]}")
    array = np.asarray(values)
    if array.dtype.kind not in "fiub" or array.ndim != 2 or array.shape[1] != len(controls):
        raise UserError(f"{where}: expected a (T, {len(controls)}) track of numbers, one column per control, "
                        f"got shape {array.shape} ({array.dtype})")
    position = {c: k for k, c in enumerate(controls)}
    needed = [c for m in entry.to_arkit for c, _ in m.terms if c not in position]
    if needed:
        raise UserError(f"{where}: the {convention_name!r} map needs controls the names lack: {needed[:5]}"
                        + (f" (+{len(needed) - 5} more)" if len(needed) > 5 else ""))
    mappings = sorted(entry.to_arkit, key=lambda m: ARKIT_FACE_ORDER.index(m.arkit))
    weights = np.zeros((len(controls), len(mappings)), dtype=np.float64)
    for j, mapping in enumerate(mappings):
        for control, weight in mapping.terms:
            weights[position[control], j] += weight
    track = np.clip(array.astype(np.float64) @ weights, 0.0, 1.0)
    return track, tuple(m.arkit for m in mappings)


def _names_of(spec, role: str) -> tuple[str, ...]:
    """Canonical camelCase names of a convention name or of a sequence of names (any case)."""
    if isinstance(spec, str):
        return convention_names(spec)
    return canonical_names(spec, where="remap", what=f"{role} blendshape names",
                           hint=f" or a convention: {', '.join(CONVENTIONS)}")


def canonical_names(names: Sequence[str], *, where: str, what: str = "blendshape names",
                    hint: str = "") -> tuple[str, ...]:
    """``names`` (ARKit names in any case) as camelCase ARKit names, or a :class:`UserError` naming
    ``where`` and the unknown names (then ``hint``) or those repeated once spelled alike."""
    names = tuple(str(n) for n in names)
    unknown = [n for n in names if arkit_name(n) is None]
    if unknown:
        raise UserError(f"{where}: unknown {what} {unknown}; expected ARKit names (any case){hint}")
    canonical = tuple(arkit_name(n) for n in names)
    repeated = sorted({n for n in canonical if canonical.count(n) > 1})
    if repeated:
        raise UserError(f"{where}: {what} repeated: {repeated}")
    return canonical


def remap_columns(src, dst) -> tuple[np.ndarray, tuple[str, ...], tuple[str, ...]]:
    """Where each destination column comes from.

    Parameters
    ----------
    src, dst : str or sequence of str
        A convention name (:data:`CONVENTIONS`) or the column names themselves
        (ARKit names in any case).

    Returns
    -------
    index : (K_dst,) int64 ndarray
        The source column of each destination column, -1 where the source lacks it.
    missing : tuple of str
        Destination shapes the source lacks, in destination order.
    dropped : tuple of str
        Source shapes the destination has no column for, in source order.
    """
    src_names, dst_names = _names_of(src, "source"), _names_of(dst, "destination")
    position = {n: i for i, n in enumerate(src_names)}
    index = np.array([position.get(n, -1) for n in dst_names], dtype=np.int64)
    missing = tuple(n for n, i in zip(dst_names, index) if i < 0)
    wanted = set(dst_names)
    dropped = tuple(n for n in src_names if n not in wanted)
    return index, missing, dropped


def _label(spec, count: int) -> str:
    """How a message names a convention or a list of names."""
    return repr(spec) if isinstance(spec, str) else f"{count} given names"


def remap(coeffs, src, dst, *, missing: str = "zero") -> np.ndarray:
    """A coefficient track moved from ``src``'s columns to ``dst``'s, matched by name.

    Values are copied, never mixed: on the shapes both conventions have the result
    is exact, so ``remap(remap(x, a, b), b, a)`` gives ``x`` back on those shapes.
    Source shapes the destination lacks are left out.

    Parameters
    ----------
    coeffs : (T, K_src) array_like of real numbers
    src, dst : str or sequence of str
        Convention names (``arkit52``, ``livelink``, ``unitalker51``, ``said32``, ...;
        ``python -m blendvoca.names list``) or the column names themselves.
    missing : {"zero", "refuse"}
        Destination shapes the source lacks: a column of 0 and a
        :class:`MissingShapesWarning` naming them, or a :class:`UserError` naming them.

    Returns
    -------
    (T, K_dst) float64 ndarray

    Raises
    ------
    UserError
        An unknown convention or name, a track whose width is not the source's
        count, a policy other than the two, or (``missing="refuse"``) shapes the
        source lacks.
    """
    if missing not in MISSING_POLICIES:
        raise UserError(f"remap: missing must be one of {MISSING_POLICIES}, got {missing!r}")
    index, absent, _ = remap_columns(src, dst)
    src_count = len(_names_of(src, "source"))
    array = np.asarray(coeffs)
    if array.dtype.kind not in "fiub":
        raise UserError(f"remap: coeffs must be real numbers, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] != src_count:
        raise UserError(f"remap: expected a (T, {src_count}) track for the source's {src_count} shapes, "
                        f"got shape {array.shape}")
    where = f"remap from {_label(src, src_count)} to {_label(dst, len(index))}"
    if absent and missing == "refuse":
        raise UserError(f"{where}: the source has no column for "
                        f"{len(absent)} shape(s): {', '.join(absent)}")
    out = np.zeros((array.shape[0], len(index)), dtype=np.float64)
    have = index >= 0
    out[:, have] = array[:, index[have]]
    if absent:
        warnings.warn(f"{where}: {len(absent)} shape(s) the source lacks are 0: "
                      + ", ".join(absent), MissingShapesWarning, stacklevel=2)
    return out
