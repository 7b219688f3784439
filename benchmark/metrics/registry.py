"""Metric metadata in one place: what each benchmark metric is called, measured in,
which direction is better, which group it belongs to and what its spread means.

``benchmark.evaluate`` builds every result entry from here, the result files carry
``label`` and ``group``, the leaderboard orders and groups its columns by it, and
docs/metrics.md's table is checked against it. Groups and their order follow the
SAiD paper's Table 1: lip sync (AV offset, AV confidence), then the distribution
metrics (multimodality, FD, WInD), then the vertex errors, the energy score and the
diversity measures. Every vertex metric comes in two reference spaces (:data:`SPACES`:
``lve_mesh`` against the source meshes, ``lve_rig`` against the rig reconstruction of the
ground-truth coefficients), so coefficient and vertex rows are read on one scale.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "ESTIMATORS",
    "GROUPS",
    "METRICS",
    "SPACES",
    "MetricInfo",
    "markdown_table",
    "metric_info",
    "ordered_metrics",
    "register_metric",
]

#: Groups in table order.
GROUPS = ("lip sync", "distribution", "vertex", "energy", "diversity")


@dataclass(frozen=True)
class MetricInfo:
    """One metric's metadata.

    Attributes
    ----------
    name : str
        Key in result files (``lve``).
    label : str
        Column header (``LVE``).
    unit : str
    higher_is_better : bool or None
        None: neither direction is better (a signed offset; closer to 0 is better for
        a lag bias): no best mark.
    group : str
        One of :data:`GROUPS`.
    spread : str
        What the entry's ``std`` is.
    min_samples : int
        Samples per sentence the metric needs (2 for the diversity measures).
    level : {"sentence", "set"}
        ``"sentence"``: a value per sentence, averaged (per-sentence rows, bootstrap
        of the mean); ``"set"``: one value for the generated set (bootstrap over
        its sentences).
    """

    name: str
    label: str
    unit: str
    higher_is_better: bool | None
    group: str
    spread: str
    min_samples: int = 1
    level: str = "sentence"

    def __post_init__(self):
        if self.group not in GROUPS:
            raise ValueError(f"MetricInfo {self.name!r}: group must be one of {GROUPS}, got {self.group!r}")
        if self.level not in ("sentence", "set"):
            raise ValueError(f"MetricInfo {self.name!r}: level must be 'sentence' or 'set', got {self.level!r}")


#: name -> MetricInfo, in table order within each group.
METRICS: dict[str, MetricInfo] = {}


def register_metric(info: MetricInfo, *, replace: bool = False) -> MetricInfo:
    """Add ``info`` to :data:`METRICS` (``replace=True`` to redefine one)."""
    if info.name in METRICS and not replace:
        raise ValueError(f"register_metric: {info.name!r} is already registered")
    METRICS[info.name] = info
    return info


def metric_info(name: str) -> MetricInfo:
    """The registered metric ``name``; KeyError listing the known names otherwise."""
    try:
        return METRICS[name]
    except KeyError:
        raise KeyError(f"unknown metric {name!r}; registered: {sorted(METRICS)}") from None


def ordered_metrics(names) -> list[str]:
    """``names`` in table order (group, then registration order); unregistered names last, sorted."""
    order = {name: i for i, name in enumerate(METRICS)}
    known = sorted((n for n in names if n in METRICS),
                   key=lambda n: (GROUPS.index(METRICS[n].group), order[n]))
    return known + sorted(n for n in names if n not in METRICS)


_SENT = "std over sentences"
_FIRST = "std over sentences (first sample)"

#: The two reference spaces of every vertex metric (suffix -> what it is compared with).
SPACES = {
    "mesh": "the source meshes (coefficient rows through each speaker's rig)",
    "rig": "the rig reconstruction of the ground-truth coefficients (vertex rows through their coefficient fit)",
}
#: Lip-sync estimators, in table order: the paper's SyncNet on renders, a learned
#: coefficient-space expert, and the weight-free geometric estimate.
ESTIMATORS = {"syncnet": ("SyncNet", "frames@25fps", _FIRST), "expert": ("expert", "frames@60fps", _SENT),
              "geometric": ("geom.", "frames@60fps", _SENT)}
_CONFIDENCE = {"syncnet": "distance", "expert": "distance", "geometric": "correlation"}


def _lipsync_metrics():
    for est, (short, unit, spread) in ESTIMATORS.items():
        yield MetricInfo(f"av_offset_{est}", f"AV offset ({short})", unit, False, "lip sync",
                         spread + "; mean of the absolute offsets")
        yield MetricInfo(f"av_confidence_{est}", f"AV conf. ({short})", _CONFIDENCE[est], True, "lip sync", spread)
        yield MetricInfo(f"av_offset_signed_{est}", f"AV offset signed ({short})", unit, None, "lip sync",
                         spread + "; + = motion after audio")
        yield MetricInfo(f"av_lag_bias_{est}", f"AV lag bias ({short})", unit, None, "lip sync",
                         spread + "; signed offset minus the ground truth's")


def _vertex_metrics():
    for space in SPACES:
        yield MetricInfo(f"lve_{space}", f"LVE {space}", "mm", False, "vertex", _SENT)
        yield MetricInfo(f"lve_squared_{space}", f"LVE (sq.) {space}", "mm^2", False, "vertex", _SENT)
        yield MetricInfo(f"mve_{space}", f"MVE {space}", "mm", False, "vertex", _SENT)
        yield MetricInfo(f"fdd_{space}", f"FDD (abs.) {space}", "mm^2", False, "vertex", _SENT)
    for space in SPACES:
        yield MetricInfo(f"energy_{space}", f"Energy {space}", "mm", False, "energy", _SENT)
    yield MetricInfo("energy_latent", "Energy latent", "latent", False, "energy", _SENT + " (mean over windows)")
    for space in SPACES:
        for name in ("apd", "upd", "lpd", "mpd"):
            yield MetricInfo(f"{name}_{space}", f"{name.upper()} {space}", "mm", True, "diversity", _SENT,
                             min_samples=2)


for _info in (
    *_lipsync_metrics(),
    # distribution, on VAE features of 120-frame windows
    MetricInfo("multimodality", "Multimodality", "latent", True, "distribution",
               "std of the pair distances", min_samples=2, level="set"),
    MetricInfo("fd", "FD", "latent^2", False, "distribution", "none (one value for the set)", level="set"),
    MetricInfo("wind", "WInD", "latent^2", False, "distribution", "std over GMM refits", level="set"),
    *_vertex_metrics(),
):
    register_metric(_info)
del _info

_BETTER = {True: "higher", False: "lower", None: "closer to 0"}


def markdown_table() -> str:
    """The registry as the Markdown table of docs/metrics.md (a test keeps the two equal)."""
    lines = ["| name | label | group | better | unit | spread (`std`) | needs S >= 2 |",
             "|---|---|---|---|---|---|---|"]
    for name in ordered_metrics(list(METRICS)):
        m = METRICS[name]
        lines.append(f"| `{m.name}` | {m.label} | {m.group} | {_BETTER[m.higher_is_better]} | "
                     f"{m.unit} | {m.spread} | {'yes' if m.min_samples >= 2 else 'no'} |")
    return "\n".join(lines) + "\n"
