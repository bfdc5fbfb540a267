"""The operator page without a browser: what the panel says (goals, mode, keys, why a mode), the
page's server (keys in, panel states out, what it refuses), and the panel of a simulated trial, on
the page and kept in its recording."""

from __future__ import annotations

import json
import time
import urllib.error
import urllib.request
from typing import Any

import numpy as np
import pytest

from drake_disamb.core.disambiguation import DEFAULT_CONFIG, Algorithm1, make_request
from drake_disamb.core.disambiguation.told_apart import told_apart
from drake_disamb.interfaces import INTERFACES
from drake_disamb.interfaces.live import AXIS_SLIDERS
from drake_disamb.operator_page import server as page_server
from drake_disamb.operator_page.model import (
    goal_rows,
    key_actions,
    leading_goal,
    mode_title,
    motion_words,
    why_line,
)
from drake_disamb.operator_page.server import OperatorPage

# -- what the panel says ------------------------------------------------------------------------------


def _two_goals_on_x() -> Any:
    """A request whose goals lie to the right (+x) and to the left (-x) of the gripper, a third far
    above: moving along x tells the first two apart."""
    goals = np.array([[0.25, 0.0, 0.0], [-0.25, 0.0, 0.0], [0.0, 0.0, 0.6]])
    modes = ((0,), (1,), (2,))
    return make_request(np.full(3, 1 / 3), np.zeros(3), goals, modes, DEFAULT_CONFIG, current_mode=1)


def test_the_why_line_names_the_mode_and_the_goals_its_motion_leads_toward() -> None:
    request = _two_goals_on_x()
    result = Algorithm1().select(request)
    told = told_apart(request, result)
    line = why_line(told, request.modes, result.mode, ["red_box", "green_can", "blue_tower"], automatic=False)
    assert line.startswith("The robot chose move right/left (x)")
    assert (
        "move right (+x) leads toward the red box" in line and "move left (-x) toward the green can" in line
    )
    by_itself = why_line(told, request.modes, result.mode, ["a", "b", "c"], automatic=True)
    assert by_itself.startswith("The robot switched by itself to move right/left (x)")
    kept = make_request(
        np.full(3, 1 / 3), np.zeros(3), request.goal_positions, request.modes, DEFAULT_CONFIG, current_mode=0
    )
    kept_result = Algorithm1().select(kept)
    line = why_line(told_apart(kept, kept_result), kept.modes, None, ["a", "b", "c"], automatic=False)
    assert line.startswith("The robot kept move right/left (x): no mode tells the goals apart better")
    assert why_line(None, kept.modes, None, ["a", "b", "c"], automatic=False).startswith(
        "The robot kept your mode"
    )


def test_each_key_says_what_it_does_in_the_current_mode() -> None:
    head = INTERFACES["head_array"]
    modes = head.modes
    rows = key_actions(head, modes, 2, requests_served=True)
    assert [(r.keys, r.action) for r in rows] == [
        ("\u2190", "move up (+z) (hold)"),
        ("\u2192", "move down (-z) (hold)"),
        ("\u2193", f"next mode: {mode_title(modes[3])}"),
        ("Space", "ask the robot to choose the mode that helps it most"),
        ("gamepad", "the D-pad works as the arrow keys, button A (0) as Space"),
    ]
    gripper = key_actions(head, modes, len(modes) - 1, requests_served=False)
    assert gripper[0].action == "open the gripper (hold)" and gripper[1].action == "close the gripper (hold)"
    assert gripper[2].action == f"next mode: {mode_title(modes[0])}"  # the cycle wraps
    assert "logged only" in gripper[3].action
    sip = key_actions(INTERFACES["sip_and_puff"], INTERFACES["sip_and_puff"].modes, 0)
    assert [r.keys for r in sip] == ["\u2191", "\u2193", "\u2192", "\u2190", "Space", "gamepad"]
    assert sip[3].action == f"previous mode: {mode_title(INTERFACES['sip_and_puff'].modes[-1])}"
    stick = INTERFACES["joystick"]
    rows = key_actions(stick, stick.modes, 0, AXIS_SLIDERS, mode_selection="direct")
    assert rows[0].keys == "A / D" and rows[0].action == "move left (-x) / move right (+x)"
    assert rows[1].keys == "S / W" and rows[1].action == "move toward you (-y) / move away from you (+y)"
    assert rows[2].action == "centre the axes (stop)"
    assert rows[3].keys == "M" and rows[3].action.startswith("select the mode the axes point at")
    assert rows[-1].keys == "gamepad"
    one_axis = key_actions(stick, stick.modes, 3, AXIS_SLIDERS)  # {wy}: the second axis is idle
    assert one_axis[1].action == "not used in this mode"
    assert motion_words(5, -1) == "rotate about z (-)"


