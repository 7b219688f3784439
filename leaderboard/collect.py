"""Reading result files and arranging them into per-dataset tables."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from benchmark.results import read_result

__all__ = ["Row", "Table", "column_decimals", "load_results", "ranks", "tables_by_manifest"]


@dataclass
class Row:
    """One method's line: label and ``{metric: (mean, std or None)}``."""

    label: str
    reference: bool
    samples: int
    metrics: dict = field(default_factory=dict)


@dataclass
class Table:
    """All results on one dataset manifest."""

    manifest_hash: str
    split: str
    num_sentences: int | None
    metrics: list  # [(name, higher_is_better, unit)] sorted by name
    rows: list  # [Row], references first, then methods, each sorted by label


def load_results(results_dir) -> list[dict]:
    """Every ``*.json`` result in ``results_dir`` (sorted by file name), schema-checked."""
    results_dir = Path(results_dir)
    if not results_dir.is_dir():
        raise FileNotFoundError(f"results directory {results_dir} does not exist")
    return [read_result(path) for path in sorted(results_dir.glob("*.json"))]


def tables_by_manifest(results: list[dict]) -> list[Table]:
    """One :class:`Table` per dataset manifest hash, so that numbers from different
    data never share a table. Tables are sorted by manifest hash.

    Raises
    ------
    ValueError
        Two results on one manifest disagree on a metric's direction or unit.
    """
    groups: dict[str, list[dict]] = {}
    for result in results:
        groups.setdefault(result["dataset"]["manifest_hash"], []).append(result)
    tables = []
    for manifest_hash in sorted(groups):
        group = groups[manifest_hash]
        metrics: dict[str, tuple] = {}
        for result in group:
            for name, fields in result["metrics"].items():
                spec = (fields["higher_is_better"], fields.get("unit") or "")
                if metrics.setdefault(name, spec) != spec:
                    raise ValueError(
                        f"manifest {manifest_hash}: metric {name!r} has direction/unit {metrics[name]} in one result "
                        f"and {spec} in {result['method'].get('label')!r}"
                    )
        labels = [r["method"].get("label") or r["method"]["name"] for r in group]
        rows = []
        for result, label in zip(group, labels):
            protocol = result["protocol"]
            if labels.count(label) > 1:
                label = f"{label} (S={protocol.get('samples')}, seed {protocol.get('seed')})"
            rows.append(Row(
                label=label,
                reference=bool(result["method"].get("reference", False)),
                samples=int(protocol.get("samples") or 1),
                metrics={k: (v["mean"], v.get("std")) for k, v in result["metrics"].items()},
            ))
        rows.sort(key=lambda r: (not r.reference, r.label.lower(), r.label))
        splits = sorted({r["dataset"].get("split", "test") for r in group})
        counts = sorted({r["dataset"].get("num_sentences") for r in group if r["dataset"].get("num_sentences")})
        tables.append(Table(
            manifest_hash=manifest_hash,
            split="/".join(splits),
            num_sentences=counts[0] if len(counts) == 1 else None,
            metrics=[(name, hib, unit) for name, (hib, unit) in sorted(metrics.items())],
            rows=rows,
        ))
    return tables


def column_decimals(values) -> int:
    """Decimals shown for a metric column (1 to 4): three significant digits of its
    largest value, and at least two of its smallest non-zero one."""
    finite = [abs(v) for v in values if v is not None and math.isfinite(v) and v != 0]
    if not finite:
        return 2
    largest = 2 - math.floor(math.log10(max(finite)))
    smallest = 1 - math.floor(math.log10(min(finite)))
    return int(min(4, max(1, largest, smallest)))


def ranks(values, higher_is_better, decimals: int) -> list:
    """Rank (1 = best) of each value among the non-None ones, compared at the shown
    precision so that equal-looking numbers share a rank; None where unranked.

    Parameters
    ----------
    values : list of float or None
    higher_is_better : bool or None
        None: the metric has no direction, nothing is ranked.
    decimals : int
    """
    if higher_is_better is None:
        return [None] * len(values)
    shown = [None if v is None else round(v, decimals) for v in values]
    distinct = sorted({v for v in shown if v is not None}, reverse=bool(higher_is_better))
    return [None if v is None else distinct.index(v) + 1 for v in shown]
