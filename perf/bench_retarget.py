"""Time one speaker's rig build and a 12-speaker build (python perf/bench_retarget.py).

Prints seconds per stage (correspondence, factorization, 32 solves, re-attach, all
51 shapes) and the 12-speaker total with the correspondence computed once on the
FLAME template and shared, as ratios against the one-speaker reference run in the
same process. Speakers are the template under random smooth identity changes.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from blendvoca.assets import load_index_list, resolve
from blendvoca.io.mesh import read_mesh
from blendvoca.retarget import (
    correspondence_for_target,
    plan_retarget,
    retargeted_deltas,
)
from blendvoca.retarget.crop import reattached_deltas
from blendvoca.retarget.deformation_gradient import deformation_gradient_displacements
from blendvoca.retarget.transfer import anchored_deltas, transferred_deltas
from blendvoca.rig import load_arkit_reference


def timed(fn, *args, **kwargs):
    t = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t


def main(argv=None) -> None:
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args(argv)
    source = load_arkit_reference("all")
    speech = load_arkit_reference("speech")
    V, F = read_mesh(resolve("flame-sample"))
    lm_s, lm_t = load_index_list("arkit-landmarks"), load_index_list("flame-landmarks")
    crop = load_index_list("flame-head-idx")

    corr, t_corr = timed(correspondence_for_target, source.neutral, source.faces, V, F, lm_s, lm_t, crop=crop)
    plan, t_plan = timed(plan_retarget, source.neutral, source.faces, V, F, lm_s, lm_t, crop=crop, correspondence=corr)

    def solve(shapes):
        aligned = plan.similarity.apply_vectors(shapes.deltas)
        dQ = deformation_gradient_displacements(plan.source_neutral_aligned, aligned, plan.source_faces)
        d = transferred_deltas(plan.system, dQ)
        ref = plan.correspondence.vertex.interpolate(aligned, plan.source_faces)
        return anchored_deltas(d, plan.system.pieces, ref, plan.correspondence.vertex.valid.astype(float))

    cropped32, t32 = timed(solve, speech)
    _, t_reattach = timed(reattached_deltas, cropped32, crop, V, F)
    _, t51 = timed(solve, source)
    one = t_plan + t32 + t_reattach
    print(f"correspondence (once per topology)      {t_corr:7.3f} s")
    print(f"alignment + crop + factorization        {t_plan:7.3f} s")
    print(f"32 solves (+ gradients, anchoring)      {t32:7.3f} s")
    print(f"re-attach 32 shapes                     {t_reattach:7.3f} s")
    print(f"51 solves (all shapes)                  {t51:7.3f} s   ratio to 32: {t51 / t32:.2f}")
    print(f"one speaker, shared correspondence      {one:7.3f} s")
    print(f"one speaker, own correspondence         {one + t_corr:7.3f} s")

    rng = np.random.default_rng(0)
    start = time.perf_counter()
    for _ in range(12):
        a = rng.uniform(0.9, 1.1, size=3)
        other = V * a + 0.003 * np.sin(rng.uniform(10, 30) * V[:, [1, 2, 0]])
        p = plan_retarget(speech.neutral, speech.faces, other, F, lm_s, lm_t, crop=crop, correspondence=corr)
        retargeted_deltas(p, speech.deltas)
    t12 = time.perf_counter() - start
    print(f"12 speakers x 32 shapes (shared corr.)  {t12:7.3f} s   ratio to one speaker: {t12 / one:.2f}; "
          f"with the one correspondence: {t12 + t_corr:.3f} s")


if __name__ == "__main__":
    main()
