"""Build report (Markdown + PNG figures in ``report/``) and the values of ``coeffs_std.csv``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from blendvoca.format.items import read_coeffs, read_oracle_coeffs, read_rig
from blendvoca.format.layout import REPORT_DIR, report_dir
from blendvoca.io.atomic import atomic_write

#: Shapes plotted against the lip aperture, when present.
TRACK_SHAPES = ("jawOpen", "mouthClose", "mouthFunnel", "mouthPucker")
#: Shapes of the rig contact sheet (at weight 1, beside the neutral): the first `RIG_SHEET_COUNT`
#: every speaker's rig has (the 32 speech shapes have no eyes or brows: then mouth shapes).
RIG_SHEET_SHAPES = ("jawOpen", "mouthFunnel", "mouthSmileLeft", "eyeBlinkLeft", "browInnerUp",
                    "mouthPucker", "mouthClose", "mouthLowerDownLeft")
RIG_SHEET_COUNT = 5
#: Tile height of the rig contact sheet, pixels (small: its renders are most of the report's pictures' cost).
RIG_TILE = 100


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


def tracks_against_figure(path, panels, *, below=None) -> None:
    """``path`` (PNG): one panel per ``(title, coeffs (T, K), shapes, signal, signal label, unit)``
    of ``panels``: the shapes' tracks (left axis) and a signal of the same frames (right axis, dashed),
    on one 60 fps time axis.

    With ``unit`` None the signal is ``(T, len(shapes))`` reference tracks of the same shapes
    (e.g. the ground truth): each drawn dashed in its shape's colour on the coefficient axis,
    labelled ``"<shape> (<signal label>)"``. ``below``, a callable ``draw(ax)``, draws one more
    panel under the tracks on its own x axis (``benchmark.run``'s training loss curve)."""
    plt = _pyplot()
    rows = len(panels) + (below is not None)
    fig, axes = plt.subplots(rows, 1, figsize=(10, 2.6 * rows), squeeze=False)
    for ax, (title, coeffs, shapes, signal, label, unit) in zip(axes[:, 0], panels):
        t = np.arange(coeffs.shape[0]) / 60.0
        for j, shape in enumerate(shapes):
            ax.plot(t, coeffs[:, j], label=shape, lw=1.2)
        ax.set_ylim(-0.02, 1.02)
        ax.set_ylabel("coefficient")
        ax.set_title(title, fontsize=9)
        if unit is None:
            reference = np.asarray(signal)
            tr = np.arange(reference.shape[0]) / 60.0
            for j, (shape, line) in enumerate(zip(shapes, list(ax.get_lines()))):
                ax.plot(tr, reference[:, j], ls="--", lw=1.0, color=line.get_color(), label=f"{shape} ({label})")
            lines = ax.get_lines()
        else:
            ax2 = ax.twinx()
            ax2.plot(t, signal, color="black", ls="--", lw=1.0, label=label)
            ax2.set_ylabel(f"{label} ({unit})")
            lines = ax.get_lines() + ax2.get_lines()
        ax.legend(lines, [ln.get_label() for ln in lines], fontsize=7, loc="upper right", ncol=3)
    axes[len(panels) - 1, 0].set_xlabel("time (s)")
    if below is not None:
        below(axes[-1, 0])
    fig.tight_layout()
    _save_figure(fig, path)


def coefficient_strip_figure(path, coeffs, names, *, title: str, fps: float = 60.0) -> None:
    """``path`` (PNG): a coefficient track ``(T, K)`` as an image, one row per blendshape
    (labelled with its name) and one column per frame, on a time axis in seconds, the values
    0..1 on a colour bar, titled ``title`` (the method and the input). Its width grows with
    the duration (1.6 in per second, 6 to 18 in)."""
    coeffs = np.asarray(coeffs, dtype=np.float64)
    if coeffs.ndim != 2 or coeffs.shape[1] != len(names):
        raise ValueError(f"coefficient_strip_figure: expected ({len(names)} names) (T, {len(names)}) "
                         f"coefficients, got shape {coeffs.shape}")
    plt = _pyplot()
    seconds = coeffs.shape[0] / fps
    fig, ax = plt.subplots(figsize=(min(18.0, max(6.0, 1.5 + 1.6 * seconds)), 1.3 + 0.13 * len(names)))
    image = ax.imshow(coeffs.T, aspect="auto", interpolation="nearest", cmap="magma_r", vmin=0.0, vmax=1.0,
                      extent=(0.0, seconds, len(names) - 0.5, -0.5))
    ax.set_yticks(np.arange(len(names)))
    ax.set_yticklabels(names, fontsize=6)
    ax.set_xlabel(f"time (s), {fps:g} frames per second")
    ax.set_title(title, fontsize=9)
    fig.colorbar(image, ax=ax, fraction=0.03, pad=0.01).set_label("coefficient")
    fig.tight_layout()
    _save_figure(fig, path)


def _tracks_figure(path, out, items, names):
    shapes = [s for s in TRACK_SHAPES if s in names]
    tracks_against_figure(path, [(f"{subject} {sentence}", read_coeffs(out, subject, sentence, names=shapes)[0],
                                  shapes, rec["stats"]["lip_aperture_mm"], "lip aperture", "mm")
                                 for (subject, sentence), rec in items])


def rig_sheet_figure(path, rigs: dict, shapes=RIG_SHEET_SHAPES, *, tile: int = RIG_TILE) -> list[str]:
    """``path`` (PNG): one row per speaker of ``rigs`` (``{subject: Rig}``): the neutral and
    each of ``shapes`` the rig has at weight 1, from the front, drawn by the retarget contact
    sheet's rasteriser (faces tinted by how far the shape moves them), with the speaker's name
    and a millimetre scale bar (metres in the rig, DESIGN.md) in the first tile. Returns the
    shapes drawn."""
    from blendvoca.retarget.contact_sheet import face_window, rasterise_front, scale_bar_pixels, shaded_face_colours

    subjects = sorted(rigs)
    drawn = [s for s in shapes if all(s in rigs[subject].names for subject in subjects)][:RIG_SHEET_COUNT]
    titles = ["neutral", *drawn]
    label_w, strip = 90, 16
    sheet = np.ones((strip + len(subjects) * tile, label_w + len(titles) * tile, 3))
    bars = []
    windows = {}
    for subject in subjects:
        rig = rigs[subject]
        deltas = np.stack([rig.deltas[rig.names.index(s)] for s in drawn]) if drawn else rig.deltas[:0]
        windows[subject] = deltas, face_window(rig.neutral, deltas)
    # one bar length for every row (the narrowest window's), drawn to each row's own scale
    narrowest = min((w for _, w in windows.values()), key=lambda w: w[1] - w[0])
    bar_mm = scale_bar_pixels(narrowest, tile, 1000.0)[0]
    for r, subject in enumerate(subjects):
        rig = rigs[subject]
        deltas, window = windows[subject]
        # only the faces with a corner in the window (the back of the head and the neck drop out)
        x0, x1, y0, y1 = window
        within = ((rig.neutral[:, 0] >= x0) & (rig.neutral[:, 0] <= x1) & (rig.neutral[:, 1] >= y0)
                  & (rig.neutral[:, 1] <= y1))
        faces = rig.faces[within[rig.faces].any(axis=1)]
        for c in range(len(titles)):
            delta = np.zeros_like(rig.neutral) if c == 0 else deltas[c - 1]
            X = rig.neutral + delta
            colours = shaded_face_colours(X, faces, np.linalg.norm(delta, axis=1) if c else None)
            y, x = strip + r * tile, label_w + c * tile
            sheet[y: y + tile, x: x + tile] = rasterise_front(X, faces, colours, window, (tile, tile))
        pixels = int(round(bar_mm / ((window[1] - window[0]) * 1000.0) * tile))
        y = strip + (r + 1) * tile - 6
        sheet[y - 3: y, label_w + 4: label_w + 4 + pixels] = 0.0
        bars.append((label_w + 4, y - 6, f"{bar_mm:g} mm"))
    labels = [((label_w + (c + 0.5) * tile), 2, title, "mt", 11) for c, title in enumerate(titles)]
    labels += [(4, strip + (r + 0.5) * tile, subject, "lm", 11) for r, subject in enumerate(subjects)]
    labels += [(x, y, text, "ls", 9) for x, y, text in bars]
    _save_labelled_image(path, sheet, labels)
    return drawn


def _save_labelled_image(path, image, labels) -> None:
    """Write ``image`` ((H, W, 3) floats in [0, 1]) as a PNG with ``labels`` ``(x, y, text, anchor,
    size in px)`` drawn in black (Pillow, matplotlib's DejaVu Sans): a picture made of pixels
    needs no figure, and its PNG costs a fraction of ``savefig``'s."""
    from matplotlib import font_manager
    from PIL import Image, ImageDraw, ImageFont

    picture = Image.fromarray(np.round(255 * np.clip(image, 0.0, 1.0)).astype(np.uint8))
    draw = ImageDraw.Draw(picture)
    fonts = {}
    for x, y, text, anchor, size in labels:
        if size not in fonts:
            fonts[size] = ImageFont.truetype(font_manager.findfont("DejaVu Sans"), size)
        draw.text((x, y), text, fill=(0, 0, 0), font=fonts[size], anchor=anchor)
    with atomic_write(path, "wb") as f:
        picture.save(f, format="PNG")


def worst_sentence(records: dict):
    """The ``(subject, sentence)`` of ``records`` with the largest ``max_error_mm`` (the report's
    "max error mm" column; ties: the first in sorted order), or None when no record has one."""
    scored = [(key, rec["stats"]["max_error_mm"]) for key, rec in sorted(records.items())
              if "max_error_mm" in rec.get("stats", {})]
    if not scored:
        return None
    return max(scored, key=lambda item: item[1])[0]


def _aligned(frames, fitted, index):
    """``frames`` rigidly aligned (rotation + translation per frame, Kabsch on ``index``) to ``fitted``."""
    A, B = frames[:, index], fitted[:, index]
    ca, cb = A.mean(axis=1, keepdims=True), B.mean(axis=1, keepdims=True)
    U, _S, Vt = np.linalg.svd(np.einsum("tvi,tvj->tij", A - ca, B - cb))
    d = np.sign(np.linalg.det(U @ Vt))
    U[:, :, 2] *= d[:, None]
    R = U @ Vt
    return np.einsum("tvi,tij->tvj", frames - ca, R) + cb


def fit_errors(rig, coeffs, frames, head_index, *, posed: bool = False) -> np.ndarray:
    """Per-frame, per-vertex distance (metres) between the rig driven by ``coeffs (T, K)`` and
    the input ``frames (T, V, 3)``, on the fitted vertices ``head_index`` (others: 0). Posed
    frames are first aligned rigidly to the fitted meshes on those vertices. Returns ``(T, V)``."""
    coeffs = np.asarray(coeffs, dtype=np.float64)
    frames = np.asarray(frames, dtype=np.float64)[: len(coeffs)]
    fitted = rig.neutral[None] + np.einsum("tk,kvc->tvc", coeffs[: len(frames)], rig.deltas)
    if posed:
        frames = _aligned(frames, fitted, head_index)
    errors = np.zeros(frames.shape[:2])
    errors[:, head_index] = np.linalg.norm(frames[:, head_index] - fitted[:, head_index], axis=2)
    return errors


def worst_fit_figure(path, rig, coeffs, frames, head_index, *, title: str, posed: bool = False) -> dict:
    """``path`` (PNG): the per-vertex fit error (mm) at the sentence's worst frame (largest
    vertex error), colour-mapped on the fitted mesh (shaded; vertices not fitted in grey) with
    a colour bar in mm. Returns ``{"frame", "max_error_mm", "rmse_mm"}`` of that frame."""
    import matplotlib

    from blendvoca.retarget.contact_sheet import face_window, rasterise_front, scale_bar_pixels, shaded_face_colours

    errors = fit_errors(rig, coeffs, frames, head_index, posed=posed) * 1000.0
    frame = int(np.argmax(errors.max(axis=1)))
    err = errors[frame]
    X = rig.neutral + np.einsum("k,kvc->vc", np.asarray(coeffs[frame], dtype=np.float64), rig.deltas)
    vmax = float(err.max()) or 1.0
    cmap = matplotlib.colormaps["inferno"]
    colour = np.full((len(X), 3), 0.8)
    colour[head_index] = cmap(0.15 + 0.85 * err[head_index] / vmax)[:, :3]
    shade = shaded_face_colours(X, rig.faces)[..., 0] / 0.80  # the Lambert term (grey 0.8 lit)
    colours = np.clip(colour[rig.faces] * shade[..., None], 0.0, 1.0)
    size = 260
    head = np.zeros(len(X), dtype=bool)
    head[head_index] = True
    window = face_window(X[head], np.zeros((0, int(head.sum()), 3)))
    image = rasterise_front(X, rig.faces, colours, window, (size, size))
    bar_mm, pixels = scale_bar_pixels(window, size, 1000.0)
    image[size - 9: size - 6, 6: 6 + pixels] = 0.0
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(4.6, 3.6))
    ax.imshow(image, interpolation="nearest")
    ax.text(6, size - 12, f"{bar_mm:g} mm", fontsize=6.5, va="bottom")
    ax.set_axis_off()
    rmse = float(np.sqrt(np.mean(err[head_index] ** 2)))
    ax.set_title(f"{title}, frame {frame} ({frame / 60.0:.2f} s)\nmax {err.max():.2f} mm, RMSE {rmse:.2f} mm",
                 fontsize=8)
    shown = matplotlib.colors.ListedColormap(cmap(np.linspace(0.15, 1.0, 256)))  # the colours drawn: 0 -> 0.15
    mappable = matplotlib.cm.ScalarMappable(norm=matplotlib.colors.Normalize(0.0, vmax), cmap=shown)
    bar = fig.colorbar(mappable, ax=ax, fraction=0.05, pad=0.03)
    bar.set_label("fit error (mm)")
    fig.tight_layout()
    _save_figure(fig, path)
    return {"frame": frame, "max_error_mm": float(err.max()), "rmse_mm": rmse}


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
REPORT_FILES = ("README.md", "usage.png", "tracks.png", "rigs.png", "worst_fit.png")


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
                 share=None, corpus=None) -> Path:
    """Write ``<out>/report/README.md`` with ``usage.png``, ``tracks.png``, ``rigs.png`` (the rig
    contact sheet of every speaker with a fitted sentence) and, given the ``corpus`` with its
    meshes, ``worst_fit.png`` (the error heat map of the sentence with the largest vertex error);
    return its path."""
    readme, usage_png, tracks_png, rigs_png, worst_png = REPORT_FILES
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
        rigs = {subject: read_rig(out, subject) for subject in sorted({s for s, _ in records})}
        drawn = rig_sheet_figure(folder / rigs_png, rigs)
        figures.append((f"Speaker rigs: neutral, {', '.join(drawn)} at weight 1 (faces tinted by how far "
                        "the shape moves them)", rigs_png))
        worst = worst_sentence(records)
        if worst is not None and corpus is not None and hasattr(corpus, "frames"):
            subject, sentence = worst
            rig = rigs[subject]
            coeffs, _ = read_coeffs(out, subject, sentence, names=rig.names)
            shown = worst_fit_figure(folder / worst_png, rig, coeffs, corpus.frames(subject, sentence),
                                     np.asarray(corpus.head_index()), title=f"{subject} {sentence}",
                                     posed=bool(getattr(corpus, "posed", False)))
            figures.append((f"Fit error of the worst sentence ({subject} {sentence}, largest max error; "
                            f"its worst frame, {shown['frame']})", worst_png))
    text = report_markdown(records, names, failures, params, figures=figures, warnings=warnings, share=share)
    path = folder / readme
    with atomic_write(path, "w", encoding="utf-8") as f:
        f.write(text)
    return path
