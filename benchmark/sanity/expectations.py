"""What each metric is declared to do under each disturbance, with the reason, and the verdict.

:data:`EXPECTATIONS` is the one table: ``(metric, disturbance) -> Expectation``. A
declaration is one of

``rises`` / ``falls``
    The values over the levels (level 0 = the undisturbed truth) have a Spearman
    correlation with the level of at least :data:`RHO_MIN` (at most -RHO_MIN), and the
    last level's value is above (below) level 0's. With a ``tolerance`` (a metric's
    noise floor, e.g. WInD's mixture fits), a value may also fall back by at most that
    much below the largest (above the smallest) before it, and the last level must
    exceed level 0 by more than it.
``must not react``
    Every level's value is within ``tolerance`` of level 0's; with ``relative_to``,
    the tolerance is also ``share`` of the largest response of the same metric to
    that other disturbance (e.g. a region metric under a disturbance of another
    region against the same disturbance of the whole face), when it was run.
``equals level``
    Every value is within ``tolerance`` of ``scale * level`` (a k-frame delay gives a
    lag bias of k frames).
``any``
    No claim (recorded, never a failure); the reason says why none can be made.

A metric that the evaluation did not return is "not scored": its declarations are
kept and reported, never failed (the expert and SyncNet rows without their models,
and the names of a protocol not yet in place). ``known_limitation`` marks a
declaration that states what a metric does where a sensible claim fails and cannot
be fixed in the metric (docs/metrics.md, "Metric sanity", says why).

A second table, :data:`REFERENCE_CLAIMS`, declares what a metric scores on the
reference rows (:data:`REFERENCE_ROWS`: a static face, the ground truth itself and,
on a one-to-many synthetic build, its oracle samples and their mean), judged by
:func:`reference_verdict`: ``equals`` (the mean is the target within a tolerance),
``interval contains`` (the 95 % interval contains the target), ``within interval of``
(the mean is at most the interval's width from the target) and ``below`` (the whole
interval is below the target).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import rankdata

__all__ = ["EXPECTATIONS", "KINDS", "REFERENCE_CLAIMS", "REFERENCE_KINDS", "REFERENCE_ROWS", "RHO_MIN", "Expectation",
           "ReferenceClaim", "declared", "reference_verdict", "spearman", "verdict"]

#: Declaration kinds.
KINDS = ("rises", "falls", "must not react", "equals level", "any")
#: Smallest |Spearman rho| of a "rises" / "falls" declaration: with 5 levels one
#: swapped neighbouring pair still passes (rho = 0.9), two do not.
RHO_MIN = 0.9


@dataclass(frozen=True)
class Expectation:
    """A declared behaviour of ``metric`` under ``disturbance`` and why."""

    metric: str
    disturbance: str
    expected: str
    reason: str
    tolerance: float = 0.0
    relative_to: str | None = None
    share: float = 0.0
    scale: float = 1.0
    known_limitation: bool = False

    def __post_init__(self):
        if self.expected not in KINDS:
            raise ValueError(f"Expectation {self.metric}/{self.disturbance}: unknown kind {self.expected!r}; "
                             f"expected one of {KINDS}")
        if not self.reason:
            raise ValueError(f"Expectation {self.metric}/{self.disturbance}: a declaration needs a reason")


def spearman(levels: Sequence[float], values: Sequence[float]) -> float:
    """Spearman rank correlation of values with levels (average ranks for ties); NaN
    when either side is constant or any value is not finite."""
    x = np.asarray(levels, dtype=np.float64)
    y = np.asarray(values, dtype=np.float64)
    if len(x) != len(y) or len(x) < 2 or not np.all(np.isfinite(y)):
        return math.nan
    rx, ry = rankdata(x), rankdata(y)
    if np.ptp(rx) == 0 or np.ptp(ry) == 0:
        return math.nan
    return float(np.corrcoef(rx, ry)[0, 1])


def verdict(expectation: Expectation, levels, values, reference=None) -> dict:
    """The entry of one (metric, disturbance): levels, values, rho, what was declared and
    whether it held.

    Parameters
    ----------
    expectation : Expectation
    levels, values : sequences of float
        ``values[i]`` is the metric at ``levels[i]``; ``levels[0]`` is the undisturbed truth.
    reference : sequence of float, optional
        The same metric's values under ``expectation.relative_to`` (``must not react``).

    Returns
    -------
    dict with ``levels``, ``values``, ``rho`` (None when undefined), ``expected``,
    ``ok``, ``reason``, ``tolerance`` (the one applied, where one is), ``why`` (what
    failed, when it failed) and ``known_limitation`` when set.
    """
    e = expectation
    levels = [float(v) for v in levels]
    values = [float(v) for v in values]
    rho = spearman(levels, values)
    entry = {"levels": levels, "values": values, "rho": None if math.isnan(rho) else rho,
             "expected": e.expected, "ok": True, "reason": e.reason}
    if e.known_limitation:
        entry["known_limitation"] = True
    v = np.asarray(values)
    why = None
    if not np.all(np.isfinite(v)):
        why = "a value is not finite"
    elif e.expected in ("rises", "falls"):
        sign = 1.0 if e.expected == "rises" else -1.0
        tol = float(e.tolerance)
        if tol > 0:
            entry["tolerance"] = tol
        u = sign * v  # rising in u
        within_floor = tol > 0 and bool(np.all(u[1:] >= np.maximum.accumulate(u)[:-1] - tol))
        if math.isnan(rho):
            why = "the values do not change with the level"
        elif sign * rho < RHO_MIN - 1e-9 and not within_floor:
            why = f"Spearman rho {rho:+.2f}, declared {'>=' if sign > 0 else '<='} {sign * RHO_MIN:+.2f}"
            if tol > 0:
                why += f" (and it falls back by more than its floor {tol:g})"
        elif not u[-1] - u[0] > tol:
            why = (f"the last level ({v[-1]:.4g}) is not {'above' if sign > 0 else 'below'} level 0 ({v[0]:.4g})"
                   + (f" by more than {tol:g}" if tol > 0 else ""))
    elif e.expected == "must not react":
        tol = float(e.tolerance)
        if e.relative_to is not None:
            if reference is None:
                entry["note"] = f"{e.relative_to!r} was not run: the absolute tolerance alone applies"
            else:
                ref = np.asarray(reference, dtype=np.float64)
                tol = max(tol, e.share * float(np.max(np.abs(ref - ref[0]))))
        entry["tolerance"] = tol
        change = float(np.max(np.abs(v - v[0])))
        if why is None and change > tol:
            why = f"moved by {change:.4g} from level 0, tolerance {tol:.4g}"
    elif e.expected == "equals level":
        entry["tolerance"] = float(e.tolerance)
        target = e.scale * np.asarray(levels)
        worst = float(np.max(np.abs(v - target)))
        if worst > e.tolerance:
            i = int(np.argmax(np.abs(v - target)))
            why = f"{v[i]:.4g} at level {levels[i]:g}, declared {target[i]:.4g} +- {e.tolerance:g}"
    if why is not None:
        entry["ok"] = False
        entry["why"] = why
    return entry


# --------------------------------------------------------------------------- the table

_ALL = ("time_shift", "time_advance", "smoothing", "noise", "damping", "mouth_damping", "sentence_swap",
        "noisy_samples", "constant_offset")
_ESTIMATORS = ("geometric", "expert", "syncnet")
#: WInD's noise floor in the sanity run (2 seeded fits): noisy samples of std 0 (two
#: copies of the truth) score about 1 on the bundled default, the issue measured 3-4
#: on the 12 x 40 board; the suite allows a fall-back of this much between levels.
WIND_FLOOR = 1.5
#: Frames of each estimator per 60 fps frame (SyncNet reads 25 fps video).
_FRAME_SCALE = {"geometric": 1.0, "expert": 1.0, "syncnet": 25.0 / 60.0}

_R_NEAREST_RIG = ("the undisturbed truth is the reference itself (rig space: error 0); any change of the "
                  "track moves every frame away from it")
_R_NEAREST_MESH = ("the ground-truth track is the build's fit to the meshes (the QP minimises the vertex "
                   "error), so moving away from it moves away from the meshes")
_R_DIVERSITY = ("a diversity measure of the samples of one sentence: independent noise makes the samples "
                "differ, so it rises; it cannot tell noise from distinct plausible motions (read it with "
                "energy_*, which penalises noise)")
_R_LIMIT_FDD_MOUTH = ("KNOWN LIMITATION (docs/metrics.md, Metric sanity): the speaker rigs' mouth shapes move "
                      "every upper-face vertex but the eyeballs (0.2 mm at the scalp, 0.7-2 mm at the brows; "
                      "the ARKit reference's do not), so the rig's upper-face dynamics follow the mouth's "
                      "amplitude; no vertex region avoids it, the fix belongs in the rig build")


def _table() -> dict:
    rows = []

    def add(metric, disturbances, expected, reason, **kw):
        for d in ([disturbances] if isinstance(disturbances, str) else disturbances):
            rows.append(Expectation(metric, d, expected, reason, **kw))

    # ---- lip sync
    for est in _ESTIMATORS:
        scale = _FRAME_SCALE[est]
        add(f"av_offset_{est}", ("time_shift", "time_advance"), "rises",
            "a delay or advance of k frames moves the best lag by k (mean |offset|: the truth's own lags are "
            "-2..2 frames, so small k may first cancel them)")
        add(f"av_offset_{est}", "sentence_swap", "rises",
            "another sentence's motion has no fixed lag to this audio: the best lag wanders")
        add(f"av_offset_signed_{est}", "time_shift", "rises", "the motion comes k frames later: the signed lag grows")
        add(f"av_offset_signed_{est}", "time_advance", "falls", "the motion comes k frames earlier")
        add(f"av_lag_bias_{est}", "time_shift", "equals level",
            "the lag bias is the mean signed offset minus the truth's on the same sentences: a delay of k "
            "frames must read k (in the estimator's frames)", tolerance=0.5, scale=scale)
        add(f"av_lag_bias_{est}", "time_advance", "equals level", "an advance of k frames must read -k",
            tolerance=0.5, scale=-scale)
        add(f"av_confidence_{est}", ("sentence_swap",), "falls",
            "another sentence's motion is not locked to this speech")
        add(f"av_confidence_{est}", ("noise", "noisy_samples"), "falls",
            "noise buries the motion that follows the speech")
        add(f"av_confidence_{est}", ("damping", "mouth_damping"), "falls",
            "a mouth that moves less shows less evidence of sync (SyncNet's and the expert's confidences "
            "drop; the geometric one is discounted by the motion's visibility)")
    add("av_confidence_geometric", "smoothing", "falls",
        "low-pass motion loses the syllable-rate opening and closing that the speech envelope has")
    add("av_offset_geometric", ("damping", "mouth_damping", "constant_offset"), "must not react",
        "the best lag of a Pearson correlation does not depend on the motion's scale or a constant",
        tolerance=0.5)
    add("av_lag_bias_geometric", ("smoothing", "noise", "damping", "mouth_damping", "constant_offset"),
        "must not react",
        "none of these moves the motion in time (the Gaussian filter is symmetric): the systematic lag stays 0",
        tolerance=0.5)
    add("av_confidence_geometric", ("time_shift", "time_advance"), "any",
        "a shifted track is as locked to the speech as the truth, only later; the confidence moves a little "
        "as the peak nears the edge of the +-15-frame search, so no claim")

    # ---- distribution (latent)
    for m in ("fd", "wind"):
        floor = {"tolerance": WIND_FLOOR} if m == "wind" else {}
        note = (f"; WInD up to its noise floor ({WIND_FLOOR:g}: its mixture fits differ even between two copies "
                "of one set)") if m == "wind" else ""
        add(m, ("noise", "noisy_samples", "damping", "mouth_damping", "smoothing"), "rises",
            "changes the distribution of the motion windows (amplitude, roughness)" + note, **floor)
        add(m, "constant_offset", "rises",
            "lifts the 71 % of frames that sit at 0 off the floor; FD reacts very strongly (FD of the truth "
            "+ 0.002 is recorded in every result as protocol.fd_floor_probe)" + note, **floor)
        add(m, ("time_shift", "time_advance"), "any",
            "compares the distribution of motion windows, not their timing against the audio: blind to a shift "
            "by construction (only the held edge frames differ); read the AV offset for sync")
        add(m, "sentence_swap", "any",
            "a swap keeps the set's motion statistics but the small test split's windows and the wrapped "
            "tracks' seams move the estimate; no claim")
    add("multimodality", "noisy_samples", "rises", _R_DIVERSITY)
    add("energy_latent", _ALL, "rises",
        "the energy score of the VAE window latents: the truth is the reference, and independent noise in "
        "the samples is penalised by the fair estimator (a proper scoring rule)")

    # ---- vertex metrics, both reference spaces
    for space in ("rig", "mesh"):
        reason = _R_NEAREST_RIG if space == "rig" else _R_NEAREST_MESH
        for m in ("lve", "lve_squared", "mve"):
            add(f"{m}_{space}", _ALL, "rises", reason)
        fdd = f"fdd_{space}"
        add(fdd, ("time_shift", "time_advance"), "must not react",
            "upper-face dynamics are a temporal standard deviation: a shift changes only the held edge frames",
            tolerance=1e-3)
        add(fdd, "damping", "rises", "a damped face moves less, so its dynamics fall away from the truth's")
        add(fdd, "mouth_damping", "rises", _R_LIMIT_FDD_MOUTH, known_limitation=True)
        add(fdd, "smoothing", "rises", "smoothing removes motion: the dynamics fall away from the truth's")
        for d in ("sentence_swap", "constant_offset"):
            add(fdd, d, "any", "changes the upper face's dynamics either way, by little; no claim")
        for p in ("apd", "upd", "lpd", "mpd"):
            add(f"{p}_{space}", "noisy_samples", "rises", _R_DIVERSITY)
    add("fdd_rig", ("noise", "noisy_samples"), "rises",
        "noise adds upper-face motion that the truth does not have")
    add("fdd_mesh", ("noise", "noisy_samples"), "falls",
        "KNOWN LIMITATION: FDD compares amounts of motion, not the motion; the meshes' upper face moves more "
        "than any 32-shape rig can (blinks, brows), so noise that adds upper-face motion brings a rig track's "
        "amount closer to the meshes' and FDD falls", known_limitation=True)
    add("energy_rig", _ALL, "rises",
        "the energy score against the truth itself: moving the samples away from it, or spreading them "
        "around it, is penalised (a proper scoring rule)")
    add("energy_mesh", [d for d in _ALL if d != "noisy_samples"], "rises", _R_NEAREST_MESH)
    add("energy_mesh", "noisy_samples", "any",
        "the rig reconstruction of the truth is itself about 0.6 mm from the meshes; a proper score rightly "
        "rewards sample spread up to that error, and penalises more: it first falls, then rises")
    # ---- dynamics: each region's motion against the truth's level (benchmark.evaluation.dynamics)
    for region in ("lips", "jaw", "upper"):
        ratio, close = f"motion_ratio_{region}", f"motion_closeness_{region}"
        add(ratio, "damping", "falls", "every coefficient scaled by 1 - level: the ratio is 1 - level exactly")
        add(close, ("damping", "smoothing"), "falls", "the motion falls below the truth's level")
        add(ratio, "smoothing", "falls", "a low-pass filter removes the fast part of the velocity")
        add(ratio, ("noise", "noisy_samples"), "rises",
            "i.i.d. noise adds frame-to-frame velocity the truth does not have")
        add(close, ("noise", "noisy_samples"), "falls",
            "the noisy motion rises above the truth's level (closeness is not clipped at 0: it keeps falling)")
        for m in (ratio, close):
            add(m, ("time_shift", "time_advance", "constant_offset"), "must not react",
                "the same motion at another time or lifted by a constant has the same velocity (only the k held "
                "edge frames, or frames clipped at 1, differ)", tolerance=0.01)
            add(m, "sentence_swap", "any",
                "other sentences' tracks keep the set's level roughly; whether a swap moves it up or down "
                "depends on which sentences are swapped, so no claim")
        if region == "upper":
            for m in (ratio, close):
                add(m, "mouth_damping", "must not react",
                    "mouth damping scales the jaw and mouth shapes only; the upper-face coefficients are untouched",
                    tolerance=1e-9)
        else:
            add(ratio, "mouth_damping", "falls", "the jaw and mouth shapes are scaled by 1 - level")
            add(close, "mouth_damping", "falls", "the jaw and mouth shapes are scaled by 1 - level")
    add("silent_lip_ratio", ("damping", "mouth_damping"), "falls",
        "the mouth's motion in the pauses is scaled with the rest of its motion")
    add("silent_lip_ratio", ("noise", "noisy_samples"), "rises",
        "noise moves the mouth where the speaker rests")
    add("silent_lip_ratio", ("time_shift", "time_advance"), "rises",
        "motion moved in time against the audio lands in the pauses: a lag or lead shows as a mouth that moves "
        "in the silences")
    add("silent_lip_ratio", "sentence_swap", "rises",
        "another sentence's motion is not silent where this audio is")
    add("silent_lip_ratio", "constant_offset", "must not react",
        "a constant does not move the mouth (frames clipped at 1 aside)", tolerance=0.01)
    add("silent_lip_ratio", "smoothing", "any",
        "a low-pass filter lowers the velocity in the pauses and also spreads speech motion into their edges; "
        "which wins depends on the pauses' lengths, so no claim")
    return _keyed(rows, lambda row: (row.metric, row.disturbance), "EXPECTATIONS")



def _keyed(items, key, name: str) -> dict:
    """``{key(item): item}``; ValueError naming ``name`` when a key is declared twice."""
    table = {}
    for item in items:
        if key(item) in table:
            raise ValueError(f"{name}: {key(item)} declared twice")
        table[key(item)] = item
    return table

#: ``(metric, disturbance) -> Expectation``: every declaration of the suite.
EXPECTATIONS = _table()

#: The reference rows of :data:`REFERENCE_CLAIMS`, in report order.
REFERENCE_ROWS = ("static", "ground_truth", "oracle_sample", "oracle_mean")
#: Reference claim kinds.
REFERENCE_KINDS = ("equals", "interval contains", "within interval of", "below")


@dataclass(frozen=True)
class ReferenceClaim:
    """What ``metric`` scores on the reference row ``row``, and why."""

    metric: str
    row: str
    expected: str
    target: float
    reason: str
    tolerance: float = 0.0

    def __post_init__(self):
        if self.expected not in REFERENCE_KINDS:
            raise ValueError(f"ReferenceClaim {self.metric}/{self.row}: unknown kind {self.expected!r}; expected one "
                             f"of {REFERENCE_KINDS}")
        if self.row not in REFERENCE_ROWS:
            raise ValueError(f"ReferenceClaim {self.metric}/{self.row}: unknown row; expected one of {REFERENCE_ROWS}")
        if not self.reason:
            raise ValueError(f"ReferenceClaim {self.metric}/{self.row}: a claim needs a reason")


def reference_verdict(claim: ReferenceClaim, entry) -> dict:
    """The entry of one (metric, reference row): ``mean``, ``ci95``, what was claimed and
    whether it held (``why`` when it did not). ``entry`` is the metric's result entry."""
    mean = float(entry["mean"])
    lo, hi = (float(v) for v in entry["ci95"])
    out = {"mean": mean, "ci95": [lo, hi], "expected": claim.expected, "target": float(claim.target),
           "ok": True, "reason": claim.reason}
    why = None
    if not all(math.isfinite(v) for v in (mean, lo, hi)):
        why = "a value is not finite"
    elif claim.expected == "equals":
        out["tolerance"] = float(claim.tolerance)
        if abs(mean - claim.target) > claim.tolerance:
            why = f"{mean:.6g}, declared {claim.target:g} +- {claim.tolerance:g}"
    elif claim.expected == "interval contains":
        if not lo <= claim.target <= hi:
            why = f"interval [{lo:.4g}, {hi:.4g}] does not contain {claim.target:g}"
    elif claim.expected == "within interval of":
        if abs(mean - claim.target) > hi - lo:
            why = f"{mean:.4g} is {abs(mean - claim.target):.4g} from {claim.target:g}, more than its interval's " \
                  f"width {hi - lo:.4g}"
    elif claim.expected == "below":
        if not hi < claim.target:
            why = f"interval [{lo:.4g}, {hi:.4g}] is not below {claim.target:g}"
    if why is not None:
        out["ok"] = False
        out["why"] = why
    return out


