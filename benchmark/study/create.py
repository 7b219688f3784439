"""Make a study from stored runs: pick sentences, render every row's clips, write the design.

``python -m benchmark.study create --results DIR --rows A,B --design ab|mos --questions lipsync,realism
--out STUDY``

- Rows: result files of ``--results`` (named by file name, label or method) whose tracks are
  stored (``benchmark.run`` stores them; the committed board's files hold scores only:
  ``leaderboard.reproduce`` recreates them), all scored on one build (``dataset.recipe_id``).
- Sentences: ``--sentences N`` of those every row stored, speakers taking turns, in a seeded
  order; a stylised or stochastic row's samples (styles) are shown in turn over the sentences.
- ``--design ab`` (CodeTalker, CDFace): every pair of rows on every sentence is an item, judged
  by ``--judgements`` participants, left/right balanced. ``--design mos`` (CDFace): every row on
  every sentence, its ``--samples`` samples side by side, rated 1 to 5.
- Each participant slot: one practice trial, its items, ``--attention-checks`` checks (the
  ground truth against the motionless face, or against another sentence's motion), after a
  sound check (a word to type, or counted beeps).

Refused with one ``error:`` line and nothing written: an unknown row, a row without stored
tracks, rows of different builds, a design that cannot give every item its judgements, an
``--out`` that exists and is not an empty folder.
"""

from __future__ import annotations

import datetime
import os
import shlex
import shutil
import sys
from pathlib import Path

import numpy as np

from blendvoca import cli
from blendvoca.errors import UserError

#: Default items per CodeTalker's comparison (30 samples x 4 comparisons = 120 pairs).
DEFAULT_SENTENCES = 30
#: Items per participant when neither --participants nor --per-participant is given (CodeTalker: 24).
DEFAULT_PER_PARTICIPANT = 24
STIMULI = "stimuli"
SOUND_CHECK_FILE = "sound-check.wav"


def add_arguments(parser) -> None:
    parser.add_argument("--results", required=True, metavar="DIR", help="folder of the rows' result files")
    parser.add_argument("--rows", required=True, metavar="A,B,...",
                        help="rows to study: result file names (without .json), labels or method names")
    parser.add_argument("--design", required=True, choices=("ab", "mos"),
                        help="ab: pairs of rows, which is better (CodeTalker, CDFace); mos: 1-5 ratings (CDFace)")
    parser.add_argument("--questions", default="lipsync,realism", metavar="Q1,Q2",
                        help="lipsync, realism, diversity, expressiveness (default lipsync,realism)")
    parser.add_argument("--out", required=True, metavar="STUDY", help="the study folder to make (new or empty)")
    parser.add_argument("--sentences", type=int, default=None, metavar="N",
                        help=f"sentences per row (default {DEFAULT_SENTENCES}, or all the rows share if fewer)")
    parser.add_argument("--participants", type=int, default=None, metavar="P",
                        help="participant slots (default: the fewest that give every item --judgements, "
                             "each judging --per-participant items)")
    parser.add_argument("--per-participant", type=int, default=None, metavar="M",
                        help="items each participant judges (default: with --participants, the fewest that cover "
                             f"every item; else {DEFAULT_PER_PARTICIPANT}, as CodeTalker, or all items if fewer)")
    parser.add_argument("--judgements", type=int, default=3, metavar="J",
                        help="participants who judge each item, at least (default 3, as CodeTalker)")
    parser.add_argument("--samples", type=int, default=None, metavar="S",
                        help="samples of a row shown side by side in one clip (default: 1 for ab, 3 for mos)")
    parser.add_argument("--attention-checks", type=int, default=2, metavar="K",
                        help="attention checks per participant (default 2)")
    parser.add_argument("--attention", choices=("static", "mismatched"), default="static",
                        help="what the ground truth is shown against in a check: the motionless face (default) or "
                             "another sentence's motion")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sentences, orders and sides (default 0)")
    parser.add_argument("--size", type=int, default=512, metavar="PX", help="side of a face's view (default 512)")
    parser.add_argument("--fps", type=float, default=30.0, help="video frame rate (default 30)")
    parser.add_argument("--max-seconds", type=float, default=None, metavar="S",
                        help="cut every clip at S seconds (default: whole sentences)")
    parser.add_argument("--min-seconds", type=float, default=120.0, metavar="S",
                        help="sessions finished faster are excluded by the analysis (default 120, as CodeTalker)")
    parser.add_argument("--sound-check", default=None, metavar="WAV|ASSET",
                        help="a recording of a spoken word (a WAV, or an asset id of blendvoca/data_manifest.yaml); "
                             "default: a word spoken by espeak-ng, or counted beeps where it is not installed")
    parser.add_argument("--sound-check-answer", default=None, metavar="WORD", help="the word spoken in --sound-check")
    parser.add_argument("--sound-check-span", default=None, metavar="START,END",
                        help="seconds of --sound-check that hold the word (default: all of it)")
    parser.add_argument("--data", default=None, metavar="DIR",
                        help="the build the rows were scored on, where it has moved (default: their dataset.path)")
    parser.add_argument("--backend", default="auto", choices=("auto", "pyrender", "software"),
                        help="renderer (default auto: pyrender on a GPU's EGL, else the numpy rasteriser)")
    cli.add_quiet_option(parser)


