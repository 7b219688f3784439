"""The results browser: data files, the local server, and the pages in headless Chromium."""

from __future__ import annotations

import json
import shutil
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from leaderboard.site import SITE_MARKER, build_site, framed_page
from leaderboard.site.serve import serve_site

from .browser import browser, open_page, require_three_js  # noqa: F401 - browser is a fixture

COMMITTED_RESULTS = Path(__file__).resolve().parents[2] / "leaderboard" / "results"


def _write_run(results, name, dataset, *, reference, samples, transform, lve):
    """A stored run in the benchmark's layout: result JSON + ``<tracks>/<subject>/sentenceNN-<k>.csv``."""
    from benchmark.results import build_result
    from blendvoca.io.coeffs import write_coeffs_csv

    tracks = results / f"{name}.tracks"
    per_sentence = []
    for subject in dataset.split("test"):
        for sentence in dataset.sentences(subject):
            gt = dataset.coeffs(subject, sentence)
            (tracks / subject).mkdir(parents=True, exist_ok=True)
            for k in range(samples):
                write_coeffs_csv(tracks / subject / f"{sentence}-{k}.csv", transform(gt, k), dataset.names)
            per_sentence.append({"subject": subject, "sentence": sentence, "lve_rig": lve + 0.1 * len(per_sentence)})
    metric = {"mean": lve, "std": 0.1, "ci95": [lve - 0.1, lve + 0.1], "n": len(per_sentence),
              "higher_is_better": False, "unit": "mm", "label": "LVE rig", "group": "vertex"}
    result = build_result(
        method={"name": name, "label": name, "class": "tests:Fake", "stochastic": samples > 1,
                "reference": reference, "config": {}, "output": "coefficients"},
        dataset={"manifest_hash": dataset.manifest_hash, "recipe_id": dataset.recipe_id, "path": str(dataset.root),
                 "split": "test",
                 "num_subjects": len(dataset.split("test")), "num_sentences": len(per_sentence)},
        protocol={"samples": samples, "seed": 0, "budget": {}, "clip": False, "n_clipped": 0, "checkpoint": None},
        metrics={"lve_rig": metric}, timings={}, per_sentence=per_sentence, tracks=tracks.name)
    (results / f"{name}.json").write_text(json.dumps(result.to_json(), indent=1))


@pytest.fixture(scope="module")
def results_dir(tmp_path_factory, built_dataset):
    from benchmark.data import open_blendvoca

    dataset = open_blendvoca(built_dataset)
    results = tmp_path_factory.mktemp("results")
    from benchmark.protocol import RunSpec, run

    # Two rows as benchmark.run stores them, two written by hand with known scores.
    for name, samples in (("ground-truth", 1), ("random", 3)):
        run(RunSpec(name, data_root=built_dataset, samples=samples, results_dir=results))
    _write_run(results, "late", dataset, reference=False, samples=3, lve=1.5,
               transform=lambda gt, k: np.clip(np.roll(gt, 3 * (k + 1), axis=0), 0, 1))
    _write_run(results, "still", dataset, reference=False, samples=1, lve=3.0,
               transform=lambda gt, k: np.zeros_like(gt))
    return results


@pytest.fixture(scope="module")
def three_js():
    """Building a site copies the pinned three.js, which `npm ci` installs."""
    require_three_js()


@pytest.fixture(scope="module")
def site(tmp_path_factory, results_dir, three_js):
    return build_site(results_dir, tmp_path_factory.mktemp("site") / "site", max_samples=2)


