"""Report parts of a coefficient corpus whose takes were cut into utterances: the utterance
table and a figure of a few coefficient tracks against the speech they go with."""

from __future__ import annotations

import numpy as np

from blendvoca.builder.report import tracks_against_figure
from blendvoca.format.items import read_audio, read_coeffs
from blendvoca.io.audio import energy_db

#: Shapes plotted against the speech envelope, when present.
SPEECH_TRACK_SHAPES = ("jawOpen", "mouthFunnel", "mouthPucker", "mouthSmileLeft", "mouthLowerDownLeft")


def utterance_lengths(utterances: dict) -> dict[str, list[float]]:
    """``{take: [seconds of each utterance, in order]}`` from the manifest's utterance records."""
    lengths: dict[str, list[float]] = {}
    for key in sorted(utterances, key=lambda k: (utterances[k]["take"], utterances[k]["start_frame"])):
        record = utterances[key]
        lengths.setdefault(record["take"], []).append(record["end_s"] - record["start_s"])
    return lengths


def utterances_markdown(utterances: dict, splits: dict | None = None) -> str:
    """A markdown section: per take, its split, utterance count, lengths and how its cuts were made."""
    lengths = utterance_lengths(utterances)
    split_of = {s: name for name, subjects in (splits or {}).items() for s in subjects}
    kinds: dict[str, dict[str, int]] = {}
    subject_of = {}
    for key, record in utterances.items():
        kinds.setdefault(record["take"], {}).setdefault(record["cut"], 0)
        kinds[record["take"]][record["cut"]] += 1
        subject_of.setdefault(record["take"], key.split("/")[0])
    every = [x for v in lengths.values() for x in v]
    lines = ["## Utterances", "",
             f"{len(every)} utterances from {len(lengths)} takes, {min(every):.2f}-{max(every):.2f} s "
             f"(median {float(np.median(every)):.2f} s, {sum(every):.1f} s in all). Each take is cut where a pause "
             "in the speech and the motion are both quiet (or where the cut list says); `forced` counts cuts "
             "made without a pause.", "",
             "| take | split | utterances | shortest (s) | median (s) | longest (s) | cuts at pauses | forced | "
             "user |", "|---|---|---|---|---|---|---|---|---|"]
    for take, values in lengths.items():
        k = kinds[take]
        lines.append(f"| {take} | {split_of.get(subject_of[take], '')} | {len(values)} | {min(values):.2f} | "
                     f"{float(np.median(values)):.2f} | {max(values):.2f} | {k.get('pause', 0)} | "
                     f"{k.get('forced', 0)} | {k.get('user', 0)} |")
    return "\n".join(lines) + "\n"


def speech_tracks_figure(path, out, items, shapes=SPEECH_TRACK_SHAPES) -> None:
    """``path`` (PNG): for each ``(subject, sentence)`` of ``items``, the tracks of ``shapes`` (those
    the folder has) and the speech energy (dB, right axis) of its audio, on one time axis."""
    panels = []
    for subject, sentence in items:
        coeffs, names = read_coeffs(out, subject, sentence)
        chosen = [s for s in shapes if s in names]
        samples, rate = read_audio(out, subject, sentence)
        panels.append((f"{subject} {sentence}", coeffs[:, [names.index(s) for s in chosen]], chosen,
                       energy_db(samples, rate, 60.0, len(coeffs)), "speech energy", "dB"))
    tracks_against_figure(path, panels)
