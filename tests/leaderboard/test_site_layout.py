"""The results site is readable at 1920x1080 in headless Chromium: the leaderboard fits the
window, the charts spread the ranked rows apart and clip no label, and the playback heads
are large, labelled and opaque.

``BLENDVOCA_SITE_SCREENSHOTS=docs/img python -m pytest tests/leaderboard/test_site_layout.py``
also writes the screenshots docs/site.md shows (site-leaderboard.png, site-chart.png,
site-playback.png, site-method.png).
"""

from __future__ import annotations

import base64
import io
import json
import os
import re
from pathlib import Path

import numpy as np
import pytest

from leaderboard.site import build_site
from leaderboard.site.serve import serve_site

from .browser import chromium_driver, open_page
from .test_site import COMMITTED_RESULTS, results_dir, three_js  # noqa: F401 (fixtures)

WIDTH, HEIGHT = 1920, 1080
#: Background of a playback view and the colour of the inside of the head (play.js).
BACKGROUND = (0xF6, 0xF6, 0xF6)
CAVITY = (0x3B, 0x14, 0x14)


def _screenshot_dir(tmp_path: Path) -> Path:
    """Where screenshots go: ``$BLENDVOCA_SITE_SCREENSHOTS`` (docs/img to refresh the docs) or a temporary folder."""
    wanted = os.environ.get("BLENDVOCA_SITE_SCREENSHOTS")
    folder = Path(wanted) if wanted else tmp_path / "screenshots"
    folder.mkdir(parents=True, exist_ok=True)
    return folder


@pytest.fixture(scope="module")
def browser():
    driver = chromium_driver()
    driver.set_window_size(WIDTH, HEIGHT + 200)  # the viewport exactly 1920x1080, as a desktop at full HD
    driver.execute_cdp_cmd("Emulation.setDeviceMetricsOverride",
                           {"width": WIDTH, "height": HEIGHT, "deviceScaleFactor": 1, "mobile": False})
    yield driver
    driver.quit()


@pytest.fixture(scope="module")
def committed_site(tmp_path_factory, three_js):  # noqa: F811
    """The site of the committed leaderboard results, served."""
    site = build_site(COMMITTED_RESULTS, tmp_path_factory.mktemp("committed") / "site")
    server, url = serve_site(site, port=0, background=True)
    yield url
    server.shutdown()


@pytest.fixture(scope="module")
def track_site(tmp_path_factory, results_dir, three_js):  # noqa: F811
    """A site of runs with stored tracks on the test dataset (playback), served."""
    site = build_site(results_dir, tmp_path_factory.mktemp("tracks") / "site", max_samples=2)
    server, url = serve_site(site, port=0, background=True)
    yield site, url
    server.shutdown()


def _tabs(browser, index: int = 0) -> list[str]:
    return browser.execute_script(f"return [...document.querySelectorAll('#table-{index} .tabs button')]"
                                  ".map(b => b.dataset.tab)")


def _show(browser, tab: str, index: int = 0) -> None:
    browser.execute_script(f"document.querySelector(`#table-{index} .tabs button[data-tab='${{arguments[0]}}']`)"
                           ".click()", tab)


def test_committed_board_fits_a_1920_window_one_group_at_a_time(browser, committed_site):
    assert open_page(browser, committed_site + "index.html") == []
    assert browser.execute_script("return [window.innerWidth, window.innerHeight]") == [WIDTH, HEIGHT]
    board = browser.execute_script("return (await (await fetch('data/leaderboard.json')).json())")
    sizes = [len(t["methods"]) + len(t["references"]) for t in board["tables"]]
    assert sum(sizes) == len(list(COMMITTED_RESULTS.glob("*.json")))  # every committed row, in its section
    for index, table in enumerate(board["tables"]):
        _fits_one_group_at_a_time(browser, table, index, sizes[index])


