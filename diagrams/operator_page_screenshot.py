"""Screenshot of the operator page in headless Chromium, after the robot chose a mode.

Runs a reaching trial with the head array (the disambiguation paradigm, the study's request
latency of 2.5 s) at real time with Meshcat and the operator page open in headless Chromium
(Debian's ``chromium`` and ``chromium-driver``; the ``selenium`` package of the test extra), driven
from the page as a person would: the Left key held for 2 s, then the request key. Once the panel
has said for a few seconds why the robot chose its mode (the scene then shows the cue of that
mode's motion), it saves a PNG of the page and prints the panel's text.

    python diagrams/operator_page_screenshot.py    # from the repository root: writes docs/operator_page.png

No network: Chromium is started with its background services off and an empty profile.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import threading
import time
from pathlib import Path

from recording_screenshot import CHROMIUM_FLAGS, chromium_paths

HOLD = 2.5
"""Seconds the panel's "why" line must have stayed before the picture is taken."""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("docs/operator_page.png"), help="PNG to write")
    parser.add_argument("--size", type=int, nargs=2, default=(1600, 900), help="the page's size in pixels")
    args = parser.parse_args(argv)
    chromium, driver_path = chromium_paths()
    if chromium is None or driver_path is None:
        print("needs the chromium and chromedriver executables (Debian: chromium-driver)", file=sys.stderr)
        return 1
    from pydrake.geometry import Meshcat, MeshcatParams
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.interfaces import InterfaceConfig
    from drake_disamb.interfaces.live import page_live_input
    from drake_disamb.operator_page.server import OperatorPage
    from drake_disamb.trial import run_trial

    scenario = load_scenario(
        "reaching",
        "{interface: head_array, duration: 90, initial_mode: 0, disambiguation: {request_latency: 2.5}}",
    )
    meshcat = Meshcat(MeshcatParams(host="localhost"))
    shot: list[str] = []
    with (
        OperatorPage("localhost", None, meshcat_port=meshcat.port()) as page,
        tempfile.TemporaryDirectory() as profile,
    ):
        source = page_live_input(page, InterfaceConfig(kind="head_array"))
        handles = build_shared_control_diagram(scenario, meshcat=meshcat, input_source=source, page=page)
        options = Options()
        for flag in (
            *CHROMIUM_FLAGS,
            f"--user-data-dir={profile}",
            f"--window-size={args.size[0]},{args.size[1]}",
        ):
            options.add_argument(flag)
        options.binary_location = chromium
        driver = webdriver.Chrome(service=Service(driver_path), options=options)
        driver.execute_cdp_cmd(
            "Emulation.setDeviceMetricsOverride",
            {"width": args.size[0], "height": args.size[1], "deviceScaleFactor": 1, "mobile": False},
        )

        def take() -> None:  # the browser, beside the simulation (Meshcat belongs to this thread)
            ActionChains(driver).key_down(Keys.ARROW_LEFT).pause(2.0).key_up(Keys.ARROW_LEFT).perform()
            ActionChains(driver).send_keys(Keys.SPACE).perform()
            deadline, since = time.monotonic() + 60.0, None
            while time.monotonic() < deadline:
                panel = page.message()["panel"]
                why = panel is not None and panel["status"]["kind"] == "why"
                since = (since or time.monotonic()) if why else None
                # once the line has stayed for HOLD s (the scene, drawn in software, lags a little)
                if since is not None and time.monotonic() - since >= HOLD:
                    args.out.parent.mkdir(parents=True, exist_ok=True)
                    driver.save_screenshot(str(args.out))
                    shot.append(driver.execute_script("return document.getElementById('panel').innerText"))
                    return
                time.sleep(0.1)

        try:
            driver.get(page.web_url())
            while page.GetNumActiveConnections() == 0 or meshcat.GetNumActiveConnections() == 0:
                time.sleep(0.1)
            time.sleep(2.0)
            taker = threading.Thread(target=take)
            taker.start()
            run_trial(handles, progress=False, realtime_rate=1.0, stop_requested=lambda: not taker.is_alive())
            taker.join()
        finally:
            driver.quit()
    if not shot:
        print("the panel never said why the robot chose a mode", file=sys.stderr)
        return 1
    print(f"wrote {args.out}")
    print(shot[0])
    return 0


if __name__ == "__main__":
    sys.exit(main())
