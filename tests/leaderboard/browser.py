"""What the results-browser tests need outside Python: headless Chromium (Debian chromium +
chromium-driver, selenium) and the site's pinned three.js (``npm ci``).

Locally a test that needs a missing one is skipped with the command that installs it;
in CI (``CI`` set) a missing one is a failure, since ``.ci/run`` installs them.
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


def unavailable(message: str):
    """Skip the test for a missing outside tool (fail in CI, which installs every one)."""
    if os.environ.get("CI"):
        pytest.fail(message)
    pytest.skip(message)


def require_three_js() -> None:
    """Skip (fail in CI) unless the site's three.js is installed, which building a site needs."""
    from leaderboard.site.vendor import VENDOR_FILES, WEB_DIR

    if not all((WEB_DIR / "node_modules" / rel).is_file() for rel in VENDOR_FILES):
        unavailable(f"three.js for the results site is not installed; run `npm ci --prefix {WEB_DIR}` once")


def chromium_driver():
    """A selenium Chrome driver on headless Chromium, or skip (fail in CI) if unavailable."""
    missing = [p for p in (CHROMIUM, CHROMEDRIVER) if not os.path.exists(p)]
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        missing.append("selenium")
    if missing:
        unavailable(f"headless Chromium unavailable ({', '.join(missing)}); apt-get install chromium chromium-driver")
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


@pytest.fixture(scope="module")
def browser():
    """A headless Chromium driver shared by a test module (imported by the modules that use it)."""
    driver = chromium_driver()
    yield driver
    driver.quit()
