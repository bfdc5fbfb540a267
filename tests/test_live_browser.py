"""Live input through a real browser: Chromium (headless) on the Meshcat page sends key presses.

Needs the ``chromium`` and ``chromedriver`` executables (Debian's ``chromium`` and
``chromium-driver`` packages, which ``.ci/run`` installs where it can) and the ``selenium`` package
(in the ``test`` extra); the tests skip with a message where any of them is missing. They check
what the live interfaces rely on: the page turns every keydown, the browser's auto-repeats of a
held key included, into a button click, and the slider keys step the joystick axes.
"""

from __future__ import annotations

import shutil
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from support import screenshot_script

from drake_disamb.interfaces import INTERFACES, InterfaceConfig
from drake_disamb.interfaces.live import AXIS_SLIDERS, MeshcatLiveInput

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")

pytestmark = pytest.mark.skipif(
    CHROMIUM is None or CHROMEDRIVER is None, reason="needs chromium and chromedriver"
)

FIND_CONTROL = (
    "return Array.from(document.querySelectorAll('.dg .cr'))"  # rows of Meshcat's control panel
    ".some(row => row.textContent.includes(arguments[0]));"
)
KEYDOWN = (
    "document.dispatchEvent(new KeyboardEvent("
    "'keydown', {code: arguments[0], key: arguments[0], repeat: arguments[1], bubbles: true}));"
)


def _wait(condition: Callable[[], bool], what: str, timeout: float = 20.0) -> None:
    deadline = time.time() + timeout
    while not condition() and time.time() < deadline:
        time.sleep(0.05)
    assert condition(), what


@pytest.fixture
def page() -> Iterator[Callable[[str], tuple[Any, Any, MeshcatLiveInput]]]:
    """``open(kind)``: a Meshcat with a live input of ``kind``, shown in headless Chromium."""
    webdriver = pytest.importorskip("selenium.webdriver", reason="needs the selenium package")
    from pydrake.geometry import Meshcat, MeshcatParams
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    opened: list[tuple[Any, MeshcatLiveInput]] = []

    def open_page(kind: str) -> tuple[Any, Any, MeshcatLiveInput]:
        meshcat = Meshcat(MeshcatParams(host="localhost"))
        system = MeshcatLiveInput(meshcat, InterfaceConfig(kind=kind))
        options = Options()
        # No sandbox (CI runs as root); nothing in the background that would reach the network.
        for flag in screenshot_script().CHROMIUM_FLAGS:
            options.add_argument(flag)
        options.binary_location = CHROMIUM
        driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
        opened.append((driver, system))
        driver.get(meshcat.web_url())
        _wait(lambda: meshcat.GetNumActiveConnections() > 0, "the browser never connected")
        first = INTERFACES[kind].live_controls[-1].label  # every interface has the request button
        _wait(lambda: driver.execute_script(FIND_CONTROL, first), "the page never showed the controls")
        return meshcat, driver, system

    yield open_page
    for driver, system in opened:
        driver.quit()
        system.remove_controls()


def _raw(system: MeshcatLiveInput) -> np.ndarray:
    from pydrake.systems.analysis import Simulator

    simulator = Simulator(system)
    simulator.AdvanceTo(0.005)  # one update at t = 0 reads the page
    return np.asarray(system.get_output_port().Eval(simulator.get_context()))


def test_head_array_key_presses_and_repeats_reach_the_raw_signal(page) -> None:  # noqa: ANN001
    meshcat, driver, system = page("head_array")
    left = INTERFACES["head_array"].live_controls[0].label
    driver.execute_script(KEYDOWN, "ArrowLeft", False)
    for _ in range(4):  # what a held key sends after the auto-repeat delay
        driver.execute_script(KEYDOWN, "ArrowLeft", True)
    _wait(lambda: meshcat.GetButtonClicks(left) >= 5, "the key presses were not counted", 10.0)
    assert meshcat.GetButtonClicks(left) == 5
    np.testing.assert_array_equal(_raw(system), [1, 0, 0, 0])


def test_joystick_slider_keys_step_the_axes(page) -> None:  # noqa: ANN001
    meshcat, driver, system = page("joystick")
    (x_name, _, x_up), (y_name, y_down, _) = AXIS_SLIDERS
    driver.execute_script(KEYDOWN, x_up, False)  # D: axis x one step up
    driver.execute_script(KEYDOWN, y_down, False)  # S: axis y one step down
    driver.execute_script(KEYDOWN, y_down, False)
    _wait(lambda: meshcat.GetSliderValue(y_name) <= -0.5, "the slider keys did not move the sliders", 10.0)
    assert meshcat.GetSliderValue(x_name) == pytest.approx(0.25)
    np.testing.assert_allclose(_raw(system), [0.25, -0.5, 0.0, 0.0])
