"""The study's web application (FastAPI): :func:`create_app` ``(folder, db_url)``.

Routes (every one under ``/s/{token}/`` checks the session token against the database)::

    GET  /                        consent page (keeps the platform's URL parameters)
    POST /start                   consent given: a new session on the least-taken slot -> /s/{token}/
    GET  /s/{token}/              the current step's page (instructions, sound check, a question, done)
    GET  /s/{token}/api/state     the current step as JSON
    POST /s/{token}/api/instructions   instructions read
    POST /s/{token}/api/sound-check    {"word": ...} -> {"passed", "attempts_left"}
    POST /s/{token}/api/answer    {"trial", "question", "choice", "rt_ms"}: written before the reply
    GET  /s/{token}/media/{id}    a stimulus of this participant's trials (by stimulus id, never a path)
    GET  /vendor/{name}, /static/{name}   jsPsych (node_modules) and the study's script/style, by name

Refusals are short JSON (``/api``) or HTML pages with a 4xx status and no traceback: an unknown
token 403, a trial or stimulus not assigned 403/404, an answer given twice or out of order 409,
a choice outside the question's 422, a body over 16 KiB 413, a chunked body 411.
"""

from __future__ import annotations

import logging
import re
from pathlib import Path
from urllib.parse import parse_qsl

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse, RedirectResponse
from pydantic import BaseModel, ConfigDict, Field
from starlette.exceptions import HTTPException as StarletteHTTPException

from benchmark.study.design import Study, read_study, verify_stimuli
from benchmark.study.server import pages
from benchmark.study.server.steps import SOUND_CHECK_ATTEMPTS, next_step, question_screens
from benchmark.study.server.store import AlreadyAnswered, Store, open_store

__all__ = ["create_app", "MAX_BODY_BYTES", "PLATFORM_PARAMETERS"]

log = logging.getLogger("benchmark.study.server")

#: The largest request body accepted (an answer is under 200 bytes).
MAX_BODY_BYTES = 16 * 1024

#: platform -> (participant id, study id, session id) URL parameters, as the platforms send them.
PLATFORM_PARAMETERS = {
    "prolific": ("PROLIFIC_PID", "STUDY_ID", "SESSION_ID"),
    "mturk": ("workerId", "hitId", "assignmentId"),
}
_ID = re.compile(r"[A-Za-z0-9_.:-]{1,64}")
_TOKEN = re.compile(r"[A-Za-z0-9_-]{20,128}")
_SECURITY_HEADERS = {
    "Content-Security-Policy": ("default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; "
                                "media-src 'self'; img-src 'self' data:; font-src 'self' data:; object-src 'none'; "
                                "base-uri 'none'; "
                                "frame-ancestors 'none'; form-action 'self'"),
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "X-Frame-Options": "DENY",
}


class Refused(Exception):
    """A request refused with ``status`` and a message (JSON under /api, an HTML page elsewhere)."""

    def __init__(self, status: int, message: str):
        super().__init__(message)
        self.status = status
        self.message = message


class Answer(BaseModel):
    model_config = ConfigDict(extra="forbid")
    trial: str = Field(min_length=1, max_length=128)
    question: str = Field(min_length=1, max_length=64)
    choice: str = Field(min_length=1, max_length=16)
    rt_ms: int | None = Field(default=None, ge=0, le=24 * 3600 * 1000)


class Word(BaseModel):
    model_config = ConfigDict(extra="forbid")
    word: str = Field(max_length=200)


class BodyLimit:
    """ASGI middleware: refuse a body over ``limit`` bytes (413) or without a length (411)."""

    def __init__(self, app, limit: int = MAX_BODY_BYTES):
        self.app = app
        self.limit = limit

    async def __call__(self, scope, receive, send):
        if scope["type"] == "http" and scope["method"] in ("POST", "PUT", "PATCH"):
            headers = dict(scope["headers"])
            length = headers.get(b"content-length")
            status = None
            if b"transfer-encoding" in headers or length is None:
                status, text = 411, "a request body needs a Content-Length"
            elif not length.isdigit() or int(length) > self.limit:
                status, text = 413, f"request body over {self.limit} bytes"
            if status is not None:
                body = ('{"error": "%s"}' % text).encode()
                await send({"type": "http.response.start", "status": status,
                            "headers": [(b"content-type", b"application/json"),
                                        (b"content-length", str(len(body)).encode()),
                                        (b"connection", b"close")]})
                await send({"type": "http.response.body", "body": body})
                return
        await self.app(scope, receive, send)


def _platform(query: dict[str, str]) -> tuple[str | None, dict[str, str]]:
    """The platform named by the URL parameters and those parameters (validated)."""
    for platform, names in PLATFORM_PARAMETERS.items():
        if names[0] in query:
            values = {name: query[name] for name in names if name in query}
            for name, value in values.items():
                if not _ID.fullmatch(value):
                    raise Refused(400, f"URL parameter {name}: expected 1-64 letters, digits or _.:-")
            return platform, values
    return None, {}


