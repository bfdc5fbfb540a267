"""The operator page in a real browser: headless Chromium, real key events (WebDriver's, as a
person's keyboard sends them) on the page the commands print.

- ``demo --live``: the panel names every goal with its probability and gives alpha as a
  percentage; holding a key moves the arm and the text follows; after the request key, within the
  request's latency plus 1 s, a line names the chosen mode and the goals it tells apart, and the
  scene shows the cue (screenshots before and after the request);
- ``study session``: a two-trial session and its questionnaire, done on the page; one record per
  trial and the answers in the folder; ``study report`` prints the questionnaire's table;
- ``demo --live --station lcm`` against ``mico-driver``: the page drives the simulated driver over
  LCM.

Needs ``chromium``, ``chromedriver`` and ``selenium`` (skipped with a message without them), as
``tests/test_live_browser.py``.
"""

from __future__ import annotations

import json
import re
import shutil
import signal
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from support import cli_process, screenshot_script, wait_for_line

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")

pytestmark = pytest.mark.skipif(
    CHROMIUM is None or CHROMEDRIVER is None, reason="needs chromium and chromedriver"
)

WINDOW = (1280, 800)
"""The browser's window (a laptop's screen)."""


def _wait(condition: Callable[[], Any], what: str, timeout: float = 30.0) -> Any:
    deadline = time.time() + timeout
    while time.time() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.1)
    raise AssertionError(what)


@pytest.fixture
def browser() -> Iterator[Any]:
    webdriver = pytest.importorskip("selenium.webdriver", reason="needs the selenium package")
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    options = Options()
    for flag in screenshot_script().CHROMIUM_FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--window-size={WINDOW[0]},{WINDOW[1]}")
    options.binary_location = CHROMIUM
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    yield driver
    driver.quit()


def _page_url(lines: list[str]) -> str:
    """The operator page's address: the line of its own after the line that names the page."""
    at = next(i for i, line in enumerate(lines) if line.startswith("operator page"))
    url = lines[at + 1].strip()
    assert re.fullmatch(r"http://localhost:\d+/", url), lines
    return url


def _open(driver: Any, url: str) -> None:
    driver.get(url)
    _wait(
        lambda: driver.execute_script("return !!(window.operatorPage && operatorPage.lastMessage)"),
        "the page never heard from its server",
        60,
    )


def _scene_drawn(driver: Any) -> None:
    """Wait until the page's scene (Meshcat in its iframe) holds the arm and the goals, and a
    moment for the browser to draw them."""
    from selenium.webdriver.common.by import By

    def drawn() -> bool:
        driver.switch_to.frame(driver.find_element(By.ID, "scene"))
        try:
            return driver.execute_script(
                "return typeof viewer !== 'undefined' && ['drake', 'shared_control']"
                ".every(k => k in viewer.scene_tree.children);"
            )
        finally:
            driver.switch_to.default_content()

    _wait(drawn, "the scene never arrived in its iframe", 60)
    time.sleep(1.0)


def _panel(driver: Any) -> dict[str, Any]:
    """The panel state the page shows now."""
    return driver.execute_script("return operatorPage.lastMessage && operatorPage.lastMessage.panel")


def _text(driver: Any) -> str:
    return driver.execute_script("return document.getElementById('panel').innerText")


def _hold(driver: Any, key: str, seconds: float) -> None:
    from selenium.webdriver.common.action_chains import ActionChains

    ActionChains(driver).key_down(key).pause(seconds).key_up(key).perform()


def _press(driver: Any, key: str) -> None:
    from selenium.webdriver.common.action_chains import ActionChains

    ActionChains(driver).send_keys(key).perform()


def _percentages(text: str, names: list[str]) -> list[int]:
    return [int(re.search(rf"{re.escape(name)}\s+(\d+) %", text).group(1)) for name in names]


def _stop(proc: Any) -> tuple[str, str]:
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    return out, err


def _trace_moved(record_dir: Path) -> float:
    """How far (m) the gripper of the folder's one recorded trial went from where it started."""
    (line,) = (record_dir / "trials.jsonl").read_text().splitlines()
    trial = json.loads(line)["trial_id"]
    with np.load(record_dir / "traces" / f"{trial}.npz") as trace:
        xyz = trace["ee_pose"][:, :3]
    return float(np.max(np.linalg.norm(xyz - xyz[0], axis=1)))


