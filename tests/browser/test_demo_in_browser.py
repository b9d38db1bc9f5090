"""An instructor demo in a real browser: JupyterLab on a loopback port, headless Chromium (Debian's, driven
by Playwright: no browser download), the gain-tuning notebook run, a slider moved from the keyboard, and the
plot shown to change. A screenshot goes to build/browser-test/."""

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pendkit.link.broker import free_port, wait_for_port
from tests.system_needs import skip_unless

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
SHOTS = ROOT / "build" / "browser-test"
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync"]


@pytest.fixture(scope="module")
def jupyterlab():
    skip_unless("chromium")
    pytest.importorskip("playwright")
    port, token = free_port(), "pendkit-browser-test"
    environment = {**os.environ, "PENDKIT_MODE": "interactive", "MPLBACKEND": "Agg"}
    server = subprocess.Popen([sys.executable, "-m", "jupyter", "lab", "--no-browser", f"--port={port}",
                               "--ServerApp.ip=127.0.0.1", f"--IdentityProvider.token={token}",
                               f"--ServerApp.root_dir={ROOT / 'docs' / 'demos'}", "--ServerApp.allow_root=True"],
                              env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        assert wait_for_port("127.0.0.1", port, 60), "JupyterLab did not start"
        yield f"http://127.0.0.1:{port}", token
    finally:
        server.terminate()
        server.wait(timeout=20)


def test_moving_a_slider_changes_the_plot(jupyterlab):
    from playwright.sync_api import sync_playwright

    url, token = jupyterlab
    SHOTS.mkdir(parents=True, exist_ok=True)
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1300, "height": 1100})
        page.goto(f"{url}/lab/tree/02_lqr_tuning.ipynb?token={token}")
        page.wait_for_selector(".jp-Notebook .jp-Cell", timeout=90_000)
        page.wait_for_selector("text=| Idle", timeout=90_000)  # the kernel is up and ready
        page.click(".jp-Notebook .jp-Cell >> nth=1")  # the code cell
        page.keyboard.press("Shift+Enter")
        slider = page.wait_for_selector(".widget-slider .noUi-handle >> nth=2", state="attached",
                                        timeout=120_000)  # the energy gain
        image = page.wait_for_selector(".widget-image", timeout=60_000)
        before = image.get_attribute("src")
        page.screenshot(path=str(SHOTS / "before.png"), full_page=True)
        slider.focus()
        for _ in range(5):
            page.keyboard.press("ArrowRight")  # keyboard-only: the widgets must work without a mouse
        deadline = time.monotonic() + 120
        after = before
        while after == before and time.monotonic() < deadline:
            time.sleep(0.5)
            after = page.query_selector(".widget-image").get_attribute("src")
        page.screenshot(path=str(SHOTS / "after.png"), full_page=True)
        value = page.inner_text(".widget-slider .widget-readout >> nth=2")
        browser.close()
    assert after != before, "the plot did not change after the slider moved"
    assert float(value) > 1.0  # the energy gain went up from 1.0
    print(f"screenshots: {SHOTS / 'before.png'}, {SHOTS / 'after.png'}")
