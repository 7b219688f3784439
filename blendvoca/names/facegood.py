"""FACEGOOD's rig controls (``facegood116``) and their map onto ARKit's shapes, as data.

FACEGOOD-Audio2Face's training takes (``bs_value_<take>.npy``) are performance captures
solved onto FACEGOOD's own rig: 116 FACS-like controls (``_l``/``_r``/``_c`` sides,
``_u``/``_d`` upper and lower lip, tongue, teeth and eye controls), none of them an ARKit
name. :data:`FACEGOOD116` is their column order, that of the repository's
``code/train/shirley_1015_bs_name.npy`` (``bs_names_1015.npy`` here): under it every pair
of ``_l``/``_r`` controls that moves correlates at r >= 0.997 over the seven takes, under the
repository's other list (``shirley_1119_bs_name.npy``) at r = 0.015.

:data:`FACEGOOD_TO_ARKIT` forms each ARKit shape as a weighted sum of controls, clipped to
[0, 1] (:func:`blendvoca.names.controls_to_arkit` applies it); every entry says how it
was decided. :data:`FACEGOOD_UNMAPPED` lists the controls with no ARKit counterpart and
what they carry. The measurements behind the decisions (which controls move, left/right
symmetry, correlation with the speech envelope) are made by ``perf/facegood_map.py`` and
written to ``docs/results/datasets-measurements.md``; ``docs/datasets.md`` shows the table.
"""

from __future__ import annotations

from dataclasses import dataclass

#: FACEGOOD's 116 controls in the column order of ``bs_value_<take>.npy``
#: (FACEGOOD-Audio2Face ``code/train/shirley_1015_bs_name.npy``).
FACEGOOD116: tuple[str, ...] = (
    'brow_lower_l', 'tongue_Scale_X', 'tongue_Scale__X', 'tongue_Scale_Y', 'tongue_Scale__Y', 'tongue_Scale_Z',
    'tongue_Scale__Z', 'nose_out_l', 'nose_out_r', 'tongue_u', 'tongue_u_u', 'cheek_suck_r', 'brow_raise_d',
    'mouth_stretch_u', 'tongue_u_d', 'tooth_d_d', 'tongue_d', 'tooth_r', 'tooth_d_u', 'cheek_UP',
    'eye_blink1_l', 'eye_blink1_r', 'eye_blink2_l', 'eye_blink2_r', 'eye_lidTight_l', 'eye_lidTight_r',
    'eye_shutTight_l', 'eye_shutTight_r', 'brow_lower_r', 'eye_upperLidRaise_l', 'eye_upperLidRaise_r',
    'eye_downLidRaise_l', 'eye_downLidRaise_r', 'jaw_sideways_l', 'jaw_sideways_r', 'jaw_thrust_c',
    'mouth_chew_c', 'mouth_chinRaise_d', 'mouth_chinRaise_u', 'brow_raise_c', 'mouth_dimple_l',
    'mouth_dimple_r', 'mouth_funnel_dl', 'mouth_funnel_dr', 'mouth_funnel_ul', 'mouth_funnel_ur',
    'mouth_lipCornerDepressFix_l', 'mouth_lipCornerDepressFix_r', 'mouth_lipCornerDepress_l',
    'mouth_lipCornerDepress_r', 'brow_raise_l', 'mouth_lipCornerPullOpen_l', 'mouth_lipCornerPullOpen_r',
    'mouth_lipCornerPull_l', 'mouth_lipCornerPull_r', 'mouth_lipStretchOpen_l', 'mouth_lipStretchOpen_r',
    'mouth_lipStretch_l', 'mouth_lipStretch_r', 'mouth_lowerLipDepress_l', 'mouth_lowerLipDepress_r',
    'brow_raise_r', 'mouth_lowerLipProtrude_c', 'mouth_oh_c', 'mouth_oo_c', 'mouth_pressFix_c',
    'mouth_press_l', 'mouth_press_r', 'mouth_pucker_l', 'mouth_pucker_r', 'mouth_screamFix_c',
    'mouth_sideways_l', 'cheek_puff_l', 'mouth_sideways_r', 'mouth_stretch_c', 'mouth_suck_dl',
    'mouth_suck_dr', 'mouth_suck_ul', 'mouth_suck_ur', 'mouth_upperLipRaise_l', 'mouth_upperLipRaise_r',
    'nose_wrinkle_l', 'nose_wrinkle_r', 'cheek_puff_r', 'tooth_l', 'eye_lookDown1_l', 'eye_lookDown2_l',
    'eye_lookLeft_l', 'eye_lookRight_l', 'eye_lookUp_l', 'eye_lookDown1_r', 'eye_lookDown2_r',
    'eye_lookLeft_r', 'cheek_raise_l', 'eye_lookRight_r', 'eye_lookUp_r', 'tongue_Rot_1X', 'tongue_Rot__1X',
    'tongue_Rot_2X', 'tongue_Rot__2X', 'tongue_Rot_3X', 'tongue_Rot__3X', 'tongue_Rot_1Y', 'tongue_Rot__1Y',
    'cheek_raise_r', 'tongue_Rot_2Y', 'tongue_Rot__2Y', 'tongue_Rot_3Y', 'tongue_Rot__3Y', 'tongue_Rot_1Z',
    'tongue_Rot__1Z', 'tongue_Rot_2Z', 'tongue_Rot__2Z', 'tongue_Rot_3Z', 'tongue_Rot__3Z', 'cheek_suck_l',

)