def test_the_page_says_what_the_robot_believes_and_why_it_chose_a_mode(browser: Any, tmp_path: Path) -> None:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    from drake_disamb.config import load_scenario

    latency = 1.5
    names = [g.name.replace("_", " ") for g in load_scenario("reaching").goals]
    record = tmp_path / "record"
    demo = cli_process(
        "demo", "--live", "--interface", "head_array", "--paradigm", "disambiguation", "--duration", "120",
        "--scenario-text", f"{{disambiguation: {{request_latency: {latency}}}, initial_mode: 0}}",
        "--quiet", "--out", str(tmp_path / "out"), "--record", str(record), "--subject", "T1",
    )  # fmt: skip
    try:
        url = _page_url(wait_for_line(demo, "running the trial", timeout=300))
        _open(browser, url)
        text = _wait(lambda: "%" in _text(browser) and _text(browser), "no panel on the page")
        for name in names:  # every goal, each with its probability in percent
            assert re.search(rf"{re.escape(name)}\s+\d+ %", text), (name, text)
        assert re.search(r"share of the motion\s+\d+ %", text, re.IGNORECASE)
        assert "move right/left (x)" in text and "\u2190" in text and "ask the robot to choose" in text
        before = _percentages(text, names)
        _scene_drawn(browser)
        browser.save_screenshot(str(tmp_path / "before_request.png"))
        _hold(browser, Keys.ARROW_LEFT, 2.5)  # the Left switch held: +x
        after = _percentages(_text(browser), names)
        assert after != before  # the belief moved with the arm, and the text with it
        _press(browser, Keys.SPACE)  # the request
        line = _wait(
            lambda: browser.execute_script(
                "const s = operatorPage.lastMessage.panel.status; return s.kind === 'why' && s.text"
            ),
            "no line says why the robot chose its mode",
            latency + 30.0,
        )
        seen = time.time()
        browser.switch_to.frame(browser.find_element(By.ID, "scene"))
        cue = browser.execute_script(
            "const n = viewer.scene_tree.find(['operator', 'cue']); let o = n.object, v = true;"
            "while (o) { v = v && o.visible; o = o.parent; } return v;"
        )
        browser.switch_to.default_content()
        assert cue, (
            f"the scene shows no cue of the new mode's motion ({time.time() - seen:.1f} s after the line)"
        )
        browser.save_screenshot(str(tmp_path / "after_request.png"))
        events = browser.execute_script("return operatorPage.events")
        pressed = max(e["wall"] for e in events if e["kind"] == "key" and e["code"] == "Space")
        shown = min(
            e["wall"]
            for e in events
            if e["kind"] == "status" and e["status"]["kind"] == "why" and e["wall"] > pressed
        )
        assert any(e["kind"] == "status" and e["status"]["kind"] == "choosing" for e in events)
        assert shown - pressed <= latency + 1.0, (shown - pressed, events[-5:])
        mode = _panel(browser)["mode"]["title"]
        assert line.startswith(f"The robot chose {mode}:"), (line, mode)
        assert sum(name in line for name in names) >= 1, line  # the goals it tells apart
        assert line in _text(browser)
    finally:
        out, err = _stop(demo)
    assert demo.returncode == 130, err
    assert _trace_moved(record) > 0.05  # 2.5 s at 0.1 m/s, less the start
    assert (tmp_path / "before_request.png").stat().st_size > 0 and (tmp_path / "after_request.png").is_file()


