"""``python -m baselines.mesh_adapter.export``: write a VOCASET-layout corpus's own
meshes as a vertex-output folder plus its adapter YAML.

Feeding the bundled synthetic corpus's own test meshes to the mesh adapter must
score close to ``ground-truth``: the check that the adapter (resampling, fit,
scoring on coefficients) loses little.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

from blendvoca import cli
from blendvoca.errors import UserError
from blendvoca.runtime.progress import bar
from blendvoca.synthetic import default_corpus
from blendvoca.vocaset import open_vocaset

__all__ = ["exported_corpus_meshes", "main"]


def exported_corpus_meshes(vocaset_root: str | os.PathLike, out_dir: str | os.PathLike, *, split: str = "test",
                           fps: int = 60, offsets: bool = False, name: str | None = None, sentences=None) -> Path:
    """Write ``<out>/vertices/<subject>/<sentence>.npy`` and ``<out>/adapter.yaml``.

    Parameters
    ----------
    vocaset_root : str or os.PathLike
        VOCASET (official or processed layout), e.g. the bundled synthetic corpus.
    out_dir : str or os.PathLike
    split : str
        Which split's speakers to export.
    fps : {60, 30}
        60 keeps every frame; 30 keeps every second one (as VOCA-style outputs),
        exercising the adapter's resampling.
    offsets : bool
        Store offsets from the speaker template instead of absolute positions.
    name : str, optional
        Leaderboard label (default ``"corpus meshes (<fps> fps)"``).
    sentences : list of str, optional
        Restrict to these sentence names.

    Returns
    -------
    Path
        The adapter YAML file, ready for ``--config config=PATH``.

    Raises
    ------
    UserError
        ``fps`` other than 30 or 60, a split the corpus does not have.
    """
    import yaml

    if fps not in (30, 60):
        raise UserError(f"exported_corpus_meshes: fps must be 30 or 60, got {fps!r}")
    corpus = open_vocaset(vocaset_root)
    if split not in corpus.splits:
        raise UserError(f"--split: expected one of {sorted(corpus.splits)}, got {split!r}")
    out_dir = Path(os.fspath(out_dir))
    vertex_dir = out_dir / "vertices"
    items = [(s, q) for s in corpus.splits[split] if s in corpus.subjects for q in corpus.sentences(s)
             if sentences is None or q in sentences]
    for subject, sentence in bar(items, desc="export meshes", unit="sentence", file=sys.stderr):
        frames = np.asarray(corpus.frames(subject, sentence), dtype=np.float64)[:: 60 // fps]
        if offsets:
            frames = frames - np.asarray(corpus.template(subject), dtype=np.float64)[None]
        target = vertex_dir / subject / f"{sentence}.npy"
        target.parent.mkdir(parents=True, exist_ok=True)
        np.save(target, frames.astype(np.float32))
    config = {
        "name": name or f"corpus meshes ({fps} fps)",
        "vertices": "vertices",
        "fps": fps,
        "template": "offsets" if offsets else "absolute",
        "delta": 0.1,
        "vertex_subset": "flame-head",  # the build's fit: the 4580-vertex head crop
        "max_frame_mismatch": 6,
        "reference": True,  # the source meshes themselves: a reference row, never ranked
    }
    path = out_dir / "adapter.yaml"
    path.write_text(yaml.safe_dump(config, sort_keys=False))
    return path


@cli.command
def main(argv=None) -> int:
    """Command line entry point (see the module docstring)."""
    parser = cli.parser("baselines.mesh_adapter.export", __doc__)
    parser.add_argument("--vocaset", default=None, help="VOCASET root (default: the bundled synthetic corpus)")
    parser.add_argument("--out", required=True, help="output folder (vertices/ + adapter.yaml)")
    parser.add_argument("--split", default="test")
    parser.add_argument("--fps", type=int, choices=(30, 60), default=60)
    parser.add_argument("--offsets", action="store_true", help="store offsets from the template")
    parser.add_argument("--name", default=None, help="leaderboard label")
    cli.add_quiet_option(parser)
    args = parser.parse_args(argv)
    vocaset = default_corpus() if args.vocaset is None else args.vocaset
    path = exported_corpus_meshes(vocaset, args.out, split=args.split, fps=args.fps, offsets=args.offsets,
                                  name=args.name)
    print(path)
    return cli.EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
