"""Blendshape naming conventions as data: each tool's or corpus's names, their order and source.

A :class:`Convention` lists the ARKit shapes a tool or corpus carries, in the order
of its columns, spelled in camelCase (``jawOpen``); ``spelling`` says how its files
spell them (Live Link Face writes PascalCase). Some conventions fix no order: the
files carry their own list of names (BEAT's JSON ``names``, Audio2Face's
``facsNames``); their ``names`` is None and a reader passes the file's list to
:func:`blendvoca.names.remap` instead of the convention's name.

A rig's own controls are a convention too (``facegood116``): its files' columns are the
rig's ``controls``, which are not ARKit names, so ``names`` is None and ``to_arkit`` (a
table of :class:`~blendvoca.names.facegood.ControlMapping`) says how each ARKit shape is
formed from them; :func:`blendvoca.names.controls_to_arkit` applies it.

Every entry names its source and says what of it was checked against that source
(``checked``), and what could not be (``unverified``); ``docs/datasets.md`` and
``python -m blendvoca.names show NAME`` print both.
"""

from __future__ import annotations

from dataclasses import dataclass

from blendvoca.names.facegood import FACEGOOD116, FACEGOOD_TO_ARKIT, ControlMapping

#: The 52 shapes in the order of Apple's ARFaceAnchor.BlendShapeLocation documentation,
#: grouped as it groups them (left eye, right eye, mouth and jaw, eyebrows/cheeks/nose,
#: tongue); Unreal's EARFaceBlendShape enumerates them in the same order.
ARKIT_FACE_ORDER: tuple[str, ...] = (
    "eyeBlinkLeft", "eyeLookDownLeft", "eyeLookInLeft", "eyeLookOutLeft", "eyeLookUpLeft",
    "eyeSquintLeft", "eyeWideLeft", "eyeBlinkRight", "eyeLookDownRight", "eyeLookInRight",
    "eyeLookOutRight", "eyeLookUpRight", "eyeSquintRight", "eyeWideRight", "jawForward",
    "jawLeft", "jawRight", "jawOpen", "mouthClose", "mouthFunnel", "mouthPucker", "mouthLeft",
    "mouthRight", "mouthSmileLeft", "mouthSmileRight", "mouthFrownLeft", "mouthFrownRight",
    "mouthDimpleLeft", "mouthDimpleRight", "mouthStretchLeft", "mouthStretchRight",
    "mouthRollLower", "mouthRollUpper", "mouthShrugLower", "mouthShrugUpper", "mouthPressLeft",
    "mouthPressRight", "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft",
    "mouthUpperUpRight", "browDownLeft", "browDownRight", "browInnerUp", "browOuterUpLeft",
    "browOuterUpRight", "cheekPuff", "cheekSquintLeft", "cheekSquintRight", "noseSneerLeft",
    "noseSneerRight", "tongueOut",
)

#: The 51 shapes of the ARKit reference rig (SAiD's ``ARKit_reference_blendshapes.zip``):
#: ARKit's 52 less tongueOut, which a closed-mouth surface mesh cannot express; alphabetical.
ARKIT_NAMES: tuple[str, ...] = tuple(sorted(n for n in ARKIT_FACE_ORDER if n != "tongueOut"))

#: BlendVOCA's 32 speech shapes in the column order of every BlendVOCA coefficient
#: file: SAiD's ``data/ARKit_blendshapes.txt`` (the asset ``arkit-blendshape-names``).
BLENDVOCA_NAMES: tuple[str, ...] = (
    "jawForward", "jawLeft", "jawRight", "jawOpen", "mouthClose", "mouthFunnel",
    "mouthPucker", "mouthLeft", "mouthRight", "mouthSmileLeft", "mouthSmileRight",
    "mouthFrownLeft", "mouthFrownRight", "mouthDimpleLeft", "mouthDimpleRight",
    "mouthStretchLeft", "mouthStretchRight", "mouthRollLower", "mouthRollUpper",
    "mouthShrugLower", "mouthShrugUpper", "mouthPressLeft", "mouthPressRight",
    "mouthLowerDownLeft", "mouthLowerDownRight", "mouthUpperUpLeft",
    "mouthUpperUpRight", "cheekPuff", "cheekSquintLeft", "cheekSquintRight",
    "noseSneerLeft", "noseSneerRight",
)


