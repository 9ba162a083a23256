"""Open an HTML report in headless Chromium (Debian's chromium + chromium-driver) and check it.

Used by the report's browser test. Offline: no network flags, the system driver, software WebGL
(SwiftShader) so the 3-D view draws without a GPU.
"""

from __future__ import annotations

import base64
import io
import math
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"


def browser_available() -> bool:
    try:
        import selenium  # noqa: F401
    except ImportError:
        return False
    return Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()


@dataclass(frozen=True)
class BrowserCheck:
    errors: list[str]  # SEVERE console entries (uncaught exceptions, failed scripts)
    tables: int  # sortable tables found
    plots: int  # plotly graph divs found
    drawn_pixels: int  # non-background pixels of the first 3-D view, rendered through WebGL
    sorted_ok: bool  # a click on a numeric header sorted that column
    headline: str  # the text of the first headline sentence ("" when the page has none)
    table_fits: bool  # the first leaderboard table needs no horizontal scroll in its container
    page_fits: bool  # the page itself needs no horizontal scroll at the window's width


def check_report(path: Path, timeout_s: float = 60.0) -> BrowserCheck:
    from PIL import Image
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.by import By

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for argument in (
        "--headless=new",
        "--no-sandbox",  # CI runs as root
        "--enable-unsafe-swiftshader",  # software WebGL: no GPU here
        "--use-angle=swiftshader",
        "--ignore-gpu-blocklist",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        "--window-size=1400,1000",
    ):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    try:
        driver.set_script_timeout(timeout_s)
        driver.get(Path(path).resolve().as_uri())
        tables = driver.find_elements(By.CSS_SELECTOR, "table.sortable")
        plots = driver.find_elements(By.CSS_SELECTOR, "div.plotly-graph-div")
        drawn = 0
        scene_ready = bool(plots) and driver.execute_script(
            "var gd = document.querySelector('div.plotly-graph-div');"
            "return !!(gd && gd._fullLayout && gd._fullLayout.scene && gd.querySelector('canvas'));"
        )
        if scene_ready:
            # Plotly.toImage redraws the WebGL scene and reads its pixels: blank if WebGL failed.
            url = driver.execute_async_script(
                "var done = arguments[arguments.length - 1];"
                "try { Plotly.toImage(document.querySelector('div.plotly-graph-div'),"
                " {format: 'png', width: 600, height: 400}).then(done, function (e) { done('error:' + e); }); }"
                " catch (e) { done('error:' + e); }"
            )
            if isinstance(url, str) and url.startswith("data:image/png;base64,"):
                image = Image.open(io.BytesIO(base64.b64decode(url.split(",", 1)[1]))).convert("RGB")
                # numpy, not Image.getdata/get_flattened_data: the count works on every Pillow.
                pixels = np.asarray(image)
                drawn = int((pixels != pixels[0, 0]).any(axis=-1).sum())
        headline, table_fits, page_fits = driver.execute_script(
            "var p = document.querySelector('p.headline');"
            "var t = document.querySelector('#leaderboards table');"
            "var box = t ? t.parentElement : null;"
            "var root = document.documentElement;"
            "return [p ? p.textContent : '', !!box && box.scrollWidth <= box.clientWidth,"
            " root.scrollWidth <= root.clientWidth];"
        )
        sorted_ok = _sorting_works(driver, By) if tables else False
        errors = [entry["message"] for entry in driver.get_log("browser") if entry["level"] == "SEVERE"]
        return BrowserCheck(errors, len(tables), len(plots), drawn, sorted_ok, headline, table_fits, page_fits)
    finally:
        driver.quit()


def _sorting_works(driver, by) -> bool:
    """Click the first numeric column with distinct values twice: ascending, then descending."""
    for table in driver.find_elements(by.CSS_SELECTOR, "table.sortable"):
        result = _sort_table(driver, by, table)
        if result is not None:
            return result
    return False


def _sort_table(driver, by, table) -> bool | None:
    headers = table.find_elements(by.TAG_NAME, "th")
    for column, header in enumerate(headers):
        values = driver.execute_script(
            "return Array.from(arguments[0].tBodies[0].rows).map(r => parseFloat(r.cells[arguments[1]].textContent));",
            table,
            column,
        )
        if len(values) < 2 or any(v is None or math.isnan(v) for v in values) or len(set(values)) < 2:
            continue
        header.click()
        ascending = driver.execute_script(
            "return Array.from(arguments[0].tBodies[0].rows).map(r => parseFloat(r.cells[arguments[1]].textContent));",
            table,
            column,
        )
        header.click()
        descending = driver.execute_script(
            "return Array.from(arguments[0].tBodies[0].rows).map(r => parseFloat(r.cells[arguments[1]].textContent));",
            table,
            column,
        )
        return ascending == sorted(values) and descending == sorted(values, reverse=True)
    return None
