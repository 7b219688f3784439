"""Where a trained CDFace model's lip error comes from, on a build's test split.

    python perf/diagnose_cdface_rollout.py --checkpoint DIR [--data BUILD] [--samples 5]

``DIR`` is a ``benchmark.run --checkpoint`` directory (or its ``cdface.pt``);
``BUILD`` defaults to the bundled-default build. For every test sentence it
samples ``S`` sequences and prints, averaged over sentences (mm):

- ``lve``: the per-sample LVE averaged over the samples (the leaderboard's LVE),
  ``lve_best``: the best sample's, ``lve_of_mean``: the LVE of the samples' mean;
- ``lve_prior``: the two part priors' reconstruction of the ground truth (encode,
  quantize, decode): the best any code sequence can do;
- ``lve_true_past``: each lip head fed the ground-truth past (teacher forcing,
  no past dropout), one value per head; far below ``lve``, the samples drift in
  their own auto-regressive rollout (exposure bias);
- ``lve_static``: the neutral face;
- ``lip_std`` / ``lip_std_gt``: temporal std of the modelled lip-part displacement;
- ``apd`` / ``upd`` / ``lpd``: the diversity measures of ``benchmark.metrics``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def sentence_figures(cdface, dataset, subject, sentence, samples: int) -> dict:
    """The figures of the module docstring for one sentence."""
    import torch

    from benchmark.metrics import vertex
    from blendvoca import rig_regions as regions

    rig = dataset.rig(subject)
    deltas = np.asarray(rig.deltas, dtype=np.float64)
    lip = regions.lip_vertices(deltas, list(rig.names))
    upper = regions.upper_face_vertices(np.asarray(rig.neutral, dtype=np.float64))
    template = dataset.template(subject)
    gt = np.asarray(dataset.vertices(subject, sentence), dtype=np.float64)
    audio, _rate = dataset.audio(subject, sentence)
    preds = cdface.generate(audio, len(gt), subject=subject, samples=samples, seed=0)
    lve = [vertex.lip_vertex_error(p, gt, lip) for p in preds]

    lips, upper_m = cdface.split_motion(gt, template)
    lips_t, upper_t = torch.from_numpy(lips)[None], torch.from_numpy(upper_m)[None]

    def full(lip_part, upper_part):
        return template[None] + cdface.parts.compose(lip_part.double().numpy(), upper_part.double().numpy()) / cdface.motion_scale

    with torch.no_grad():
        prior = full(cdface.model.lip_vq(lips_t)[0][0], cdface.model.upper_vq(upper_t)[0][0])
        forced = cdface.model.teacher_forced(lips_t, upper_t, cdface.features(audio, len(gt)), torch.tensor([0]))
    true_past = [vertex.lip_vertex_error(full(forced["lips"][i, 0], forced["upper"][0, 0, 0]), gt, lip)
                 for i in range(forced["lips"].shape[0])]
    pred_lips, _ = cdface.parts.split((preds - template[None, None]) * cdface.motion_scale)
    return {
        "lve": float(np.mean(lve)), "lve_best": float(np.min(lve)),
        "lve_of_mean": vertex.lip_vertex_error(preds.mean(axis=0), gt, lip),
        "lve_prior": vertex.lip_vertex_error(prior, gt, lip), "lve_true_past": np.asarray(true_past),
        "lve_static": vertex.lip_vertex_error(np.repeat(template[None], len(gt), 0), gt, lip),
        "lip_std": float(pred_lips.std(axis=1).mean()), "lip_std_gt": float(lips.std(axis=0).mean()),
        "apd": vertex.average_pairwise_distance(preds), "upd": vertex.average_pairwise_distance(preds, upper),
        "lpd": vertex.average_pairwise_distance(preds, lip),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--checkpoint", required=True, help="benchmark.run --checkpoint directory or its cdface.pt")
    parser.add_argument("--data", default=None, help="BlendVOCA build (default: the bundled-default build)")
    parser.add_argument("--samples", type=int, default=5)
    args = parser.parse_args(argv)

    import torch

    from baselines.cdface.generate import checkpoint_file
    from baselines.cdface.pipeline import CDFace
    from benchmark.data import open_blendvoca
    from benchmark.protocol import default_data_root
    from blendvoca.runtime.threads import limit_threads

    limit_threads(1, torch_only=True)
    try:
        cdface = CDFace.load(checkpoint_file(args.checkpoint))
    except FileNotFoundError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    dataset = open_blendvoca(args.data or default_data_root())
    rows = [sentence_figures(cdface, dataset, subject, sentence, args.samples)
            for subject in dataset.split("test") for sentence in dataset.sentences(subject)]
    for key in rows[0]:
        mean = np.mean([row[key] for row in rows], axis=0)
        print(f"{key:14s} {np.array2string(np.round(mean, 3)) if np.ndim(mean) else f'{mean:.3f}'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
