"""Build report (Markdown + PNG figures in ``report/``) and the values of ``coeffs_std.csv``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from blendvoca.format.items import read_coeffs, read_oracle_coeffs
from blendvoca.format.layout import REPORT_DIR, report_dir
from blendvoca.io.atomic import atomic_write

#: Shapes plotted against the lip aperture, when present.
TRACK_SHAPES = ("jawOpen", "mouthClose", "mouthFunnel", "mouthPucker")


def coeffs_std(tracks) -> np.ndarray:
    """Per-blendshape temporal standard deviation over all frames of all tracks.

    Parameters
    ----------
    tracks : sequence of (T_i, K) ndarray

    Returns
    -------
    (K,) ndarray
        Population standard deviation (ddof 0) of the concatenated frames.
    """
    stacked = np.concatenate([np.asarray(t, dtype=np.float64) for t in tracks], axis=0)
    return stacked.std(axis=0)


def _pyplot():
    """``matplotlib.pyplot`` on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save_figure(fig, path):
    """Write ``fig`` as a PNG at ``path`` and close it."""
    # No metadata: identical builds give identical PNG bytes.
    with atomic_write(path, "wb") as f:
        fig.savefig(f, format="png", dpi=90, metadata={"Software": None})
    _pyplot().close(fig)


def _usage_figure(path, names, usage, activity):
    plt = _pyplot()
    x = np.arange(len(names))
    fig, axes = plt.subplots(2, 1, figsize=(11, 6), sharex=True)
    axes[0].bar(x, usage, color="tab:blue")
    axes[0].set_ylabel("mean coefficient")
    axes[0].set_title("Coefficient usage per blendshape (all sentences)")
    width = 0.27
    for i, (kind, color) in enumerate((("lower", "tab:gray"), ("upper", "tab:red"), ("rate", "tab:orange"))):
        axes[1].bar(x + (i - 1) * width, activity[kind], width, label=kind, color=color)
    axes[1].set_ylabel("fraction active")
    axes[1].set_title("Constraint activity per blendshape")
    axes[1].legend()
    axes[1].set_xticks(x)
    axes[1].set_xticklabels(names, rotation=70, fontsize=7)
    fig.tight_layout()
    _save_figure(fig, path)


def tracks_against_figure(path, panels) -> None:
    """``path`` (PNG): one panel per ``(title, coeffs (T, K), shapes, signal (T,), signal label, unit)``
    of ``panels``: the shapes' tracks (left axis) and a signal of the same frames (right axis, dashed),
    on one 60 fps time axis."""
    plt = _pyplot()
    fig, axes = plt.subplots(len(panels), 1, figsize=(10, 2.6 * len(panels)), squeeze=False)
    for ax, (title, coeffs, shapes, signal, label, unit) in zip(axes[:, 0], panels):
        t = np.arange(coeffs.shape[0]) / 60.0
        for j, shape in enumerate(shapes):
            ax.plot(t, coeffs[:, j], label=shape, lw=1.2)
        ax.set_ylim(-0.02, 1.02)
        ax.set_ylabel("coefficient")
        ax.set_title(title, fontsize=9)
        ax2 = ax.twinx()
        ax2.plot(t, signal, color="black", ls="--", lw=1.0, label=label)
        ax2.set_ylabel(f"{label} ({unit})")
        lines = ax.get_lines() + ax2.get_lines()
        ax.legend(lines, [ln.get_label() for ln in lines], fontsize=7, loc="upper right", ncol=3)
    axes[-1, 0].set_xlabel("time (s)")
    fig.tight_layout()
    _save_figure(fig, path)


def _tracks_figure(path, out, items, names):
    shapes = [s for s in TRACK_SHAPES if s in names]
    tracks_against_figure(path, [(f"{subject} {sentence}", read_coeffs(out, subject, sentence, names=shapes)[0],
                                  shapes, rec["stats"]["lip_aperture_mm"], "lip aperture", "mm")
                                 for (subject, sentence), rec in items])


