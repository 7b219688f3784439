"""The study's HTML pages and the browser files they load.

Pages are written here with every inserted text HTML-escaped; the trial pages carry their data
as a JSON block (``<script type="application/json">``, with ``<``, ``>`` and ``&`` escaped) that
``web/study.js`` reads and turns into a jsPsych trial. jsPsych and its plugins come from
``benchmark/study/web/node_modules`` (``npm ci --prefix benchmark/study/web``, pinned by its
``package-lock.json``), sent by the server itself: no CDN.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

from blendvoca.errors import UserError

__all__ = ["VENDOR_FILES", "WEB_DIR", "STATIC_FILES", "require_jspsych", "consent_page", "study_page",
           "done_page", "message_page"]

#: Folder holding ``package.json`` / ``package-lock.json`` and the study's own script and style.
WEB_DIR = Path(__file__).resolve().parents[1] / "web"

#: URL name under ``/vendor/`` -> path under ``node_modules``.
VENDOR_FILES = {
    "jspsych.js": "jspsych/dist/index.browser.min.js",
    "jspsych.css": "jspsych/css/jspsych.css",
    "plugin-html-button-response.js": "@jspsych/plugin-html-button-response/dist/index.browser.min.js",
    "plugin-survey-text.js": "@jspsych/plugin-survey-text/dist/index.browser.min.js",
    "jspsych.package.json": "jspsych/package.json",  # its version and licence (MIT)
}

#: URL name under ``/static/`` -> file in WEB_DIR.
STATIC_FILES = {"study.js": "study.js", "study.css": "study.css"}

MEDIA_TYPES = {".mp4": "video/mp4", ".webm": "video/webm", ".m4a": "audio/mp4", ".wav": "audio/wav",
               ".mp3": "audio/mpeg", ".ogg": "audio/ogg"}

DEFAULT_CONSENT = """
<p>You are invited to take part in a research study on how people judge computer-animated faces.
You will watch short animations of a talking face, with sound, and answer questions about them.
It takes about {minutes} minutes. Please use headphones or speakers in a quiet place.</p>
<p>Your participation is voluntary. You may stop at any time by closing this page; nothing you answered
is used against you. We store your answers, the time you took, and your crowd-platform id (so that the
platform can pay you). We store no name, e-mail address, IP address or other personal data.
The anonymised answers may be published with the study's results.</p>
<p>If you have questions about this study, contact the researchers named on the recruiting platform.</p>
"""


def require_jspsych(node_modules=None) -> Path:
    """The folder holding the pinned jsPsych files; a UserError with the command if absent."""
    node_modules = Path(node_modules) if node_modules is not None else WEB_DIR / "node_modules"
    missing = [rel for rel in VENDOR_FILES.values() if not (node_modules / rel).is_file()]
    if missing:
        raise UserError(f"benchmark.study serve: jsPsych is not installed ({node_modules / missing[0]} missing); "
                        f"run `npm ci --prefix {WEB_DIR}` once (it installs the versions pinned in "
                        f"{WEB_DIR / 'package-lock.json'})")
    return node_modules


def _page(title: str, body: str, *, scripts: tuple[str, ...] = (), data: dict | None = None) -> str:
    data_block = ""
    if data is not None:
        text = json.dumps(data).replace("&", "\\u0026").replace("<", "\\u003c").replace(">", "\\u003e")
        data_block = f'<script type="application/json" id="study-data">{text}</script>\n'
    script_tags = "".join(f'<script src="{html.escape(src)}"></script>\n' for src in scripts)
    return f"""<!doctype html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="referrer" content="no-referrer">
<title>{html.escape(title)}</title>
<link rel="stylesheet" href="/vendor/jspsych.css">
<link rel="stylesheet" href="/static/study.css">
</head>
<body>
{body}
{data_block}{script_tags}</body>
</html>
"""


def consent_page(consent_html: str, minutes: int, hidden: dict[str, str], preview: bool) -> str:
    """The landing page: the consent text and a form that starts the session (POST /start)."""
    fields = "".join(f'<input type="hidden" name="{html.escape(k)}" value="{html.escape(v)}">'
                     for k, v in hidden.items())
    if preview:
        action = "<p class=\"note\">Accept the task on the platform first; then this page lets you start.</p>"
    else:
        action = (f'<form method="post" action="/start">{fields}'
                  '<label class="consent"><input type="checkbox" name="consent" value="yes" id="consent-box" required> '
                  'I have read the above and agree to take part.</label>'
                  '<p><button class="jspsych-btn" type="submit" id="start">Start</button></p></form>')
    body = (f'<main class="page" data-step="consent"><h1>Consent</h1><div class="consent-text">'
            f'{consent_html.replace("{minutes}", str(int(minutes)))}</div>{action}</main>')
    return _page("Consent", body)


def study_page(data: dict) -> str:
    """A page whose one jsPsych trial (instructions, sound check or one question) web/study.js runs."""
    scripts = ("/vendor/jspsych.js", "/vendor/plugin-html-button-response.js", "/vendor/plugin-survey-text.js",
               "/static/study.js")
    body = '<div id="progress" class="progress"></div><div id="jspsych-target"></div>'
    return _page("Study", body, scripts=scripts, data=data)


def done_page(code: str, completion_url: str | None) -> str:
    link = ""
    if completion_url:
        href = completion_url.replace("{code}", code)
        link = (f'<p><a class="jspsych-btn" id="completion-link" href="{html.escape(href)}">'
                "Return to the platform</a></p>")
    body = ('<main class="page" data-step="done"><h1>Thank you</h1><p>You have finished the study.</p>'
            f'<p>Your completion code is <strong id="completion-code">{html.escape(code)}</strong>.</p>{link}</main>')
    return _page("Thank you", body)


def message_page(title: str, message: str) -> str:
    body = (f'<main class="page" data-step="message"><h1>{html.escape(title)}</h1>'
            f'<p id="message">{html.escape(message)}</p></main>')
    return _page(title, body)
