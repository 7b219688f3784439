"""Serving a generated site on localhost (browsers refuse ES modules and fetches from file://)."""

from __future__ import annotations

import functools
import http.server
import threading
from pathlib import Path

__all__ = ["serve_site", "site_server"]


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format, *args):  # noqa: A002 - the stdlib's signature
        pass


def site_server(site_dir, *, host: str = "127.0.0.1", port: int = 0) -> http.server.ThreadingHTTPServer:
    """An HTTP server for ``site_dir`` on ``host:port`` (port 0: a free one), not yet serving.

    Returns
    -------
    http.server.ThreadingHTTPServer
        ``server.server_address`` gives the bound address; call ``serve_forever``
        (or run it in a thread) and ``shutdown`` when done.
    """
    site_dir = Path(site_dir)
    if not (site_dir / "index.html").is_file():
        raise FileNotFoundError(f"leaderboard.site: {site_dir} has no index.html; build the site first")
    handler = functools.partial(_QuietHandler, directory=str(site_dir))
    return http.server.ThreadingHTTPServer((host, int(port)), handler)


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
