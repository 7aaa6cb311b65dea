"""Headless Chromium driven by Selenium, for the viewer's end-to-end tests and its benchmark
(Debian's chromium and chromium-driver; Selenium is in the `test` extra, imported here only
when a browser is started)."""
from __future__ import annotations

import os
from pathlib import Path

CHROMIUM = os.environ.get("CLSHADE_CHROMIUM", "/usr/bin/chromium")
CHROMEDRIVER = os.environ.get("CLSHADE_CHROMEDRIVER", "/usr/bin/chromedriver")
#: No GPU, no sandbox (containers), no network beyond the page, a device pixel per CSS pixel.
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage", "--force-device-scale-factor=1")


def missing() -> str | None:
    """Why no browser can be started here, or None."""
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (pip install 'clshade[test]')"
    if not (Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()):
        return (f"no browser: {CHROMIUM} and {CHROMEDRIVER} are needed (apt-get install chromium chromium-driver; "
                ".ci/install-browser)")
    return None


def chromium(profile: str | Path, width: int, height: int, script_timeout_s: float):
    """A new headless Chromium with a fresh profile folder and a window of width × height."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in (*FLAGS, f"--window-size={width},{height}", f"--user-data-dir={profile}"):
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    driver.set_script_timeout(script_timeout_s)
    return driver