def _fits_one_group_at_a_time(browser, table: dict, index: int, rows: int) -> None:
    groups = [g["name"] for g in table["groups"]]
    assert _tabs(browser, index) == groups and len(groups) > 1
    for group in groups:
        _show(browser, group, index)
        shown = browser.execute_script(
            "const t = document.querySelector(arguments[0] + ' table.leaderboard');"
            "const visible = [...t.querySelectorAll('th[data-metric]')].filter(th => th.offsetParent !== null);"
            "return {metrics: visible.map(th => th.dataset.metric), table: t.scrollWidth,"
            " page: document.documentElement.scrollWidth, window: window.innerWidth,"
            " rows: t.querySelectorAll('tr[data-run]').length,"
            " sticky: getComputedStyle(t.querySelector('td.label')).position};", f"#table-{index}")
        wanted = next(g["metrics"] for g in table["groups"] if g["name"] == group)
        assert shown["metrics"] == wanted, group
        assert shown["table"] <= shown["window"] and shown["page"] <= shown["window"], (group, shown)
        assert shown["rows"] == rows and shown["sticky"] == "sticky"
        # every visible label cell shows its whole text
        clipped = browser.execute_script(
            f"return [...document.querySelectorAll('#table-{index} table.leaderboard th, "
            f"#table-{index} table.leaderboard td')]"
            ".filter(c => c.offsetParent !== null && c.scrollWidth > c.clientWidth).map(c => c.textContent)")
        assert clipped == [], (group, clipped)


def test_committed_charts_spread_the_ranked_rows_and_clip_no_label(browser, committed_site):
    assert open_page(browser, committed_site + "index.html") == []
    board = browser.execute_script("return (await (await fetch('data/leaderboard.json')).json())")
    # the synthetic board's section (its FD spans a static face at 6,556 and trained rows at 2-14)
    index, table = next((i, t) for i, t in enumerate(board["tables"]) if t["manifest_hash"].startswith("54a623f25316"))
    checked = 0
    for group in table["groups"]:
        _show(browser, group["name"], index)
        charts = browser.execute_script("""
            return [...document.querySelectorAll(arguments[0] + ' .charts:not([hidden]) .chart')].map(chart => {
              const svg = chart.querySelector('svg'), box = svg.getBoundingClientRect();
              const marks = [...svg.querySelectorAll('.mark.ranked')].map(m => {
                const r = m.getBoundingClientRect();
                return [m.dataset.run, r.left + r.width / 2 - box.left, r.top + r.height / 2 - box.top];
              });
              const texts = [...svg.querySelectorAll('text')].map(t => {
                const b = t.getBBox();
                return [t.textContent, b.x, b.y, b.x + b.width, b.y + b.height];
              });
              return {metric: chart.dataset.metric, width: Number(svg.getAttribute('width')),
                      log: svg.classList.contains('log-axis'), left: Number(svg.dataset.plotLeft),
                      right: Number(svg.dataset.plotRight),
                      height: Number(svg.getAttribute('height')), marks, texts,
                      offAxis: [...svg.querySelectorAll('.mark.off-axis')].map(m => m.dataset.run),
                      ticks: [...svg.querySelectorAll('text.tick')].map(t => Number(t.textContent))};
            });""", f"#table-{index}")
        for chart in charts:
            name = chart["metric"]
            means = {r["run"]: r["metrics"][name]["mean"] for r in table["methods"]
                     if (r["metrics"].get(name) or {}).get("mean") is not None}
            assert sorted(m[0] for m in chart["marks"]) == sorted(means), name
            x = {run: cx for run, cx, _ in chart["marks"]}
            scale = np.log10 if chart["log"] else (lambda v: v)
            spread = np.ptp([scale(v) for v in means.values()])
            # the axis is the ranked rows' intervals, not an outlying reference row's value: their means
            # take the share of the plot that their spread has of the intervals' span (less the margins)
            ends = [scale(e) for r in table["methods"] for e in ((r["metrics"].get(name) or {}).get("ci95") or ())
                    if e is not None and (not chart["log"] or e > 0)] + [scale(v) for v in means.values()]
            if spread > 0:
                share = spread / (max(ends) - min(ends))
                assert np.ptp(list(x.values())) >= 0.8 * share * (chart["right"] - chart["left"]), name
            for a in means:  # in the order of their means, at distinct pixels (unless under 1 % of the spread apart)
                for b in means:
                    if means[a] < means[b]:
                        assert x[b] >= x[a], (name, a, b)
                        if scale(means[b]) - scale(means[a]) >= 0.01 * spread:
                            assert x[b] - x[a] >= 1.0, (name, a, b, x[a], x[b])
            for text, x0, y0, x1, y1 in chart["texts"]:
                assert x0 >= 0 and y0 >= 0 and x1 <= chart["width"] and y1 <= chart["height"], (name, text)
                assert not re.fullmatch(r"-0(\.0*)?", text), (name, text)
            checked += 1
            if name == "fd":  # the static reference row (FD ~6,556) is off the axis, not setting it
                static = next(r["run"] for r in table["references"] if r["label"] == "static")
                assert static in chart["offAxis"]
                assert max(chart["ticks"]) < 1000  # the axis is the ranked rows' (FD 4.8 to 13.5), not static's
    assert checked >= 20
    # the table prints tiny values in scientific notation, never as "-0.00000"
    cells = browser.execute_script("return [...document.querySelectorAll('td')].map(c => c.firstChild && "
                                   "c.firstChild.textContent)")
    assert not [c for c in cells if c and re.fullmatch(r"-0(\.0*)?", c)]


