"""Behaviour estimates of :mod:`drake_disamb.study.measures.calibration`: ending and starting in the gripper
mode and the commanded path, on hand-made trials (read directly and through a study folder) and on
the authors' logs (skipped where the logs are absent)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from drake_disamb.interfaces import gripper_mode, interface_modes, mode_name
from drake_disamb.study.data.folder import LoggedTrial, StudyFolder, save_trace
from drake_disamb.study.data.records import TrialRecord, append_record
from drake_disamb.study.measures.calibration import estimate_behaviour, format_estimates

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "tnsre2020_human_study"
DT = 0.05
"""The hand-made traces' sample period (s): the logs' mode sampling."""


def _line(est, name: str) -> str:
    """The line of ``format_estimates(est)`` that starts with ``name``."""
    return next(x for x in format_estimates(est).splitlines() if x.startswith(name))


def _trial(
    trial_id: str,
    interface: str,
    task: str,
    initial: int,
    changes: list[tuple[float, int]],
    duration: float,
    *,
    t0: float = 0.0,
    t_end: float | None = None,
    paradigm: str = "manual",
    valid: bool = True,
) -> LoggedTrial:
    """A trial of ``interface`` starting in mode index ``initial`` whose user switches are
    ``changes`` (time s, mode index entered); its trace samples the mode every :data:`DT` from
    ``t0`` to ``t_end`` (``duration`` by default)."""
    modes = interface_modes(interface)
    t = np.round(np.arange(t0, (duration if t_end is None else t_end) + DT / 2, DT), 6)
    mode = np.full(t.size, float(initial))
    for at, index in changes:
        mode[t >= at - 1e-9] = index
    u_h = np.zeros((t.size, 6))
    u_h[(t > 0.5) & (t < 1.5), 0] = 0.05  # a command before the first switch
    record = TrialRecord(
        trial_id=trial_id, subject="S01", interface=interface, task=task, paradigm=paradigm,
        disambiguation_method="algorithm1" if paradigm == "disambiguation" else None, repetition=0, seed=0,
        start_pose=0, initial_mode=mode_name(modes[initial]), intended_goals=[0], reached_goals=[0],
        success=True, done=True, duration=duration, completion_time=duration, mode_switches=len(changes),
        requests=0, automatic_switches=0, button_presses=len(changes), request_times=[],
        mode_switch_times=[at for at, _ in changes],
        mode_switch_modes=[mode_name(modes[i]) for _, i in changes], automatic_switch_times=[],
        mean_alpha=0.0, assistance_onset=None, wall_time=0.0, valid=valid,
    )  # fmt: skip
    trace = {
        "t": t,
        "mode": mode,
        "u_h": u_h,
        "u": u_h.copy(),
        "belief": np.full((t.size, 2), 0.5),
        "alpha": np.zeros(t.size),
    }
    return LoggedTrial(record, trace, request_switch_times=np.zeros(0))


def _trials() -> list[LoggedTrial]:
    j, h = gripper_mode("joystick"), gripper_mode("head_array")  # the gripper modes: 4 and 6
    return [
        # in, out of and back into the gripper mode: ends there 5 s after its second change into it;
        # the trace starts before the start (as the logs' do), with presses there that do not count
        _trial(
            "J1",
            "joystick",
            "pouring",
            0,
            [(-1.0, j), (-0.5, 0), (10.0, j), (12.0, 1), (20.0, j)],
            25.0,
            t0=-2.0,
        ),
        # starts in the gripper mode, leaves it and comes back 3 s before the end; the trace goes
        # on after the end, out of and back into the gripper mode: those changes do not count
        _trial("J2", "joystick", "pouring", j, [(5.0, 0), (27.0, j), (31.0, 0), (32.0, j)], 30.0, t_end=33.0),
        # passes through the gripper mode without ending there
        _trial("J3", "joystick", "pouring", 0, [(8.0, j), (9.0, 2)], 20.0, paradigm="disambiguation"),
        # the trace goes on after the end, into the gripper mode: the mode at the end is not it
        _trial("J4", "joystick", "reaching", 1, [(10.5, j)], 10.0, t_end=12.0),
        # not analysed: a failed trial and an Automatic one, both ending in the gripper mode
        _trial("J5", "joystick", "reaching", j, [(2.0, 0), (4.0, j)], 9.0, valid=False),
        _trial("J6", "joystick", "reaching", j, [(2.0, 0), (4.0, j)], 9.0, paradigm="automatic"),
        _trial("H1", "head_array", "reaching", h, [(2.0, 0)], 10.0),
    ]


def _check(est) -> None:  # noqa: ANN001
    joy, head = est.gripper_end["joystick"], est.gripper_end["head_array"]
    assert list(est.gripper_end) == ["joystick", "head_array"] and list(joy) == ["reaching", "pouring"]
    assert (joy["pouring"].share, joy["pouring"].n) == (pytest.approx(2 / 3), 3)
    assert joy["pouring"].time_to_end == pytest.approx(4.0)  # median of 5 s and 3 s
    assert joy["pouring"].entries == pytest.approx(1.5)  # J1 twice, J2 once (J3 does not end there)
    assert (joy["reaching"].share, joy["reaching"].n) == (0.0, 1)
    assert math.isnan(joy["reaching"].time_to_end) and math.isnan(joy["reaching"].entries)
    assert (head["reaching"].share, head["reaching"].n) == (0.0, 1) and "pouring" not in head
    assert est.starts_in_gripper == {"joystick": (0.25, 4), "head_array": (1.0, 1)}
    assert _line(est, "ends in gripper mode") == (
        "ends in gripper mode         joystick reaching 0.00 of 1, pouring 0.67 of 3 (median 4.0 s from "
        "the change to the end, 1.5 changes into it); head array reaching 0.00 of 1"
    )
    assert _line(est, "starts in gripper mode") == (
        "starts in gripper mode       joystick 0.25 of 4 (1/5 = 0.20 if uniform over all modes), "
        "head array 1.00 of 1 (1/7 = 0.14 if uniform over all modes)"
    )


def test_gripper_end_and_start_of_hand_made_trials() -> None:
    _check(estimate_behaviour(_trials()))


def test_gripper_estimates_are_the_same_from_a_study_folder(tmp_path: Path) -> None:
    (tmp_path / "traces").mkdir()
    for trial in _trials():
        append_record(tmp_path / "trials.jsonl", trial.record)
        save_trace(tmp_path / "traces" / f"{trial.record.trial_id}.npz", trial.trace)
    trials = StudyFolder(tmp_path).read_trials()
    assert all(t.request_switch_times.size == 0 for t in trials)  # every change is a user switch
    _check(estimate_behaviour(trials))


def test_people_let_go_at_the_end_of_pouring_and_start_in_any_mode() -> None:
    if not DATA.is_dir():
        pytest.skip(f"the authors' human logs are not at {DATA} (../shared/data, never copied here)")
    from drake_disamb.study.data.authors import read_trials

    est = estimate_behaviour(read_trials(DATA))
    assert est.gripper_end["joystick"]["pouring"].share > 0.8
    assert 1.0 < est.gripper_end["joystick"]["pouring"].time_to_end < 8.0
    assert est.gripper_end["joystick"]["reaching"].share == 0.0
    assert est.gripper_end["head_array"]["reaching"].share == 0.0
    # the trial order drew the initial mode over all modes, the gripper mode included
    assert 0.1 < est.starts_in_gripper["joystick"][0] < 0.35
    assert 0.05 < est.starts_in_gripper["head_array"][0] < 0.25


def test_commanded_path_integrates_the_blended_command_over_the_trial() -> None:
    from drake_disamb.study.measures.course import command_path

    trial = _trial("p", "joystick", "reaching", 0, [], 3.0)
    trial.trace["u"][:, 4] = 0.1  # 0.1 rad/s about y throughout
    path, rotation, moving = command_path(trial)
    # 0.05 m/s from 0.55 to 1.45 s, each sample held DT: 19 samples
    assert path == pytest.approx(19 * DT * 0.05) and moving == pytest.approx(19 * DT)
    assert rotation == pytest.approx(0.1 * 3.0)  # 60 samples held DT, the last one not at all
    est = estimate_behaviour([trial, _trial("q", "joystick", "reaching", 0, [], 3.0)])
    c = est.command_path["joystick"]["reaching"]
    assert c.n == 2 and c.path == pytest.approx(19 * DT * 0.05) and c.speed == pytest.approx(0.05)
    assert "commanded path per trial     joystick reaching 0.05 m" in format_estimates(est)
    del trial.trace["u"]  # a trace without the blended command counts in no path
    assert command_path(trial) is None
    assert estimate_behaviour([trial]).command_path == {}


def test_switches_after_each_request_count_the_users_switches_until_the_next_request() -> None:
    import dataclasses

    trial = _trial("J7", "joystick", "reaching", 0, [(6.0, 1), (7.0, 2), (8.0, 0), (21.0, 1)], 30.0,
                   paradigm="disambiguation")  # fmt: skip
    record = dataclasses.replace(trial.record, request_times=[5.0, 20.0], requests=2, button_presses=6)
    est = estimate_behaviour([LoggedTrial(record, trial.trace, request_switch_times=np.zeros(0))])
    assert est.switches_after_request["joystick"] == (2.0, 2.0, 2)  # 3 after the first, 1 after the second
    assert est.switches_after_request["head_array"][2] == 0
    line = _line(est, "switches after a request")
    assert "joystick mean 2.00, median 2 (n=2)" in line


def test_the_mode_each_request_chose_is_told_translation_or_rotation() -> None:
    import dataclasses

    from drake_disamb.study.measures.course import request_modes

    # Joystick modes: 0 {vx, vy}, 1 {vx, vz}, 2 {wx, wz}, 3 {wy}. Requests switched to 1 at 3 s and to
    # 2 at 12 s; the user switched to 0 at 8 s (not a request's).
    trial = _trial("J8", "joystick", "reaching", 3, [(3.0, 1), (8.0, 0), (12.0, 2)], 20.0,
                   paradigm="disambiguation")  # fmt: skip
    record = dataclasses.replace(
        trial.record, mode_switch_times=[8.0], mode_switch_modes=["vx_vy"], mode_switches=1,
        request_times=[0.5, 9.5], requests=2, button_presses=3,
    )  # fmt: skip
    logged = LoggedTrial(record, trial.trace, request_switch_times=np.array([3.0, 12.0]))
    assert request_modes(logged) == [True, False]
    est = estimate_behaviour([logged])
    assert est.request_translation["joystick"] == (0.5, 2)
    assert est.request_translation["head_array"][1] == 0
    line = _line(est, "request chose translation")
    assert "joystick 0.50 (n=2)" in line


def test_reversals_count_the_command_turning_back_within_a_dwell() -> None:
    # One dwell (no switch): +x from 0.5 to 1.5 s, a tiny -x at 1.7 s (under a tenth of the
    # largest: the stick's dead zone, not counted), then -x from 2.0 to 2.5 s: one reversal; a turn
    # of 90 degrees (to +y) is not one.
    trial = _trial("R1", "joystick", "reaching", 0, [], 4.0)
    t, u = trial.trace["t"], trial.trace["u_h"]
    u[np.isclose(t, 1.7), 0] = -0.001
    u[(t > 2.0) & (t < 2.5), 0] = -0.05
    u[(t > 2.5) & (t < 3.0), 1] = 0.05
    est = estimate_behaviour([trial])
    assert est.reversals_per_dwell["joystick"] == (1.0, 1)
    assert est.reversals_per_dwell["head_array"][1] == 0
    line = _line(est, "reversals per dwell")
    assert "joystick 1.00 (n=1)" in line


def test_the_correction_probability_counts_stops_of_a_tenth_to_half_a_second_per_interface() -> None:
    # One joystick dwell: commands 0.5-1.5 s, a stop of 0.05 s (a stick through its centre: not
    # counted), commands to 2.0 s, a stop of 0.3 s (a correction), commands to 3.0 s, a pause of
    # 0.6 s (not a correction), commands to 4.0 s: c = 1, p = 0.5. A head-array dwell with none.
    joy = _trial("C1", "joystick", "reaching", 0, [], 5.0)
    t, u = joy.trace["t"], joy.trace["u_h"]
    for a, b in ((1.55, 2.0), (2.3, 3.0), (3.6, 4.0)):
        u[(t > a - 1e-9) & (t < b), 0] = 0.05
    head = _trial("C2", "head_array", "reaching", 0, [], 3.0)
    est = estimate_behaviour([joy, head])
    assert est.correction_prob_by_interface == {"joystick": {"S01": 0.5}, "head_array": {"S01": 0.0}}
    assert est.corrections_per_dwell["joystick"] == 2.0  # the pooled count keeps every stop under 0.5 s
    assert _line(est, "correction probability").startswith(
        "correction probability       joystick S01 0.50; head array S01 0.00"
    )


def test_the_study_systems_requests_chose_translation_modes() -> None:
    # What the people's logs show of the system (the preset's agreement term follows it).
    if not DATA.is_dir():
        pytest.skip(f"the authors' human logs are not at {DATA} (../shared/data, never copied here)")
    from drake_disamb.study.data.authors import read_trials

    est = estimate_behaviour(read_trials(DATA))
    for interface in ("joystick", "head_array"):
        share, n = est.request_translation[interface]
        assert n > 50 and share > 0.9, (interface, share, n)


def test_pauses_split_by_whether_the_assistance_moved_the_arm_and_the_uncommanded_motion() -> None:
    trial = _trial("J8", "joystick", "reaching", 0, [], 20.0, t_end=20.0 - DT)  # 400 samples, 0.05 s apart
    t = trial.trace["t"]
    u_h = np.zeros((t.size, 6))
    for a, b in ((1.0, 5.0), (6.0, 10.0), (12.0, 15.0)):  # commanding 11 s, paused 5-6 s and 10-12 s
        u_h[(t >= a - 1e-9) & (t < b - 1e-9), 0] = 0.05
    assisting = (t >= 9.0 - 1e-9) & (t < 13.0 - 1e-9)  # alpha > 0 from 9 to 13 s
    u = u_h.copy()
    u[assisting & (u_h[:, 0] == 0), 1] = 0.02  # the assistance moves the arm while the user rests
    trial.trace.update(u_h=u_h, u=u, alpha=np.where(assisting, 0.5, 0.0))
    est = estimate_behaviour([trial])
    # The 10-12 s pause began with alpha > 0 (2 s of commanding so), the 5-6 s one without (9 s).
    assert est.carry_rate["S01"] == pytest.approx(1 / 2.0, rel=0.05)
    assert est.carry_duration.median == pytest.approx(2.0, abs=0.06) and est.carry_duration.n == 1
    assert est.unassisted_pause_rate["S01"] == pytest.approx(1 / 9.0, rel=0.05)
    assert est.unassisted_pause_duration.median == pytest.approx(1.0, abs=0.06)
    moved, moved_assisted, n = est.uncommanded_motion["joystick"]["reaching"]
    assert n == 1 and moved == pytest.approx(2.0, abs=0.06)
    assert moved_assisted == pytest.approx(2.0, abs=0.06)
    text = format_estimates(est)
    assert "while the assistance moves the arm: S01 0.5" in text
    assert "joystick reaching 2.0 s (2.0 s with alpha > 0, median of 1)" in text


def test_changes_per_minute_while_the_assistance_helps_and_while_it_pulls_elsewhere() -> None:
    # Reaching, goal 0 of 2 (rho1 = 0.6): helped 0-10 s, unsure 10-20 s, misled (argmax goal 1) 20-30 s.
    changes = [(5.0, 1), (11.0, 2), (14.5, 0), (18.0, 1), (25.0, 2)]  # 3 s or more apart: 5 changes
    trial = _trial("J9", "joystick", "reaching", 0, changes, 30.0, t_end=30.0 - DT)
    t = trial.trace["t"]
    belief = np.tile([0.5, 0.5], (t.size, 1))
    belief[t < 10.0 - 1e-9] = [0.8, 0.2]
    belief[t >= 20.0 - 1e-9] = [0.2, 0.8]
    trial.trace["belief"] = belief
    trial.trace["u_h"] = np.zeros((t.size, 6))  # no command: each switch is a change of its own
    est = estimate_behaviour([trial])
    helped, unsure = est.changes_per_minute_helped["joystick"]
    misled, unsure_too = est.changes_per_minute_misled["joystick"]
    assert helped == pytest.approx(6.0, rel=0.02) and misled == pytest.approx(6.0, rel=0.02)
    assert unsure == pytest.approx(18.0, rel=0.02) and unsure_too == unsure
    text = format_estimates(est)
    assert "joystick 6.0 while the argmax is the goal, 18.0 while unsure (forgone while helped: 0.67)" in text
    assert "joystick 6.0 while the argmax is another goal, 18.0 while unsure (forgone while misled" in text


def test_confident_share_by_half_of_the_trial() -> None:
    # 40 s of reaching, 2 goals (rho1 0.6): confident 0-10 s and 20-35 s: first half 10 of 20 s,
    # second half 15 of 20 s.
    trial = _trial("J8", "joystick", "reaching", 0, [], 40.0, t_end=40.0 - DT)
    t = trial.trace["t"]
    belief = np.tile([0.5, 0.5], (t.size, 1))
    belief[t < 10.0 - 1e-9] = [0.8, 0.2]
    belief[(t >= 20.0 - 1e-9) & (t < 35.0 - 1e-9)] = [0.3, 0.7]
    trial.trace["belief"] = belief
    est = estimate_behaviour([trial])
    first, second = est.confident_by_half["joystick"]["reaching"]
    assert first == pytest.approx(0.5, abs=0.01) and second == pytest.approx(0.75, abs=0.01)
    assert "joystick reaching 0.50 / 0.75" in format_estimates(est)


def test_an_estimate_is_one_function_and_one_row_of_the_table(monkeypatch: pytest.MonkeyPatch) -> None:
    from drake_disamb.study.measures import calibration

    trials = [_trial("J1", "joystick", "reaching", 0, [(2.0, 1)], 4.0)]
    est = estimate_behaviour(trials)
    names = [m.name for m in calibration.MEASURES]
    assert list(est) == names and len(set(names)) == len(names) == 46
    assert est["tail"] is est.tail and est.n_trials == 1
    with pytest.raises(AttributeError, match="BehaviourEstimates has no measure 'no_such'"):
        _ = est.no_such
    lines = format_estimates(est).splitlines()
    # one line per estimate with a text, two of the gripper and of the commanding
    assert len(lines) == sum(m.text is not None for m in calibration.MEASURES) + 2
    longest = calibration.Measure(
        "longest_trial",
        lambda measured: max(v.record.duration for v in measured),
        lambda v, est: f"longest trial {v:.1f} s of {est.n_trials}",
    )
    monkeypatch.setattr(calibration, "MEASURES", (*calibration.MEASURES, longest))
    est = estimate_behaviour(trials)
    assert est.longest_trial == 4.0
    assert format_estimates(est).splitlines() == [*lines, "longest trial 4.0 s of 1"]


def test_trials_of_an_interface_the_logs_lack_are_left_out(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A simulated study with sip-and-puff trials: the estimates are measured on the logs'
    interfaces only (the same as without them), and ``study calibrate --simulated`` says how many
    it left out; a folder of sip-and-puff trials only is one line and status 2, not a traceback."""
    from drake_disamb.cli import main

    puff = _trial("P1", "sip_and_puff", "reaching", 0, [(2.0, 1), (4.0, 2)], 10.0)
    assert format_estimates(estimate_behaviour([*_trials(), puff])) == format_estimates(
        estimate_behaviour(_trials())
    )
    if not DATA.is_dir():
        pytest.skip(f"the authors' human-study logs are not at {DATA}")
    for name, trials in (("both", [*_trials(), puff]), ("puff", [puff])):
        folder = tmp_path / name
        (folder / "traces").mkdir(parents=True)
        for trial in trials:
            append_record(folder / "trials.jsonl", trial.record)
            save_trace(folder / "traces" / f"{trial.record.trial_id}.npz", trial.trace)
    assert main(["study", "calibrate", str(DATA), "--simulated", str(tmp_path / "both")]) == 0
    assert "(1 trials of sip_and_puff left out: the logs have only joystick and head_array)" in (
        capsys.readouterr().out
    )
    assert main(["study", "calibrate", str(DATA), "--simulated", str(tmp_path / "puff")]) == 2
    err = capsys.readouterr().err
    assert "of the joystick or head_array, got none" in err and "Traceback" not in err