def measured_share(out, splits: dict, items, names, *, count: int, declared: dict) -> dict:
    """The audio-determined share measured on the fitted tracks of a synthetic corpus.

    With the ground truth and the K fitted oracle samples of every sentence (K + 1
    draws of the motion given the audio and the speaker), the share of a speaker's
    speech-shape coefficient variance that the inputs determine is
    ``1 - E[Var(coeffs | audio, speaker)] / E[Var(coeffs | speaker)]``: the pooled
    within-sentence variance (``ddof=1`` over the draws, summed over the
    coefficients) over the pooled variance of each speaker's ground-truth frames
    about that speaker's mean (so the figure does not grow with the number of
    speakers pooled; the differences between speakers are the speaker id's and
    determined anyway). Also the share of the test split's variance (about its
    mean) that ``oracle-mean`` (the mean of the K samples) explains,
    ``1 - SS(truth - mean) / SS(truth - its mean)``, which is lower by about
    ``(1 - share) / K`` (the Monte-Carlo mean's own variance) and higher by the
    test speakers' differences.

    Parameters
    ----------
    out : path
        The build.
    splits : dict
        Split name -> subjects.
    items : sequence of (subject, sentence)
        Sentences with their oracle tracks fitted.
    names : sequence of str
    count : int
        K.
    declared : dict
        ``{"declared": F, "oracle_samples": K}`` from the corpus.

    Returns
    -------
    dict
        ``declared``, ``oracle_samples``, ``measured`` / ``measured_test`` / ``oracle_mean_test``
        (None without oracle tracks), ``sentences``.
    """
    result = {"declared": declared.get("declared"), "oracle_samples": declared.get("oracle_samples"),
              "measured": None, "measured_test": None, "oracle_mean_test": None, "sentences": len(items)}
    if not items or not count or not names:
        return result
    test = set(splits.get("test", ()))
    within = {"all": 0.0, "test": 0.0}
    truths = {"all": {}, "test": {}}
    means = []
    for subject, sentence in items:
        truth, _ = read_coeffs(out, subject, sentence, names=names)
        draws = [truth] + [read_oracle_coeffs(out, subject, sentence, k, names=names)[0] for k in range(count)]
        t = min(len(d) for d in draws)
        stack = np.stack([np.asarray(d[:t], dtype=np.float64) for d in draws])
        groups = ("all", "test") if subject in test else ("all",)
        for g in groups:
            within[g] += float(stack.var(axis=0, ddof=1).sum())
            truths[g].setdefault(subject, []).append(stack[0])
        if subject in test:
            means.append((stack[0], stack[1:].mean(axis=0)))

    def share(g):
        if not truths[g] or count < 1:
            return None
        per_speaker = [np.concatenate(tracks) for tracks in truths[g].values()]
        total = sum(float(((y - y.mean(axis=0)) ** 2).sum()) for y in per_speaker)
        return None if total <= 0 else 1.0 - within[g] / total

    result["measured"], result["measured_test"] = share("all"), share("test")
    if means:
        y = np.concatenate([a for a, _ in means])
        m = np.concatenate([b for _, b in means])
        total = float(((y - y.mean(axis=0)) ** 2).sum())
        result["oracle_mean_test"] = None if total <= 0 else 1.0 - float(((y - m) ** 2).sum()) / total
    return result


def _share_lines(share: dict) -> list[str]:
    lines = ["## Audio-determined share", "",
             f"The synthetic corpus declares F = {share['declared']:g} (`--audio-determined`): the share of the "
             "speech shapes' coefficient variance that the inputs (audio, speaker id) determine."]
    if share.get("measured") is None:
        lines += ["Not measured: the corpus has no oracle samples (generate it with `--oracle-samples K`).", ""]
        return lines

    def fmt(v):
        return "-" if v is None else f"{v:.3f}"

    lines += [f"Measured on the fitted tracks, from the ground truth and {share['oracle_samples']} oracle samples "
              f"of each of {share['sentences']} sentences (1 - pooled within-sentence variance / pooled "
              "within-speaker variance): "
              f"**{fmt(share['measured'])}** (test split: {fmt(share['measured_test'])}); share of the test "
              f"split's variance that oracle-mean explains: {fmt(share['oracle_mean_test'])} (lower by about "
              "(1 - F) / K: the mean of K samples keeps 1/K of their variance).", ""]
    return lines