def test_site_data_files(site, results_dir):
    board = json.loads((site / "data" / "leaderboard.json").read_text())
    (table,) = board["tables"]
    assert [r["run"] for r in table["methods"]] == ["late", "still"]
    references = {r["label"]: r for r in table["references"]}
    assert sorted(references) == ["ground-truth", "random"]
    assert references["random"]["samples"] == 3 and references["ground-truth"]["has_tracks"]
    assert all(m["ci95"] is not None for m in references["random"]["metrics"].values())
    # the bundled default's 4 test sentences are too few to resample (a sign test could not reject):
    # the older rule, intervals [1.4, 1.6] and [2.9, 3.1] do not overlap; no probabilities
    assert table["num_sentences"] < 5
    assert table["methods"][0]["best"] == ["lve_rig"] and table["best_rule"]["lve_rig"] == "intervals"
    assert table["notes"]["fallback"] == [n for n, rule in table["best_rule"].items() if rule == "intervals"]
    runs = table["improvement"]["runs"]
    assert runs[:2] == ["late", "still"] and sorted(runs[2:]) == sorted(references[k]["run"] for k in references)
    assert "lve_rig" not in table["improvement"]["metrics"]
    run = json.loads((site / "data" / "runs" / "late.json").read_text())
    assert len(run["per_sentence"]) == len(run["sentences"]) > 0
    first = run["sentences"][0]
    assert first["samples"] == 3
    track_dir = site / "data" / "tracks" / "late" / first["subject"]
    assert sorted(p.name for p in track_dir.glob(f"{first['sentence']}-*.json")) == [
        f"{first['sentence']}-0.json", f"{first['sentence']}-1.json"]  # max_samples=2
    gt = json.loads((site / "data" / "sentences" / first["subject"] / f"{first['sentence']}.json").read_text())
    assert len(gt["coeffs"]) == len(gt["lip_motion_mm"]) == len(gt["envelope"])
    assert 0 <= min(gt["envelope"]) and max(gt["envelope"]) == 1
    assert (site / "data" / "rigs" / f"{first['subject']}.glb").is_file()
    assert (site / "vendor" / "three.module.js").is_file() and (site / SITE_MARKER).is_file()
    # a web server (another user) can read it: not the private modes of the temporaries it is written through
    import stat

    from blendvoca.io.atomic import permissions_for

    allowed = permissions_for(site / "missing", directory=True)  # 0o777 less the umask
    for path in [site, *site.rglob("*")]:
        mode = stat.S_IMODE(path.stat().st_mode)
        wanted = allowed & (0o555 if path.is_dir() else 0o444)  # readable (and enterable) as the umask allows
        assert mode & wanted == wanted, f"{path}: {oct(mode)}"


def test_out_folder_is_never_a_users(tmp_path, results_dir, three_js):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep me")
    with pytest.raises(ValueError, match="not a site written by this tool"):
        build_site(results_dir, mine)
    assert (mine / "notes.txt").read_text() == "keep me"
    again = build_site(results_dir, tmp_path / "site")
    build_site(results_dir, again)  # a previous site is replaced
    assert not list(tmp_path.glob(".*.tmp"))


@pytest.mark.parametrize("name, title", [("index", "BlendVOCA leaderboard"), ("method", "BlendVOCA run"),
                                         ("play", "BlendVOCA playback")])
def test_pages_share_one_frame(name, title):
    """Each page of static/ holds only its own head and body lines; the built page has the shared frame once."""
    page = framed_page(Path(__file__).resolve().parents[2] / "leaderboard" / "site" / "static" / f"{name}.html")
    assert page.startswith('<!doctype html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n'
                           f"<title>{title}</title>\n")
    assert page.endswith(f'<script type="module" src="assets/{"leaderboard" if name == "index" else name}.js">'
                         "</script>\n</body>\n</html>\n")
    for line in ("<head>", "</head>", "<body>", "</body>", '<link rel="stylesheet" href="assets/site.css">',
                 '<script src="assets/file-notice.js"></script>', '<nav><a href="index.html">Leaderboard</a></nav>'):
        assert page.count(line + "\n") == 1, line
    assert page.index("</head>") < page.index("<body>") < page.index("<nav>") < page.index("<h1")


def test_a_page_without_its_head_and_body_blocks_is_refused(tmp_path):
    page = tmp_path / "broken.html"
    page.write_text("<h1>no head</h1>\n")
    with pytest.raises(ValueError, match="broken.html: expected a <head> block and a <body> block"):
        framed_page(page)


