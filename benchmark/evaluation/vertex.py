"""The vertex family: LVE, LVE², MVE, |FDD|, the energy score and the diversity measures
of each sentence's vertices, in the two reference spaces (:data:`SPACES`), with their
metadata (:data:`METRICS`)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from benchmark.evaluation.entries import sentence_entries
from benchmark.evaluation.sentences import by_metric, map_sentences, rig_regions
from benchmark.metrics import vertex
from benchmark.metrics.bootstrap import BOOTSTRAP_RESAMPLES
from benchmark.metrics.energy import vertex_energy_score
from benchmark.metrics.info import MetricInfo, declared

__all__ = ["DIVERSITY", "METRICS", "SPACES", "own_vertex_metrics", "sentence_vertex_values", "vertex_metrics",
           "vertex_values"]

#: The two reference spaces of every vertex metric (suffix -> what it is compared with).
SPACES = {
    "mesh": "the source meshes (coefficient rows through each speaker's rig)",
    "rig": "the rig reconstruction of the ground-truth coefficients (vertex rows through their coefficient fit)",
}
#: Vertex metrics that do not depend on the reference (equal in both spaces when the
#: samples are the same vertices).
DIVERSITY = ("apd", "upd", "lpd", "mpd")
_SENT = "std over sentences"

#: The family's metrics, in table order within each group.
METRICS = declared(
    *(MetricInfo(f"{name}_{space}", f"{label} {space}", unit, False, "vertex", _SENT) for space in SPACES
      for name, label, unit in (("lve", "LVE", "mm"), ("lve_squared", "LVE (sq.)", "mm^2"), ("mve", "MVE", "mm"),
                                ("fdd", "FDD (abs.)", "mm^2"))),
    *(MetricInfo(f"energy_{space}", f"Energy {space}", "mm", False, "energy", _SENT) for space in SPACES),
    *(MetricInfo(f"{name}_{space}", f"{name.upper()} {space}", "mm", True, "diversity", _SENT, min_samples=2)
      for space in SPACES for name in DIVERSITY),
)


def sentence_vertex_values(preds, gt_v, neutral, lip, upper, *, diversity: bool = True) -> dict:
    """LVE, LVE², MVE, |FDD| per sample, the energy score and, for S >= 2, the diversity
    measures of one sentence (in one reference space: ``gt_v`` is the reference).

    Parameters
    ----------
    preds : (S, T, V, 3) ndarray
    gt_v : (T, V, 3) ndarray
    neutral : (V, 3) ndarray
    lip, upper : int ndarrays
        Lip and upper-face vertex indices.
    diversity : bool
        Compute the diversity measures (they do not depend on ``gt_v``).

    Returns
    -------
    dict
        ``lve``, ``lve_squared``, ``mve``, ``fdd``: (S,) arrays; ``energy``: float (mm);
        ``apd``, ``upd``, ``lpd``, ``mpd``: floats (S >= 2 and ``diversity`` only).
    """
    out = {"lve": [], "lve_squared": [], "mve": [], "fdd": []}
    gt_dynamics = {}
    for p in preds:
        out["lve"].append(vertex.lip_vertex_error(p, gt_v, lip))
        out["lve_squared"].append(vertex.lip_vertex_error(p, gt_v, lip, squared=True))
        out["mve"].append(vertex.mean_vertex_error(p, gt_v))
        # |FDD| per sequence: CodeTalker's signed mean lets too-lively and
        # too-still sequences cancel, and a ranking needs "closer to 0 is better".
        # (upper_face_dynamics_deviation, with the ground truth's term computed
        # once per length rather than once per sample.)
        t = min(len(p), len(gt_v))
        if t not in gt_dynamics:
            gt_dynamics[t] = vertex.motion_dynamics(gt_v[:t], neutral, upper)
        out["fdd"].append(abs(gt_dynamics[t] - vertex.motion_dynamics(p[:t], neutral, upper)))
    out = {k: np.asarray(v, dtype=np.float64) for k, v in out.items()}
    out["energy"] = vertex_energy_score(preds, gt_v)
    if diversity and len(preds) >= 2:
        out.update(vertex.diversity_metrics(preds, upper, lip))
    return out


def _in_space(values: dict, space: str) -> dict:
    """``values`` of :func:`sentence_vertex_values` named for ``space`` (``lve`` -> ``lve_rig``)."""
    return {f"{name}_{space}": value for name, value in values.items()}


def vertex_values(ground_truth, generated, rigs, names, workers: int = 1, *, mesh_vertices=None,
                  own_vertices=None, spaces=("mesh", "rig")) -> dict:
    """Per-sentence vertex metrics and energy scores in the reference ``spaces``,
    ``{name: {key: value}}``.

    Rig space: the rig reconstruction of ``generated`` against that of the ground-truth
    coefficients. Mesh space: ``own_vertices[key]`` (a vertex method's own output) or,
    for coefficient rows, the rig reconstruction of ``generated``, against
    ``mesh_vertices(subject, sentence)`` (the source meshes).
    """
    regions = rig_regions(rigs, names)
    if "mesh" in spaces and mesh_vertices is None:
        raise ValueError("vertex_values: the mesh space needs the source meshes (mesh_vertices)")

    def task(key):
        subject, sentence = key
        neutral, deltas, lip, upper = regions[subject]
        own = own_vertices is not None
        preds_rig = None
        if "rig" in spaces or not own:
            preds_rig = np.stack([vertex.rig_vertices(neutral, deltas, t) for t in generated[key]])
        out = {}
        if "rig" in spaces:
            gt_rig = vertex.rig_vertices(neutral, deltas, ground_truth[key])
            out.update(_in_space(sentence_vertex_values(preds_rig, gt_rig, neutral, lip, upper), "rig"))
        if "mesh" in spaces:
            gt_mesh = np.asarray(mesh_vertices(subject, sentence), dtype=np.float64)
            preds = np.asarray(own_vertices[key], dtype=np.float64) if own else preds_rig
            if preds.shape[2:] != gt_mesh.shape[1:] or gt_mesh.shape[1:] != neutral.shape:
                raise ValueError(f"vertex metrics {subject}/{sentence}: expected vertices (S, T, {neutral.shape[0]}, "
                                 f"3) like the source meshes {gt_mesh.shape} and the rig {neutral.shape}, got "
                                 f"{preds.shape}")
            # coefficient rows: the same vertices in both spaces, so the same diversity
            mesh = sentence_vertex_values(preds, gt_mesh, neutral, lip, upper,
                                          diversity=own or "rig" not in spaces)
            if not own and "rig" in spaces:
                mesh.update({n: out[f"{n}_rig"] for n in DIVERSITY if f"{n}_rig" in out})
            out.update(_in_space(mesh, "mesh"))
        return out

    return by_metric(map_sentences(task, generated, workers=workers, desc="vertex metrics"))


def vertex_metrics(ground_truth, generated, rigs: Mapping, names, *, seed: int = 0,
                   resamples: int = BOOTSTRAP_RESAMPLES, mesh_vertices=None) -> dict:
    """LVE, MVE, FDD, the energy score and the diversity measures of coefficient tracks
    through each speaker's rig: ``*_rig`` against the rig reconstruction of the ground
    truth and, with ``mesh_vertices``, ``*_mesh`` against the source meshes.

    Parameters
    ----------
    ground_truth : (subject, sentence) -> (T, C); generated : same keys -> (S, T, C)
    rigs : subject -> rig with ``neutral``, ``deltas``, ``names``
    names : column names of the tracks
    mesh_vertices : callable (subject, sentence) -> (T, V, 3), optional
        The source meshes (``dataset.vertices``).

    Returns
    -------
    dict of metric entries; spread = std over sentences.
    """
    spaces = ("mesh", "rig") if mesh_vertices is not None else ("rig",)
    values = vertex_values(ground_truth, generated, rigs, names, mesh_vertices=mesh_vertices, spaces=spaces)
    return sentence_entries(values, METRICS, seed=seed, resamples=resamples)[0]


def own_vertex_metrics(generated_vertices: Mapping, ground_truth_vertices, rigs: Mapping, names, *,
                       seed: int = 0, resamples: int = BOOTSTRAP_RESAMPLES) -> dict:
    """The mesh-space vertex metrics (``*_mesh``) of a vertex-output method's own vertices.

    Parameters
    ----------
    generated_vertices : mapping (subject, sentence) -> (S, T, V, 3)
        The method's vertices (metres, the speaker's topology).
    ground_truth_vertices : callable (subject, sentence) -> (T, V, 3)
        The source meshes (``dataset.vertices``).
    rigs : subject -> rig
        Define the lip region (from the rig's mouth shapes) and the face regions.
    names : column names of the rig's shapes

    Returns
    -------
    dict of metric entries; spread = std over sentences.
    """
    values = vertex_values(None, generated_vertices, rigs, names, mesh_vertices=ground_truth_vertices,
                           own_vertices=generated_vertices, spaces=("mesh",))
    return sentence_entries(values, METRICS, seed=seed, resamples=resamples)[0]