def report_markdown(records: dict, names, failures, params, *, figures=(), warnings=(), share=None) -> str:
    """Return the report text.

    Parameters
    ----------
    records : dict
        ``{(subject, sentence): record}`` of successful sentences (``record["stats"]``).
    names : sequence of str
        Coefficient names.
    failures : list of dict
    params : dict
    figures : sequence of (title, relative path)
    warnings : sequence of dict
        ``{"subject", "sentence", "message"}`` of implausible inputs built all the same.
    share : dict, optional
        A synthetic corpus's audio-determined share (:func:`measured_share`); None
        (VOCASET, older synthetic corpora): no such section.
    """
    lines = ["# BlendVOCA build report", ""]
    lines.append(f"Parameters: shapes = {params.get('shapes')}, delta = {params.get('delta')}. "
                 "Errors are in millimetres, measured on the fitted head vertices; "
                 "RMSE is the per-frame root mean square vertex error averaged over frames, "
                 "max is the largest vertex error in any frame.")
    lines.append("")
    subjects = sorted({s for s, _ in records})
    lines += [f"Fitted sentences: {len(records)} of {len(subjects)} speakers; failures: {len(failures)}.", "",
              "Stage timings of the latest build that did work: [timings.md](timings.md) (not in the "
              "manifest: they change from run to run).", ""]
    if failures:
        lines += ["## Failures", "", "| speaker | sentence | stage | reason |", "|---|---|---|---|"]
        for f in failures:
            reason = str(f["reason"]).replace("|", "\\|").replace("\n", " ")
            lines.append(f"| {f['subject']} | {f['sentence'] or '-'} | {f['stage']} | {reason} |")
        lines.append("")
    if warnings:
        lines += ["## Warnings", "", "Built all the same; check these inputs.", "",
                  "| speaker | sentence | warning |", "|---|---|---|"]
        for w in warnings:
            message = str(w["message"]).replace("|", "\\|").replace("\n", " ")
            lines.append(f"| {w['subject']} | {w['sentence'] or '-'} | {message} |")
        lines.append("")
    if share is not None:
        lines += _share_lines(share)
    lines += ["## Per speaker", "", "| speaker | sentences | frames | RMSE mm (mean) | max error mm |",
              "|---|---:|---:|---:|---:|"]
    for subject in subjects:
        recs = [r["stats"] for (s, _), r in sorted(records.items()) if s == subject]
        frames = sum(r["frames"] for r in recs)
        rmse = sum(r["rmse_mm"] * r["frames"] for r in recs) / max(frames, 1)
        lines.append(f"| {subject} | {len(recs)} | {frames} | {rmse:.3f} | "
                     f"{max(r['max_error_mm'] for r in recs):.3f} |")
    lines += ["", "## Per sentence", "",
              "| speaker | sentence | frames | RMSE mm | max error mm | at 0 % | at 1 % | rate-limited % | solver |",
              "|---|---|---:|---:|---:|---:|---:|---:|---|"]
    for (subject, sentence), rec in sorted(records.items()):
        st = rec["stats"]
        a = st["active"]
        lines.append(f"| {subject} | {sentence} | {st['frames']} | {st['rmse_mm']:.3f} | {st['max_error_mm']:.3f} | "
                     f"{100 * a['lower']:.1f} | {100 * a['upper']:.1f} | {100 * a['rate']:.2f} | {st['solver']} |")
    if records:
        usage, activity = _aggregate(records)
        lines += ["", "## Coefficient usage and constraint activity per blendshape", "",
                  "Mean coefficient over all frames; fraction of frames at each bound and of "
                  "frame transitions at the rate limit.", "",
                  "| blendshape | mean | at 0 | at 1 | rate-limited |", "|---|---:|---:|---:|---:|"]
        for j, name in enumerate(names):
            lines.append(f"| {name} | {usage[j]:.4f} | {activity['lower'][j]:.3f} | "
                         f"{activity['upper'][j]:.3f} | {activity['rate'][j]:.4f} |")
    for title, rel in figures:
        lines += ["", f"## {title}", "", f"![{title}]({rel})"]
    return "\n".join(lines) + "\n"


