"""The web viewer in a real headless Chromium (Debian's chromium + chromedriver, driven by Selenium).

Against a live `physmind serve` on loopback: open the viewer on a seven-object world, check the
canvas draws, run simulate_edit from the form built from its JSON Schema, check the result and the
rollout it made appear, compare the two rollouts. Prints the first-paint time (not asserted).
`make install` installs the browser; a missing browser fails this test with the reason.
Set PHYSMIND_VIEWER_SCREENSHOT=path.png to keep a screenshot (the README's is made so).
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx
import pytest
from PIL import Image

from physmind.local_server import stop_process
from world.io import world_to_dict

REPO = Path(__file__).resolve().parents[2]
CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")
RED = (220, 50, 47)  # render/style.py COLOR_RGB["red"], body 0 of the seven-object world

# Pixels of a canvas that differ from its background, and those of one colour (returned as [painted, colour]).
COUNT_PIXELS_JS = """
const canvas = document.getElementById(arguments[0]);
const data = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
let painted = 0, colour = 0;
for (let i = 0; i < data.length; i += 4) {
  if (Math.abs(data[i] - 250) + Math.abs(data[i + 1] - 250) + Math.abs(data[i + 2] - 248) > 30) painted++;
  if (Math.abs(data[i] - arguments[1]) < 10 && Math.abs(data[i + 1] - arguments[2]) < 10 && Math.abs(data[i + 2] - arguments[3]) < 10) colour++;
}
return [painted, colour];
"""


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@pytest.fixture()
def live_server(tmp_path):
    port = _free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith("PHYSMIND_")}
    env["PHYSMIND_LOG_LEVEL"] = "WARNING"
    log = open(tmp_path / "server.log", "wb")
    process = subprocess.Popen([sys.executable, "-m", "physmind.cli", "serve", "--host", "127.0.0.1", "--port", str(port),
                                "--data-dir", str(tmp_path / "data")], cwd=REPO, env=env, stdout=log, stderr=subprocess.STDOUT)
    url = f"http://127.0.0.1:{port}"
    try:
        deadline = time.monotonic() + 60
        while True:
            try:
                if httpx.get(url + "/healthz", timeout=2).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            if time.monotonic() > deadline or process.poll() is not None:
                pytest.fail(f"the server did not start: {(tmp_path / 'server.log').read_text()[-2000:]}")
            time.sleep(0.2)
        yield url
    finally:
        stop_process(process)
        log.close()


def _chromium():
    missing = [str(p) for p in (CHROMIUM, CHROMEDRIVER) if not p.exists()]
    if missing:
        pytest.fail(f"browser test needs {', '.join(missing)}: run `make install` as root (it installs the Debian "
                    "packages chromium and chromium-driver) or `apt-get install -y chromium chromium-driver`")
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    options.binary_location = str(CHROMIUM)
    for argument in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage", "--window-size=1400,1300"):
        options.add_argument(argument)
    # An explicit driver path: Selenium uses the system chromedriver and never downloads one.
    return webdriver.Chrome(service=Service(executable_path=str(CHROMEDRIVER)), options=options)


@pytest.mark.slow
def test_viewer_in_headless_chromium_browser(live_server, seven_world):
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import Select, WebDriverWait

    started = time.perf_counter()
    created = httpx.post(live_server + "/v1/worlds", json={"world": world_to_dict(seven_world), "name": "seven objects"}, timeout=60)
    assert created.status_code == 201, created.text
    world_id = created.json()["world_id"]
    driver = _chromium()
    try:
        wait = WebDriverWait(driver, 60)
        driver.get(f"{live_server}/viewer/#world={world_id}")
        wait.until(lambda d: d.find_element(By.ID, "canvas").get_attribute("data-painted") == "1")
        first_paint_ms = driver.execute_script("return window.physmindTimings.firstWorldPaintMs")
        print(f"\nviewer first paint of the 7-object world: {first_paint_ms:.0f} ms after navigation start (loopback)")

        painted, red = driver.execute_script(COUNT_PIXELS_JS, "canvas", *RED)
        assert painted > 2000, f"the canvas is (nearly) blank: {painted} painted pixels"
        assert red > 30, "body 0 (red) is not drawn on the factual rollout"
        assert driver.find_element(By.CSS_SELECTOR, f'#world-list li[data-world-id="{world_id}"]').is_displayed()
        assert len(driver.find_elements(By.CSS_SELECTOR, "#objects tbody tr")) == 7
        timeline_painted, _ = driver.execute_script(COUNT_PIXELS_JS, "timeline", 0, 0, 0)
        assert timeline_painted > 200

        # simulate_edit from the form built from its JSON Schema.
        assert Select(driver.find_element(By.ID, "tool-select")).first_selected_option.text == "simulate_edit"
        Select(driver.find_element(By.ID, "arg-edit_type")).select_by_value("remove_object")
        driver.find_element(By.ID, "arg-object_id").send_keys("0")
        Select(driver.find_element(By.ID, "arg-trajectory_detail")).select_by_value("summary")
        driver.find_element(By.ID, "tool-run").click()
        wait.until(lambda d: d.find_element(By.ID, "tool-result").get_attribute("data-state") in ("ok", "error"))
        result_element = driver.find_element(By.ID, "tool-result")
        assert result_element.get_attribute("data-state") == "ok", result_element.text
        result = json.loads(result_element.text)
        rollout_id = result["rollout_id"]
        assert rollout_id.startswith("r-") and result["edit_manifest"]["applied"]["edit_type"] == "remove_object"
        wait.until(lambda d: d.find_element(By.ID, "tool-rollout").get_attribute("data-rollout-id") == rollout_id)
        assert Select(driver.find_element(By.ID, "rollout-select")).first_selected_option.text == rollout_id
        rollouts = httpx.get(f"{live_server}/v1/worlds/{world_id}/rollouts", timeout=30).json()["rollouts"]
        assert rollout_id in [r["rollout_id"] for r in rollouts]
        painted, red = driver.execute_script(COUNT_PIXELS_JS, "canvas", *RED)
        assert painted > 2000 and red == 0, f"the edited rollout (object 0 removed) should show no red body: {red} red pixels"

        # Compare view: the factual and the edited rollout side by side.
        driver.find_element(By.ID, "compare-run").click()
        wait.until(lambda d: "added collisions" in d.find_element(By.ID, "compare-summary").text)
        for canvas_id in ("compare-canvas-a", "compare-canvas-b"):
            assert driver.execute_script(COUNT_PIXELS_JS, canvas_id, 0, 0, 0)[0] > 1000
        screenshot = os.environ.get("PHYSMIND_VIEWER_SCREENSHOT")
        if screenshot:
            # The factual rollout mid-replay (trails, collision markers) for the README; 256 colours keep the file small.
            driver.set_window_size(1640, 1000)
            driver.execute_script("state.current = 'base'; state.frame = 45; document.getElementById('rollout-select').value = 'base';"
                                  "renderPlayer(); window.scrollTo(0, 0)")
            driver.save_screenshot(screenshot)
            Image.open(screenshot).convert("RGB").quantize(256).save(screenshot, optimize=True)
    finally:
        driver.quit()
    print(f"browser test: {time.perf_counter() - started:.1f} s (world upload, browser start, viewer, tool run, compare)")
