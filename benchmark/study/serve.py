"""``python -m benchmark.study serve STUDY``: the study's web application for participants.

Checks the study first (its stimuli present and unchanged, sha256 against ``study.json``; jsPsych
installed by ``npm ci --prefix benchmark/study/web``) and serves nothing if a check fails. Answers
go to ``STUDY/answers.sqlite`` (SQLite, WAL mode) or to ``--db postgresql://USER@HOST:PORT/NAME``.
Binds to 127.0.0.1 unless ``--host`` says otherwise; behind a reverse proxy keep 127.0.0.1 and
let the proxy face the internet (docs/study.md, "Behind a reverse proxy").

Participants open ``http://HOST:PORT/`` (with the platform's URL parameters: Prolific's
``PROLIFIC_PID``, ``STUDY_ID``, ``SESSION_ID``; MTurk's ``workerId``, ``hitId``, ``assignmentId``).
"""

from __future__ import annotations

import errno
import socket

from blendvoca.errors import UserError


def add_arguments(parser) -> None:
    parser.add_argument("study", help="the study folder (made by python -m benchmark.study create)")
    parser.add_argument("--db", metavar="URL", default=None,
                        help="database URL (default sqlite:///STUDY/answers.sqlite; postgresql://... for PostgreSQL)")
    parser.add_argument("--host", default="127.0.0.1", help="address to bind (default 127.0.0.1: this machine only)")
    parser.add_argument("--port", type=int, default=8000, help="port (default 8000)")
    parser.add_argument("--completion-url", metavar="URL", default=None,
                        help="where the last page sends participants; {code} is replaced by the completion code "
                             "(Prolific: https://app.prolific.com/submissions/complete?cc={code})")
    parser.add_argument("--completion-code", metavar="CODE", default=None,
                        help="one completion code for everybody (Prolific gives one per study); "
                             "default: a code per participant (MTurk), listed by export")
    parser.add_argument("--forwarded-allow-ips", metavar="IPS", default="127.0.0.1",
                        help="proxies whose X-Forwarded-* headers are trusted (default 127.0.0.1)")


def _check_port(host: str, port: int) -> None:
    if not 0 < port < 65536:
        raise UserError(f"--port {port}: expected a port number from 1 to 65535")
    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
    except socket.gaierror as error:
        raise UserError(f"--host {host!r}: cannot resolve it ({error.strerror})") from None
    family, kind, proto, _, address = infos[0]
    with socket.socket(family, kind, proto) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind(address)
        except OSError as error:
            reason = "is in use" if error.errno == errno.EADDRINUSE else f"cannot be bound ({error.strerror})"
            raise UserError(f"{host}:{port} {reason}; choose another --port") from None


def run(args) -> int:
    import uvicorn

    from benchmark.study.server import create_app
    from benchmark.study.server.store import default_db_url

    if args.completion_code is not None and not args.completion_code.replace("-", "").isalnum():
        raise UserError(f"--completion-code {args.completion_code!r}: expected letters, digits and -")
    _check_port(args.host, args.port)
    # the study is checked (stimuli, jsPsych) before the database is opened: a refused study writes nothing
    app = create_app(args.study, args.db, completion_url=args.completion_url, completion_code=args.completion_code)
    store = app.state.store
    where = store.url.render_as_string(hide_password=True) if args.db else default_db_url(args.study)
    print(f"serving {args.study} at http://{args.host}:{args.port}/ (answers in {where}); Ctrl-C stops",
          flush=True)
    uvicorn.run(app, host=args.host, port=args.port, log_level="warning", proxy_headers=True,
                forwarded_allow_ips=args.forwarded_allow_ips, server_header=False)
    return 0
