"""Reading result files and arranging them into per-dataset tables.

Columns are the metrics of the results, grouped and ordered by the metric registry
(:mod:`benchmark.metrics.registry`: lip sync, distribution, vertex, diversity, as in
the SAiD paper's Table 1); rows are the methods, and the reference rows (ground
truth, corpus meshes, mean, static, random) apart, never ranked.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from benchmark.metrics.registry import METRICS, ordered_metrics
from benchmark.results import read_result
from blendvoca.errors import DataError, UserError

__all__ = ["Column", "Row", "Table", "best_rows", "column_decimals", "load_results", "ranks", "tables_by_manifest"]

#: Group of metrics the registry does not know.
OTHER_GROUP = "other"


@dataclass(frozen=True)
class Column:
    """One metric column."""

    name: str
    label: str
    unit: str
    higher_is_better: bool | None
    group: str


@dataclass
class Row:
    """One method's line: ``metrics[name] = (mean, std or None, ci95 [lo, hi] or None)``."""

    label: str
    reference: bool
    samples: int
    metrics: dict = field(default_factory=dict)
    output: str = "coefficients"
    #: Position of the row's result in the list given to :func:`tables_by_manifest`.
    source: int | None = None


@dataclass
class Table:
    """All results on one dataset manifest."""

    manifest_hash: str
    split: str
    num_sentences: int | None
    columns: list  # [Column] in registry order
    rows: list  # [Row] methods, sorted by label
    references: list  # [Row] reference rows, sorted by label

    @property
    def groups(self) -> list:
        """``[(group, [Column])]`` in table order."""
        out = []
        for column in self.columns:
            if not out or out[-1][0] != column.group:
                out.append((column.group, []))
            out[-1][1].append(column)
        return out


def load_results(results_dir) -> list[dict]:
    """Every ``*.json`` result in ``results_dir`` (str or os.PathLike; sorted by file name), schema-checked.

    Raises
    ------
    UserError
        ``results_dir`` is not a folder.
    DataError
        A file that is not a result (not JSON, off the schema, or holding a field the
        tables read with the wrong type); the message names the file.
    """
    results_dir = Path(results_dir)
    if not results_dir.is_dir():
        raise UserError(f"results directory {results_dir} does not exist")
    return [_tabulable(read_result(path), path) for path in sorted(results_dir.glob("*.json"))]


def _tabulable(result: dict, path: Path) -> dict:
    """``result`` unchanged when the fields the tables read have their types (the schema
    check leaves some free); DataError naming ``path`` and the field otherwise."""
    expected = (
        ("dataset", "manifest_hash", str, False),
        ("dataset", "split", str, True),
        ("dataset", "num_sentences", int, True),
        ("method", "name", str, False),
        ("method", "label", str, True),
        ("method", "output", str, True),
        ("protocol", "samples", int, True),
        ("protocol", "seed", int, True),
    )
    for section, key, kind, optional in expected:
        value = result[section].get(key)
        if value is None and (optional or key not in result[section]):
            continue
        if isinstance(value, bool) or not isinstance(value, kind):
            raise DataError(f"{path}: {section}.{key}: expected {'an integer' if kind is int else 'a string'}, "
                            f"got {value!r}")
    return result


def _column(name: str, fields: dict) -> Column:
    info = METRICS.get(name)
    if info is not None:
        return Column(name, info.label, info.unit, info.higher_is_better, info.group)
    return Column(name, fields.get("label") or name, fields.get("unit") or "", fields["higher_is_better"],
                  OTHER_GROUP)


def tables_by_manifest(results: list[dict]) -> list[Table]:
    """One :class:`Table` per dataset manifest hash, so that numbers from different
    data never share a table. Tables are sorted by manifest hash.

    Raises
    ------
    DataError
        Two results on one manifest disagree on a metric's direction or unit.
    """
    groups: dict[str, list[tuple[int, dict]]] = {}
    for index, result in enumerate(results):
        groups.setdefault(result["dataset"]["manifest_hash"], []).append((index, result))
    tables = []
    for manifest_hash in sorted(groups):
        sources = [index for index, _ in groups[manifest_hash]]
        group = [result for _, result in groups[manifest_hash]]
        specs: dict[str, tuple] = {}
        columns: dict[str, Column] = {}
        for result in group:
            for name, fields in result["metrics"].items():
                spec = (fields["higher_is_better"], fields.get("unit") or "")
                if specs.setdefault(name, spec) != spec:
                    raise DataError(
                        f"manifest {manifest_hash}: metric {name!r} has direction/unit {specs[name]} in one result "
                        f"and {spec} in {result['method'].get('label')!r}"
                    )
                columns.setdefault(name, _column(name, fields))
        labels = [r["method"].get("label") or r["method"]["name"] for r in group]
        rows = []
        for source, result, label in zip(sources, group, labels):
            protocol = result["protocol"]
            if labels.count(label) > 1:
                label = f"{label} (S={protocol.get('samples')}, seed {protocol.get('seed')})"
            rows.append(Row(
                label=label,
                reference=bool(result["method"].get("reference", False)),
                samples=int(protocol.get("samples") or 1),
                metrics={k: (v["mean"], v.get("std"), v.get("ci95")) for k, v in result["metrics"].items()},
                output=result["method"].get("output", "coefficients"),
                source=source,
            ))
        rows.sort(key=lambda r: (r.label.lower(), r.label))
        splits = sorted({r["dataset"].get("split", "test") for r in group})
        counts = sorted({r["dataset"].get("num_sentences") for r in group if r["dataset"].get("num_sentences")})
        known = ordered_metrics([n for n in columns if n in METRICS])
        other = sorted(n for n in columns if n not in METRICS)
        tables.append(Table(
            manifest_hash=manifest_hash,
            split="/".join(splits),
            num_sentences=counts[0] if len(counts) == 1 else None,
            columns=[columns[n] for n in known + other],
            rows=[r for r in rows if not r.reference],
            references=[r for r in rows if r.reference],
        ))
    return tables


def column_decimals(values) -> int:
    """Decimals shown for a metric column (1 to 4): three significant digits of its
    largest value, and at least two of its smallest non-zero one (numerical zeros, below
    1e-6 of the largest, are ignored)."""
    finite = [abs(v) for v in values if v is not None and math.isfinite(v) and v != 0]
    if finite:  # values below 1e-6 of the column's largest are numerical zeros (e.g. FD -5e-7)
        finite = [v for v in finite if v >= 1e-6 * max(finite)]
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


def best_rows(rows: list, column: Column) -> set:
    """Indices of the rows marked best in ``column``: the method with the best mean,
    when its 95 % interval does not overlap the runner-up's (every other method's
    interval then lies beyond it too, or is further away in mean). Nothing is marked
    with fewer than two methods, without a direction, or when an interval is missing.

    Non-overlap of two 95 % intervals is a conservative test of a difference (it
    implies p < 0.05 for independent estimates) that needs nothing but the result
    files; a paired test would need both runs' per-sentence rows.
    """
    if column.higher_is_better is None:
        return set()
    scored = [(i, row.metrics[column.name]) for i, row in enumerate(rows) if column.name in row.metrics]
    if len(scored) < 2:
        return set()
    sign = -1.0 if column.higher_is_better else 1.0
    scored.sort(key=lambda item: sign * item[1][0])
    (best, (_, _, ci_best)), (_, (_, _, ci_next)) = scored[0], scored[1]
    if ci_best is None or ci_next is None:
        return set()
    separated = ci_best[0] > ci_next[1] if column.higher_is_better else ci_best[1] < ci_next[0]
    return {best} if separated else set()