def test_cli_errors_are_one_line(tmp_path, capsys):
    from leaderboard.site.__main__ import main

    assert main(["--results", str(tmp_path / "none"), "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: ") and "does not exist" in err[0]


def test_server_answers_byte_ranges(site):
    server, url = serve_site(site, port=0, background=True)
    try:
        wav = next((site / "data" / "audio").rglob("*.wav"))
        rel = wav.relative_to(site).as_posix()
        request = urllib.request.Request(url + rel, headers={"Range": "bytes=4-11"})
        with urllib.request.urlopen(request) as response:
            assert response.status == 206
            assert response.headers["Content-Range"] == f"bytes 4-11/{wav.stat().st_size}"
            assert response.read() == wav.read_bytes()[4:12]
        with urllib.request.urlopen(url + rel) as response:
            assert response.status == 200 and response.read() == wav.read_bytes()
    finally:
        server.shutdown()


@pytest.fixture(scope="module")
def served(site):
    server, url = serve_site(site, port=0, background=True)
    yield url
    server.shutdown()


def test_leaderboard_page_rows_and_sorting(browser, served, results_dir):
    assert open_page(browser, served + "index.html") == []
    runs = browser.execute_script("return [...document.querySelectorAll('tbody.methods tr')].map(r => r.dataset.run)")
    refs = browser.execute_script("return [...document.querySelectorAll('tbody.references tr[data-run]')]"
                                  ".map(r => r.dataset.run)")
    assert runs == ["late", "still"] and len(refs) == 2
    assert sorted(runs + refs) == sorted(p.stem for p in results_dir.glob("*.json"))  # one row per stored run
    browser.find_element("css selector", "#table-0 .tabs button[data-tab='vertex']").click()  # its metric group
    header = browser.find_element("css selector", "th[data-metric='lve_rig']")
    header.click()  # descending first
    assert browser.execute_script("return [...document.querySelectorAll('tbody.methods tr')]"
                                  ".map(r => r.dataset.run)") == ["still", "late"]
    header.click()
    assert browser.execute_script("return [...document.querySelectorAll('tbody.methods tr')]"
                                  ".map(r => r.dataset.run)") == ["late", "still"]
    assert browser.find_elements("css selector", ".chart[data-metric='lve_rig'] circle")
    assert browser.find_elements("css selector", "p.fallback-note")


def test_method_page_scores_and_plots(browser, served):
    assert open_page(browser, served + "method.html?run=late") == []
    rows = browser.find_elements("css selector", "#per-sentence-table tbody tr")
    assert len(rows) == browser.execute_script("return (await (await fetch('data/runs/late.json')).json())"
                                               ".per_sentence.length")
    browser.find_element("id", "worst-first").click()
    values = browser.execute_script("return [...document.querySelectorAll('#per-sentence-table tbody tr')]"
                                    ".map(r => Number(r.cells[2].dataset.value))")
    assert values == sorted(values, reverse=True)  # LVE: lower is better, worst (largest) first
    assert browser.find_elements("css selector", "#coefficient-plot polyline")
    assert browser.find_elements("css selector", "#lip-plot polyline")


def test_playback_moves_the_mouth_in_sync_with_the_audio(browser, served, site):
    run = json.loads((site / "data" / "runs" / "late.json").read_text())
    first = run["sentences"][0]
    url = f"{served}play.html?subject={first['subject']}&sentence={first['sentence']}&runs=late&samples=2"
    assert open_page(browser, url) == []
    assert browser.execute_script("return window.player.panels()") == ["ground truth", "late #0", "late #1"]
    gt = json.loads((site / "data" / "sentences" / first["subject"] / f"{first['sentence']}.json").read_text())
    assert browser.execute_script("return window.player.duration()") == pytest.approx(gt["duration"], abs=0.01)

    def canvas_at(seconds):
        return browser.execute_async_script(
            "const done = arguments[arguments.length - 1];"
            "window.player.seek(arguments[0]).then(() => done([window.player.frame, "
            "[...document.querySelectorAll('#players canvas')].map(c => c.toDataURL()).join()]));", seconds)

    jaw = gt["names"].index("jawOpen")
    opening = [f[jaw] for f in gt["coeffs"]]
    closed, opened = int(np.argmin(opening)), int(np.argmax(opening))
    frame_a, image_a = canvas_at((closed + 0.5) / 60)
    frame_b, image_b = canvas_at((opened + 0.5) / 60)
    assert (frame_a, frame_b) == (closed, opened)
    assert image_a != image_b
    assert [e for e in browser.get_log("browser") if e["level"] == "SEVERE"] == []


def test_site_from_the_committed_results_loads(three_js, browser, tmp_path):
    site = build_site(COMMITTED_RESULTS, tmp_path / "site")
    server, url = serve_site(site, port=0, background=True)
    try:
        assert open_page(browser, url + "index.html") == []
        shown = browser.execute_script("return document.querySelectorAll('tr[data-run]').length")
        assert shown == len(list(COMMITTED_RESULTS.glob("*.json")))
        assert open_page(browser, url + "play.html") == []
    finally:
        server.shutdown()
        shutil.rmtree(site)


def _v3_runs(tmp_path):
    """Two methods (one trained with two seeds, not settled) and a reference row, as SiteRuns."""
    from benchmark.results import build_result, check
    from leaderboard.site.data import SiteRun

    sentences = [("S1", f"sentence{i:02d}") for i in range(30)]
    base = np.linspace(1.0, 3.0, len(sentences))

    def rows(values):
        return [{"subject": s, "sentence": q, "lve_rig": float(v), "av_offset_geometric": 0.0}
                for (s, q), v in zip(sentences, values)]

    def result(label, values, reference=False, **extra):
        mean = float(np.mean(values))
        metrics = {"lve_rig": {"mean": mean, "std": 0.1, "ci95": [mean - 0.2, mean + 0.2], "higher_is_better": False,
                               "unit": "mm"},
                   "av_offset_geometric": {"mean": 0.0, "std": 0.0, "ci95": [0.0, 0.0], "higher_is_better": False,
                                           "unit": "frames@60fps"}}
        out = build_result(method={"name": label, "label": label, "reference": reference, "config": {}},
                           dataset={"manifest_hash": "h", "split": "test", "num_sentences": len(sentences)},
                           protocol={"samples": 1, "seed": 0}, metrics=metrics, timings={},
                           provenance={"date": "2026-01-01"}, per_sentence=rows(values)).to_json()
        out.update(extra)
        return out

    seeds = [base, base + 0.02]
    two = result("two-seeds", np.mean(seeds, axis=0), seeds=[0, 1], per_seed=[
        {"seed": k, "metrics": {"lve_rig": float(v.mean())}, "per_sentence": rows(v)} for k, v in enumerate(seeds)],
        convergence={"checked_at_step": 50, "total_steps": 100, "settled": False,
                     "metrics": {"lve_rig": {"half_budget": 2.5, "full_budget": 2.0, "half_width": 0.1,
                                             "settled": False}}})
    two["metrics"]["lve_rig"]["seed_range"] = [float(seeds[0].mean()), float(seeds[1].mean())]
    results = [two, result("one-seed", base + 0.5), result("ground-truth", base - 1.0, reference=True)]
    return [SiteRun(tmp_path / f"{r['method']['name']}.json", check(r)) for r in results]


def test_site_data_shows_seeds_settling_best_rules_and_improvement(tmp_path):
    from leaderboard.site.data import leaderboard_data, run_page_data

    runs = _v3_runs(tmp_path)
    (table,) = leaderboard_data(runs)["tables"]
    methods = {r["label"]: r for r in table["methods"]}
    two = methods["two-seeds"]
    assert two["seeds"] == [0, 1] and two["settled"] is False and "LVE rig 2.51 (now 2.01) would leave no row bold (now two-seeds is), would no longer beat one-seed" in two["not_settled"]
    assert two["metrics"]["lve_rig"]["seed_range"] == pytest.approx([2.0, 2.02])
    assert methods["one-seed"]["settled"] is None and methods["one-seed"]["metrics"]["lve_rig"]["seed_range"] is None
    assert two["best"] == ["lve_rig"] and table["best_rule"]["lve_rig"] == "resampling"
    assert table["best_rule"]["av_offset_geometric"] == "resampling" and "av_offset_geometric" not in two["best"]
    assert "random per-sentence lag" in table["notes"]["av_offset"] and table["notes"]["fallback"] == []
    runs_order = table["improvement"]["runs"]
    assert runs_order == ["one-seed", "two-seeds", "ground-truth"]  # methods by label, then the reference rows
    matrix = table["improvement"]["metrics"]["lve_rig"]
    i, j, k = (runs_order.index(r.id) for r in runs)
    assert matrix[i][j] == 1.0 and matrix[k][i] == 1.0  # the ground truth beats everything (shown, never marked)
    assert matrix[i][j] == table["best_probability"]["lve_rig"]
    page = run_page_data(runs[0])
    assert page["seeds"] == [0, 1] and page["convergence"]["settled"] is False and len(page["per_seed"]) == 2


def test_leaderboard_page_shows_seed_ranges_settling_and_the_av_note(three_js, browser, tmp_path):
    from benchmark.results import write

    results = tmp_path / "results"
    for run in _v3_runs(tmp_path):
        write(results / f"{run.id}.json", run.result)
    site = build_site(results, tmp_path / "site")
    server, url = serve_site(site, port=0, background=True)
    try:
        assert open_page(browser, url + "index.html") == []
        shown = browser.execute_script(
            "const row = document.querySelector('tbody.methods tr[data-run=\"two-seeds\"]');"
            "return [row.querySelector('.not-settled').textContent, row.querySelector('.not-settled').title,"
            " [...row.querySelectorAll('.seeds')].map(s => s.textContent),"
            " document.querySelector('tbody.methods tr[data-run=\"one-seed\"] .not-settled') === null];")
        assert shown[0] == "\u2020" and "LVE rig 2.51 (now 2.01) would leave no row bold (now two-seeds is), would no longer beat one-seed" in shown[1] and shown[3]
        assert shown[2] == ["seeds [2.00, 2.02]"]
        notes = browser.execute_script("return [...document.querySelectorAll('p.note')].map(p => p.className + ': ' "
                                       "+ p.textContent)")
        assert any(n.startswith("note av-note") and "random per-sentence lag" in n for n in notes)
        assert any(n.startswith("note not-settled-note") and "two-seeds" in n for n in notes)
        assert browser.execute_script("return document.querySelector(\"th[data-metric='av_offset_geometric']\")"
                                      ".title").count("uniform over -2..2 frames") == 1
        # the probability of improvement for a chosen metric: P(two-seeds better than one-seed) = 100 %
        select = browser.find_element("css selector", "#improvement-0 select.improvement-metric")
        browser.execute_script("arguments[0].value = 'lve_rig'; arguments[0].dispatchEvent(new Event('change'))",
                               select)
        cell = browser.execute_script(
            "const m = document.querySelector('#improvement-0 table.improvement-matrix[data-metric=\"lve_rig\"]');"
            "const runs = [...m.querySelectorAll('tbody tr')].map(r => r.dataset.row);"
            "const row = m.querySelector('tr[data-row=\"two-seeds\"]');"
            "const cell = row.cells[1 + runs.indexOf('one-seed')]; return [cell.textContent, cell.className];")
        assert cell == ["100%", "sure"]
    finally:
        server.shutdown()


def test_pages_opened_from_a_file_say_how_to_serve_them(browser, site):
    """From file:// the browser refuses the module scripts and data: the page itself says what to do."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    for page in ("index.html", "method.html", "play.html"):
        browser.get((site / page).as_uri())
        note = WebDriverWait(browser, 20).until(lambda d: d.find_elements(By.ID, "file-protocol"))[0].text
        assert f'python -m http.server --directory "{site}/" 8000' in note, note
        assert f"http://localhost:8000/{page}" in note and "--serve" in note, note
    browser.get_log("browser")  # the file:// pages' refusals, expected above
    # served over http, no such note
    server, url = serve_site(site, port=0, background=True)
    try:
        assert open_page(browser, url + "index.html") == []
        assert browser.find_elements(By.ID, "file-protocol") == []
    finally:
        server.shutdown()


def test_runs_without_stored_tracks_say_what_playback_needs(three_js, browser, tmp_path):
    """The committed results hold no tracks: the playback and method pages say so and what recreates them."""
    results = tmp_path / "results"
    results.mkdir()
    for path in sorted(COMMITTED_RESULTS.glob("*.json"))[:3]:
        shutil.copyfile(path, results / path.name)
    site = build_site(results, tmp_path / "site")
    server, url = serve_site(site, port=0, background=True)
    try:
        assert open_page(browser, url + "play.html") == []
        note = browser.execute_script("return document.getElementById('playback-needs').textContent")
        assert "--data" in note and "leaderboard.reproduce" in note, note
        run = sorted(results.glob("*.json"))[0].stem
        page = json.loads((site / "data" / "runs" / f"{run}.json").read_text())
        assert "not next to its result file" in page["tracks_note"] and "leaderboard.reproduce" in page["tracks_note"]
    finally:
        server.shutdown()