def test_every_goal_gets_a_percentage_and_the_guess_needs_a_lead() -> None:
    rows = goal_rows([0.5, 0.3, 0.2], ["red_box", "green_can", "blue_tower"], ["#a", "#b", "#c"])
    assert [(r["name"], r["percent"], r["leading"]) for r in rows] == [
        ("red box", 50, True),
        ("green can", 30, False),
        ("blue tower", 20, False),
    ]
    assert leading_goal([0.34, 0.33, 0.33]) is None  # nothing stands out
    assert leading_goal([0.2, 0.45, 0.35]) == 1
    assert leading_goal([np.nan, 0.5, 0.5]) is None
    assert goal_rows([np.nan, 1.0], ["a", "b"], ["#a", "#b"])[0]["percent"] == 0


def test_the_pages_scripts_parse(tmp_path: Any) -> None:
    """The page's script, and the recording's replay around it, are JavaScript that parses."""
    import shutil
    import subprocess

    from drake_disamb.operator_page.replay import add_panel_replay
    from drake_disamb.operator_page.server import asset_text

    node = shutil.which("node")
    if node is None:
        pytest.skip("needs node (Node.js) to parse the page's JavaScript")
    page = add_panel_replay("<html><body></body></html>", [{"t": 0.0, "title": "</script>"}])
    replay = page.split("<script>")[-1].split("</script>")[0]
    for name, text in (("panel.js", asset_text("panel.js")), ("replay.js", replay)):
        (tmp_path / name).write_text(text)
        checked = subprocess.run([node, "--check", str(tmp_path / name)], capture_output=True, text=True)
        assert checked.returncode == 0, (name, checked.stderr)
    assert "<\\/script>" in page  # the log cannot end its script element


# -- the page's server ----------------------------------------------------------------------------------


def _post(page: OperatorPage, body: dict[str, Any], headers: dict[str, str] | None = None) -> int:
    data = json.dumps({"page": "p1", **body}).encode()
    request = urllib.request.Request(
        page.web_url() + "input", data, {"Content-Type": "application/json", **(headers or {})}
    )
    try:
        return urllib.request.urlopen(request, timeout=5).status
    except urllib.error.HTTPError as exc:
        return exc.code


@pytest.fixture
def page() -> Any:
    with OperatorPage("localhost", None) as served:
        served.AddButton("Left", "ArrowLeft")
        served.AddButton("Request", "Space")
        served.AddSlider("Axis x", -1.0, 1.0, 0.25, 0.0, "KeyA", "KeyD")
        served.repeat_while_held(["ArrowLeft"])
        yield served