def _names(text: str, flag: str) -> list[str]:
    names = [n.strip() for n in str(text).split(",") if n.strip()]
    if not names:
        raise UserError(f"{flag}: expected a comma-separated list, got {text!r}")
    return names


def _span(text):
    if text is None:
        return None
    try:
        start, end = (float(x) for x in text.split(","))
    except ValueError:
        raise UserError(f"--sound-check-span {text!r}: expected START,END in seconds, e.g. 1.2,1.7") from None
    return start, end


def _check_out(out: Path) -> None:
    if out.exists() and not (out.is_dir() and not any(out.iterdir())):
        what = "a folder that is not empty" if out.is_dir() else "a file"
        raise UserError(f"--out {out}: exists and is {what}; give a new or empty folder (nothing is overwritten)")
    if not out.parent.is_dir():
        raise UserError(f"--out {out}: the folder {out.parent} does not exist")


def _check_numbers(args) -> None:
    if args.size < 16:
        raise UserError(f"--size must be at least 16 pixels, got {args.size}")
    if not (np.isfinite(args.fps) and args.fps > 0):
        raise UserError(f"--fps must be a positive number, got {args.fps}")
    if args.max_seconds is not None and not args.max_seconds > 0:
        raise UserError(f"--max-seconds must be positive, got {args.max_seconds}")
    if args.samples is not None and args.samples < 1:
        raise UserError(f"--samples must be at least 1, got {args.samples}")
    if args.attention_checks < 0:
        raise UserError(f"--attention-checks must be at least 0, got {args.attention_checks}")
    if args.min_seconds < 0:
        raise UserError(f"--min-seconds must be at least 0, got {args.min_seconds}")


