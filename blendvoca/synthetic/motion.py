"""Procedural facial motion: driving signals turned into vertex animation.

The model is deliberately *not* a blendshape rig (and in particular not the
ARKit reference rig that BlendVOCA later transfers and fits), so fitting the
synthetic motion leaves a realistic, non-zero residual:

- the jaw *rotates* about a hinge axis (x axis through the hinge point) by
  ``jaw * max_jaw_angle``; vertices follow the rotated position by their
  harmonic jaw weight (a non-linear function of the signal);
- lip closure and labiodental contact cancel part of the jaw motion on the
  lips (a product of two signals) and press the lips together / raise the
  lower lip to the upper teeth;
- rounding protrudes and narrows the lips, spreading widens them (two
  different fields for the two signs of one signal);
- blinks lower the upper eyelids by the measured lid gap, brows rise;
- (corpora with undetermined components) a smile widens the mouth and lifts
  and pulls back its corners, a corner pull does it on one side, a lip press
  squeezes the closed lips, and a speaker's asymmetry makes one side of the
  lips move more than the other.
"""

from __future__ import annotations

import numpy as np

from blendvoca.synthetic.regions import FaceRegions


def jaw_rotation_offsets(vertices: np.ndarray, hinge: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Offsets ``(T, V, 3)`` of every vertex rotated about the hinge's x axis.

    Parameters
    ----------
    vertices : (V, 3) ndarray
    hinge : (3,) ndarray
    angles : (T,) ndarray
        Opening angles in radians (positive opens: the chin moves down and back).
    """
    rel = np.asarray(vertices, dtype=np.float64) - hinge
    c = np.cos(angles)[:, None]
    s = np.sin(angles)[:, None]
    out = np.zeros((len(angles), len(rel), 3))
    out[:, :, 1] = rel[:, 1] * (c - 1.0) - rel[:, 2] * s
    out[:, :, 2] = rel[:, 1] * s + rel[:, 2] * (c - 1.0)
    return out


def animate_face(neutral: np.ndarray, regions: FaceRegions, signals: dict[str, np.ndarray], *,
                 max_jaw_angle: float = 0.09, protrusion: float = 0.006, narrowing: float = 0.28,
                 spreading: float = 0.12, press: float = 0.0012, labiodental_lift: float = 0.003,
                 brow_lift: float = 0.004, asymmetry: float = 0.0, smile_width: float = 0.12,
                 corner_lift: float = 0.003, corner_pull: float = 0.004) -> np.ndarray:
    """Vertex animation ``(T, V, 3) float64`` of one sentence.

    Parameters
    ----------
    neutral : (V, 3) ndarray
        The speaker's neutral face (metres).
    regions : FaceRegions
        From ``face_regions`` on that neutral.
    signals : dict of (T,) ndarray
        ``jaw``, ``round``, ``closure``, ``labiodental``, ``blink``, ``brow``
        (see ``motion_signals``).
    max_jaw_angle : float
        Jaw rotation (radians) at ``jaw == 1``; 0.09 rad opens the incisors by
        about 8 mm, typical of speech.
    protrusion, press, labiodental_lift, brow_lift : float
        Displacements in metres at full signal.
    narrowing, spreading : float
        Relative change of the mouth width at full rounding / spreading.
    asymmetry : float
        A speaker's left/right asymmetry: the lip fields are scaled by
        ``1 + asymmetry * side`` (side -1 .. 1 across the mouth).
    smile_width, corner_lift, corner_pull : float
        A full smile widens the mouth by ``smile_width`` (relative) and lifts the
        corners by ``corner_lift`` (m); a full corner pull moves one corner
        ``corner_pull`` outwards (m). Only used with the optional signals
        ``smile``, ``corner_left`` (+x side), ``corner_right`` and ``press``.
    """
    V = np.asarray(neutral, dtype=np.float64)
    missing = [k for k in ("jaw", "round", "closure", "labiodental", "blink", "brow") if k not in signals]
    if missing:
        raise ValueError(f"animate_face: signals lack {missing}; got {sorted(signals)}")
    jaw = np.asarray(signals["jaw"], dtype=np.float64)
    T = len(jaw)
    for k in ("round", "closure", "labiodental", "blink", "brow"):
        if np.shape(signals[k]) != (T,):
            raise ValueError(f"animate_face: signal {k!r} has shape {np.shape(signals[k])}, expected ({T},) like 'jaw'")
    closure = np.asarray(signals["closure"], dtype=np.float64)
    labio = np.asarray(signals["labiodental"], dtype=np.float64)
    rnd = np.asarray(signals["round"], dtype=np.float64)

    lips, wj = regions.lips, regions.jaw
    upper = lips * (1.0 - wj)
    lower = lips * wj
    rel = V - regions.mouth_center
    n = len(V)

    # Linear part: each signal times a fixed displacement field, one matrix product.
    r_plus, r_minus = np.clip(rnd, 0, None), np.clip(-rnd, 0, None)
    fields = np.zeros((6, n, 3))
    # Rounding (+) narrows and protrudes; spreading (-) widens and pulls back.
    fields[0] = np.stack([-narrowing * rel[:, 0], np.zeros(n), np.full(n, protrusion)], axis=1) * lips[:, None]
    fields[1] = np.stack([spreading * rel[:, 0], 0.2 * spreading * np.abs(rel[:, 0]),
                          np.full(n, -0.25 * protrusion)], axis=1) * lips[:, None]
    # Closure presses the lips together; labiodental raises and retracts the lower lip.
    fields[2, :, 1] = press * (lower - upper)
    fields[2, :, 2] = -0.4 * press * lips
    fields[3, :, 1] = labiodental_lift * lower
    fields[3, :, 2] = -labiodental_lift * lower
    # Blinks lower the upper lids by most of the lid gap; brows rise.
    fields[4, :, 1] = -0.85 * regions.lid_gap * regions.upper_lid + 0.1 * regions.lid_gap * regions.lower_lid
    fields[5, :, 1] = brow_lift * regions.brows
    fields[5, :, 2] = 0.1 * brow_lift * regions.brows
    drive = np.stack([r_plus, r_minus, closure, labio, np.asarray(signals["blink"], dtype=np.float64),
                      np.asarray(signals["brow"], dtype=np.float64)], axis=1)
    extra = [k for k in ("smile", "corner_left", "corner_right", "press") if k in signals]
    if extra or asymmetry:
        fields, drive = _gesture_fields(fields, drive, signals, extra, regions, rel, upper, lower, T,
                                        asymmetry=asymmetry, press=press, smile_width=smile_width,
                                        corner_lift=corner_lift, corner_pull=corner_pull)
    out = (drive @ fields.reshape(len(fields), -1)).reshape(T, n, 3)
    out += V[None]

    # Jaw (non-linear): only the vertices it reaches. The lips resist the opening
    # while they are closed or touching the teeth.
    idx = np.flatnonzero(wj > 1e-4)  # harmonic weights are tiny but non-zero far away
    hold = np.clip(closure[:, None] * lips[None, idx] + 0.7 * labio[:, None] * lower[None, idx], 0.0, 1.0)
    weight = wj[None, idx] * (1.0 - hold)
    out[:, idx] += weight[:, :, None] * jaw_rotation_offsets(V[idx], regions.hinge, jaw * max_jaw_angle)
    return out


def _gesture_fields(fields, drive, signals, extra, regions, rel, upper, lower, T, *, asymmetry, press,
                    smile_width, corner_lift, corner_pull):
    """The fields and drive of `animate_face` with a speaker's asymmetry and the gesture signals added."""
    lips = regions.lips
    side = np.clip(rel[:, 0] / (0.5 * regions.mouth_width), -1.0, 1.0)
    if asymmetry:
        fields = fields.copy()
        fields[:2] *= (1.0 + asymmetry * side)[None, :, None]
    corner = np.abs(side) ** 2 * lips
    added, columns = [], []
    for name in extra:
        field = np.zeros((len(rel), 3))
        if name == "smile":
            field[:, 0] = smile_width * rel[:, 0] * lips * (1.0 + asymmetry * side)
            field[:, 1] = corner_lift * corner * (1.0 + asymmetry * side)
            field[:, 2] = -0.6 * corner_lift * corner
        elif name in ("corner_left", "corner_right"):
            one_side = np.clip(side if name == "corner_left" else -side, 0.0, 1.0) ** 2 * lips
            field[:, 0] = np.sign(side) * corner_pull * one_side
            field[:, 1] = 0.4 * corner_pull * one_side
            field[:, 2] = -0.5 * corner_pull * one_side
        else:  # press: the closed lips squeezed together and rolled in, the chin boss raised
            field[:, 1] = 1.5 * press * (lower - upper) + 0.6 * press * lower
            field[:, 2] = -0.8 * press * lips
        added.append(field)
        columns.append(np.asarray(signals[name], dtype=np.float64).reshape(T))
    if added:
        fields = np.concatenate([fields, np.stack(added)])
        drive = np.concatenate([drive, np.stack(columns, axis=1)], axis=1)
    return fields, drive
