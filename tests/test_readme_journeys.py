"""The README's commands run as written, in order, on the bundled default.

Every ```bash block of README.md is preceded by a marker comment that says what this
test does with it:

``<!-- journey: run -->``
    Its lines run, in README order, in one bash shell (so an ``export`` carries to
    later blocks) whose working folder is a fresh "clone" folder in a temporary
    directory, with the public assets and the real recordings next to it as
    ``../shared/assets`` and ``../shared/realdata`` (the layout Quick start describes) and ``python`` the interpreter running this test.
``<!-- journey: run; not run: PREFIX (why), PREFIX (why) -->``
    As ``run``, except the ``&&``-separated commands starting with one of the
    prefixes (e.g. ``pip install``: the test runs in the environment it installed).
``<!-- journey: skip: why -->``
    Not run (it needs data a user brings, or hours).

A new ```bash block without a marker fails :func:`test_every_readme_block_is_marked`,
so a README command is either run here or says why not. The commands name no
placeholder a user would have to make: what they read is the bundled build
(``$BUILD``), the assets (``$WAV``, ``python -m blendvoca.assets path speech-voca``) or what an
earlier command wrote (:func:`test_run_blocks_read_no_placeholder`), and what they
write in the clone is in ``.gitignore`` (:func:`test_what_run_blocks_write_is_ignored_by_git`).
:data:`FIXTURES` (shell lines that would make a placeholder before its first use) is
therefore empty. A line ending in ``--serve`` starts the server in the background on a
free port, loads its ``index.html`` and stops it.

Time budget: :data:`BUDGET_S`, 10 minutes on 2 cores (the README's commands use short
training budgets for that reason). It takes about 2.5 minutes on 2 idle cores when
the user cache (``BLENDVOCA_CACHE``) already holds the bundled-default build, as it
does in CI once another test has built it, and about 1.2 minutes more without.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
#: Wall-clock limit of the whole journey in CI (2 cores), in seconds.
BUDGET_S = 600

_MARKER = re.compile(r"<!--\s*journey:\s*(?P<body>.*?)\s*-->\s*\n```bash\n(?P<code>.*?)```", re.S)
_BLOCK = re.compile(r"```bash\n(.*?)```", re.S)

#: Shell lines that make a placeholder file, run before the first command naming it: none, the README's
#: commands run on the bundled build and the assets as written.
FIXTURES: dict = {}


def readme_blocks(text: str | None = None) -> list[dict]:
    """``[{"mode": "run"|"skip", "not_run": [prefix, ...], "why": str, "code": str}]`` in README order."""
    text = README.read_text() if text is None else text
    blocks = []
    for match in _MARKER.finditer(text):
        body = match.group("body")
        mode, _, rest = body.partition(";") if not body.startswith("skip") else ("skip", "", body[5:])
        mode = mode.strip()
        not_run = []
        if mode == "run" and rest.strip().startswith("not run:"):
            not_run = [prefix.strip() for prefix, _ in re.findall(r"([^,()]+?)\s*\(([^)]*)\)", rest.split(":", 1)[1])]
        blocks.append({"mode": mode, "not_run": not_run, "why": rest.strip(" :"), "code": match.group("code")})
    return blocks


def journey_lines(blocks) -> list[str]:
    """The shell lines the journey runs: run blocks' lines without their not-run commands."""
    lines = []
    for block in blocks:
        if block["mode"] != "run":
            continue
        for line in block["code"].splitlines():
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            kept = [part.strip() for part in line.split("&&")
                    if not any(part.strip().startswith(prefix) for prefix in block["not_run"])]
            if kept:
                lines.append(" && ".join(kept))
    return lines


def _serve_check(line: str) -> str:
    """A ``--serve`` line as background server + one page load + stop."""
    command = re.sub(r"\s+#.*$", "", line) + " --port 0"
    return (f"{command} > serve.log 2>&1 & server=$!\n"
            "for _ in $(seq 1200); do grep -q 'serving .* at http' serve.log && break; sleep 0.5; done\n"
            "python -c \"import re, sys, urllib.request; url = re.search(r'http://\\S+/', open('serve.log').read())[0]; "
            "page = urllib.request.urlopen(url + 'index.html', timeout=30).read(); "
            "sys.exit(b'leaderboard' not in page)\" || { cat serve.log; kill $server; false; }\n"
            "kill $server")


def journey_script(lines) -> str:
    """One bash script: each step announced (for the failure message), fixtures before first use."""
    out = ["set -eo pipefail"]
    made = set()
    for n, line in enumerate(lines):
        for name, make in FIXTURES.items():
            if name not in made and re.search(rf"(^|[\s=]){re.escape(name)}(\s|$)", line):
                out.append(make)
                made.add(name)
        out.append(f"echo \"::step {n} $(date +%s.%N) \" >&2")
        out.append(_serve_check(line) if re.search(r"--serve(\s|$|\s+#)", line) else line)
    out.append("echo \"::step end $(date +%s.%N) \" >&2")
    return "\n".join(out) + "\n"


def test_every_readme_block_is_marked():
    """A README command block says whether the journey runs it, and why not when it does not."""
    marked = readme_blocks()
    assert len(marked) == len(_BLOCK.findall(README.read_text())), \
        "every ```bash block of README.md needs a <!-- journey: ... --> marker right before it"
    for block in marked:
        assert block["mode"] in ("run", "skip"), block
        assert block["mode"] == "run" or block["why"], f"a skipped block says why: {block}"


