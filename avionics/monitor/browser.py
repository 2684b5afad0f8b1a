"""Headless Chromium for the monitor's browser tests, screenshots and frame-rate benchmark (selenium with
Debian's chromium and chromium-driver; nothing is downloaded). Loopback only; every background-networking
feature of Chromium is off."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--disable-dev-shm-usage", "--disable-features=Translate,MediaRouter,OptimizationHints",
                  "--no-default-browser-check", "--password-store=basic", "--hide-scrollbars")


def find_chromium() -> tuple[str | None, str | None]:
    """(chromium binary, chromedriver) or Nones."""
    browser = os.environ.get("CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
    driver = os.environ.get("CHROMEDRIVER") or shutil.which("chromedriver") or (
        "/usr/bin/chromedriver" if Path("/usr/bin/chromedriver").exists() else None)
    return browser, driver


def why_unavailable() -> str | None:
    """None when a headless browser can be started here; otherwise the reason (for a pytest skip)."""
    browser, driver = find_chromium()
    if browser is None:
        return "chromium not installed (Debian: apt-get install -y chromium chromium-driver; .ci/run does this)"
    if driver is None:
        return "chromedriver not installed (Debian: apt-get install -y chromium-driver)"
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium not installed (pip install '.[test]')"
    return None


class Browser:
    """One headless Chromium window with a fresh profile, driven by selenium."""

    def __init__(self, width: int = 1600, height: int = 1000):
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service

        browser, driver = find_chromium()
        self.profile = tempfile.mkdtemp(prefix="daa-chromium-")
        options = webdriver.ChromeOptions()
        options.binary_location = browser
        for flag in CHROMIUM_FLAGS:
            options.add_argument(flag)
        options.add_argument(f"--user-data-dir={self.profile}")
        options.add_argument(f"--window-size={width},{height}")
        self.driver = webdriver.Chrome(service=Service(executable_path=driver), options=options)
        self.driver.set_script_timeout(30)

    def open(self, url: str) -> None:
        self.driver.get(url)

    def js(self, script: str, *args):
        return self.driver.execute_script(script, *args)

    def screenshot(self, path: str | Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        self.driver.save_screenshot(str(path))
        return path

    def close(self) -> None:
        try:
            self.driver.quit()
        finally:
            shutil.rmtree(self.profile, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
