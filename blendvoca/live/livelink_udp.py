"""Live Link Face's UDP packet: the one owner of the datagram Epic's iOS app sends and
Unreal's Live Link Face source (``AppleARKitFaceSupport``'s remote listener) reads.

One datagram per frame, version 6, every field big-endian (Unreal's
``FNboSerializeToBuffer``, network byte order)::

    uint8    packet version (6)
    int32    byte length of the device id, then its UTF-8 bytes (no terminator)
    int32    byte length of the subject name, then its UTF-8 bytes
    int32    frame number      \\  FQualifiedFrameTime: FFrameTime (frame, sub-frame)
    float32  sub-frame          |  and FFrameRate (numerator / denominator frames
    int32    rate numerator     |  per second: 60/1, 60000/1001 for 59.94)
    int32    rate denominator  /
    uint8    value count (61)
    61 x float32               the 52 ARKit shapes in Unreal's ``EARFaceBlendShape``
                               order (:data:`blendvoca.names.ARKIT_FACE_ORDER`: jawLeft
                               before jawRight, unlike the app's CSV), then head yaw,
                               pitch, roll and each eye's yaw, pitch, roll

The receiver drops a datagram whose version is not 6 or whose count is not 61, so
both are fixed here. Unreal's default port is 11111.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from blendvoca.errors import DataError, UserError
from blendvoca.names import ARKIT_FACE_ORDER, LIVELINK_ROTATION_COLUMNS, arkit_name

#: The packet version Unreal's Live Link Face source accepts.
PACKET_VERSION = 6
#: The 61 values of a packet, in their order (camelCase ARKit shapes, then the rotations).
PACKET_NAMES: tuple[str, ...] = tuple(ARKIT_FACE_ORDER) + tuple(LIVELINK_ROTATION_COLUMNS)
#: Unreal's default Live Link Face port.
DEFAULT_PORT = 11111
#: Longest device id or subject name sent (Unreal reserves 256 characters for each).
MAX_NAME_BYTES = 255

_HEAD = struct.Struct(">B")
_LENGTH = struct.Struct(">i")
_TIME = struct.Struct(">ifiiB")
_VALUES = np.dtype(">f4")


@dataclass(frozen=True)
class LiveLinkPacket:
    """One decoded datagram (:func:`decode_packet`).

    Attributes
    ----------
    device_id, subject : str
    frame_number : int
    sub_frame : float
    rate : (int, int)
        Frames per second as numerator, denominator.
    values : (61,) float32 ndarray
        In :data:`PACKET_NAMES` order.
    version : int
    """

    device_id: str
    subject: str
    frame_number: int
    sub_frame: float
    rate: tuple[int, int]
    values: np.ndarray
    version: int = PACKET_VERSION


def rate_fraction(fps: float) -> tuple[int, int]:
    """``fps`` as Unreal's ``FFrameRate`` (numerator, denominator): 60 -> (60, 1), 59.94 ->
    (60000, 1001), 29.97 -> (30000, 1001); any other rate as the nearest fraction with a
    denominator up to 1001."""
    if not fps > 0:
        raise UserError(f"frame rate must be positive, got {fps}")
    for nominal in (24, 30, 48, 60, 120):
        if abs(fps - nominal * 1000 / 1001) < 5e-3:
            return nominal * 1000, 1001
    fraction = Fraction(fps).limit_denominator(1001)
    return fraction.numerator, fraction.denominator


def _name_bytes(text: str, what: str) -> bytes:
    data = str(text).encode("utf-8")
    if len(data) > MAX_NAME_BYTES:
        raise UserError(f"Live Link {what} {text[:40]!r}...: {len(data)} bytes; the receiver takes at most "
                        f"{MAX_NAME_BYTES}")
    return _LENGTH.pack(len(data)) + data


def encode_packet(values, *, device_id: str, subject: str, frame_number: int, rate: tuple[int, int] = (60, 1),
                  sub_frame: float = 0.0) -> bytes:
    """The datagram of one frame: ``values`` (61,) in :data:`PACKET_NAMES` order (sent as float32)."""
    values = np.asarray(values, dtype=np.float64)
    if values.shape != (len(PACKET_NAMES),):
        raise UserError(f"a Live Link packet carries {len(PACKET_NAMES)} values, got shape {values.shape}")
    return b"".join((_HEAD.pack(PACKET_VERSION), _name_bytes(device_id, "device id"),
                     _name_bytes(subject, "subject name"),
                     _TIME.pack(int(frame_number), float(sub_frame), int(rate[0]), int(rate[1]), len(PACKET_NAMES)),
                     values.astype(_VALUES).tobytes()))


def decode_packet(data: bytes) -> LiveLinkPacket:
    """Read one datagram (:func:`encode_packet`'s layout).

    Raises
    ------
    DataError
        Another version, a count other than 61, a length that does not fit its fields
        (truncated, or bytes left over), a name that is no UTF-8.
    """
    data = bytes(data)
    at = 0

    def take(n: int, what: str) -> bytes:
        nonlocal at
        if n < 0 or at + n > len(data):
            raise DataError(f"Live Link packet of {len(data)} bytes ends inside its {what} (byte {at}, "
                            f"{n} more needed)")
        chunk = data[at:at + n]
        at += n
        return chunk

    (version,) = _HEAD.unpack(take(1, "version"))
    if version != PACKET_VERSION:
        raise DataError(f"Live Link packet version {version}; expected {PACKET_VERSION}")
    names = []
    for what in ("device id", "subject name"):
        (length,) = _LENGTH.unpack(take(4, f"{what} length"))
        try:
            names.append(take(length, what).decode("utf-8"))
        except UnicodeDecodeError as error:
            raise DataError(f"Live Link packet: the {what} is no UTF-8 ({error})") from None
    frame, sub_frame, numerator, denominator, count = _TIME.unpack(take(_TIME.size, "frame time"))
    if count != len(PACKET_NAMES):
        raise DataError(f"Live Link packet carries {count} values; expected {len(PACKET_NAMES)}")
    values = np.frombuffer(take(4 * count, "values"), dtype=_VALUES).astype(np.float32)
    if at != len(data):
        raise DataError(f"Live Link packet has {len(data) - at} bytes after its {count} values")
    return LiveLinkPacket(device_id=names[0], subject=names[1], frame_number=frame, sub_frame=sub_frame,
                          rate=(numerator, denominator), values=values, version=version)


def unknown_names(names: Sequence[str]) -> list[str]:
    """The names among ``names`` that a Live Link packet has no slot for (not one of the 52 ARKit
    shapes, any case, nor one of the 9 rotations)."""
    rotations = {r.lower() for r in LIVELINK_ROTATION_COLUMNS}
    return [n for n in names if arkit_name(n) is None and str(n).lower() not in rotations]


def packet_values(weights, names: Sequence[str], pose=None) -> np.ndarray:
    """``(T, 61)`` float32 packet values of a track: each column of ``weights`` (T, K) in its slot
    (``names``: ARKit names in any case or rotation names), the slots it lacks 0, ``pose`` (T, 9)
    (the rotations, as a Live Link Face take has them) in the last nine.

    Raises
    ------
    UserError
        A name the packet has no slot for (each named), a name twice, a shape mismatch.
    """
    weights = np.asarray(weights, dtype=np.float64)
    if weights.ndim != 2 or weights.shape[1] != len(names):
        raise UserError(f"expected (T, {len(names)}) weights for {len(names)} names, got shape {weights.shape}")
    unknown = unknown_names(names)
    if unknown:
        raise UserError(f"Live Link Face's packet has no slot for {unknown}; it carries the 52 ARKit shapes "
                        f"({', '.join(ARKIT_FACE_ORDER[:3])}, ...) and the 9 rotations ({', '.join(LIVELINK_ROTATION_COLUMNS[:3])}, ...)")
    lower = [n.lower() for n in PACKET_NAMES]
    slots = [lower.index(str(n).lower()) for n in names]
    if len(set(slots)) != len(slots):
        repeated = sorted({str(n) for n, s in zip(names, slots) if slots.count(s) > 1})
        raise UserError(f"names given twice (any case): {repeated}")
    out = np.zeros((len(weights), len(PACKET_NAMES)), dtype=np.float32)
    out[:, slots] = weights
    if pose is not None:
        pose = np.asarray(pose, dtype=np.float64)
        if pose.shape != (len(weights), len(LIVELINK_ROTATION_COLUMNS)):
            raise UserError(f"expected ({len(weights)}, 9) rotations, got shape {pose.shape}")
        out[:, len(ARKIT_FACE_ORDER):] = pose
    return out
