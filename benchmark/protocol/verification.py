"""What a run reads, verified against the build's ``manifest.json`` before anything runs
and again after the method generated (issue 56).

Before: the files of every split (what the method trains on as well as what it is
scored against) are checked against the manifest's digests, and the ground truth of the
scored split is read into memory (``dataset.hold``), so that the scores compare with what
was verified whatever a plug-in does to the folder. After generation: the same files are
checked again, so a plug-in that wrote into the build (a test CSV rewritten during
``generate``) stops the run with exit 4 naming the file, nothing stored.
"""

from __future__ import annotations

from blendvoca.errors import CheckFailed

__all__ = ["held_ground_truth", "reverified", "verified_inputs", "verified_subjects"]


def verified_subjects(dataset, split: str) -> list:
    """The speakers whose files a run reads: those of every split of the build (the method
    may train on any of them), else those of ``split``."""
    splits = getattr(dataset, "splits", None)
    if isinstance(splits, dict) and splits:
        seen = []
        for subjects in splits.values():
            seen += [s for s in subjects if s not in seen]
        return seen
    return list(dataset.split(split))


def verified_inputs(spec, dataset) -> int | None:
    """The number of files checked against the manifest (every split's), None when not
    checked (``spec.verify`` off, or a dataset without ``verify``).

    Raises
    ------
    CheckFailed
        A file differs from what the build made (the message names it).
    """
    verify = getattr(dataset, "verify", None) if getattr(spec, "verify", True) else None
    return None if verify is None else int(verify(verified_subjects(dataset, spec.split)))


def held_ground_truth(spec, dataset) -> None:
    """Read the scored split's ground truth (tracks, samples, audio, rigs) into memory
    (``dataset.hold``, where the dataset has it) before the method runs."""
    hold = getattr(dataset, "hold", None)
    if hold is not None:
        hold(dataset.split(spec.split))


def reverified(spec, dataset, *, when: str = "while the method ran") -> None:
    """Check the run's files against the manifest again (after the method ran).

    Raises
    ------
    CheckFailed
        A file changed ``when``: the message names it and says nothing was stored.
    """
    verify = getattr(dataset, "verify", None) if getattr(spec, "verify", False) else None
    if verify is None:
        return
    try:
        verify(verified_subjects(dataset, spec.split))
    except CheckFailed as exc:
        raise CheckFailed(f"the build changed {when}, nothing was stored: {exc}") from None