def run(args) -> int:
    from benchmark.study import design as d
    from benchmark.study import schedule, stimuli
    from blendvoca.runtime.progress import bar, set_progress

    set_progress(not args.quiet)
    _check_numbers(args)
    out = Path(args.out).expanduser()
    _check_out(out)
    row_names = _names(args.rows, "--rows")
    question_ids = _names(args.questions, "--questions")
    if len(set(question_ids)) != len(question_ids):
        raise UserError(f"--questions names a question twice: {args.questions}")
    questions = [d.question(q, args.design) for q in question_ids]
    if args.design == "ab" and len(row_names) < 2:
        raise UserError(f"--design ab compares pairs of rows: --rows needs at least two, got {args.rows!r}")
    rows = stimuli.find_rows(args.results, row_names, args.data)
    root = rows[0].dataset_root

    def rng(stage: int) -> np.random.Generator:
        return np.random.default_rng([args.seed, stage])

    candidates = stimuli.candidate_sentences(rows)
    count = args.sentences if args.sentences is not None else min(DEFAULT_SENTENCES, len(candidates))
    order = stimuli.round_robin(candidates, rng(1))
    chosen = stimuli.choose_sentences(candidates, count, rng(1))
    practice_sentence = order[count] if len(order) > count else chosen[0]

    rows_by_name = {row.name: row for row in rows}
    if args.design == "ab":
        items = schedule.ab_items(row_names, len(chosen), rng(2))
    else:
        items = schedule.mos_items(row_names, len(chosen))
    asked_per = args.per_participant
    if args.participants is None:  # the fewest participants, each judging --per-participant (default 24) items
        if asked_per is None:
            asked_per = min(len(items), DEFAULT_PER_PARTICIPANT)
        participants = max(args.judgements, schedule.slots_needed(len(items), args.judgements, max(asked_per, 1)))
    else:
        participants = args.participants
    per_participant = schedule.per_participant_for(len(items), args.judgements, participants, asked_per)

    if args.sound_check:
        sound = stimuli.recorded_word(args.sound_check, args.sound_check_answer, _span(args.sound_check_span))
    elif args.sound_check_answer or args.sound_check_span:
        raise UserError("--sound-check-answer and --sound-check-span go with --sound-check WAV")
    else:
        sound = stimuli.spoken_word(rng(3))

    # --- the clips to render -------------------------------------------------------------
    wanted = args.samples if args.samples is not None else (1 if args.design == "ab" else 3)
    offsets = {row.name: int(rng(4).integers(1 << 16)) + j for j, row in enumerate(rows)}
    plan = []  # (key, kind, subject, sentence, payload, role)
    item_clip = {}
    for k, (subject, sentence) in enumerate(chosen):
        for row in rows:
            samples = stimuli.samples_shown(row.num_samples(subject, sentence), wanted, k, offsets[row.name])
            key = (row.name, subject, sentence)
            item_clip[key] = len(plan)
            plan.append((key, "row", subject, sentence, (row, samples), "item"))
    if practice_sentence in chosen:
        practice_rows = {name: item_clip[(name, *practice_sentence)]
                         for name in row_names[: 2 if args.design == "ab" else 1]}
    else:
        practice_rows = {}
        for name in row_names[: 2 if args.design == "ab" else 1]:
            row = rows_by_name[name]
            samples = stimuli.samples_shown(row.num_samples(*practice_sentence), wanted, 0, offsets[name])
            practice_rows[name] = len(plan)
            plan.append(((name, *practice_sentence), "row", *practice_sentence, (row, samples), "practice"))
    attention_pool = max(args.attention_checks, 2) if args.attention_checks else 0
    attention_clips = []
    for j in range(attention_pool):
        subject, sentence = chosen[j % len(chosen)]
        if j >= len(chosen):  # more checks than sentences: the same sentence again, sides swapped below
            attention_clips.append(attention_clips[j % len(chosen)])
            continue
        other = None
        if args.attention == "mismatched":
            others = [q for s, q in candidates if s == subject and q != sentence]
            other = others[j % len(others)] if others else None
            if other is None:
                print(f"note: {subject} has no other sentence to mismatch {sentence} with: its check shows the "
                      "motionless face", file=sys.stderr)
        truth = len(plan)
        plan.append((("_ground_truth", subject, sentence), "truth", subject, sentence, None, "attention"))
        distractor = len(plan)
        plan.append(((f"_mismatched:{other}" if other else "_static", subject, sentence), "mismatched" if other else "static",
                     subject, sentence, other, "attention"))
        attention_clips.append((truth, distractor))

    # opaque names: a clip's file name says nothing of its row
    names = [f"v{n + 1:03d}" for n in rng(5).permutation(len(plan))]
    staging = out.parent / f".{out.name}.partial-{os.getpid()}"
    staging.mkdir()
    try:
        (staging / STIMULI).mkdir()
        heads, audios = {}, {}
        stimuli_out = {}
        for index, (key, kind, subject, sentence, payload, role) in enumerate(bar(plan, desc="stimuli", unit="clip")):
            if subject not in heads:
                heads[subject] = stimuli.Head(root, subject)
            head = heads[subject]
            if (subject, sentence) not in audios:
                audios[(subject, sentence)] = stimuli.sentence_audio(root, subject, sentence, args.max_seconds)
            audio = audios[(subject, sentence)]
            frames_needed = int(np.ceil(len(audio) / stimuli.RATE * stimuli.TRACK_FPS)) + 1
            if kind == "row":
                row, samples = payload
                sources = stimuli.row_sources(row, subject, sentence, samples, head)
            elif kind == "truth":
                samples, sources = (0,), [stimuli.ground_truth_source(root, subject, sentence, head)]
            elif kind == "mismatched":
                samples, sources = (0,), [stimuli.ground_truth_source(root, subject, payload, head)]
            else:
                samples, sources = (0,), [stimuli.static_source(frames_needed, head)]
            relative = f"{STIMULI}/{names[index]}.mp4"
            clip = stimuli.render_clip(staging / relative, sources, head, audio, size=args.size, fps=args.fps,
                                       backend=args.backend)
            stimuli_out[names[index]] = d.Stimulus(
                path=relative, sha256=d.sha256_of(staging / relative), row=key[0], subject=subject,
                sentence=sentence,
                sample=int(samples[0]), seconds=round(clip.seconds, 6), samples=tuple(int(s) for s in samples),
                role=role, fps=float(args.fps), width=clip.width, height=clip.height, frames=clip.frames)
        stimulus_of = {index: names[index] for index in range(len(plan))}

        # --- trials ----------------------------------------------------------------------
        trials: dict[str, d.Trial] = {}
        asked = tuple(question_ids)

        def item_trial(item, judgement: int) -> str:
            subject, sentence = chosen[item.sentence]
            clips = [stimulus_of[item_clip[(name, subject, sentence)]] for name in item.rows]
            if args.design == "ab":
                flipped = judgement % 2 == 1
                left_right = clips[::-1] if flipped else clips
                trial_id = f"{item.id}-{'ba' if flipped else 'ab'}"
                trials.setdefault(trial_id, d.Trial(trial_id, "ab", tuple(left_right), asked, None, item.id))
            else:
                trial_id = f"{item.id}-mos"
                trials.setdefault(trial_id, d.Trial(trial_id, "mos", tuple(clips), asked, None, item.id))
            return trial_id

        if args.design == "ab":
            attention_question = "lipsync" if "lipsync" in question_ids else question_ids[0]
        else:
            attention_question = d.ATTENTION_QUESTION
            questions.append(d.question(d.ATTENTION_QUESTION, "mos"))
        attention_ids = []
        for j, (truth, distractor) in enumerate(attention_clips):
            truth_left = j % 2 == 0
            pair = (truth, distractor) if truth_left else (distractor, truth)
            trial_id = f"attention{j + 1:02d}"
            trials[trial_id] = d.Trial(trial_id, "attention", tuple(stimulus_of[c] for c in pair),
                                       (attention_question,), "left" if truth_left else "right", None)
            attention_ids.append(trial_id)
        practice_clips = tuple(stimulus_of[practice_rows[name]] for name in practice_rows)
        trials["practice"] = d.Trial("practice", "practice", practice_clips, asked, None, None)

        slots = []
        dealt = schedule.deal(len(items), participants, per_participant, rng(6))
        order_rng = rng(7)
        for s, pairs in enumerate(dealt):
            body = [item_trial(items[i], judgement) for i, judgement in pairs]
            checks = [attention_ids[(s * args.attention_checks + t) % len(attention_ids)]
                      for t in range(args.attention_checks)] if attention_ids else []
            slots.append(d.Slot(s, tuple(schedule.place(body, checks, "practice", order_rng))))

        study = d.Study(
            design=args.design, seed=args.seed, questions=tuple(questions), stimuli=stimuli_out,
            trials=tuple(sorted(trials.values(), key=lambda t: t.id)), participants=tuple(slots),
            sound_check=None, min_seconds=float(args.min_seconds), judgements_per_item=args.judgements,
            rows={row.name: row.record() for row in rows},
            created={"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
                     "command": _command(args),
                     "git_revision": _revision()},
            settings={"size": args.size, "fps": float(args.fps), "max_seconds": args.max_seconds,
                      "samples": wanted, "participants": participants, "per_participant": per_participant,
                      "attention_checks": args.attention_checks, "attention": args.attention,
                      "backend": args.backend, "items": len(items),
                      "sentences": [list(pair) for pair in chosen], "practice_sentence": list(practice_sentence),
                      "dataset_root": str(root), "recipe_id": rows[0].run.result.dataset.key})
        stimuli.write_sound_check(sound, staging / STIMULI / SOUND_CHECK_FILE)
        study = _with_sound_check(study, d.SoundCheck(
            f"{STIMULI}/{SOUND_CHECK_FILE}", d.sha256_of(staging / STIMULI / SOUND_CHECK_FILE), sound.answer,
            sound.accepted, sound.prompt, sound.source))
        d.write_study(study, staging)
        d.verify_stimuli(d.read_study(staging), staging)
        if out.exists():
            out.rmdir()  # empty (checked above)
        os.rename(staging, out)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    judged = len(items) * args.judgements
    print(f"wrote {out}: {len(stimuli_out)} clips, {len(items)} items x >= {args.judgements} judgements "
          f"({participants} participants x {per_participant} items, {args.attention_checks} attention checks and a "
          f"practice trial each; {participants * per_participant - judged} judgements beyond the minimum)")
    return cli.EXIT_OK


def _command(args) -> str:
    """The command line that makes this study again (every option spelled out)."""
    words = ["python", "-m", "benchmark.study", "create"]
    for flag in ("results", "rows", "design", "questions", "out", "sentences", "participants", "per_participant",
                 "judgements", "samples", "attention_checks", "attention", "seed", "size", "fps", "max_seconds",
                 "min_seconds", "sound_check", "sound_check_answer", "sound_check_span", "data", "backend"):
        value = getattr(args, flag, None)
        if value is not None:
            words += ["--" + flag.replace("_", "-"), str(value)]
    return shlex.join(words)


def _with_sound_check(study, sound_check):
    from dataclasses import replace

    return replace(study, sound_check=sound_check)


def _revision():
    from benchmark.results import git_revision

    return git_revision().get("revision")
