"""Serving a generated site on localhost (browsers refuse ES modules and fetches from file://)."""

from __future__ import annotations

import errno
import functools
import http.server
import re
import threading
from pathlib import Path

from blendvoca.errors import UserError

__all__ = ["serve_site", "site_server"]


class _SiteHandler(http.server.SimpleHTTPRequestHandler):
    """The stdlib's static handler plus single byte ranges (``Range: bytes=a-b``):
    browsers seek in audio only when the server answers ranges with 206."""

    def log_message(self, format, *args):  # noqa: A002 - the stdlib's signature
        pass

    def send_head(self):
        spec = self.headers.get("Range", "")
        m = re.fullmatch(r"bytes=(\d*)-(\d*)", spec.strip())
        path = Path(self.translate_path(self.path))
        if not m or not path.is_file() or not (m.group(1) or m.group(2)):
            return super().send_head()
        size = path.stat().st_size
        if m.group(1):
            start = int(m.group(1))
            end = min(int(m.group(2)), size - 1) if m.group(2) else size - 1
        else:  # suffix range: the last N bytes
            start, end = max(0, size - int(m.group(2))), size - 1
        if start >= size or start > end:
            self.send_response(416)
            self.send_header("Content-Range", f"bytes */{size}")
            self.end_headers()
            return None
        f = open(path, "rb")  # noqa: SIM115 - closed by copyfile's caller (do_GET)
        f.seek(start)
        self.send_response(206)
        self.send_header("Content-Type", self.guess_type(str(path)))
        self.send_header("Content-Range", f"bytes {start}-{end}/{size}")
        self.send_header("Content-Length", str(end - start + 1))
        self.send_header("Accept-Ranges", "bytes")
        self.end_headers()
        return _Limited(f, end - start + 1)


class _Limited:
    """A file object that reads at most ``remaining`` bytes (the end of a range)."""

    def __init__(self, f, remaining: int):
        self._f, self._remaining = f, remaining

    def read(self, n: int = -1) -> bytes:
        if self._remaining <= 0:
            return b""
        n = self._remaining if n is None or n < 0 else min(n, self._remaining)
        data = self._f.read(n)
        self._remaining -= len(data)
        return data

    def close(self) -> None:
        self._f.close()


def site_server(site_dir, *, host: str = "127.0.0.1", port: int = 0) -> http.server.ThreadingHTTPServer:
    """An HTTP server for ``site_dir`` on ``host:port`` (port 0: a free one), not yet serving.

    Returns
    -------
    http.server.ThreadingHTTPServer
        ``server.server_address`` gives the bound address; call ``serve_forever``
        (or run it in a thread) and ``shutdown`` when done.

    Raises
    ------
    UserError
        No ``index.html`` in ``site_dir``, or ``port`` in use (the message names ``--port``).
    """
    site_dir = Path(site_dir)
    if not (site_dir / "index.html").is_file():
        raise UserError(f"leaderboard.site: {site_dir} has no index.html; build the site first")
    handler = functools.partial(_SiteHandler, directory=str(site_dir))
    try:
        return http.server.ThreadingHTTPServer((host, int(port)), handler)
    except OSError as exc:
        if exc.errno in (errno.EADDRINUSE, errno.EACCES):
            why = "in use by another program" if exc.errno == errno.EADDRINUSE else "not open to this user"
            raise UserError(f"--port {port}: {host}:{port} is {why}; serve on another with --port N "
                            "(--port 0: any free port)") from None
        raise


def serve_site(site_dir, *, host: str = "127.0.0.1", port: int = 8000, background: bool = False):
    """Serve ``site_dir`` until interrupted (or, with ``background``, in a daemon thread).

    Returns
    -------
    (server, url)
        With ``background``; otherwise returns when interrupted.
    """
    server = site_server(site_dir, host=host, port=port)
    url = f"http://{server.server_address[0]}:{server.server_address[1]}/"
    if background:
        threading.Thread(target=server.serve_forever, daemon=True).start()
        return server, url
    print(f"serving {site_dir} at {url} (Ctrl-C stops)", flush=True)
    try:
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server.server_close()
    return server, url
