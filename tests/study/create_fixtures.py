"""Stored rows and studies for the study tests, made in about a second on the bundled default.

:func:`write_stored_rows` writes result files with stored tracks exactly as ``benchmark.run``
lays them out (``benchmark.results.write`` + ``benchmark.runs.TrackWriter``), without scoring
(which takes about 20 s a row): the study kit reads only the tracks and the build's identity.
:func:`make_study` runs ``python -m benchmark.study create`` on them: the fewest seconds a
study for an end-to-end test takes (1 s clips at 256 px and 30 fps)::

    from tests.study.create_fixtures import make_study
    study = make_study(tmp_path / "ab", design="ab")     # rows truth,still; lipsync,realism
    study = make_study(tmp_path / "mos", design="mos")   # row sampler (3 samples)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: The rows :func:`write_stored_rows` writes: name -> (output, samples, what the tracks are).
ROWS = {
    "truth": ("coefficients", 1, "the ground truth"),
    "still": ("coefficients", 1, "the neutral face (all zeros)"),
    "sampler": ("coefficients", 3, "the ground truth plus smooth noise, 3 samples (stochastic)"),
    "meshes": ("vertices", 1, "the ground truth's vertices through the rig (a vertex row)"),
    "elsewhere": ("coefficients", 1, "zeros, scored on another build (recipe_id differs)"),
    "scores-only": ("coefficients", 1, "a result file without stored tracks"),
}


def bundled_build() -> Path:
    """The bundled-default BlendVOCA build (built once into the cache)."""
    from benchmark.protocol import default_data_root

    return Path(default_data_root())


def _test_sentences(root: Path):
    import json

    from blendvoca.format import coeffs_path

    subjects = json.loads((root / "splits.json").read_text())["test"]
    return [(s, p.stem) for s in subjects for p in sorted(coeffs_path(root, s, "x").parent.glob("sentence*.csv"))
            if "-" not in p.stem]


def write_stored_rows(results: Path, root: Path | None = None, rows=tuple(ROWS)) -> Path:
    """Result files (and tracks) of ``rows`` (names of :data:`ROWS`) in ``results``, on ``root``
    (default: the bundled build)."""
    from benchmark.results import build_result, write
    from benchmark.runs import TrackWriter
    from blendvoca.format import coeffs_path, dataset_id, rig_path
    from blendvoca.io.coeffs import read_coeffs_csv
    from blendvoca.rig import Rig

    root = Path(root) if root is not None else bundled_build()
    results = Path(results)
    results.mkdir(parents=True, exist_ok=True)
    recipe = dataset_id(root)
    sentences = _test_sentences(root)
    rng = np.random.default_rng(0)
    for name in rows:
        output, samples, _ = ROWS[name]
        writer = None
        if name != "scores-only":
            rig_of = {}
            writer = TrackWriter(results / name, ())
            for subject, sentence in sentences:
                if subject not in rig_of:
                    rig_of[subject] = Rig.load(rig_path(root, subject))
                rig = rig_of[subject]
                truth, names = read_coeffs_csv(coeffs_path(root, subject, sentence), names=rig.names)
                writer.names = tuple(names)
                if name == "truth" or name == "meshes":
                    tracks = truth[None]
                elif name == "sampler":
                    from scipy.ndimage import gaussian_filter1d

                    noise = gaussian_filter1d(rng.normal(size=(samples, *truth.shape)), 6, axis=1)
                    tracks = np.clip(truth[None] + 0.5 * noise / np.abs(noise).max(), 0, 1)
                else:
                    tracks = np.zeros((1, *truth.shape))
                writer.write_tracks(subject, sentence, tracks)
                if output == "vertices":
                    writer.write_vertices(subject, sentence, rig.evaluate(truth)[None], np.asarray(rig.neutral))
            writer.commit()
        result = build_result(
            method={"name": name, "class": "tests.study.create_fixtures", "stochastic": samples > 1,
                    "reference": True, "output": output, "config": {}},
            dataset={"recipe_id": recipe if name != "elsewhere" else "0" * 64, "path": str(root), "split": "test",
                     "num_sentences": len(sentences), "num_subjects": len({s for s, _ in sentences})},
            protocol={"samples": samples, "seed": 0},
            metrics={"lve": {"mean": 1.0, "std": None, "higher_is_better": False, "unit": "mm"}},
            timings={}, provenance={}, tracks=None if writer is None else name)
        write(results / f"{name}.json", result)
    return results


def make_study(out: Path, *, design: str = "ab", rows: str | None = None, results: Path | None = None,
               extra=()) -> Path:
    """A small study (2 sentences, 1 s clips, 256 px, 30 fps) made by ``python -m benchmark.study create``:
    ``ab`` of rows truth,still (questions lipsync,realism) or ``mos`` of the sampler's 3 samples."""
    from benchmark.study.__main__ import main

    out = Path(out)
    if results is None:
        results = write_stored_rows(out.parent / f"{out.name}-results", rows=("truth", "still", "sampler"))
    rows = rows or ("truth,still" if design == "ab" else "sampler")
    questions = "lipsync,realism" if design == "ab" else "lipsync,realism,diversity"
    code = main(["create", "--results", str(results), "--rows", rows, "--design", design, "--questions", questions,
                 "--out", str(out), "--size", "256", "--max-seconds", "1", "--sentences", "2", "--quiet", *extra])
    if code != 0:
        raise RuntimeError(f"benchmark.study create exited {code}")
    return out