def _swap(names: tuple[str, ...], a: str, b: str) -> tuple[str, ...]:
    """``names`` with ``a`` and ``b`` exchanged (both must be present)."""
    i, j = names.index(a), names.index(b)
    out = list(names)
    out[i], out[j] = out[j], out[i]
    return tuple(out)


#: Live Link Face's CSV shape columns (camelCase here; the app writes PascalCase): ARKit's
#: order except that JawRight comes before JawLeft and MouthRight before MouthLeft.
LIVELINK_ORDER: tuple[str, ...] = _swap(_swap(ARKIT_FACE_ORDER, "jawLeft", "jawRight"), "mouthLeft", "mouthRight")

#: UniTalker's 51 ``inhouse_blendshape_weight`` columns (its D6 and D7 corpora): the
#: Faceshift-style grouping (eyes by action, brows, jaw, lips), ARKit's 52 less tongueOut.
UNITALKER_ORDER: tuple[str, ...] = (
    "eyeBlinkLeft", "eyeBlinkRight", "eyeSquintLeft", "eyeSquintRight", "eyeLookDownLeft",
    "eyeLookDownRight", "eyeLookInLeft", "eyeLookInRight", "eyeWideLeft", "eyeWideRight",
    "eyeLookOutLeft", "eyeLookOutRight", "eyeLookUpLeft", "eyeLookUpRight", "browDownLeft",
    "browDownRight", "browInnerUp", "browOuterUpLeft", "browOuterUpRight", "jawOpen", "mouthClose",
    "jawLeft", "jawRight", "jawForward", "mouthUpperUpLeft", "mouthUpperUpRight",
    "mouthLowerDownLeft", "mouthLowerDownRight", "mouthRollUpper", "mouthRollLower",
    "mouthSmileLeft", "mouthSmileRight", "mouthDimpleLeft", "mouthDimpleRight", "mouthStretchLeft",
    "mouthStretchRight", "mouthFrownLeft", "mouthFrownRight", "mouthPressLeft", "mouthPressRight",
    "mouthPucker", "mouthFunnel", "mouthLeft", "mouthRight", "mouthShrugLower", "mouthShrugUpper",
    "noseSneerLeft", "noseSneerRight", "cheekPuff", "cheekSquintLeft", "cheekSquintRight",
)

#: 3D-ETF's 52 columns (EmoTalk's output): the 51 in alphabetical order, then tongueOut.
ETF_ORDER: tuple[str, ...] = ARKIT_NAMES + ("tongueOut",)


@dataclass(frozen=True)
class Convention:
    """One tool's or corpus's blendshape names.

    Attributes
    ----------
    name : str
        The registry key (``arkit52``, ``livelink``, ...).
    title : str
        What uses it, in a few words.
    names : tuple of str or None
        The shapes in column order, camelCase ARKit names; None when every file
        carries its own list (then ``count`` is the usual count, if one is known).
    count : int or None
    spelling : {"camel", "pascal"}
        How the convention's files spell the names.
    source : str
        Where the names and order come from: repository, path and commit, or a URL.
    checked : str
        What was compared with the source.
    unverified : str
        What could not be checked against a primary source ("" when nothing).
    controls : tuple of str or None
        A rig convention's columns: the rig's own control names (then ``names`` is None).
    to_arkit : tuple of ControlMapping
        How a rig convention's controls form ARKit shapes (empty for the others).
    """

    name: str
    title: str
    names: tuple[str, ...] | None
    count: int | None
    spelling: str
    source: str
    checked: str
    unverified: str = ""
    controls: tuple[str, ...] | None = None
    to_arkit: tuple[ControlMapping, ...] = ()

    @property
    def lacks(self) -> tuple[str, ...] | None:
        """ARKit's shapes (of the 52, in ARKit's order) this convention has no column for
        (a rig convention: that its controls do not form); None when the names come with each file."""
        if self.names is None and not self.to_arkit:
            return None
        present = set(self.names) if self.names is not None else {m.arkit for m in self.to_arkit}
        return tuple(n for n in ARKIT_FACE_ORDER if n not in present)

    def columns(self) -> tuple[str, ...] | None:
        """The names as the convention's files spell them (PascalCase for ``pascal``; a rig's controls)."""
        if self.controls is not None:
            return self.controls
        if self.names is None:
            return None
        if self.spelling == "pascal":
            return tuple(n[0].upper() + n[1:] for n in self.names)
        return self.names


