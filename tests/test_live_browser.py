"""Live input through a real browser: Chromium (headless) on the Meshcat page sends key presses.

Needs the ``chromium`` and ``chromedriver`` executables and the ``selenium`` package, which the
project does not install; the test skips with a message where any of them is missing. It checks
what the head-array switches rely on: the page turns every keydown, the browser's auto-repeats of
a held key included, into a button click.
"""

from __future__ import annotations

import shutil
import time

import numpy as np
import pytest

from drake_disamb.core.interfaces import InterfaceConfig
from drake_disamb.systems.live import LIVE_CONTROLS, MeshcatLiveInput

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")


@pytest.mark.skipif(CHROMIUM is None or CHROMEDRIVER is None, reason="needs chromium and chromedriver")
def test_key_presses_and_repeats_in_a_browser_reach_the_raw_signal() -> None:
    webdriver = pytest.importorskip("selenium.webdriver", reason="needs the selenium package")
    from pydrake.geometry import Meshcat, MeshcatParams
    from pydrake.systems.analysis import Simulator
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    meshcat = Meshcat(MeshcatParams(host="localhost"))
    system = MeshcatLiveInput(meshcat, InterfaceConfig(kind="head_array"))
    left = LIVE_CONTROLS["head_array"][0][0]
    options = Options()
    for flag in ("--headless=new", "--no-sandbox"):
        options.add_argument(flag)
    options.binary_location = CHROMIUM
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    try:
        driver.get(meshcat.web_url())
        deadline = time.time() + 20
        while meshcat.GetNumActiveConnections() == 0 and time.time() < deadline:
            time.sleep(0.1)
        assert meshcat.GetNumActiveConnections() > 0, "the browser never connected"
        find = (
            "return Array.from(document.querySelectorAll('.dg .function'))"  # Meshcat's control panel
            ".some(b => b.textContent === arguments[0]);"
        )
        deadline = time.time() + 20
        while not driver.execute_script(find, left) and time.time() < deadline:  # the page builds it
            time.sleep(0.1)
        assert driver.execute_script(find, left), "the page never showed the Left button"
        press = (
            "document.dispatchEvent(new KeyboardEvent("
            "'keydown', {code: 'ArrowLeft', key: 'ArrowLeft', repeat: %s, bubbles: true}));"
        )
        driver.execute_script(press % "false")
        for _ in range(4):  # what a held key sends after the auto-repeat delay
            driver.execute_script(press % "true")
        deadline = time.time() + 10
        while meshcat.GetButtonClicks(left) < 5 and time.time() < deadline:
            time.sleep(0.05)
        assert meshcat.GetButtonClicks(left) == 5
        simulator = Simulator(system)
        simulator.AdvanceTo(0.005)
        np.testing.assert_array_equal(system.get_output_port().Eval(simulator.get_context()), [1, 0, 0, 0])
    finally:
        driver.quit()
        system.remove_controls()
