"""What the study-server tests share: a tiny study folder with real MP4 clips (built with the
design's dataclasses, not with ``create``), the server in a thread or a process, a throwaway
PostgreSQL cluster, and scripted participants (over the API with httpx, or clicking the real
pages in headless Chromium).

A final end-to-end test (create -> serve -> participants -> analyze) calls
:func:`serve_in_thread` (or :func:`start_server_process`) on the created folder, then
:func:`browser_participant` for each scripted participant, then
:func:`benchmark.study.export.export_study`.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from benchmark.study.design import (
    Question,
    Slot,
    SoundCheck,
    Stimulus,
    Study,
    Trial,
    question,
    sha256_of,
    write_study,
)

ROOT = Path(__file__).resolve().parents[2]
SOUND_WORD = "apple"


# -- a tiny study ----------------------------------------------------------------------------------

def make_clip(path: Path, color: str, tone: int, seconds: float = 1.0, size: int = 64) -> Path:
    """A real H.264 + AAC MP4 (a coloured frame with a moving box, a sine tone) via imageio-ffmpeg."""
    import imageio_ffmpeg

    path.parent.mkdir(parents=True, exist_ok=True)
    command = [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-loglevel", "error", "-y",
               "-f", "lavfi", "-i", f"color=c={color}:size={size}x{size}:rate=30:duration={seconds}",
               "-f", "lavfi", "-i", f"sine=frequency={tone}:duration={seconds}",
               "-c:v", "libx264", "-pix_fmt", "yuv420p", "-c:a", "aac", "-b:a", "64k", "-shortest",
               "-movflags", "+faststart", str(path)]
    subprocess.run(command, check=True)
    return path


CLIPS = {"good-s1": ("green", 440), "bad-s1": ("red", 440), "good-s2": ("green", 550), "bad-s2": ("red", 550),
         "gt-s3": ("white", 660), "static-s3": ("gray", 660), "sound": ("black", 880)}


def make_clips(folder: Path) -> Path:
    for name, (color, tone) in CLIPS.items():
        make_clip(folder / f"{name}.mp4", color, tone)
    return folder


def tiny_study(folder: Path, clips: Path, *, design: str = "ab", slots: int = 3, prompt_suffix: str = "",
               pairs: int = 2) -> Study:
    """A study folder in ``folder``: ``pairs`` compared pairs (ab; the clips reused past 2) or 4
    rated clips (mos), one attention check, one practice trial, ``slots`` participant slots
    (orders rotated), a sound check."""
    stimuli_dir = folder / "stimuli"
    stimuli_dir.mkdir(parents=True, exist_ok=True)
    for clip in clips.glob("*.mp4"):
        shutil.copyfile(clip, stimuli_dir / clip.name)
    rows = {"good": "good", "bad": "bad", "gt": "ground-truth", "static": "static"}
    stimuli = {}
    for name in CLIPS:
        if name == "sound":
            continue
        row, sentence = name.split("-")
        stimuli[name] = Stimulus(path=f"stimuli/{name}.mp4", sha256=sha256_of(stimuli_dir / f"{name}.mp4"),
                                 row=rows[row], subject="FaceTalk_test", sentence=sentence, sample=0, seconds=1.0)
    ids = ("lipsync", "realism")
    questions = tuple(Question(q.id, q.prompt + prompt_suffix, q.choices) for q in (question(i, design) for i in ids))
    if design == "ab":
        trials = [Trial("t1", "ab", ("good-s1", "bad-s1"), ids), Trial("t2", "ab", ("bad-s2", "good-s2"), ids),
                  Trial("att1", "attention", ("gt-s3", "static-s3"), ids, expected="left"),
                  Trial("practice", "practice", ("good-s1", "static-s3"), ("lipsync",))]
        trials += [Trial(f"t{k}", "ab", (("good-s1", "bad-s1"), ("bad-s2", "good-s2"))[k % 2], ids)
                   for k in range(3, pairs + 1)]
    else:
        trials = [Trial(f"m-{s}", "mos", (s,), ids) for s in ("good-s1", "bad-s1", "good-s2", "bad-s2")]
        trials += [Trial("practice", "practice", ("gt-s3",), ("lipsync",))]
    judged = [t.id for t in trials if t.kind != "practice"]
    participants = tuple(Slot(k, tuple(judged[k % len(judged):] + judged[:k % len(judged)])) for k in range(slots))
    study = Study(design=design, seed=0, questions=questions, stimuli=stimuli, trials=tuple(trials),
                  participants=participants,
                  sound_check=SoundCheck("stimuli/sound.mp4", sha256_of(stimuli_dir / "sound.mp4"), SOUND_WORD),
                  min_seconds=5.0, judgements_per_item=3,
                  rows={r: {"result": f"{r}.json", "result_sha256": "0" * 64, "recipe_id": "test", "label": r}
                        for r in rows.values()})
    write_study(study, folder)
    return study


def screens_of(study: Study, slot: int):
    from benchmark.study.server.steps import question_screens

    return question_screens(study, slot)


# -- the server --------------------------------------------------------------------------------------

def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def serve_in_thread(folder, db_url: str | None = None, **app_options):
    """The study served by uvicorn in a thread on a free loopback port; yields its base URL."""
    import uvicorn

    from benchmark.study.server import create_app

    app = create_app(folder, db_url, **app_options)
    port = free_port()
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    deadline = time.monotonic() + 30
    while not server.started:
        if time.monotonic() > deadline or not thread.is_alive():
            raise RuntimeError("the study server did not start")
        time.sleep(0.05)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        thread.join(10)
        app.state.store.close()


def start_server_process(folder, port: int, db_url: str | None = None) -> subprocess.Popen:
    """``python -m benchmark.study serve`` as a child process; returns once it answers."""
    from benchmark.study.server.load import start_server

    return start_server(folder, port, db_url)


# -- PostgreSQL ---------------------------------------------------------------------------------------

def postgres_bin() -> Path | None:
    found = sorted(Path("/usr/lib/postgresql").glob("*/bin/initdb"))
    return found[-1].parent if found else None


@contextlib.contextmanager
def postgres_cluster():
    """A throwaway PostgreSQL cluster (initdb + pg_ctl, in a temporary folder, on a free port);
    yields its URL. Skips (fails in CI) when PostgreSQL is not installed. As root, the cluster
    runs as the ``postgres`` user (PostgreSQL refuses to run as root)."""
    import tempfile

    bin_dir = postgres_bin()
    if bin_dir is None:
        message = "PostgreSQL is not installed; apt-get install postgresql"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    run_as = []
    folder = Path(tempfile.mkdtemp(prefix="blendvoca-pg-"))
    if os.geteuid() == 0:
        import pwd

        try:
            owner = pwd.getpwnam("postgres")
        except KeyError:
            pytest.skip("PostgreSQL refuses to run as root and there is no 'postgres' user to run it as")
        os.chown(folder, owner.pw_uid, owner.pw_gid)
        run_as = ["runuser", "-u", "postgres", "--"]
    data, port, user = folder / "data", free_port(), "study"
    try:
        subprocess.run([*run_as, str(bin_dir / "initdb"), "-D", str(data), "-U", user, "-A", "trust", "-E", "UTF8"],
                       check=True, capture_output=True)
        subprocess.run([*run_as, str(bin_dir / "pg_ctl"), "-D", str(data), "-l", str(folder / "log"), "-w", "-o",
                        f"-p {port} -k {folder} -c listen_addresses=127.0.0.1", "start"],
                       check=True, capture_output=True)
        try:
            subprocess.run([str(bin_dir / "createdb"), "-h", "127.0.0.1", "-p", str(port), "-U", user, "study"],
                           check=True, capture_output=True)
            yield f"postgresql://{user}@127.0.0.1:{port}/study"
        finally:
            subprocess.run([*run_as, str(bin_dir / "pg_ctl"), "-D", str(data), "-m", "immediate", "-w", "stop"],
                           capture_output=True)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


# -- scripted participants --------------------------------------------------------------------------

def start_api_session(client, base: str = "", **platform) -> str:
    """Consent through ``POST /start`` (with platform URL parameters); returns the session's path."""
    response = client.post(f"{base}/start", data={"consent": "yes", **platform}, follow_redirects=False)
    assert response.status_code == 303, response.text
    return response.headers["location"]