def _reference_claims() -> dict:
    claims = []
    static = "a face that never moves has no motion: ratio 0, closeness 0 exactly"
    truth = "the ground truth against itself: ratio 1, closeness 1 exactly"
    sample = ("the oracle samples are draws from the same conditional distribution as the ground truth: their "
              "level is the truth's up to the sampling error that the interval measures")
    mean = ("the mean of the oracle samples averages away the motion the audio does not determine: damped by "
            "design, so its level is below the truth's")
    for region in ("lips", "jaw", "upper"):
        ratio, close = f"motion_ratio_{region}", f"motion_closeness_{region}"
        claims += [ReferenceClaim(ratio, "static", "equals", 0.0, static),
                   ReferenceClaim(close, "static", "equals", 0.0, static),
                   ReferenceClaim(ratio, "ground_truth", "equals", 1.0, truth),
                   ReferenceClaim(close, "ground_truth", "equals", 1.0, truth),
                   ReferenceClaim(ratio, "oracle_sample", "interval contains", 1.0, sample),
                   ReferenceClaim(close, "oracle_sample", "within interval of", 1.0, sample),
                   ReferenceClaim(ratio, "oracle_mean", "below", 1.0, mean),
                   ReferenceClaim(close, "oracle_mean", "below", 1.0, mean)]
    claims += [ReferenceClaim("silent_lip_ratio", "static", "equals", 0.0, static),
               ReferenceClaim("silent_lip_ratio", "ground_truth", "equals", 1.0, truth),
               ReferenceClaim("silent_lip_ratio", "oracle_sample", "interval contains", 1.0, sample)]
    return _keyed(claims, lambda claim: (claim.metric, claim.row), "REFERENCE_CLAIMS")


#: ``(metric, reference row) -> ReferenceClaim``.
REFERENCE_CLAIMS = _reference_claims()

_NO_CLAIM = "no claim declared for this pair"


def declared(metric: str, disturbance: str, table=None) -> Expectation:
    """The declaration of ``(metric, disturbance)``, or an ``any`` without a claim."""
    table = EXPECTATIONS if table is None else table
    return table.get((metric, disturbance)) or Expectation(metric, disturbance, "any", _NO_CLAIM)