def test_keys_are_clicks_and_a_held_drive_key_repeats_until_released(
    page: OperatorPage, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert page.GetNumActiveConnections() == 0
    assert _post(page, {"type": "alive", "gamepad": None}) == 204
    assert page.GetNumActiveConnections() == 1
    assert _post(page, {"type": "down", "code": "Space"}) == 204
    assert _post(page, {"type": "down", "code": "Space"}) == 204  # another press (the page drops repeats)
    assert page.GetButtonClicks("Request") == 2
    assert _post(page, {"type": "down", "code": "KeyD"}) == 204
    assert page.GetSliderValue("Axis x") == 0.25
    assert _post(page, {"type": "down", "code": "ArrowLeft"}) == 204
    assert page.GetButtonClicks("Left") == 1
    held_from = time.monotonic()
    while time.monotonic() - held_from < 3 * page_server.HOLD_REPEAT + 0.05:
        _post(page, {"type": "alive"})  # the heartbeat keeps the page (and its held key)
        time.sleep(0.05)
    assert page.GetButtonClicks("Left") >= 4  # the press and a repeat every HOLD_REPEAT s
    assert _post(page, {"type": "up", "code": "ArrowLeft"}) == 204
    released = page.GetButtonClicks("Left")
    time.sleep(2 * page_server.HOLD_REPEAT)
    assert page.GetButtonClicks("Left") == released  # no repeat once released
    # A page that loses the focus lets go of its keys; one whose heartbeat stops is gone.
    assert _post(page, {"type": "down", "code": "ArrowLeft"}) == 204
    assert _post(page, {"type": "release"}) == 204
    time.sleep(2 * page_server.HOLD_REPEAT)
    assert page.GetButtonClicks("Left") == released + 1
    assert _post(page, {"type": "down", "code": "ArrowLeft"}) == 204
    time.sleep(page_server.PAGE_STALE + 0.1)
    assert page.GetNumActiveConnections() == 0
    stale = page.GetButtonClicks("Left")
    time.sleep(2 * page_server.HOLD_REPEAT)
    assert page.GetButtonClicks("Left") == stale  # released as of its last heartbeat
    page.reset_controls()
    assert page.GetButtonClicks("Left") == 0 and page.GetSliderValue("Axis x") == 0.0


def test_the_gamepad_is_the_pages_and_goes_with_it(page: OperatorPage) -> None:
    pad = {"index": 0, "axes": [0.5, -2.0, "x"], "button_values": [1.0, 0.0]}
    assert _post(page, {"type": "alive", "gamepad": pad}) == 204
    got = page.GetGamepad()
    assert got.index == 0 and got.axes == (0.5, -1.0, 0.0) and got.button_values == (1.0, 0.0)
    time.sleep(page_server.PAGE_STALE + 0.1)
    assert page.GetGamepad().index is None


def test_the_page_refuses_what_it_does_not_send(page: OperatorPage) -> None:
    assert _post(page, {"type": "down", "code": "Space"}, {"Origin": "http://evil.example"}) == 403
    assert _post(page, {"type": "launch"}) == 400
    assert _post(page, {"type": "down", "code": ""}) == 400
    assert _post(page, {"type": "action", "name": "start"}) == 400  # no such action bound now
    data = json.dumps({"page": "p1", "type": "down", "code": "Space"}).encode()
    form = urllib.request.Request(page.web_url() + "input", data, {"Content-Type": "text/plain"})
    with pytest.raises(urllib.error.HTTPError, match="415"):
        urllib.request.urlopen(form, timeout=5)
    assert page.GetButtonClicks("Request") == 0


def test_the_page_streams_the_panel_and_the_screens_actions(page: OperatorPage) -> None:
    html = urllib.request.urlopen(page.web_url(), timeout=5).read().decode()
    assert '<script src="panel.js"></script>' in html and "{{" not in html
    page.set_screen({"id": "s", "kind": "message", "title": "Trial 1"}, {"Enter": "start"})
    page.show({"t": 0.0, "wall": 1.0, "title": "x", "share": 10})
    page.show({"t": 0.5, "wall": 2.0, "title": "x", "share": 10})  # says nothing new: not sent
    stream = urllib.request.urlopen(page.web_url() + "events", timeout=5)
    first = json.loads(stream.readline().decode().removeprefix("data: "))
    assert first["panel"]["t"] == 0.0 and first["screen"]["title"] == "Trial 1"
    assert first["actions"] == {"Enter": "start"} and "ArrowLeft" in first["codes"]
    stream.close()
    assert _post(page, {"type": "action", "name": "start"}) == 204
    assert page.wait_action({"start"}, 1.0) == ("start", None)
    assert page.wait_action({"start"}, 0.0) is None


# -- the panel of a trial --------------------------------------------------------------------------------


class _SpyMeshcat:
    """Meshcat, with the cue's visibility calls noted."""

    def __init__(self, meshcat: Any) -> None:
        self.meshcat = meshcat
        self.cue: list[tuple[float, bool]] = []

    def __getattr__(self, name: str) -> Any:
        return getattr(self.meshcat, name)

    def SetProperty(self, path: str, prop: str, value: Any, time_in_recording: float | None = None) -> None:  # noqa: N802
        if path == "/operator/cue" and prop == "visible":
            self.cue.append((time_in_recording, value))
        if time_in_recording is None:
            self.meshcat.SetProperty(path, prop, value)
        else:
            self.meshcat.SetProperty(path, prop, value, time_in_recording)


def test_a_simulated_trial_shows_the_panel_and_its_recording_keeps_it(tmp_path: Any) -> None:
    from pydrake.geometry import Meshcat, MeshcatParams

    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.operator_page.replay import PANEL_LOG_ID
    from drake_disamb.plotting import write_trial_figures
    from drake_disamb.systems.panel import CUE_SECONDS
    from drake_disamb.trial import run_trial

    scenario = load_scenario(
        "reaching",
        "{interface: head_array, paradigm: disambiguation, duration: 12, "
        "disambiguation: {request_latency: 0.5}}",
    )
    meshcat = Meshcat(MeshcatParams(host="localhost"))
    with OperatorPage("localhost", None, meshcat_port=meshcat.port()) as page:
        handles = build_shared_control_diagram(scenario, meshcat=meshcat, page=page)
        panel = handles.systems["panel"]
        spy = panel._meshcat = _SpyMeshcat(meshcat)
        result = run_trial(handles, progress=False, realtime_rate=0.0)
        shown = page.message()["panel"]
    names = [g.name.replace("_", " ") for g in scenario.goals]
    assert [g["name"] for g in shown["goals"]] == names
    log = panel.recorder.log
    kinds = [s["status"]["kind"] for s in log]
    choosing = kinds.index("choosing")
    why = kinds.index("why")
    request, switch = result.request_times[0], result.disambiguation_switch_times[0]
    assert switch == pytest.approx(request + 0.5, abs=0.011)
    assert 0 < log[choosing]["t"] - request <= 0.02 + 1e-9  # the next panel state
    assert 0 < log[why]["t"] - switch <= 0.03 + 1e-9  # the panel state after the switch
    line = log[why]["status"]["text"]
    assert line.startswith("The robot chose") and sum(name in line for name in names) >= 1
    assert log[why]["status"]["detail"].startswith("Chose mode")
    # The scene's cue: shown at the switch, gone CUE_SECONDS later or at the next mode change.
    on = [t for t, visible in spy.cue if visible]
    off = [t for t, visible in spy.cue if not visible and t > on[0]]
    assert on[0] == pytest.approx(log[why]["t"], abs=0.03)
    changed = [e.time for e in result.events if e.time > on[0] and e.kind == "mode_switch"]
    assert off[0] == pytest.approx(min([on[0] + CUE_SECONDS, *[t + 0.02 for t in changed]]), abs=0.03)
    written = write_trial_figures(result, handles, tmp_path)
    html = (tmp_path / "recording.html").read_text()
    assert tmp_path / "recording.html" in written
    kept = json.loads(html.split(f'id="{PANEL_LOG_ID}">')[1].split("</script>")[0])
    assert [s["status"]["text"] for s in kept] == [s["status"]["text"] for s in log]
    assert "OperatorPanel.render" in html and "viewer.animator.time" in html
