"""Blendshape names: the ARKit shapes of the reference rig (51: all but tongueOut), BlendVOCA's 32 speech shapes and their
left/right mirror pairs, and the orders and spellings other tools use for the 52 ARKit shapes
(ARKit's own order, Live Link Face's CSV columns in PascalCase).

`BLENDVOCA_NAMES` is the column order of every BlendVOCA coefficient file; it equals
the asset ``arkit-blendshape-names`` (``tests/test_names.py`` checks that).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from blendvoca.errors import UserError

ARKIT_NAMES: tuple[str, ...] = (
    "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft",
    "browOuterUpRight", "cheekPuff", "cheekSquintLeft", "cheekSquintRight",
    "eyeBlinkLeft", "eyeBlinkRight", "eyeLookDownLeft", "eyeLookDownRight",
    "eyeLookInLeft", "eyeLookInRight", "eyeLookOutLeft", "eyeLookOutRight",
    "eyeLookUpLeft", "eyeLookUpRight", "eyeSquintLeft", "eyeSquintRight",
    "eyeWideLeft", "eyeWideRight", "jawForward", "jawLeft", "jawOpen", "jawRight",
    "mouthClose", "mouthDimpleLeft", "mouthDimpleRight", "mouthFrownLeft",
    "mouthFrownRight", "mouthFunnel", "mouthLeft", "mouthLowerDownLeft",
    "mouthLowerDownRight", "mouthPressLeft", "mouthPressRight", "mouthPucker",
    "mouthRight", "mouthRollLower", "mouthRollUpper", "mouthShrugLower",
    "mouthShrugUpper", "mouthSmileLeft", "mouthSmileRight", "mouthStretchLeft",
    "mouthStretchRight", "mouthUpperUpLeft", "mouthUpperUpRight", "noseSneerLeft",
    "noseSneerRight",
)
# ARKit defines 52 shapes; the reference rig has all of them but tongueOut (51),
# which a closed-mouth surface mesh cannot express.

BLENDVOCA_NAMES: tuple[str, ...] = (
    "jawForward", "jawLeft", "jawRight", "jawOpen", "mouthClose", "mouthFunnel",
    "mouthPucker", "mouthLeft", "mouthRight", "mouthSmileLeft", "mouthSmileRight",
    "mouthFrownLeft", "mouthFrownRight", "mouthDimpleLeft", "mouthDimpleRight",
    "mouthStretchLeft", "mouthStretchRight", "mouthRollLower", "mouthRollUpper",
    "mouthShrugLower", "mouthShrugUpper", "mouthPressLeft", "mouthPressRight",
    "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft",
    "mouthUpperUpRight", "cheekPuff", "cheekSquintLeft", "cheekSquintRight",
    "noseSneerLeft", "noseSneerRight",
)


# The 52 shapes in the order of ARKit's ARFaceAnchor.BlendShapeLocation as Unreal's
# EARFaceBlendShape lists them (eyes, jaw, mouth, brows, cheeks, nose, tongue): the order
# of Live Link Face's network packets and of Audio2Face-3D's ARKit blendshape export.
ARKIT_FACE_ORDER: tuple[str, ...] = (
    "eyeBlinkLeft", "eyeLookDownLeft", "eyeLookInLeft", "eyeLookOutLeft", "eyeLookUpLeft",
    "eyeSquintLeft", "eyeWideLeft", "eyeBlinkRight", "eyeLookDownRight", "eyeLookInRight",
    "eyeLookOutRight", "eyeLookUpRight", "eyeSquintRight", "eyeWideRight", "jawForward",
    "jawLeft", "jawRight", "jawOpen", "mouthClose", "mouthFunnel", "mouthPucker", "mouthLeft",
    "mouthRight", "mouthSmileLeft", "mouthSmileRight", "mouthFrownLeft", "mouthFrownRight",
    "mouthDimpleLeft", "mouthDimpleRight", "mouthStretchLeft", "mouthStretchRight",
    "mouthRollLower", "mouthRollUpper", "mouthShrugLower", "mouthShrugUpper", "mouthPressLeft",
    "mouthPressRight", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft",
    "mouthUpperUpRight", "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft",
    "browOuterUpRight", "cheekPuff", "cheekSquintLeft", "cheekSquintRight", "noseSneerLeft",
    "noseSneerRight", "tongueOut",
)

# Live Link Face's CSV export: the same 52 shapes in PascalCase, except that the app
# writes JawRight before JawLeft and MouthRight before MouthLeft; then head and eye
# rotations. Columns: Timecode, BlendShapeCount, these 52, these 9 (63 in all).
LIVELINK_SHAPE_COLUMNS: tuple[str, ...] = tuple(
    n[0].upper() + n[1:]
    for n in ARKIT_FACE_ORDER[:15] + ("jawRight", "jawLeft") + ARKIT_FACE_ORDER[17:21]
    + ("mouthRight", "mouthLeft") + ARKIT_FACE_ORDER[23:]
)
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
