"""How long a change in the diagram takes to show on the operator page, at real time.

A simulated head-array user reaches (the disambiguation paradigm, requests answered 0.5 s later)
at real time, with Meshcat and the operator page, while headless Chromium shows the page. Every
panel state carries the wall time at which the diagram published it (``wall``); the page notes
when each arrived and when it drew it (the animation frame after its arrival), on the same clock
(``performance.timeOrigin + performance.now()``). Printed: the publish-to-screen delay's median,
99th percentile and largest over every state the page drew (and the part of it to the page's
receipt), and the bound from the change itself: a change waits at most one publish period
(``PanelVisualizer``'s 20 ms) for the next state. The target: under 100 ms at the 99th
percentile. Chromium renders the scene in software (no GPU), as on a machine without a graphics
card, the heavier case.

Usage: ``python benchmarks/bench_page_latency.py [--seconds 20]`` (needs ``chromium``,
``chromedriver`` and ``selenium``).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from pathlib import Path

import numpy as np
from _host import HostMeter, host_summary

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "diagrams"))
from recording_screenshot import CHROMIUM_FLAGS  # noqa: E402 (the flags every headless page here uses)

PUBLISH_PERIOD = 0.02
"""The panel's publish period (s): the longest a change waits for the next panel state."""

TARGET = 0.1
"""The target (s) for the 99th percentile."""


def browser():  # noqa: ANN201 (a selenium WebDriver)
    """Headless Chromium, or exit with a message when it cannot run."""
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.options import Options
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        sys.exit("needs the selenium package (pip install selenium)")
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    driver_path = shutil.which("chromedriver")
    if chromium is None or driver_path is None:
        sys.exit("needs chromium and chromedriver")
    options = Options()
    for flag in (*CHROMIUM_FLAGS, "--window-size=1280,800"):
        options.add_argument(flag)
    options.binary_location = chromium
    return webdriver.Chrome(service=Service(driver_path), options=options)


def measure(seconds: float) -> tuple[np.ndarray, float]:
    """``(delays s, real-time rate)``: per state the page drew while ``seconds`` of a trial ran at
    real time, the delay from its publish to the page's drawing it and to its arrival (``(n, 2)``)."""
    from pydrake.geometry import Meshcat, MeshcatParams

    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.operator_page.server import OperatorPage
    from drake_disamb.trial import run_trial

    scenario = load_scenario(
        "reaching",
        f"{{interface: head_array, paradigm: disambiguation, duration: {seconds:g}, "
        "disambiguation: {request_latency: 0.5}}",
    )
    meshcat = Meshcat(MeshcatParams(host="localhost"))
    with OperatorPage("localhost", None, meshcat_port=meshcat.port()) as page:
        handles = build_shared_control_diagram(scenario, meshcat=meshcat, page=page)
        run_trial(build_shared_control_diagram(scenario), progress=False)  # the kernels loaded first
        driver = browser()
        try:
            driver.get(page.web_url())
            deadline = time.monotonic() + 60.0
            while page.GetNumActiveConnections() == 0 or meshcat.GetNumActiveConnections() == 0:
                if time.monotonic() > deadline:
                    sys.exit("the browser never opened the page")
                time.sleep(0.1)
            time.sleep(2.0)  # the scene drawn
            start = time.perf_counter()
            result = run_trial(handles, progress=False, realtime_rate=1.0, stop_at_success=False)
            wall = time.perf_counter() - start
            time.sleep(0.5)  # the last states drawn
            received = driver.execute_script("return operatorPage.received")
        finally:
            driver.quit()
    delays = np.array([[shown - sent, arrived - sent] for _, sent, shown, arrived in received], dtype=float)
    return delays, result.time / wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="seconds of trial (default: 20)")
    args = parser.parse_args()
    print(f"operator page latency: {args.seconds:g} s of a trial at real time; {host_summary()}")
    with HostMeter() as host:
        delays, rate = measure(args.seconds)
    if delays.size == 0:
        sys.exit("the page drew no panel state")
    ms, arrival = 1000.0 * delays[:, 0], 1000.0 * delays[:, 1]
    p50, p99 = np.percentile(ms, [50, 99])
    print(
        f"publish to screen: {len(ms)} states drawn, p50 {p50:.1f} ms, p99 {p99:.1f} ms, "
        f"largest {ms.max():.1f} ms (of which to the page's receipt: p50 {np.median(arrival):.1f} ms, "
        f"p99 {np.percentile(arrival, 99):.1f} ms); real-time rate {rate:.2f}; {host.describe()}"
    )
    bound = 1000.0 * PUBLISH_PERIOD
    print(
        f"change to screen (at most one publish period, {bound:.0f} ms, more): p50 <= {p50 + bound:.1f} ms, "
        f"p99 <= {p99 + bound:.1f} ms; target p99 < {1000 * TARGET:.0f} ms: "
        f"{'met' if p99 + bound < 1000 * TARGET else 'NOT met'}"
    )


if __name__ == "__main__":
    main()
