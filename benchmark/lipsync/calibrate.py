"""Calibrate the lip-sync estimators on a build by shifting every utterance's audio.

``python -m benchmark.lipsync.calibrate --data BUILD [--split test] [--sync-expert PT]
[--syncnet-weights PT] [--shifts 0,1,-1,2,-2,4,-4,8,-8] [--out FILE.md|FILE.json]``
delays (positive) or advances (negative) the audio of every utterance of the split by
each shift, in 60 fps frames, and runs every estimator on it: the geometric one
through the build's rig, the learned expert (``--sync-expert``; for a build of
recorded speech the project's real-speech expert when none is given) and SyncNet on
renders (``--syncnet-weights``). A sound estimator reads ``k`` frames less with the
audio delayed by ``k`` than on the same utterance unshifted (a capture's own offset
is the reference, not 0). The table (markdown on stdout, and in ``--out``: markdown,
or JSON with every estimate for a ``.json`` name) gives, per estimator, the share of
utterance-shifts that moved by the shift within one frame, the spread of the
unshifted estimates, their agreement with the geometric estimator's and the
confidence on true against shifted pairs.

``--beat2 NPZ`` calibrates the geometric estimator on an SMPL-X take with its speech
(BEAT2: ``NPZ`` and the ``.wav`` of the same stem): the jaw's opening angle
(``poses[:, 66:69]``) is the mouth activity, the take cut into utterances at its pauses
as the builds cut long takes (:func:`blendvoca.datasets.utterances.take_spans`), or into
fixed ``--window``-second pieces.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from blendvoca import cli
from blendvoca.errors import DataError, UserError



def _shifts(text: str) -> tuple[int, ...]:
    from benchmark.lipsync.calibration import checked_shifts

    parts = [p.strip() for p in text.split(",") if p.strip()]
    try:
        values = [int(p) for p in parts]
    except ValueError:
        raise UserError(f"--shifts: expected comma-separated whole frames such as 0,1,-1,2,-2, got {text!r}") from None
    try:
        return checked_shifts(values)
    except UserError as exc:
        raise UserError(f"--shifts {text}: {str(exc).removeprefix('shifts: ')}") from None


def build_utterances(dataset, split: str, *, expert=None, syncnet=None, max_lag: int = 15):
    """``(utterances, estimators, frames_per_shift)`` for :func:`~benchmark.lipsync.calibration.calibrate`
    on a split of a build."""
    from blendvoca import rig_regions as regions
    from benchmark.lipsync.calibration import Utterance
    from benchmark.lipsync.geometric import geometric_sync, mouth_activity
    from benchmark.metrics.vertex import rig_vertices

    try:
        subjects = dataset.split(split)
    except (KeyError, ValueError):
        raise UserError(f"--split: the build has no split {split!r} (it has {sorted(dataset.splits)})") from None
    keys = [(s, n) for s in subjects for n in dataset.sentences(s)]
    if not keys:
        raise UserError(f"--split {split}: no utterances in that split of {dataset.root}")
    names = tuple(dataset.names)
    rigs, utterances = {}, []
    for subject, sentence in keys:
        if subject not in rigs:
            rig = dataset.rig(subject)
            order = [tuple(rig.names).index(n) for n in names]
            deltas = np.asarray(rig.deltas, dtype=np.float64)[order]
            neutral = np.asarray(rig.neutral, dtype=np.float64)
            rigs[subject] = (neutral, deltas, regions.lip_vertices(deltas, names), rig.faces)
        neutral, deltas, lip, faces = rigs[subject]
        coeffs = np.asarray(dataset.coeffs(subject, sentence), dtype=np.float64)
        samples, rate = dataset.audio(subject, sentence)
        verts = rig_vertices(neutral, deltas, coeffs)
        motion = {"geometric": mouth_activity(verts, neutral, lip)}
        if expert is not None:
            motion["expert"] = coeffs
        if syncnet is not None:
            from benchmark.lipsync.syncnet_eval import syncnet_frames

            motion["syncnet"] = syncnet_frames(verts, faces)
        utterances.append(Utterance(name=f"{subject}/{sentence}", audio=np.asarray(samples, dtype=np.float32),
                                    rate=int(rate), motion=motion))
    estimators = {"geometric": lambda act, x, r: geometric_sync(act, x, r, 60.0, max_lag)}
    frames = {"geometric": 1.0}
    if expert is not None:
        estimators["expert"] = lambda c, x, r: expert.sync(c, x, r)
        frames["expert"] = 1.0
    if syncnet is not None:
        from benchmark.lipsync.syncnet_eval import VIDEO_FPS, syncnet_sync

        estimators["syncnet"] = lambda f, x, r: syncnet_sync(syncnet, f, x, r)
        frames["syncnet"] = VIDEO_FPS / 60.0
    return utterances, estimators, frames


def jaw_utterances(npz, window: float | None = None, max_lag: int = 15):
    """``(utterances, estimators, frames_per_shift)`` of an SMPL-X take and its speech
    (the ``.wav`` beside ``npz``), cut at its pauses (``window`` None) or into
    ``window``-second pieces; the geometric estimator reads the jaw's opening angle (no
    visibility discount: it is an angle)."""
    from benchmark.lipsync.calibration import Utterance
    from benchmark.lipsync.geometric import geometric_sync
    from benchmark.lipsync.jaw import read_smplx_jaw
    from blendvoca.io.audio import load_audio

    npz = Path(npz).expanduser()
    wav = npz.with_suffix(".wav")
    if not npz.is_file():
        raise UserError(f"--beat2 {npz}: no such file (an SMPL-X .npz with the take's .wav beside it)")
    if not wav.is_file():
        raise UserError(f"--beat2 {npz}: expected the take's speech at {wav}, which does not exist")
    if window is not None and not window > 0:
        raise UserError(f"--window: expected seconds > 0, got {window}")
    jaw = read_smplx_jaw(npz, 60.0)
    samples = load_audio(wav)
    total = min(len(jaw), int(len(samples) * 60 // 16000))
    jaw, samples = jaw[:total], samples[: round(total * 16000 / 60)]
    if window is None:
        from blendvoca.datasets.utterances import take_spans

        spans = [(s.start, s.end) for s in take_spans(jaw[:, None], samples, 16000, 60.0, where=str(npz))]
    else:
        n = int(round(window * 60))
        if total < n:
            raise DataError(f"{npz}: the take is {total / 60:.1f} s long, shorter than one {window:g} s window")
        spans = [(start, start + n) for start in range(0, total - n + 1, n)]
    utterances = []
    for start, end in spans:
        audio = samples[round(start * 16000 / 60): round(end * 16000 / 60)]
        utterances.append(Utterance(name=f"{npz.stem}/{start / 60:.1f}-{end / 60:.1f}s", audio=audio, rate=16000,
                                    motion={"geometric": jaw[start:end]}))
    estimators = {"geometric": lambda act, x, r: geometric_sync(act, x, r, 60.0, max_lag, visibility=0.0)}
    return utterances, estimators, {"geometric": 1.0}


def write_output(path: Path, cal, title: str) -> None:
    """The table as markdown, or with a ``.json`` name the summary and every estimate, atomically."""
    from benchmark.lipsync.calibration import calibration_markdown
    from blendvoca.io.atomic import atomic_write

    if path.suffix.lower() == ".json":
        text = json.dumps({"title": title, **cal.summary()}, indent=1) + "\n"
    else:
        text = calibration_markdown(cal, title)
    with atomic_write(path, "w", encoding="utf-8") as f:
        f.write(text)


@cli.command
def main(argv=None) -> int:
    parser = cli.parser("benchmark.lipsync.calibrate", __doc__)
    parser.add_argument("--split", default="test", help="the build's split (default test)")
    parser.add_argument("--sync-expert", default=None, metavar="PATH",
                        help="learned sync expert (default: the project's real-speech expert for a build of "
                             "recorded speech, none for a synthetic build)")
    parser.add_argument("--syncnet-weights", default=None, metavar="PATH",
                        help="SyncNet weights: adds SyncNet on renders (slow)")
    parser.add_argument("--shifts", default=",".join(str(s) for s in (0, 1, -1, 2, -2, 4, -4, 8, -8)),
                        help="audio shifts in 60 fps frames, 0 included (default 0,1,-1,2,-2,4,-4,8,-8)")
    parser.add_argument("--beat2", default=None, metavar="NPZ",
                        help="calibrate the geometric estimator on an SMPL-X take (BEAT2 .npz + .wav) instead "
                             "of a build: the jaw's opening angle is the mouth activity")
    parser.add_argument("--window", type=float, default=None,
                        help="--beat2: cut the take into pieces of this many seconds (default: at its pauses)")
    parser.add_argument("--out", default=None, metavar="FILE", help="also write the table (.md) or every "
                                                                     "estimate (.json)")
    cli.add_data_option(parser, help="BlendVOCA build (blendvoca.build output)")
    cli.add_quiet_option(parser)
    args = parser.parse_args(argv)
    shifts = _shifts(args.shifts)
    if (args.data is None) == (args.beat2 is None):
        raise UserError("give --data BUILD or --beat2 NPZ (one of them)")

    from benchmark.lipsync.calibration import calibrate, calibration_markdown

    if args.beat2 is not None:
        utterances, estimators, frames = jaw_utterances(args.beat2, args.window)
        cut = "cut at pauses" if args.window is None else f"{args.window:g} s windows"
        title = f"{Path(args.beat2).name}: {len(utterances)} utterances ({cut}), jaw opening angle"
    else:
        from benchmark.data import open_blendvoca
        from benchmark.lipsync.default_expert import default_sync_expert
        from benchmark.lipsync.expert import load_expert

        data = Path(args.data).expanduser()
        if not data.is_dir():
            raise UserError(f"--data {data}: no such folder (a BlendVOCA build)")
        dataset = open_blendvoca(data)
        expert_path = args.sync_expert if args.sync_expert is not None else default_sync_expert(dataset)
        expert = load_expert(expert_path) if expert_path is not None else None
        syncnet = None
        if args.syncnet_weights is not None:
            from benchmark.lipsync import load_syncnet

            syncnet = load_syncnet(args.syncnet_weights)
        utterances, estimators, frames = build_utterances(dataset, args.split, expert=expert, syncnet=syncnet)
        title = f"{data.name} {args.split} split: {len(utterances)} utterances"
        if expert is not None:
            title += f"; expert {Path(expert_path).name} (weights {expert.weights_digest()[:12]})"
    cal = calibrate(utterances, estimators, shifts=shifts, frames_per_shift=frames)
    print(calibration_markdown(cal, title), end="")
    if args.out is not None:
        write_output(Path(args.out).expanduser(), cal, title)
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
