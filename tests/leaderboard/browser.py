"""Headless Chromium for the results-browser tests (Debian chromium + chromium-driver, selenium).

Locally the browser tests are skipped when Chromium, ChromeDriver or selenium is
missing; in CI (``CI`` set) a missing browser is a failure, since ``.ci/run``
installs them.
"""

from __future__ import annotations

import os
import shutil
import time

import pytest

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"

#: Flags for a closed network and no GPU: software WebGL (SwiftShader), no
#: background connections, audio allowed to play without a click.
CHROMIUM_FLAGS = (
    "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--window-size=1280,1000", "--autoplay-policy=no-user-gesture-required",
    "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
)


def chromium_driver():
    """A selenium Chrome driver on headless Chromium, or skip (fail in CI) if unavailable."""
    missing = [p for p in (CHROMIUM, CHROMEDRIVER) if not os.path.exists(p)]
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        missing.append("selenium")
    if missing:
        message = f"headless Chromium unavailable ({', '.join(missing)}); apt-get install chromium chromium-driver"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in CHROMIUM_FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={os.environ.get('TMPDIR', '/tmp')}/blendvoca-chromium-{os.getpid()}")
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)


def open_page(driver, url: str, timeout: float = 60.0) -> list[dict]:
    """Load ``url``, wait until the page sets ``body[data-ready]``, return the console errors."""
    driver.get(url)
    deadline = time.monotonic() + timeout
    while driver.execute_script("return document.body && document.body.dataset.ready") != "true":
        if time.monotonic() > deadline:
            logs = driver.get_log("browser")
            raise AssertionError(f"{url} did not become ready in {timeout} s; console: {logs}")
        time.sleep(0.1)
    return [entry for entry in driver.get_log("browser") if entry["level"] == "SEVERE"]
