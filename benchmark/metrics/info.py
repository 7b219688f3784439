"""What one benchmark metric is: :class:`MetricInfo` (name, label, unit, direction,
group, spread) and the entry a result file keeps for it (:meth:`MetricInfo.entry`).

Each metric family of :mod:`benchmark.evaluation` declares its metrics with this
class beside their computation; :mod:`benchmark.evaluation.registry` gathers them.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["GROUPS", "MetricInfo", "declared"]

#: Groups in table order.
GROUPS = ("lip sync", "distribution", "dynamics", "vertex", "energy", "diversity")


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
    ideal : float
        The best value of a metric without a better direction (``higher_is_better``
        None): 0 for an offset or a lag bias, 1 for a ratio to the ground truth's level.
    """

    name: str
    label: str
    unit: str
    higher_is_better: bool | None
    group: str
    spread: str
    min_samples: int = 1
    level: str = "sentence"
    ideal: float = 0.0

    def __post_init__(self):
        if self.group not in GROUPS:
            raise ValueError(f"MetricInfo {self.name!r}: group must be one of {GROUPS}, got {self.group!r}")
        if self.level not in ("sentence", "set"):
            raise ValueError(f"MetricInfo {self.name!r}: level must be 'sentence' or 'set', got {self.level!r}")

    def entry(self, mean, std=None, *, ci95=None, n=None, sample_std=None, **extra) -> dict:
        """This metric's result entry: ``{"mean", "std", "ci95", "n", "higher_is_better",
        "unit", "label", "group"[, "sample_std"]}`` plus ``extra``."""
        mean = float(mean)
        entry = {"mean": mean, "std": None if std is None else float(std),
                 "ci95": [mean, mean] if ci95 is None else [float(ci95[0]), float(ci95[1])],
                 "n": None if n is None else int(n), "higher_is_better": self.higher_is_better, "unit": self.unit,
                 "label": self.label, "group": self.group}
        if sample_std is not None:
            entry["sample_std"] = float(sample_std)
        entry.update(extra)
        return entry


def declared(*infos: MetricInfo) -> dict[str, MetricInfo]:
    """``{name: info}`` of a family's declarations, in their order (a name twice is an error)."""
    table: dict[str, MetricInfo] = {}
    for info in infos:
        if info.name in table:
            raise ValueError(f"metric {info.name!r} is declared twice")
        table[info.name] = info
    return table