def _aggregate(records):
    weights = np.array([r["stats"]["frames"] for r in records.values()], dtype=np.float64)
    usage = np.array([r["stats"]["usage"] for r in records.values()])
    usage = weights @ usage / weights.sum()
    activity = {
        kind: weights @ np.array([r["stats"]["active_per_shape"][kind] for r in records.values()]) / weights.sum()
        for kind in ("lower", "upper", "rate")
    }
    return usage, activity


#: Stage timings of the latest build that did work, relative to ``out``: not in the
#: manifest (they change from run to run while the data outputs stay byte-identical).
TIMINGS = f"{REPORT_DIR}/timings.md"
#: The report's files in ``report/`` (the manifest lists them; the data's identity leaves them out).
REPORT_FILES = ("README.md", "usage.png", "tracks.png")


def timings_markdown(stages: dict, *, workers: int) -> str:
    """Return the stage timing table.

    Parameters
    ----------
    stages : dict
        ``{"rigs": {"wall", "built", "compute", "io"}, "fits": {...}, "summary": {"wall", "report"}}``,
        seconds; ``compute`` and ``io`` summed over the items built (all worker processes).
    workers : int
    """
    lines = ["# BlendVOCA build timings", "",
             f"The latest build that did work, on {workers} worker process(es). Wall: the stage's elapsed "
             "time; compute and I/O: summed over the items built in every worker (rigs: the deformation "
             "transfer, plus the correspondence shared by all speakers computed once in the main process; "
             "fits: the constrained fit; I/O: reading and hashing the inputs, writing the outputs and records).",
             "", "| stage | items built | wall s | compute s | I/O s |", "|---|---|---|---|---|"]
    fitted = ("rigs", "fits", "oracle") if "oracle" in stages else ("rigs", "fits")
    for stage in fitted:
        st = stages[stage]
        lines.append(f"| {stage} | {st['built']} | {st['wall']:.2f} | {st['compute']:.2f} | {st['io']:.2f} |")
    st = stages["summary"]
    lines.append(f"| report | - | {st['report']:.2f} | {st['report']:.2f} | - |")
    lines.append(f"| summary I/O (coeffs_std, residuals, splits, manifest) | - | {st['wall'] - st['report']:.2f} "
                 f"| - | {st['wall'] - st['report']:.2f} |")
    total = sum(stages[k]["wall"] for k in (*fitted, "summary"))
    lines += [f"| total | - | {total:.2f} | - | - |", ""]
    return "\n".join(lines)


def write_timings(out, stages: dict, *, workers: int) -> Path:
    """Write `TIMINGS` (see `timings_markdown`); return its path."""
    path = Path(out) / TIMINGS
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_write(path, "w", encoding="utf-8") as f:
        f.write(timings_markdown(stages, workers=workers))
    return path


def write_report(out, records: dict, names, failures, params, *, num_tracks: int = 3, warnings=(),
                 share=None) -> Path:
    """Write ``<out>/report/README.md`` with ``usage.png`` and ``tracks.png``; return its path."""
    readme, usage_png, tracks_png = REPORT_FILES
    folder = report_dir(out)
    folder.mkdir(parents=True, exist_ok=True)
    figures = []
    if records and names:
        usage, activity = _aggregate(records)
        _usage_figure(folder / usage_png, list(names), usage, activity)
        figures.append(("Coefficient usage and constraint activity", usage_png))
        chosen = sorted(records.items())[:: max(1, len(records) // num_tracks)][:num_tracks]
        _tracks_figure(folder / tracks_png, out, chosen, list(names))
        figures.append(("Coefficient tracks against the lip aperture of the input meshes", tracks_png))
    text = report_markdown(records, names, failures, params, figures=figures, warnings=warnings, share=share)
    path = folder / readme
    with atomic_write(path, "w", encoding="utf-8") as f:
        f.write(text)
    return path