def api_participant(client, path: str, choose, base: str = "", stop_after: int | None = None) -> int:
    """Answer a session's screens over the JSON API; ``choose(screen) -> choice``. Returns the
    number of answers acknowledged (stops early after ``stop_after``)."""
    acknowledged = 0
    state = client.get(f"{base}{path}api/state").json()
    while state["step"] != "done":
        if state["step"] == "instructions":
            state = client.post(f"{base}{path}api/instructions").json()
        elif state["step"] == "sound_check":
            state = client.post(f"{base}{path}api/sound-check", json={"word": SOUND_WORD}).json()["state"]
        else:
            if stop_after is not None and acknowledged >= stop_after:
                return acknowledged
            screen = state["screen"]
            response = client.post(f"{base}{path}api/answer", json={
                "trial": screen["trial"], "question": screen["question"], "choice": choose(screen), "rt_ms": 1234})
            assert response.status_code == 200, response.text
            acknowledged += 1
            state = response.json()["state"]
    return acknowledged


def page_step(driver) -> str | None:
    """The step the study page in ``driver`` shows once it is ready (``consent``,
    ``instructions``, ``sound_check``, ``question``, ``done``); None while it loads."""
    return driver.execute_script(
        "const m = document.querySelector('main[data-step]');"
        "if (m) return m.dataset.step;"
        "return document.body && document.body.dataset.ready === 'true' ? document.body.dataset.step : null;")


