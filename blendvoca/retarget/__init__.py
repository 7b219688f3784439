"""Rig construction: the ARKit reference rig onto any head mesh by deformation transfer.

Steps (one file each): `similarity_transform` (landmark alignment with residual),
`crop_mesh` / `reattached_deltas` (crop and re-attach), `register_source_to_target`
and `triangle_correspondence` (Sumner-Popovic correspondence), `transfer_system` /
`transferred_deltas` / `anchored_deltas` (deformation transfer: one factorization,
many solves), `retarget_report` (quality report), `contact_sheet` (front-view image).
`retarget_rig` does all of it in one call; `correspondence_for_target` lets many
targets of one topology share a correspondence.
"""

from .alignment import Similarity, similarity_transform
from .contact_sheet import contact_sheet
from .correspondence import VertexCorrespondence, triangle_correspondence, vertex_correspondence
from .crop import Crop, connected_pieces, crop_mesh, reattach_deltas, reattached_deltas, seam_distances
from .deformation_gradient import (deformation_gradient_displacements, deformation_gradient_operator,
                                   deformation_gradients, fourth_vertices)
from .pipeline import (Correspondence, RetargetPlan, correspondence_for_target, plan_retarget, retarget_rig,
                       retargeted_deltas)
from .registration import register_source_to_target
from .report import report_markdown, retarget_report
from .transfer import TransferSystem, anchored_deltas, transfer_system, transferred_deltas

__all__ = [
    "Correspondence", "Crop", "RetargetPlan", "Similarity", "TransferSystem", "VertexCorrespondence",
    "anchored_deltas", "connected_pieces", "contact_sheet", "correspondence_for_target", "crop_mesh",
    "deformation_gradient_displacements", "deformation_gradient_operator", "deformation_gradients",
    "fourth_vertices", "plan_retarget", "reattach_deltas", "reattached_deltas", "register_source_to_target",
    "report_markdown", "retarget_report", "retarget_rig", "retargeted_deltas", "seam_distances",
    "similarity_transform", "transfer_system", "transferred_deltas", "triangle_correspondence",
    "vertex_correspondence",
]
