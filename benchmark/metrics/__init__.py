"""Benchmark metrics: pure functions over arrays.

Latent-space (features from any extractor, e.g. the published VAE):
:func:`frechet_distance`, :func:`frechet_distance_from_stats`, :func:`wind`,
:func:`multimodality`; the window protocol :func:`cut_windows`.
Vertex-space (through a speaker rig, mm): :mod:`benchmark.metrics.vertex`.
The energy score of samplers: :func:`energy_scores`, :func:`vertex_energy_score`.
"""

from benchmark.metrics.energy import energy_scores, vertex_energy_score
from benchmark.metrics.frechet import feature_statistics, frechet_distance, frechet_distance_from_stats
from benchmark.metrics.multimodality import multimodality, paired_samples
from blendvoca.rig_regions import lip_vertices, lower_face_vertices, nose_tip_index, upper_face_vertices
from benchmark.metrics.vertex import (
    average_pairwise_distance,
    diversity_metrics,
    lip_vertex_error,
    mean_vertex_error,
    motion_dynamics,
    minimum_pairwise_distance,
    pairwise_distances,
    rig_vertices,
    sequence_distance,
    upper_face_dynamics_deviation,
)
from benchmark.metrics.wind import (
    cached_gmm_components_many,
    gmm_components,
    gmm_components_many,
    gmm_fit_key,
    transport_cost,
    wind,
    wind_from_gmms,
    wind_scores,
)
from benchmark.metrics.windows import Windows, cut_windows, slice_windows, window_starts

__all__ = [
    "Windows", "average_pairwise_distance", "cached_gmm_components_many", "cut_windows", "diversity_metrics", "energy_scores", "feature_statistics", "frechet_distance",
    "frechet_distance_from_stats", "gmm_components", "gmm_components_many", "gmm_fit_key", "lip_vertex_error", "lip_vertices",
    "lower_face_vertices", "mean_vertex_error", "minimum_pairwise_distance", "motion_dynamics", "multimodality", "nose_tip_index",
    "paired_samples", "pairwise_distances", "rig_vertices", "sequence_distance", "slice_windows", "transport_cost", "upper_face_dynamics_deviation",
    "upper_face_vertices", "vertex_energy_score", "wind", "wind_from_gmms", "wind_scores", "window_starts",
]
