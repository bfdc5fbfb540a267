"""The sip-and-puff's live keys through a real browser (headless Chromium on the Meshcat page), as in
``test_live_browser.py`` (whose page fixture this uses; skipped without chromium, chromedriver or
selenium)."""

from __future__ import annotations

import numpy as np
import pytest
from test_live_browser import CHROMEDRIVER, CHROMIUM, KEYDOWN, _raw, _wait, page  # noqa: F401

from drake_disamb.interfaces import INTERFACES

pytestmark = pytest.mark.skipif(
    CHROMIUM is None or CHROMEDRIVER is None, reason="needs chromium and chromedriver"
)


def test_sip_and_puff_keys_reach_the_raw_pressure(page) -> None:  # noqa: ANN001, F811
    meshcat, driver, system = page("sip_and_puff")
    labels = {c.keycode: c.label for c in INTERFACES["sip_and_puff"].live_controls}
    driver.execute_script(KEYDOWN, "ArrowLeft", False)  # a soft sip: one pulse of -0.4
    _wait(lambda: meshcat.GetButtonClicks(labels["ArrowLeft"]) == 1, "the soft sip was not counted", 10.0)
    np.testing.assert_allclose(_raw(system), [-0.4, 0, 0, 0])
    driver.execute_script(KEYDOWN, "ArrowUp", False)  # a hard puff, held by the key's repeats
    for _ in range(4):
        driver.execute_script(KEYDOWN, "ArrowUp", True)
    _wait(lambda: meshcat.GetButtonClicks(labels["ArrowUp"]) >= 5, "the hard puff was not counted", 10.0)
    np.testing.assert_allclose(_raw(system), [1, 0, 0, 0])  # the soft sip waits for the breath to end
    driver.execute_script(KEYDOWN, "Space", False)  # the request switch, beside the breath
    _wait(lambda: meshcat.GetButtonClicks(labels["Space"]) == 1, "the request was not counted", 10.0)
    np.testing.assert_allclose(_raw(system), [1, 0, 0, 1])
    driver.execute_script(KEYDOWN, "ArrowDown", False)  # a hard sip opens the puff at once
    _wait(lambda: meshcat.GetButtonClicks(labels["ArrowDown"]) == 1, "the hard sip was not counted", 10.0)
    np.testing.assert_allclose(_raw(system), [-1, 0, 0, 1])
