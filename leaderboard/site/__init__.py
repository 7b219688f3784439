"""``python -m leaderboard.site``: a static results browser generated from stored runs.

Three pages, working offline through any local web server (``--serve`` starts one):

- ``index.html``: the leaderboard (one metric group at a time, chosen by tabs, with
  intervals, sortable, a sticky method column, reference rows apart; a chart per metric
  scaled to the ranked rows);
- ``method.html?run=<run>``: one run's per-sentence scores, coefficient tracks
  against the ground truth, lip motion against the speech envelope, provenance;
- ``play.html?subject=<s>&sentence=<q>&runs=<run>,...``: ground truth and the chosen
  runs side by side on the speaker's rig, a labelled column each (front and side
  views), in sync with the sentence's audio.

See docs/site.md.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

from blendvoca.errors import OutputDirError, out_of_resources, ran_out_of
from blendvoca.runtime.staging import staged_folder

from .data import load_site_runs, with_dataset, write_site_data
from .vendor import copy_vendor_files

__all__ = ["SITE_MARKER", "build_site"]

#: File that marks a folder as a site written by this tool (only such a folder is replaced).
SITE_MARKER = ".blendvoca-site"
_STATIC = Path(__file__).resolve().parent / "static"
#: What every page shares (doctype, stylesheet, file notice, navigation); ``{head}`` and ``{body}`` are the page's own.
_FRAME = Path(__file__).resolve().parent / "page.html"


def framed_page(page: Path) -> str:
    """The HTML of a page of ``static/`` (its own ``<head>`` and ``<body>`` lines) inside ``page.html``."""
    parts = re.fullmatch(r"<head>\n(.*)</head>\n<body>\n(.*)</body>\n", page.read_text(encoding="utf-8"), re.S)
    if parts is None:
        raise ValueError(f"{page}: expected a <head> block and a <body> block, each opening and closing on a line")
    return _FRAME.read_text(encoding="utf-8").format(head=parts[1], body=parts[2])


def _check_out(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise OutputDirError(f"leaderboard.site: --out {out} is a file, expected a folder")
    if out.is_dir() and any(out.iterdir()) and not (out / SITE_MARKER).is_file():
        raise OutputDirError(f"leaderboard.site: --out {out} is a non-empty folder that is not a site written by this "
                         f"tool (no {SITE_MARKER}); choose an empty or new folder")


def build_site(results_dir, out, *, data=None, max_samples: int = 3, node_modules=None) -> Path:
    """Generate the site for the runs in ``results_dir`` into ``out``.

    The site is written into a temporary folder beside ``out`` and moved into place
    at the end, so an interrupted build leaves the previous site (or nothing).
    ``out`` must be new, empty, or a site this function wrote before.

    Parameters
    ----------
    results_dir : path-like
        Folder of result JSON files (``benchmark.run --results``), with their stored tracks.
    out : path-like
    data : path-like, optional
        A BlendVOCA build to use for the runs scored on it (same manifest hash)
        instead of the path their result files recorded. Runs whose dataset is not
        on this machine get leaderboard and score pages but no plots or playback.
    max_samples : int
        Samples per sentence of a stochastic run offered for playback.
    node_modules : path-like, optional
        Where npm installed three.js (default: ``leaderboard/site/web/node_modules``).

    Returns
    -------
    Path
        ``out``.
    """
    out = Path(out).expanduser().resolve()
    _check_out(out)
    runs = load_site_runs(results_dir)
    if data is not None:
        runs = with_dataset(runs, data)
    try:
        return _write_site(out, runs, max_samples=max_samples, node_modules=node_modules)
    except OSError as exc:
        if ran_out_of(exc) is not None:  # nothing half-written stays (staged): say what ran out, where
            raise out_of_resources(exc, f"--out {out}: writing the site") from exc
        raise


def _write_site(out: Path, runs, *, max_samples, node_modules) -> Path:
    with staged_folder(out, replace=True) as tmp:  # _check_out: a site this tool wrote, or empty
        copy_vendor_files(tmp, node_modules)
        for page in sorted(_STATIC.iterdir()):
            if page.is_file():
                target = tmp / ("assets" if page.suffix in (".js", ".css") else "") / page.name
                target.parent.mkdir(parents=True, exist_ok=True)
                if page.suffix == ".html":
                    target.write_text(framed_page(page), encoding="utf-8")
                else:
                    shutil.copyfile(page, target)
        write_site_data(runs, tmp / "data", max_samples=max_samples)
        (tmp / SITE_MARKER).write_text("written by python -m leaderboard.site\n")
    return out
