"""Method plug-ins: the contract (:class:`Method`, :class:`Budget`, :class:`Dataset`,
:class:`Utterance`) and the registry.

Built-in methods are registered lazily here, so importing this package imports no
baseline (and no torch).
"""

from . import contract
from .base import Budget, Method, TrainingRequest, progress_bars, show_progress
from .contract import *  # noqa: F403 - the contract's names (its __all__) are this package's
from .registry import (
    ENTRY_POINT_GROUP,
    UnknownMethodError,
    available_methods,
    get_method,
    method_listing,
    method_schema,
    register,
    register_lazy,
    unregister,
)
from .validate import MethodError, MethodOutputError, validated_tracks, validated_vertices

__all__ = [
    *contract.__all__,
    "BUILTIN_METHODS",
    "ENTRY_POINT_GROUP",
    "Budget",
    "Method",
    "TrainingRequest",
    "MethodError",
    "MethodOutputError",
    "UnknownMethodError",
    "available_methods",
    "get_method",
    "method_listing",
    "method_schema",
    "progress_bars",
    "register",
    "register_lazy",
    "show_progress",
    "unregister",
    "validated_tracks",
    "validated_vertices",
]

#: Methods shipped with the project, as lazy ``"module:Class"`` targets.
BUILTIN_METHODS = {
    "ground-truth": "baselines.bounds.ground_truth:GroundTruthMethod",
    "mean": "baselines.bounds.mean:MeanMethod",
    "static": "baselines.bounds.static:StaticMethod",
    "random": "baselines.bounds.random_walk:RandomWalkMethod",
    "corpus-meshes": "baselines.bounds.corpus_meshes:CorpusMeshesMethod",
    "oracle-sample": "baselines.bounds.oracle:OracleSampleMethod",
    "oracle-mean": "baselines.bounds.oracle:OracleMeanMethod",
    "regression": "baselines.regression.plugin:RegressionMethod",
    "mesh-adapter": "baselines.mesh_adapter.plugin:MeshAdapterMethod",
    "said": "baselines.said.plugin:SAiDMethod",
    "faceformer": "baselines.faceformer.plugin:FaceFormerMethod",
    "codetalker": "baselines.codetalker.plugin:CodeTalkerMethod",
    "cdface": "baselines.cdface.plugin:CDFaceMethod",
}

for _name, _target in BUILTIN_METHODS.items():
    register_lazy(_name, _target)
del _name, _target