@dataclass(frozen=True)
class ControlMapping:
    """One ARKit shape formed from rig controls: ``clip(sum(w * control), 0, 1)``.

    Attributes
    ----------
    arkit : str
        The ARKit shape (camelCase).
    terms : tuple of (control, weight)
    basis : str
        How the mapping was decided and checked.
    """

    arkit: str
    terms: tuple[tuple[str, float], ...]
    basis: str


_FACS = "name semantics (FACS action unit {au}, as ARKit's {arkit})"
_SYM = "; left/right pair moves together (r >= 0.997 over the seven takes)"
_STILL = "; constant 0 in all seven takes, so only the name decides it"


def _pair(arkit: str, control: str, au: str, *, moves: bool) -> tuple[ControlMapping, ControlMapping]:
    """``arkitLeft``/``arkitRight`` from ``control_l``/``control_r`` (FACEGOOD's ``_l`` read as the face's left,
    ARKit's ``Left``)."""
    basis = _FACS.format(au=au, arkit=arkit) + (_SYM if moves else _STILL)
    return (ControlMapping(f"{arkit}Left", ((f"{control}_l", 1.0),), basis),
            ControlMapping(f"{arkit}Right", ((f"{control}_r", 1.0),), basis))


#: Every ARKit shape FACEGOOD's controls form, in ARKit's order of the mouth, jaw, cheeks,
#: nose and brows (eyes and tongue are not mapped: :data:`FACEGOOD_UNMAPPED`).
FACEGOOD_TO_ARKIT: tuple[ControlMapping, ...] = (
    ControlMapping("jawForward", (("jaw_thrust_c", 1.0),), "name semantics (jaw thrust, AU29)" + _STILL),
    ControlMapping("jawLeft", (("jaw_sideways_l", 1.0),),
                   "name semantics (jaw sideways, AU30); moves a little (max 0.05) in one take only"),
    ControlMapping("jawRight", (("jaw_sideways_r", 1.0),), "name semantics (jaw sideways, AU30)" + _STILL),
    ControlMapping("jawOpen", (("mouth_stretch_c", 1.0), ("mouth_oh_c", 0.25)),
                   "the rig has no jaw control: mouth_stretch_c (FACS AU27, mouth stretch: the jaw pulled wide "
                   "open) carries the opening and follows the speech envelope best (r = 0.74 averaged over the "
                   "takes); mouth_oh_c (an open, rounded 'o') opens the jaw too: adding it at weight 0.25 "
                   "raises the envelope correlation in 6 of 7 takes (mean r 0.756), at 0.5 or more lowers it "
                   "(perf/facegood_map.py)"),
    ControlMapping("mouthFunnel", tuple((f"mouth_funnel_{s}", 0.25) for s in ("ul", "ur", "dl", "dr")),
                   "name semantics (lip funneler, AU22): the mean of the four lip quarters" + _SYM),
    ControlMapping("mouthPucker", (("mouth_pucker_l", 0.5), ("mouth_pucker_r", 0.5), ("mouth_oo_c", 1.0)),
                   "name semantics (lip pucker, AU18): the mean of the two sides plus mouth_oo_c, the rig's "
                   "'oo' (rounded, protruded lips), clipped to 1" + _SYM + "; the share of oo_c is a choice, "
                   "not a measurement"),
    ControlMapping("mouthLeft", (("mouth_sideways_l", 1.0),), "name semantics (mouth sideways)" + _STILL),
    ControlMapping("mouthRight", (("mouth_sideways_r", 1.0),), "name semantics (mouth sideways)" + _STILL),
    *_pair("mouthSmile", "mouth_lipCornerPull", "AU12, lip corner puller", moves=True),
    *_pair("mouthFrown", "mouth_lipCornerDepress", "AU15, lip corner depressor", moves=False),
    *_pair("mouthDimple", "mouth_dimple", "AU14, dimpler", moves=True),
    *_pair("mouthStretch", "mouth_lipStretch", "AU20, lip stretcher", moves=True),
    ControlMapping("mouthRollLower", (("mouth_suck_dl", 0.5), ("mouth_suck_dr", 0.5)),
                   "name semantics (lip suck, AU28, lower lip): the mean of the two sides" + _SYM),
    ControlMapping("mouthRollUpper", (("mouth_suck_ul", 0.5), ("mouth_suck_ur", 0.5)),
                   "name semantics (lip suck, AU28, upper lip): the mean of the two sides" + _SYM),
    ControlMapping("mouthShrugLower", (("mouth_chinRaise_d", 1.0),),
                   "name semantics (chin raiser, AU17), _d read as the lower part as in the funnel and suck "
                   "controls" + _STILL),
    ControlMapping("mouthShrugUpper", (("mouth_chinRaise_u", 1.0),),
                   "name semantics (chin raiser, AU17), _u read as the upper part as in the funnel and suck "
                   "controls; moves (max 0.48); which ARKit shrug it is, is the least certain entry"),
    *_pair("mouthPress", "mouth_press", "AU24, lip presser", moves=True),
    *_pair("mouthLowerDown", "mouth_lowerLipDepress", "AU16, lower lip depressor", moves=True),
    *_pair("mouthUpperUp", "mouth_upperLipRaise", "AU10, upper lip raiser", moves=True),
    ControlMapping("cheekPuff", (("cheek_puff_l", 0.5), ("cheek_puff_r", 0.5)),
                   "name semantics (cheek puff): the mean of the two sides" + _STILL),
    *_pair("cheekSquint", "cheek_raise", "AU6, cheek raiser", moves=False),
    *_pair("noseSneer", "nose_wrinkle", "AU9, nose wrinkler", moves=True),
    *_pair("browDown", "brow_lower", "AU4, brow lowerer", moves=False),
    ControlMapping("browInnerUp", (("brow_raise_c", 1.0),), "name semantics (inner brow raiser, AU1)" + _STILL),
    *_pair("browOuterUp", "brow_raise", "AU2, outer brow raiser", moves=False),
)


def _carries(control: str) -> str:
    """What an unmapped control carries, from its name."""
    if control.startswith("tongue_"):
        return "tongue (scale and rotation of its segments)"
    if control.startswith("tooth_"):
        return "teeth (the lower or upper row moved apart from the jaw)"
    if control.startswith("eye_"):
        return "eyes (blinks in two stages, lid tightening and raising, gaze)"
    return "a corrective or extra mouth, cheek, nose or brow shape with no ARKit counterpart"


_MAPPED = {c for m in FACEGOOD_TO_ARKIT for c, _ in m.terms}

#: FACEGOOD's controls that form no ARKit shape, in column order, with what each carries.
FACEGOOD_UNMAPPED: tuple[tuple[str, str], ...] = tuple((c, _carries(c)) for c in FACEGOOD116 if c not in _MAPPED)
