"""The sip-and-puff: its mapping, the simulated user operating it, the live page, a trial and a study."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from support import SRC, cli_process, interrupt

from drake_disamb.interfaces import (
    INTERFACES,
    InterfaceConfig,
    command_from_raw,
    initial_state,
    interface_update,
)
from drake_disamb.interfaces.kinds.sip_and_puff import SipAndPuff
from drake_disamb.interfaces.live import LiveState, live_raw_step
from drake_disamb.user import UserConfig, UserState, user_step

CFG = InterfaceConfig(kind="sip_and_puff")
KIND = CFG.variant
IDENTITY = [1.0, 0.0, 0.0, 0.0]

PROTOCOL = """\
# A small study of the sip-and-puff beside the head array (docs/scenarios.md, "A third interface").
subjects: 1
interfaces: [sip_and_puff, head_array]
paradigms:
  - {name: manual, trials: 1}
  - {name: disambiguation, trials: 1}
disambiguation_method: algorithm1
request_latency: [2.0, 2.5]
duration: 120.0
tasks:
  - task: reaching
    start_poses:
      - {name: home}
"""


def feed(raws: list[list[float]], state=None, t0: float = 0.0):  # noqa: ANN001, ANN201
    """Run the interface update on ``raws`` (10 ms apart); the final state and every event."""
    state = initial_state(CFG) if state is None else state
    events = []
    for k, raw in enumerate(raws):
        state, more = interface_update(state, raw, t0 + 0.01 * k, CFG)
        events += more
    return state, events


def test_it_is_registered_with_its_modes_layout_and_keys() -> None:
    assert list(INTERFACES) == ["joystick", "head_array", "sip_and_puff"]
    assert INTERFACES["sip_and_puff"] is KIND and KIND.label == "Sip-and-puff"
    assert CFG.modes == ((0,), (1,), (2,), (3,), (4,), (5,), (6,))
    assert CFG.raw_layout == ("pressure", "unused_1", "unused_2", "disambiguation_button")
    roles = [c.role for c in KIND.live_controls]
    assert roles == ["drive+", "drive-", "next", "previous", "request"]
    assert [c.keycode for c in KIND.live_controls] == [
        "ArrowUp",
        "ArrowDown",
        "ArrowRight",
        "ArrowLeft",
        "Space",
    ]
    assert not KIND.proportional and KIND.steps_back and KIND.mode_selections == ("cycle",)


def test_hard_breaths_drive_the_active_dimension_both_ways() -> None:
    state, events = feed([[1.0, 0, 0, 0]])
    u, _ = command_from_raw(state.held_raw, state.mode, CFG)
    assert events == [] and u.tolist() == pytest.approx([0.1, 0, 0, 0, 0, 0])  # hard puff: +vx at 0.1 m/s
    state, _ = feed([[-0.7, 0, 0, 0]], state)
    u, _ = command_from_raw(state.held_raw, state.mode, CFG)
    assert u.tolist() == pytest.approx([-0.1, 0, 0, 0, 0, 0])  # hard sip: -vx
    state, _ = feed([[0.5, 0, 0, 0]], state)  # soft: no drive
    assert command_from_raw(state.held_raw, state.mode, CFG)[0].tolist() == [0.0] * 6


def test_a_soft_breath_steps_the_mode_when_it_ends_and_a_hard_one_never_does() -> None:
    soft_puff, soft_sip = KIND.step_raw(1), KIND.step_raw(-1)
    assert soft_puff[0] == pytest.approx(0.4) and soft_sip[0] == pytest.approx(-0.4)
    rest = [0.0, 0.0, 0.0, 0.0]
    state, events = feed([soft_puff, soft_puff, soft_puff])
    assert state.mode == 0 and events == []  # held: nothing until it ends
    state, events = feed([rest], state)
    assert state.mode == 1 and [(e.kind, e.from_mode, e.to_mode) for e in events] == [("mode_switch", 0, 1)]
    state, events = feed([soft_sip, rest, soft_sip, rest], state)
    assert state.mode == 6 and len(events) == 2 and state.mode_switch_count == 3  # back round to the gripper
    # A hard breath rises through the soft band and falls through it again: a drive, no mode change.
    state, events = feed([[0.3, 0, 0, 0], [1.0, 0, 0, 0], [1.0, 0, 0, 0], [0.3, 0, 0, 0], rest], state)
    assert events == [] and state.mode == 6
    # A puff that turns into a sip without rest is a new breath: the soft puff is not counted.
    state, events = feed([soft_puff, soft_sip, rest], state)
    assert [(e.from_mode, e.to_mode) for e in events] == [(6, 5)]


def test_the_gripper_mode_opens_on_a_hard_puff_and_requests_are_the_switch() -> None:
    state, _ = feed([KIND.step_raw(-1), [0, 0, 0, 0], [1.0, 0, 0, 0]])
    assert state.mode == 6
    u, gripper = command_from_raw(state.held_raw, state.mode, CFG)
    assert u.tolist() == [0.0] * 6 and gripper == pytest.approx(0.02)
    state, events = feed([KIND.request_raw()], state, 1.0)
    assert [e.kind for e in events] == ["disambiguation_request"] and state.request_count == 1


def test_pressure_is_clipped_and_non_finite_reads_as_rest() -> None:
    state, _ = feed([[5.0, 0, 0, 0]])
    assert state.held_raw[0] == 2.0
    state, _ = interface_update(state, [float("nan"), 0, 0, 0], 0.5, CFG)
    assert state.held_raw[0] == 0.0 and state.nonfinite_count == 1


@pytest.mark.parametrize(("soft", "hard"), [(0.0, 0.6), (0.6, 0.6), (0.2, 1.5), (float("nan"), 0.6)])
def test_threshold_validation(soft: float, hard: float) -> None:
    with pytest.raises(
        ValueError, match=r"SipAndPuff\.soft_threshold, hard_threshold: expected 0 < soft < hard"
    ):
        SipAndPuff(soft_threshold=soft, hard_threshold=hard)


def test_the_simulated_user_changes_mode_the_shorter_way_round_and_drives_with_full_breaths() -> None:
    goal = np.array([0.0, 0.0, 0.0, *IDENTITY])
    config = UserConfig(request_at_start=False, request_when_unhelped_for=None)
    # Only wz is off (0.3 rad): from mode vx (0) the target wz (5) is one soft sip back, not five puffs.
    half = 0.15
    ee = np.array([0.0, 0.0, 0.0, np.cos(half), 0.0, 0.0, -np.sin(half)])
    s = user_step(UserState(), 0.0, 0, ee, goal.reshape(1, 7), 0, CFG, config)
    assert s.raw.tolist() == pytest.approx(KIND.step_raw(-1)) and s.target_mode == 5
    # In mode wz it drives with a full sip or puff toward the goal.
    s = user_step(UserState(), 0.0, 5, ee, goal.reshape(1, 7), 0, CFG, config)
    assert abs(s.raw[0]) == 1.0 and s.raw[1:].tolist() == [0.0, 0.0, 0.0]


def test_a_closed_loop_user_reaches_its_goal_through_the_raw_signal() -> None:
    """The reaching trial with the sip-and-puff: the simulated user steps modes both ways."""
    import dataclasses

    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.trial import run_trial

    scenario = dataclasses.replace(load_scenario("reaching"), interface="sip_and_puff", duration=40.0)
    result = run_trial(build_shared_control_diagram(scenario), progress=False)
    assert result.success and result.mode_switches > 0
    switches = [e for e in result.events if e.kind == "mode_switch"]
    steps = {(e.to_mode - e.from_mode) % 7 for e in switches}
    assert steps <= {1, 6} and steps  # one step forward or one back per soft breath


def test_live_keys_hold_a_hard_breath_and_pulse_a_soft_one() -> None:
    """Up holds a hard puff (drives); Right / Left are one soft puff / sip followed by rest, each one
    mode step; a soft breath waits while a hard one is held."""
    counts = np.zeros(5)
    state, raws = LiveState(), []
    itf, steps = initial_state(CFG), []
    clicks = {0.0: [0], 1.0: [2], 1.2: [3, 3], 1.5: [0, 2]}
    for k in range(260):
        t = round(k * 0.01, 10)
        for b in clicks.get(t, []):
            counts[b] += 1
        state = live_raw_step(state, t, "sip_and_puff", counts)
        raws.append(state.raw[0])
        itf, events = interface_update(itf, state.raw, t, CFG)
        steps += [(round(t, 2), e.from_mode, e.to_mode) for e in events]
    raws = np.array(raws)
    assert np.all(raws[:59] == 1.0) and raws[61] == 0.0  # held for the hold time (0.6 s)
    assert raws[100] == pytest.approx(0.4) and raws[101] == 0.0  # one soft puff, then rest
    assert [s[1:] for s in steps] == [(0, 1), (1, 0), (0, 6), (6, 0)]
    assert steps[-1][0] >= 2.1  # the Right at 1.5 s waited for the hard puff (Up at 1.5 s) to end


def cli(*argv: str) -> subprocess.CompletedProcess:
    env = dict(
        os.environ, PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""), MPLBACKEND="Agg"
    )
    return subprocess.run(
        [sys.executable, "-m", "drake_disamb.cli", *argv],
        capture_output=True,
        text=True,
        env=env,
        timeout=900,
    )


def test_demo_runs_the_sip_and_puff(tmp_path: Path) -> None:
    res = cli("demo", "--interface", "sip_and_puff", "--no-meshcat", "--quiet", "--out", str(tmp_path / "d"))
    assert res.returncode == 0, res.stderr
    metrics = json.loads((tmp_path / "d" / "metrics.json").read_text())
    assert metrics["interface"] == "sip_and_puff" and metrics["success"] is True


def test_demo_live_shows_the_sip_and_puff_keys(tmp_path: Path) -> None:
    """``demo --live --interface sip_and_puff`` prints the breath keys, runs the trial from the page
    and ends cleanly on Ctrl-C (the page's keys: test_live_browser_sip_and_puff.py)."""
    proc = cli_process("demo", "--quiet", "--live", "--interface", "sip_and_puff", "--out", str(tmp_path))
    interrupt(proc, signal.SIGINT, ready="Right (soft puff)", after=2.0)  # its help, then the trial
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert (
        metrics["interface"] == "sip_and_puff" and metrics["live"] is True and metrics["interrupted"] is True
    )
    assert metrics["mode_switches"] == 0 and metrics["disambiguation_requests"] == 0  # nobody at the page


@pytest.mark.slow
def test_a_study_with_the_sip_and_puff_runs_and_reports(tmp_path: Path) -> None:
    protocol = tmp_path / "protocol.yaml"
    protocol.write_text(PROTOCOL, encoding="utf-8")
    res = cli(
        "study", "run", "--protocol", str(protocol), "--out", str(tmp_path / "s"), "--workers", "2", "--quiet"
    )
    assert res.returncode == 0, res.stderr
    lines = (tmp_path / "s" / "trials.jsonl").read_text().splitlines()
    records = [json.loads(line) for line in lines if '"trial_id"' in line]
    assert {r["interface"] for r in records} == {"sip_and_puff", "head_array"} and len(records) == 4
    res = cli("study", "report", str(tmp_path / "s"), "--no-mixed-model")
    assert res.returncode == 0, res.stderr
    page = (tmp_path / "s" / "report" / "index.html").read_text(encoding="utf-8")
    assert "sip_and_puff" in page or "Sip-and-puff" in page
    summary = json.loads((tmp_path / "s" / "report" / "summary.json").read_text())
    assert "sip_and_puff" in json.dumps(summary)
