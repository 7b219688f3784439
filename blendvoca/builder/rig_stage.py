"""The build's rig stage: one triangle correspondence for the build (in the build process),
then each speaker's rig (a task per speaker in the worker processes)."""

from __future__ import annotations

import time

from blendvoca import format as fmt
from blendvoca.errors import DataError
from blendvoca.format.hashing import array_digest, stage_key
from blendvoca.format.manifest import remove_manifest
from blendvoca.retarget import correspondence_for_target
from blendvoca.rig import load_arkit_reference
from blendvoca.runtime.threads import limited_threads
from blendvoca.vocaset.checks import template_scale_problem

from .speaker import head_faces, speaker_rig
from .state import is_up_to_date, read_record, record_path
from .worker import WORKER, record_built, recorded_failure, static_inputs

#: Bumped when the stage's algorithm changes its outputs (invalidates records).
RIG_STAGE_VERSION = "2"  # 2: one triangle correspondence per build, on the reference speaker


def rig_stage_key(template_digest, faces_digest, static, params, correspondence_template):
    # The rig depends on the template the shared correspondence was computed on
    # (the reference speaker's) as well as on the speaker's own template.
    return stage_key({
        "stage": "rig", "version": RIG_STAGE_VERSION, "shapes": static["shapes"],
        "template": template_digest, "faces": faces_digest, "assets": static["assets"],
        "correspondence_template": correspondence_template,
        "params": {k: params[k] for k in ("shapes",)},
    })


def reference_rig(static, params):
    """The ARKit reference rig, parsed once per process and only when a rig is (re)built."""
    if "reference" not in static:
        static["reference"] = load_arkit_reference(params["shapes"])
    return static["reference"]


def shared_correspondence(corpus, subjects, out, params):
    """One triangle correspondence for the whole build, computed in the parent process.

    It is computed on the first speaker (corpus order) whose template can be
    read and reused for every speaker (one topology). Returns
    ``{"template": digest, "correspondence": Correspondence or None}``; the
    correspondence is computed only when some rig is out of date (a rerun with
    nothing to do pays only for reading and hashing the templates). ``{}``
    when no template can be read (every rig fails on its own then).
    """
    static = static_inputs(params["shapes"], corpus)
    faces = corpus.faces
    faces_digest = array_digest(faces)
    reference_template = reference_digest = None
    stale = False
    for subject in subjects:
        try:
            template = corpus.template(subject)
        except Exception:  # that speaker's rig task reports it
            stale = True
            continue
        if template_scale_problem(template):  # that speaker's rig task refuses it
            stale = True
            continue
        digest = array_digest(template)
        if reference_template is None:
            reference_template, reference_digest = template, digest
        key = rig_stage_key(digest, faces_digest, static, params, reference_digest)
        if not is_up_to_date(out, read_record(record_path(out, "rigs", subject)), key):
            stale = True
        if stale and reference_template is not None:
            break
    if reference_template is None:
        return {}
    shared = {"template": reference_digest, "correspondence": None}
    if stale:
        try:
            with limited_threads(1):  # as in the workers, so shared results match theirs bit for bit
                reference = reference_rig(static, params)
                shared["correspondence"] = correspondence_for_target(
                    reference.neutral, reference.faces, reference_template, faces,
                    static["reference_landmarks"], static["landmarks"], crop=static["head_index"])
        except Exception:  # each rig task computes (and reports) its own then
            shared["correspondence"] = None
    return shared


def speaker_task(subject):
    """Build (or confirm) one speaker's rig; returns a status dict."""
    corpus, out, params, static, shared = (WORKER[k] for k in ("corpus", "out", "params", "static", "shared"))
    path = record_path(out, "rigs", subject)
    clock = time.perf_counter()
    try:
        template = corpus.template(subject)
        check_template_scale(subject, template)
        faces = corpus.faces
        inputs = {"template": array_digest(template), "faces": array_digest(faces)}
        # Without a shared correspondence (no readable reference template) each rig uses its own.
        reference_digest = shared.get("template", inputs["template"])
        key = rig_stage_key(inputs["template"], inputs["faces"], static, params, reference_digest)
        record = read_record(path)
        if is_up_to_date(out, record, key):
            return {"subject": subject, "status": "skipped", "key": key}
        correspondence = shared.get("correspondence")
        if correspondence is None and reference_digest != inputs["template"]:
            raise DataError(f"{subject}: the correspondence shared by all speakers could not be computed "
                                 "on the reference speaker's template (see that speaker's rig failure)")
        reference = reference_rig(static, params)
        read_s, clock = time.perf_counter() - clock, time.perf_counter()
        rig = speaker_rig(reference, template, faces, static["reference_landmarks"],
                          static["landmarks"], static["head_index"], correspondence=correspondence)
        compute_s, clock = time.perf_counter() - clock, time.perf_counter()
        remove_manifest(out)
        head = static["head_index"]
        hfaces = head_faces(rig.faces, head, rig.num_vertices)
        files = [fmt.write_rig(out, subject, rig)]
        # SAiD's layout: the head crop of the neutral and of every blendshape
        files += fmt.write_said_rig(out, subject, rig.neutral[head], rig.deltas[:, head], rig.names, hfaces)
        seconds = record_built(path, {"key": key, "subject": subject, "inputs": inputs}, sorted(files),
                               read_s=read_s, compute_s=compute_s, clock=clock)
        return {"subject": subject, "status": "built", "key": key, "seconds": seconds}
    except Exception as error:  # recorded, the build carries on
        return recorded_failure(out, path, error, {"subject": subject})


def check_template_scale(subject, template):
    """Refuse a template in another unit than metres: its rig and every fit would be nonsense (errors in metres)."""
    problem = template_scale_problem(template)
    if problem:
        raise DataError(f"{subject}: {problem}")
