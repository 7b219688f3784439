"""Metric metadata in one place: what each benchmark metric is called, measured in,
which direction is better, which group it belongs to and what its spread means.

Each metric family declares its metrics beside their computation (``METRICS`` of
:mod:`~benchmark.evaluation.lipsync`, :mod:`~benchmark.evaluation.vertex`,
:mod:`~benchmark.evaluation.latent`, :mod:`~benchmark.evaluation.dynamics`); this module gathers them into :data:`METRICS`. The evaluation builds every result entry from here,
the result files carry ``label`` and ``group``, the leaderboard orders and groups its
columns by it, and docs/metrics.md's table is checked against it. Groups and their
order follow the SAiD paper's Table 1: lip sync (AV offset, AV confidence), then the
distribution metrics (multimodality, FD, WInD), then the dynamics (each region's motion
against the ground truth's level: beside FD it says whether a distant row moves too
little or too much), then the vertex errors, the energy
score and the diversity measures. Every vertex metric comes in two reference spaces
(:data:`SPACES`: ``lve_mesh`` against the source meshes, ``lve_rig`` against the rig
reconstruction of the ground-truth coefficients), so coefficient and vertex rows are
read on one scale.
"""

from __future__ import annotations

from benchmark.evaluation import dynamics, latent, lipsync, vertex
from benchmark.evaluation.lipsync import ESTIMATORS
from benchmark.evaluation.vertex import SPACES
from benchmark.metrics.info import GROUPS, MetricInfo

__all__ = [
    "ESTIMATORS",
    "FAMILIES",
    "GROUPS",
    "METRICS",
    "SPACES",
    "MetricInfo",
    "markdown_table",
    "metric_entry",
    "metric_info",
    "ordered_metrics",
    "register_metric",
]

#: The metric families, in registration order (within a group, table order follows it).
FAMILIES = (lipsync, vertex, latent, dynamics)

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


def metric_entry(name: str, mean, std=None, **kw) -> dict:
    """A result entry for the registered metric ``name`` (:meth:`MetricInfo.entry`)."""
    return metric_info(name).entry(mean, std, **kw)


def ordered_metrics(names) -> list[str]:
    """``names`` in table order (group, then registration order); unregistered names last, sorted."""
    order = {name: i for i, name in enumerate(METRICS)}
    known = sorted((n for n in names if n in METRICS),
                   key=lambda n: (GROUPS.index(METRICS[n].group), order[n]))
    return known + sorted(n for n in names if n not in METRICS)


for _family in FAMILIES:
    for _info in _family.METRICS.values():
        register_metric(_info)
del _family, _info

_BETTER = {True: "higher", False: "lower"}


def markdown_table() -> str:
    """The registry as the Markdown table of docs/metrics.md (a test keeps the two equal)."""
    lines = ["| name | label | group | better | unit | spread (`std`) | needs S >= 2 |",
             "|---|---|---|---|---|---|---|"]
    for name in ordered_metrics(list(METRICS)):
        m = METRICS[name]
        better = _BETTER[m.higher_is_better] if m.higher_is_better is not None else f"closer to {m.ideal:g}"
        lines.append(f"| `{m.name}` | {m.label} | {m.group} | {better} | "
                     f"{m.unit} | {m.spread} | {'yes' if m.min_samples >= 2 else 'no'} |")
    return "\n".join(lines) + "\n"