def test_a_session_and_its_questionnaire_done_at_the_page(browser: Any, tmp_path: Path) -> None:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys
    from selenium.webdriver.support.ui import Select
    from test_study_session import protocol_file

    out = tmp_path / "sessions"
    session = cli_process(
        "study",
        "session",
        "--subject",
        "P01",
        "--out",
        str(out),
        "--protocol",
        str(protocol_file(tmp_path, 6.0)),
    )
    try:
        _open(browser, _page_url(wait_for_line(session, "trial 1 of 2", timeout=300)))

        def screen_title() -> str:
            return browser.execute_script(
                "const s = document.getElementById('op-screen'); return s && !s.closest('[hidden]') && "
                "s.querySelector('h1').textContent"
            )

        assert _wait(screen_title, "no instructions").startswith("Trial 1 of 2: Head array, reaching")
        assert "Your goal: the" in browser.find_element(By.ID, "op-screen").text
        browser.save_screenshot(str(tmp_path / "instructions.png"))
        _press(browser, Keys.ENTER)  # the person is ready
        _wait(lambda: not screen_title(), "the trial did not start")
        _hold(browser, Keys.ARROW_LEFT, 1.0)
        title = _wait(
            lambda: (screen_title() or "").startswith("Trial 2") and screen_title(), "no second trial", 60
        )
        assert "Rest as long as you like" in browser.find_element(By.ID, "op-screen").text
        assert title.startswith("Trial 2 of 2: Head array, reaching")
        _press(browser, Keys.ENTER)
        _wait(lambda: not screen_title(), "the second trial did not start")
        time.sleep(1.0)
        _press(browser, Keys.ESCAPE)  # the experimenter ends it
        _wait(lambda: screen_title() == "Questionnaire", "no questionnaire", 60)
        selects = browser.find_elements(By.CSS_SELECTOR, "#op-survey select")
        names = [f"Q{k}|head_array/reaching" for k in (1, 2, 3)] + ["Q4", "Q5", "Q6", "Q7"]
        assert [s.get_attribute("name") for s in selects] == names
        for select, value in zip(
            selects, ["5", "6", "4", "head_array", "head_array", "disambiguation"], strict=False
        ):
            Select(select).select_by_value(value)
        browser.find_element(By.ID, "op-go").click()  # Q7 unanswered: the page says so, keeps the rest
        _wait(
            lambda: "Q7: choose one of" in browser.find_element(By.ID, "op-screen-error").text, "no error", 30
        )
        assert Select(selects[1]).first_selected_option.get_attribute("value") == "6"
        Select(selects[6]).select_by_value("manual")
        browser.save_screenshot(str(tmp_path / "questionnaire.png"))
        browser.find_element(By.ID, "op-go").click()
        _wait(lambda: screen_title() == "Thank you!", "the session did not end", 60)
        stdout, err = session.communicate(timeout=60)
    finally:
        if session.poll() is None:
            session.kill()
    assert session.returncode == 0, err
    records = [json.loads(line) for line in (out / "trials.jsonl").read_text().splitlines()]
    assert [r["trial_id"] for r in records] == [
        "P01-head_array-reaching-manual-r0",
        "P01-head_array-reaching-disambiguation-r0",
    ]
    assert all(r["source"] == "human" for r in records)
    assert (
        records[0]["extra"]["ended_by"] == "time limit" and records[1]["extra"]["ended_by"] == "experimenter"
    )
    survey = json.loads((out / "surveys.jsonl").read_text())
    assert survey["ratings"]["Q2"] == {"head_array/reaching": 6} and survey["preferences"]["Q7"] == "manual"
    report = cli_process("study", "report", str(out), "--no-mixed-model")
    printed, err = report.communicate(timeout=300)
    assert report.returncode == 0, err
    assert "Questionnaire" in printed and "6.19 \u00b1 0.75" in printed and "disambiguation/manual" in printed


def test_the_page_drives_the_simulated_driver_over_lcm(browser: Any, tmp_path: Path) -> None:
    from selenium.webdriver.common.keys import Keys
    from test_station_lcm import multicast_url

    url = multicast_url(7695)
    driver = cli_process("mico-driver", "--lcm-url", url, "--duration", "300")
    record = tmp_path / "record"
    demo = None
    try:
        wait_for_line(driver, "mico-driver:", timeout=120)
        demo = cli_process(
            "demo", "--live", "--interface", "sip_and_puff", "--duration", "120", "--scenario-text",
            f"{{initial_mode: 2, station: !Lcm {{lcm_url: '{url}', status_timeout: 0.25}}}}",
            "--quiet", "--out", str(tmp_path / "out"), "--record", str(record), "--subject", "T1",
        )  # fmt: skip
        _open(browser, _page_url(wait_for_line(demo, "running the trial", timeout=300)))
        text = _wait(lambda: "%" in _text(browser) and _text(browser), "no panel on the page")
        assert "move up/down (z)" in text and "move up (+z) (hold)" in text  # the hard puff, now
        _hold(browser, Keys.ARROW_UP, 2.5)
        browser.save_screenshot(str(tmp_path / "lcm.png"))
    finally:
        out, err = _stop(demo) if demo is not None else ("", "")
        driver.send_signal(signal.SIGINT)
        driver.communicate(timeout=60)
    assert demo is not None and demo.returncode == 130, err
    assert "station fault" not in err
    assert _trace_moved(record) > 0.05


@pytest.mark.slow
def test_the_latency_benchmark_measures_the_page() -> None:
    """``benchmarks/bench_page_latency.py`` measures every state the page drew: drawn after it
    arrived, which is after it was published."""
    from support import benchmark_module

    pytest.importorskip("selenium.webdriver", reason="needs the selenium package")
    with benchmark_module("bench_page_latency") as bench:
        delays, rate = bench.measure(4.0)
    assert delays.ndim == 2 and delays.shape[1] == 2 and len(delays) >= 10
    shown, arrived = delays[:, 0], delays[:, 1]
    assert np.all(np.isfinite(delays)) and np.all(arrived > -0.005) and np.all(shown >= arrived)
    assert 0.5 < rate < 1.5  # at real time