def create_app(folder, db_url: str | None = None, *, completion_url: str | None = None,
               completion_code: str | None = None, store: Store | None = None,
               node_modules=None) -> FastAPI:
    """The study's ASGI application for the study in ``folder`` (answers in ``db_url``).

    Raises ``UserError``/``DataError`` when the study's stimuli are missing or changed or jsPsych
    is not installed, before anything is served.
    """
    folder = Path(folder).resolve()
    study = read_study(folder)
    verify_stimuli(study, folder)
    vendor_dir = pages.require_jspsych(node_modules)
    store = store or open_store(folder, db_url)
    slots = [slot.slot for slot in study.participants]
    if not slots:
        from blendvoca.errors import DataError
        raise DataError(f"{folder / 'study.json'}: the design has no participant slots")
    consent_file = folder / "consent.html"
    consent_html = consent_file.read_text(encoding="utf-8") if consent_file.is_file() else pages.DEFAULT_CONSENT
    media = {key: folder / s.path for key, s in study.stimuli.items()}
    if study.sound_check is not None:
        media["sound-check"] = folder / study.sound_check.path
    minutes = max(1, round(max(study.min_seconds, _seconds_per_participant(study)) / 60))

    app = FastAPI(title="BlendVOCA study", docs_url=None, redoc_url=None, openapi_url=None)
    app.state.study, app.state.store, app.state.folder = study, store, folder
    app.add_middleware(BodyLimit, limit=MAX_BODY_BYTES)

    def is_api(request: Request) -> bool:
        return "/api/" in request.url.path

    def refusal(request: Request, status: int, message: str):
        if is_api(request):
            return JSONResponse({"error": message}, status_code=status)
        return HTMLResponse(pages.message_page("Sorry", message), status_code=status)

    @app.exception_handler(Refused)
    async def _refused(request: Request, error: Refused):
        return refusal(request, error.status, error.message)

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, error: StarletteHTTPException):
        messages = {404: "not found", 405: "method not allowed"}
        return refusal(request, error.status_code, messages.get(error.status_code, "request refused"))

    @app.exception_handler(RequestValidationError)
    async def _invalid(request: Request, error: RequestValidationError):
        fields = sorted({".".join(str(p) for p in e.get("loc", ())[1:]) or "body" for e in error.errors()})
        return refusal(request, 422, f"malformed request: check {', '.join(fields)[:200]}")

    @app.exception_handler(Exception)
    async def _internal(request: Request, error: Exception):
        log.exception("internal error on %s", request.url.path)
        return refusal(request, 500, "internal error")

    @app.middleware("http")
    async def _headers(request: Request, call_next):
        response = await call_next(request)
        for name, value in _SECURITY_HEADERS.items():
            response.headers.setdefault(name, value)
        if not request.url.path.startswith(("/vendor/", "/static/")) and "/media/" not in request.url.path:
            response.headers.setdefault("Cache-Control", "no-store")
        return response

    def session(token: str):
        participant = store.participant_by_token(token) if _TOKEN.fullmatch(token) else None
        if participant is None:
            raise Refused(403, "unknown or expired session; open the study's link again")
        return participant

    def state(participant) -> dict:
        answered = store.answered(participant.id)
        step, screen = next_step(study, participant, answered)
        screens = question_screens(study, participant.slot)
        counted = [s for s in screens if not s.practice]
        done = sum((s.trial, s.question) in answered for s in counted)
        out = {"step": step, "progress": {"done": done, "total": len(counted)}}
        if step == "sound_check":
            out["sound_check"] = {"media": "media/sound-check", "prompt": study.sound_check.prompt,
                                  "attempts_left": SOUND_CHECK_ATTEMPTS - participant.sound_check_attempts,
                                  "failed_before": participant.sound_check_attempts > 0}
        if screen is not None:
            trial = study.trial(screen.trial)
            q = study.question(screen.question)
            out["screen"] = {"trial": trial.id, "question": q.id, "prompt": q.prompt, "choices": list(q.choices),
                             "kind": trial.kind, "practice": screen.practice, "first_of_trial": screen.first_of_trial,
                             "media": [f"media/{s}" for s in trial.stimuli]}
        if step == "done":
            out["completion_code"] = completion_code or participant.completion_code
        return out

    @app.get("/", response_class=HTMLResponse)
    def landing(request: Request):
        query = dict(request.query_params)
        platform, values = _platform(query)
        preview = query.get("assignmentId") == "ASSIGNMENT_ID_NOT_AVAILABLE"
        return HTMLResponse(pages.consent_page(consent_html, minutes, values, preview))

    @app.post("/start")
    async def start(request: Request):
        try:
            form = dict(parse_qsl((await request.body()).decode("utf-8"), max_num_fields=20))
        except (UnicodeDecodeError, ValueError):
            raise Refused(400, "malformed form") from None
        if form.get("consent") != "yes":
            raise Refused(400, "consent is needed to take part; tick the box on the first page")
        platform, values = _platform(form)
        if platform == "mturk" and values.get("assignmentId") in (None, "ASSIGNMENT_ID_NOT_AVAILABLE"):
            raise Refused(400, "accept the task on Mechanical Turk first")
        names = PLATFORM_PARAMETERS.get(platform, (None, None, None))
        pid, study_id, session_id = (values.get(n) if n else None for n in names)
        if platform is not None:
            earlier = store.participant_by_platform(platform, pid)
            if earlier is not None:
                participant, started_in = earlier
                if started_in != session_id:
                    raise Refused(409, "this platform id has already taken part in this study")
                # the same platform session, back again: a new token, the same place in the study
                return RedirectResponse(f"/s/{store.new_token(participant.id)}/", status_code=303)
        token, _ = store.add_participant(slots, platform, pid, study_id, session_id, completion_code)
        return RedirectResponse(f"/s/{token}/", status_code=303)

    @app.get("/s/{token}/", response_class=HTMLResponse)
    def page(token: str):
        participant = session(token)
        current = state(participant)
        if current["step"] == "done":
            store.mark_finished(participant.id)
            return HTMLResponse(pages.done_page(current["completion_code"], completion_url))
        current["instructions"] = {"minutes": minutes} if current["step"] == "instructions" else None
        return HTMLResponse(pages.study_page(current))

    @app.get("/s/{token}/api/state")
    def get_state(token: str):
        participant = session(token)
        current = state(participant)
        if current["step"] == "done":
            store.mark_finished(participant.id)
        return current

    @app.post("/s/{token}/api/instructions")
    def instructions(token: str):
        participant = session(token)
        store.mark_instructions_read(participant.id)
        return state(store.participant_by_token(token))

    @app.post("/s/{token}/api/sound-check")
    def sound_check(token: str, word: Word):
        participant = session(token)
        if study.sound_check is None or next_step(study, participant, set())[0] != "sound_check":
            raise Refused(409, "the sound check is not the current step")
        passed = study.sound_check.accepts(word.word)
        participant = store.record_sound_check(participant.id, passed, SOUND_CHECK_ATTEMPTS)
        return {"passed": passed, "attempts_left": SOUND_CHECK_ATTEMPTS - participant.sound_check_attempts,
                "state": state(participant)}

    @app.post("/s/{token}/api/answer")
    def answer(token: str, given: Answer):
        participant = session(token)
        screens = question_screens(study, participant.slot)
        if not any(s.trial == given.trial and s.question == given.question for s in screens):
            raise Refused(403, "this trial and question are not assigned to this session")
        answered = store.answered(participant.id)
        if (given.trial, given.question) in answered:
            raise Refused(409, "this question was already answered")
        step, screen = next_step(study, participant, answered)
        if step != "question" or (screen.trial, screen.question) != (given.trial, given.question):
            raise Refused(409, "not the current question; reload the page")
        choices = study.question(given.question).choices
        if given.choice not in choices:
            raise Refused(422, f"choice must be one of {', '.join(choices)}")
        try:
            store.add_answer(participant.id, given.trial, given.question, given.choice, given.rt_ms)
        except AlreadyAnswered:
            raise Refused(409, "this question was already answered") from None
        current = state(participant)
        if current["step"] == "done":
            store.mark_finished(participant.id)
        return {"ok": True, "state": current}

    @app.get("/s/{token}/media/{name}")
    def stimulus(token: str, name: str):
        participant = session(token)
        allowed = {"sound-check"} if study.sound_check is not None else set()
        by_id = study.trials_by_id()
        for screen in question_screens(study, participant.slot):
            allowed.update(by_id[screen.trial].stimuli)
        if name not in allowed or name not in media:
            raise Refused(404, "not found")
        path = media[name]
        return FileResponse(path, media_type=pages.MEDIA_TYPES.get(path.suffix.lower(), "application/octet-stream"))

    @app.get("/vendor/{name}")
    def vendor(name: str):
        if name not in pages.VENDOR_FILES:
            raise Refused(404, "not found")
        return _static_file(vendor_dir / pages.VENDOR_FILES[name])

    @app.get("/static/{name}")
    def static(name: str):
        if name not in pages.STATIC_FILES:
            raise Refused(404, "not found")
        return _static_file(pages.WEB_DIR / pages.STATIC_FILES[name])

    return app


def _static_file(path: Path) -> FileResponse:
    types = {".js": "text/javascript", ".css": "text/css"}
    return FileResponse(path, media_type=types.get(path.suffix, "text/plain"),
                        headers={"Cache-Control": "public, max-age=3600"})


def _seconds_per_participant(study: Study) -> float:
    by_id = study.trials_by_id()
    if not study.participants:
        return 0.0
    trials = study.participants[0].trials
    return sum(max((study.stimuli[s].seconds for s in by_id[t].stimuli), default=0) * len(by_id[t].stimuli) + 10
               for t in trials)