_APPLE = "https://developer.apple.com/documentation/arkit/arfaceanchor/blendshapelocation"

#: Every convention by name. Add one by adding an entry (tests check each round trip to arkit52).
CONVENTIONS: dict[str, Convention] = {c.name: c for c in (
    Convention(
        "arkit52", "Apple ARKit face tracking (ARFaceAnchor.BlendShapeLocation)", ARKIT_FACE_ORDER, 52, "camel",
        source=f"{_APPLE} (machine-readable: https://developer.apple.com/tutorials/data/documentation/arkit/"
               "arfaceanchor/blendshapelocation.json)",
        checked="the 52 names and their grouping in the documentation's topics (left eye, right eye, mouth and "
                "jaw, eyebrows/cheeks/nose, tongue); this order is the documentation's, ARKit's dictionary of "
                "coefficients itself has no order"),
    Convention(
        "arkit51", "the ARKit reference rig (SAiD's reference blendshapes), alphabetical", ARKIT_NAMES, 51, "camel",
        source="github.com/yunik1004/SAiD data/ARKit_reference_blendshapes.zip (the asset arkit-reference-rig, "
               "blendvoca/data_manifest.yaml)",
        checked="the OBJ file names in the zip (tests/test_names.py)"),
    Convention(
        "livelink", "Epic's Live Link Face app, CSV export (after Timecode, BlendShapeCount)", LIVELINK_ORDER, 52,
        "pascal",
        source="Live Link Face (iOS) CSV export; shape set as Unreal's EARFaceBlendShape "
               "(https://dev.epicgames.com/documentation/unreal-engine/API/Plugins/AppleARKit)",
        checked="the header of real exports: Timecode, BlendShapeCount (or BlendshapeCount: both spellings "
                "occur), the 52 shapes in this order (JawRight before JawLeft, MouthRight before MouthLeft), then "
                "the 9 head and eye rotations (tests/export: Live Link import and export)",
        unverified="Epic publishes no specification of the CSV; the order is that of exported takes"),
    Convention(
        "unitalker51", "UniTalker's inhouse_blendshape_weight (corpora D6, D7)", UNITALKER_ORDER, 51, "camel",
        source="github.com/X-niper/UniTalker dataset/dataset_config.py @ f8fcb10293c1ec1bc781ef6679b383ce8d6243ac "
               "(D6/D7: annot_type inhouse_blendshape_weight, annot_dim 51); the order is that of UniTalker's "
               "ARKit resource inhouse_arkit.npz, copied in github.com/GoldenFishes/UniTAF "
               "a2f/resources/binary_resources/inhouse_arkit.npz @ 41d0760302cda6141d00e26bdd49291cff2f53b1",
        checked="the order: the resource's 51 'blendshape' deltas equal the ARKit reference rig's "
                "(arkit-reference-rig) one for one in this order (largest difference 0.0; its meanshape equals "
                "the rig's neutral), and the count (51) and annotation type in dataset_config.py"),
    Convention(
        "beat", "BEAT (PantoMatrix): facial JSON captured with ARKit, one file per take", None, None, "camel",
        source="github.com/PantoMatrix/PantoMatrix dataloaders/beat.py @ 152d7c714522da77074016180366fcd43842057b "
               "(reads frames[i]['weights'] and frames[i]['time'] of <take>.json, 60 fps)",
        checked="the keys frames, weights and time and the 60 fps capture rate, from BEAT's own loader",
        unverified="the shape order: each file lists its shapes under 'names' (seen in third-party readers, "
                   "not in BEAT's loader, which uses the weights positionally), so the adapter takes the order "
                   "from each file and refuses a file without it; whether a take has 51 or 52 shapes is read "
                   "from the file too"),
    Convention(
        "a2f52", "NVIDIA Audio2Face-3D, ARKit blendshape export (52 poses)", ARKIT_FACE_ORDER, 52, "camel",
        source="Audio2Face blendshape JSON export (facsNames, weightMat; blendvoca/export/a2f_json.py); "
               "solver configuration fields as in github.com/tridot-io/Audio2Face-3D-SDK (fork of NVIDIA's "
               "Audio2Face-3D SDK), audio2face-sdk @ 717cef92f732982bbbbf3dc5a6b46fcf88da815f",
        checked="the export's keys (facsNames lists the pose names of each file)",
        unverified="the pose order of NVIDIA's character models: it lives in the binary bs_skin_*.npz "
                   "(poseNames) that could not be read here; files carry facsNames, and readers map by name, "
                   "so the order listed (ARKit's) only decides what this project writes"),
    Convention(
        "a2f46", "NVIDIA Audio2Face, 46-pose blendshape solve", None, 46, "camel",
        source="NVIDIA Audio2Face blendshape solve (numPoses of the character's bs_skin configuration)",
        checked="nothing: no primary source listing the 46 poses could be read here",
        unverified="which 46 of ARKit's shapes, and their order; exported files carry them in facsNames, "
                   "so pass the file's list to remap"),
    Convention(
        "metahuman", "Epic MetaHuman face (ARKit curves driven from Live Link Face)",
        tuple(n for n in ARKIT_FACE_ORDER if n != "mouthClose"), 51, "pascal",
        source="Epic MetaHuman ARKit mapping (pose asset of the MetaHuman face)",
        checked="nothing against Epic's asset",
        unverified="that the MetaHuman face lacks mouthClose (and only it) is reported by users, not checked "
                   "against Epic's pose asset here; the order is ARKit's, and names are matched by name"),
    Convention(
        "said32", "SAiD / BlendVOCA speech shapes (every BlendVOCA coefficient file)", BLENDVOCA_NAMES, 32, "camel",
        source="github.com/yunik1004/SAiD data/ARKit_blendshapes.txt @ bb7b18018358d3156569d8051f386943744a5ea0 "
               "(the asset arkit-blendshape-names)",
        checked="against the asset file and SAiD's coeffs_std.csv header (tests/test_names.py)"),
    Convention(
        "etf52", "3D-ETF (EmoTalk): 52 ARKit-compatible coefficients", ETF_ORDER, 52, "camel",
        source="github.com/psyai-net/EmoTalk_release render.py @ 2d0fbde4b5a369adda37311b19d2f2c9360e36ae "
               "(model_bsList, the order its outputs and renders use)",
        checked="the 52 names and their order in model_bsList"),
    Convention(
        "facegood116", "FACEGOOD-Audio2Face's rig: 116 FACS-like controls (not ARKit names)", None, 116, "camel",
        source="github.com/FACEGOOD/FACEGOOD-Audio2Face code/train/shirley_1015_bs_name.npy @ "
               "e6d41b6ed9e414b2f7427e52e18c401f7d1775a8 (the columns of code/train/bs_value/bs_value_*.npy)",
        checked="the 116 names and their order against the file (tests/datasets/test_facegood.py, through the "
                "asset resolver); that it is the values' order: the moving left/right control pairs correlate "
                "at r >= 0.997 under it over the seven takes (0.015 under the repository's 1119 list, as the real-data folder's SOURCES.md records); the map "
                "onto ARKit by FACS name semantics, left/right symmetry and the speech envelope "
                "(docs/results/datasets-measurements.md)",
        unverified="FACEGOOD publishes no description of its controls nor meshes of the rig: the map onto "
                   "ARKit rests on the names (FACS action units), except jawOpen, measured against the speech "
                   "envelope; which side '_l' is (the face's left, as ARKit's Left, is assumed: the takes are "
                   "symmetric, so the data cannot tell); mouth_chinRaise_u/_d as mouthShrugUpper/Lower; the "
                   "weight of mouth_oo_c in mouthPucker",
        controls=FACEGOOD116, to_arkit=FACEGOOD_TO_ARKIT),
)}