def test_marker_parsing():
    text = ("<!-- journey: run; not run: pip install (env), python -m pytest (itself) -->\n```bash\n"
            "export A=1   # note\npip install x && python -m a.b\npython -m pytest\n```\n"
            "<!-- journey: skip: needs data -->\n```bash\npython -m c\n```\n")
    blocks = readme_blocks(text)
    assert [b["mode"] for b in blocks] == ["run", "skip"] and blocks[1]["why"] == "needs data"
    assert blocks[0]["not_run"] == ["pip install", "python -m pytest"]
    assert journey_lines(blocks) == ["export A=1   # note", "python -m a.b"]


@pytest.mark.slow
@pytest.mark.timeout(BUDGET_S + 120)
def test_readme_journey_runs_as_written(tmp_path):
    """Quick start (less the install and the test command) and every runnable "Using it" command,
    in order, exit 0 within :data:`BUDGET_S`."""
    from tests.leaderboard.browser import require_three_js

    require_three_js()  # the site step needs `npm ci --prefix leaderboard/site/web`, which the journey does not run
    named = [Path(p) for p in os.environ.get("BLENDVOCA_ASSETS", "").split(os.pathsep) if p]
    assets = next((p for p in named if (p / "said").is_dir()), ROOT.parent / "shared" / "assets").resolve()
    if not assets.is_dir():
        pytest.skip(f"no assets folder at {assets} (set BLENDVOCA_ASSETS)")
    realdata = next((p for p in named if (p / "facegood").is_dir()), ROOT.parent / "shared" / "realdata").resolve()
    if not realdata.is_dir():  # the journey builds FACEGOOD and verifies every asset
        pytest.skip(f"no real recordings at {realdata} (the README's FACEGOOD build needs shared/realdata)")
    (tmp_path / "shared").mkdir()
    (tmp_path / "shared" / "assets").symlink_to(assets)
    (tmp_path / "shared" / "realdata").symlink_to(realdata)
    clone = tmp_path / "clone"
    clone.mkdir()
    lines = journey_lines(readme_blocks())
    assert any("blendvoca.build" in line for line in lines) and any("benchmark.run" in line for line in lines)
    script = clone / ".journey.sh"
    script.write_text(journey_script(lines))
    env = {key: value for key, value in os.environ.items() if key not in ("BLENDVOCA_ASSETS", "PWD")}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = str(ROOT)
    started = time.monotonic()
    proc = subprocess.run(["bash", str(script)], cwd=clone, env=env, capture_output=True, text=True,
                          timeout=BUDGET_S + 60)
    wall = time.monotonic() - started
    steps = [(m.group(1), float(m.group(2))) for m in re.finditer(r"::step (\S+) (\S+)", proc.stderr)]
    timings = [f"{float(b[1]) - float(a[1]):7.1f} s  {lines[int(a[0])]}" for a, b in zip(steps, steps[1:])]
    report = "\n".join(timings)
    if proc.returncode != 0:
        failed = lines[int(steps[-1][0])] if steps and steps[-1][0] != "end" else "?"
        pytest.fail(f"README journey: `{failed}` exited {proc.returncode}\n{report}\n"
                    f"--- stderr (tail)\n{proc.stderr[-4000:]}\n--- stdout (tail)\n{proc.stdout[-2000:]}")
    print(f"README journey: {wall:.0f} s\n{report}")
    assert wall < BUDGET_S, f"README journey took {wall:.0f} s, budget {BUDGET_S} s:\n{report}"
    for made in ("runs", "tables", "site/index.html", "coeffs.csv", "take.glb", "take.mp4", "samples.npy",
                 "said-ckpt/said.pt"):
        assert (clone / made).exists(), f"the journey did not make {made}"


def test_run_blocks_read_no_placeholder():
    """What a run block reads (``--audio``, ``--rig``, ``--coeffs``) is a variable the README sets from the
    bundled build or the assets, or a file an earlier run line wrote."""
    lines = journey_lines(readme_blocks())
    assert not FIXTURES
    script = "\n".join(lines)
    assert 'WAV="$(python -m blendvoca.assets path ' in script and 'BUILD="${BLENDVOCA_CACHE:-' in script
    for n, line in enumerate(lines):
        for flag, value in re.findall(r"--(audio|rig|coeffs)\s+(\S+)", line):
            value = value.strip('"')
            if value.startswith("$"):
                continue
            earlier = "\n".join(lines[:n])
            assert re.search(rf"--out\s+{re.escape(value)}(\s|$)", earlier), \
                f"README: `{line}` reads {value} (--{flag}), which no earlier command writes"


def test_what_run_blocks_write_is_ignored_by_git():
    """Every relative ``--out``, ``--results`` and ``--checkpoint`` of a run block is in ``.gitignore``."""
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    written = set()
    for line in journey_lines(readme_blocks()):
        for _flag, value in re.findall(r"--(out|results|checkpoint)\s+(\S+)", line):
            value = value.strip('"')
            if not value.startswith(("$", "~", "/")):
                written.add(value.rstrip("/") + ("/x" if value.endswith("/") else ""))
    assert {"runs/x", "tables/x", "coeffs.csv", "samples.npy"} <= written
    proc = subprocess.run(["git", "check-ignore", "--no-index", *sorted(written)], cwd=ROOT, capture_output=True,
                          text=True, check=False)
    ignored = set(proc.stdout.split())
    assert ignored == written, f"not in .gitignore: {sorted(written - ignored)}"