def _png(data_url: str) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(base64.b64decode(data_url.split(",", 1)[1]))).convert("RGB"))


def test_playback_heads_are_large_labelled_and_opaque(browser, track_site, tmp_path):
    from scipy import ndimage

    site, url = track_site
    run = json.loads((site / "data" / "runs" / "late.json").read_text())
    first = run["sentences"][0]
    assert open_page(browser, f"{url}play.html?subject={first['subject']}&sentence={first['sentence']}"
                              "&runs=late,still&samples=2") == []
    titles = browser.execute_script("return window.player.panels()")
    assert titles == ["ground truth", "late #0", "late #1", "still"]
    heads = browser.execute_script(
        "return [...document.querySelectorAll('#players figure.head')].map(f => {"
        " const c = f.querySelector('canvas'); return [f.querySelector('figcaption').textContent,"
        " c.clientWidth, c.clientHeight, c.width, c.height]; })")
    assert [h[0] for h in heads] == titles  # a label per column
    assert all(h[1] >= 300 and h[2] >= 600 for h in heads), heads
    assert browser.execute_script("return document.documentElement.scrollWidth") <= WIDTH

    gt = json.loads((site / "data" / "sentences" / first["subject"] / f"{first['sentence']}.json").read_text())
    opening = [f[gt["names"].index("jawOpen")] for f in gt["coeffs"]]
    opened = int(np.argmax(opening))
    browser.execute_async_script("const done = arguments[arguments.length - 1];"
                                 "window.player.seek(arguments[0]).then(done);", (opened + 0.5) / 60)
    folder = _screenshot_dir(tmp_path)
    browser.find_element("id", "players").screenshot(str(folder / "site-playback.png"))
    image = _png(browser.execute_script("return document.querySelector('#players canvas').toDataURL()"))
    view = image.shape[1]
    front = image[:view]  # the ground truth's front view at its widest-open mouth
    face = np.any(np.abs(front.astype(int) - BACKGROUND) > 3, axis=-1)
    rows, cols = np.nonzero(face)
    assert rows.max() - rows.min() + 1 >= 300 and cols.max() - cols.min() + 1 >= 0.5 * view  # the head's size
    # opaque: no background shows through the face (every background region touches the view's border)
    regions, count = ndimage.label(~face)
    border = set(np.unique(np.concatenate([regions[0], regions[-1], regions[:, 0], regions[:, -1]])))
    enclosed = [k for k in range(1, count + 1) if k not in border and (regions == k).sum() > 4]
    assert enclosed == [], [(regions == k).sum() for k in enclosed]


def test_screenshots_of_the_table_and_a_chart(browser, committed_site, track_site, tmp_path):
    folder = _screenshot_dir(tmp_path)
    assert open_page(browser, committed_site + "index.html?group=distribution") == []
    browser.execute_script("window.scrollTo(0, 0)")
    browser.save_screenshot(str(folder / "site-leaderboard.png"))
    browser.find_element("css selector", "#table-0 .chart[data-metric='fd']").screenshot(
        str(folder / "site-chart.png"))
    _, url = track_site
    assert open_page(browser, url + "method.html?run=late") == []
    browser.find_element("id", "plots").screenshot(str(folder / "site-method.png"))
    outside = browser.execute_script(
        "return [...document.querySelectorAll('#plots svg')].flatMap(svg => [...svg.querySelectorAll('text')]"
        ".filter(t => { const b = t.getBBox(); return b.x < 0 || b.y < 0 || b.x + b.width > svg.width.baseVal.value"
        " || b.y + b.height > svg.height.baseVal.value; }).map(t => t.textContent))")
    assert outside == []  # the method page's plots clip no text either
    from PIL import Image

    assert Image.open(folder / "site-leaderboard.png").size == (WIDTH, HEIGHT)
    assert Image.open(folder / "site-chart.png").size[0] >= 500
