"""``leaderboard.site``'s own messages: the hint to serve, a busy port."""

from __future__ import annotations

import socket

import pytest

import leaderboard.site.__main__ as site_main
from blendvoca import cli
from blendvoca.errors import UserError
from leaderboard.site.serve import site_server


@pytest.fixture()
def site_dir(tmp_path):
    (tmp_path / "site").mkdir()
    (tmp_path / "site" / "index.html").write_text("<html></html>")
    return tmp_path / "site"


def test_a_busy_port_names_the_port_option(site_dir):
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        with pytest.raises(UserError, match=rf"--port {port}: 127\.0\.0\.1:{port} is in use .*--port N \(--port 0: "
                                            r"any free port\)"):
            site_server(site_dir, port=port)
    server = site_server(site_dir, port=0)  # a free one
    server.server_close()


def test_the_serve_hint_is_printed_only_without_serve(site_dir, tmp_path, monkeypatch, capsys):
    served = []
    monkeypatch.setattr(site_main, "build_site", lambda results, out, **kwargs: site_dir)
    monkeypatch.setattr(site_main, "serve_site", lambda out, port: served.append((out, port)))
    argv = ["--results", str(tmp_path), "--out", str(site_dir)]
    assert site_main.main([*argv, "--serve", "--port", "8123"]) == cli.EXIT_OK
    err = capsys.readouterr().err
    assert served == [(site_dir, 8123)] and "--serve" not in err and f"site written to {site_dir}" in err
    assert site_main.main(argv) == cli.EXIT_OK
    assert "--serve" in capsys.readouterr().err and len(served) == 1


def test_a_busy_port_from_the_command_is_one_error_line(site_dir, tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(site_main, "build_site", lambda results, out, **kwargs: site_dir)
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        code = site_main.main(["--results", str(tmp_path), "--out", str(site_dir), "--serve", "--port", str(port),
                               "--quiet"])
    assert code == cli.EXIT_USER
    err = [line for line in capsys.readouterr().err.splitlines() if line.startswith("error")]
    assert len(err) == 1 and "--port" in err[0]
