"""A screenshot of a study's first A/B trial page, as a participant sees it, in headless Chromium.

    python perf/study_screenshot.py STUDY --out docs/img/study-trial.png

Serves STUDY on loopback, clicks through consent, instructions and the sound check (typing the
design's answer), presses Play on the first trial and takes the picture while the right clip
plays. docs/img/study-trial.png is a study made by ``benchmark.study create`` on the bundled
default (rows truth and still of ``tests/study/create_fixtures.py``, ``--size 320
--max-seconds 2``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study", type=Path)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--width", type=int, default=1100)
    parser.add_argument("--height", type=int, default=960)
    args = parser.parse_args(argv)

    from selenium.webdriver.common.by import By

    from benchmark.study.design import read_study
    from tests.leaderboard.browser import chromium_driver
    from tests.study.server_fixtures import page_step, serve_in_thread

    study = read_study(args.study)
    driver = chromium_driver()
    driver.set_window_size(args.width, args.height)

    def step():
        return page_step(driver)

    def wait_for(name, seconds=30):
        deadline = time.monotonic() + seconds
        while step() != name:
            if time.monotonic() > deadline:
                raise SystemExit(f"error: the page did not reach {name!r} (at {step()!r})")
            time.sleep(0.05)

    try:
        with serve_in_thread(args.study) as url:
            driver.get(url + "/")
            wait_for("consent")
            driver.find_element(By.ID, "consent-box").click()
            driver.find_element(By.ID, "start").click()
            wait_for("instructions")
            driver.find_element(By.ID, "continue").click()
            if study.sound_check is not None:
                wait_for("sound_check")
                driver.find_element(By.CSS_SELECTOR, "#jspsych-survey-text-form input[type=text]").send_keys(
                    study.sound_check.answer)
                driver.find_element(By.ID, "jspsych-survey-text-next").click()
            wait_for("question")
            driver.find_element(By.ID, "play").click()
            seconds = max(s.seconds for s in study.stimuli.values())
            time.sleep(seconds * 1.5)  # the left clip has played, the right one is halfway
            args.out.parent.mkdir(parents=True, exist_ok=True)
            driver.save_screenshot(str(args.out))
    finally:
        driver.quit()
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
