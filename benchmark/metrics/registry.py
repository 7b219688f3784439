"""Metric metadata in one place: what each benchmark metric is called, measured in,
which direction is better, which group it belongs to and what its spread means.

``benchmark.evaluate`` builds every result entry from here, the result files carry
``label`` and ``group``, the leaderboard orders and groups its columns by it, and
docs/metrics.md's table is checked against it. Groups and their order follow the
SAiD paper's Table 1: lip sync (AV offset, AV confidence), then the distribution
metrics (multimodality, FD, WInD), then the vertex errors and the diversity measures.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "GROUPS",
    "METRICS",
    "MetricInfo",
    "markdown_table",
    "metric_info",
    "ordered_metrics",
    "register_metric",
]

#: Groups in table order.
GROUPS = ("lip sync", "distribution", "vertex", "diversity")


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
    higher_is_better : bool
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
    higher_is_better: bool
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
for _info in (
    # lip sync: the paper's AV offset / confidence (SyncNet on renders), a learned
    # coefficient-space expert, and the weight-free geometric estimate
    MetricInfo("av_offset_syncnet", "AV offset (SyncNet)", "frames@25fps", False, "lip sync",
               "std over sentences (first sample)"),
    MetricInfo("av_confidence_syncnet", "AV conf. (SyncNet)", "distance", True, "lip sync",
               "std over sentences (first sample)"),
    MetricInfo("av_offset_expert", "AV offset (expert)", "frames@60fps", False, "lip sync", _SENT),
    MetricInfo("av_confidence_expert", "AV conf. (expert)", "score", True, "lip sync", _SENT),
    MetricInfo("av_offset_geometric", "AV offset (geom.)", "frames@60fps", False, "lip sync", _SENT),
    MetricInfo("av_confidence_geometric", "AV conf. (geom.)", "correlation", True, "lip sync", _SENT),
    # distribution, on VAE features of 120-frame windows
    MetricInfo("multimodality", "Multimodality", "latent", True, "distribution",
               "std of the pair distances", min_samples=2, level="set"),
    MetricInfo("fd", "FD", "latent^2", False, "distribution", "none (one value for the set)", level="set"),
    MetricInfo("wind", "WInD", "latent^2", False, "distribution", "std over GMM refits", level="set"),
    # vertex errors against the ground-truth meshes
    MetricInfo("lve", "LVE", "mm", False, "vertex", _SENT),
    MetricInfo("lve_squared", "LVE (sq.)", "mm^2", False, "vertex", _SENT),
    MetricInfo("mve", "MVE", "mm", False, "vertex", _SENT),
    MetricInfo("fdd", "FDD (abs.)", "mm^2", False, "vertex", _SENT),
    # diversity between samples of the same audio
    MetricInfo("apd", "APD", "mm", True, "diversity", _SENT, min_samples=2),
    MetricInfo("upd", "UPD", "mm", True, "diversity", _SENT, min_samples=2),
    MetricInfo("lpd", "LPD", "mm", True, "diversity", _SENT, min_samples=2),
    MetricInfo("mpd", "MPD", "mm", True, "diversity", _SENT, min_samples=2),
):
    register_metric(_info)
del _info


def markdown_table() -> str:
    """The registry as the Markdown table of docs/metrics.md (a test keeps the two equal)."""
    lines = ["| name | label | group | better | unit | spread (`std`) | needs S >= 2 |",
             "|---|---|---|---|---|---|---|"]
    for name in ordered_metrics(list(METRICS)):
        m = METRICS[name]
        lines.append(f"| `{m.name}` | {m.label} | {m.group} | {'higher' if m.higher_is_better else 'lower'} | "
                     f"{m.unit} | {m.spread} | {'yes' if m.min_samples >= 2 else 'no'} |")
    return "\n".join(lines) + "\n"