def browser_participant(driver, url: str, choose, *, reload_after: int | None = None,
                        sound_word: str = SOUND_WORD, platform: dict | None = None,
                        timeout: float = 60.0) -> dict:
    """Click through the real pages in ``driver`` (selenium): consent, instructions, sound check,
    practice, every question (pressing Play and waiting for the clips to end), until the
    completion code. ``choose(screen_data) -> choice``; ``reload_after=k`` reloads the page once
    after k answered questions (the session must resume). Returns
    ``{"code", "answers", "session_url", "reloaded"}``."""
    from urllib.parse import urlencode

    from selenium.webdriver.common.by import By

    def wait(condition, what):
        deadline = time.monotonic() + timeout
        while True:
            value = condition()
            if value:
                return value
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out waiting for {what} on {driver.current_url}; "
                                     f"page: {driver.page_source[:2000]}; console: {driver.get_log('browser')}")
            time.sleep(0.05)

    def step():
        return page_step(driver)

    def clicked_to_next_page(element):
        driver.execute_script("window.__studyOldPage = true")
        element.click()
        wait(lambda: driver.execute_script("return window.__studyOldPage !== true"), "the next page to load")

    driver.get(url + ("/?" + urlencode(platform) if platform else "/"))
    wait(lambda: step() == "consent", "the consent page")
    driver.find_element(By.ID, "consent-box").click()
    clicked_to_next_page(driver.find_element(By.ID, "start"))
    answers, reloaded, session_url = 0, False, driver.current_url
    while True:
        current = wait(step, "a page")
        if current == "done":
            break
        if current == "instructions":
            clicked_to_next_page(driver.find_element(By.ID, "continue"))
        elif current == "sound_check":
            driver.find_element(By.ID, "play").click()
            wait(lambda: driver.execute_script("return document.getElementById('play').textContent === 'Play again'"),
                 "the sound check clip to end")
            box = driver.find_element(By.CSS_SELECTOR, "#jspsych-survey-text-form input[type=text]")
            box.send_keys(sound_word)
            clicked_to_next_page(driver.find_element(By.ID, "jspsych-survey-text-next"))
        elif current == "question":
            if reload_after is not None and answers == reload_after and not reloaded:
                reloaded = True
                driver.execute_script("window.__studyOldPage = true")
                driver.refresh()
                wait(lambda: driver.execute_script("return window.__studyOldPage !== true"), "the reload")
                assert driver.current_url == session_url
                continue
            screen = driver.execute_script("return JSON.parse(document.getElementById('study-data').textContent)")
            buttons = driver.find_elements(By.CSS_SELECTOR, "button.answer")
            if screen["screen"]["first_of_trial"]:
                assert all(b.get_attribute("disabled") for b in buttons), "answers enabled before the clips played"
                driver.find_element(By.ID, "play").click()
                wait(lambda: driver.execute_script("return document.body.dataset.watched === 'true'"),
                     "the clips to play to their end")
            choice = choose(screen["screen"])
            clicked_to_next_page(driver.find_element(By.CSS_SELECTOR, f"button.answer[data-value='{choice}']"))
            if not screen["screen"]["practice"]:
                answers += 1
        else:
            raise AssertionError(f"unexpected page {current!r}: {driver.page_source[:1000]}")
    code = driver.find_element(By.ID, "completion-code").text
    return {"code": code, "answers": answers, "session_url": session_url, "reloaded": reloaded}


# -- fixtures (imported by the test modules) --------------------------------------------------------

@pytest.fixture(scope="session")
def study_clips(tmp_path_factory):
    """The tiny study's MP4 clips, made once per session."""
    return make_clips(tmp_path_factory.mktemp("study-clips"))


@pytest.fixture(scope="session")
def jspsych_installed():
    """Serving needs the pinned jsPsych (npm ci); skip (fail in CI) without it."""
    from benchmark.study.server.pages import VENDOR_FILES, WEB_DIR

    if not all((WEB_DIR / "node_modules" / rel).is_file() for rel in VENDOR_FILES.values()):
        message = f"jsPsych for the study server is not installed; run `npm ci --prefix {WEB_DIR}` once"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)


@pytest.fixture
def ab_study(tmp_path, study_clips, jspsych_installed):
    """``(folder, study)``: a fresh A/B study folder."""
    folder = tmp_path / "study"
    return folder, tiny_study(folder, study_clips)
