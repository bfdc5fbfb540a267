"""One set of bounds per quantity: the scenario, the protocol, the command-line options and
``study ablate --switch`` refuse the same values, each with one line naming the field."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from test_scenarios import _reaching_dict

from drake_disamb.cli import main
from drake_disamb.config import scenario_from_dict
from drake_disamb.config.checks import MAX_DURATION, MAX_REQUEST_LATENCY
from drake_disamb.study.design import protocol as P

SRC = Path(__file__).resolve().parents[1] / "src"


@pytest.mark.parametrize(
    "path, value, message",
    [
        ("inference.dft.tau1", 0.0, "scenario.inference.dft.tau1: expected a finite number > 0"),
        ("inference.dft.tau2", 0.0, "scenario.inference.dft.tau2: expected a finite number > 0"),
        ("inference.dft.lam", -1.0, "scenario.inference.dft.lam: expected numbers >= 0"),
        ("duration", 1e12, f"scenario.duration: expected a number of seconds in \\(0, {MAX_DURATION:g}\\]"),
        ("disambiguation.request_latency", 1e9, "scenario.disambiguation.request_latency: expected"),
        ("success.hold_time", 60.0, "scenario.success.hold_time: expected .* shorter than the duration"),
        ("success.hold_time", -1.0, "scenario.success.hold_time"),
    ],
)
def test_a_scenario_value_out_of_bounds_names_the_field(path: str, value: float, message: str) -> None:
    data = _reaching_dict()
    node = data
    parts = path.split(".")
    for part in parts[:-1]:
        node = node.setdefault(part, {})
    node[parts[-1]] = value
    with pytest.raises(ValueError, match=message):
        scenario_from_dict(data)


def _set(path: str, value: object):  # noqa: ANN202
    """An edit of a scenario's plain data: ``path`` (dotted; ``name[i]``, a list entry) set to ``value``."""

    def edit(data: dict) -> None:
        node = data
        *parents, last = path.split(".")
        for part in parents:
            name, _, index = part.partition("[")
            node = node[name][int(index[:-1])] if index else node.setdefault(name, {})
        node[last] = value

    return edit


def _second_stage_of_one_goal(data: dict) -> None:
    data["stages"].append({"name": "place"})
    data["goals"][4]["stage"] = 1
    data["user"]["goals"] = [0, 0]


@pytest.mark.parametrize(
    "edit, message",
    [
        # The loop's period: every system ticks at it (the task manager, the user's decisions, the
        # autonomy, inference, blender, disambiguation, trigger and the gripper controller).
        (
            _set("control_period", 0.0),
            r"scenario\.control_period: expected a finite number in \[0\.001, 0\.1\] s, got 0\.0",
        ),
        (_set("control_period", float("nan")), r"scenario\.control_period: expected a finite number"),
        # The belief's size: at least one goal, the same number in every stage.
        (_set("goals", []), r"scenario\.goals: expected at least one goal, got \[\]"),
        (_second_stage_of_one_goal, r"scenario\.stages\[1\]: every stage needs the same number of goals"),
        # The task manager's goal poses, tolerances, hold times, release openings and targets.
        (_set("goals[2].position", [0.1, float("nan"), 0.3]), r"scenario\.goals\[2\]\.position"),
        (
            _set("goals[2].orientation", [0, 0, 0, 0]),
            r"scenario\.goals\[2\]\.orientation: expected a non-zero",
        ),
        (
            _set("success.position_tolerance", 0.0),
            r"scenario\.success\.position_tolerance: expected a finite",
        ),
        (_set("success.orientation_tolerance", -1.0), r"scenario\.success\.orientation_tolerance: expected"),
        (
            _set("stages[0].hold_time", -0.1),
            r"scenario\.stages\[0\]\.hold_time: expected a finite number >= 0",
        ),
        (
            _set("stages[0].release_opening", -0.1),
            r"scenario\.stages\[0\]\.release_opening: expected an opening",
        ),
        (_set("user.goals", [5]), r"scenario\.user\.goals\[0\]: expected a goal index in \[0, 4\], got 5"),
        # The simulated user decides at most once a control period, and waits two decisions after a
        # press (the system asserts both).
        (
            _set("user.config.decision_period", 0.005),
            r"scenario\.user\.config\.decision_period: expected at least the control period "
            r"\(0\.01 s\), got 0\.005",
        ),
        (
            _set("user.config.reaction_time", 0.15),
            r"scenario\.user\.config\.reaction_time: expected reaction_time - reaction_time_jitter to be "
            r"at least two decision periods \(0\.2 s\), got 0\.15 - ",
        ),
        # The automatic trigger's (the interface's) request latency; the inference's matrix sizes.
        (
            _set("disambiguation.request_latency", -1.0),
            r"scenario\.disambiguation\.request_latency: expected",
        ),
        (
            _set("inference.dft.transition", [[1.0, 0.0], [0.0, 1.0]]),
            r"scenario\.inference\.dft\.transition: expected a 5 x 5 matrix",
        ),
        # The differential IK's start set point.
        (
            _set("start_joint_positions", [0.0, 9.0, 0.0, 0.0, 0.0, 0.0]),
            r"scenario\.start_joint_positions\[1\]: expected an angle within joint 2's limits",
        ),
    ],
)
def test_what_a_system_relies_on_is_refused_at_resolution(edit, message: str) -> None:  # noqa: ANN001
    """Each bound a shared-control system relies on is checked once, when the scenario is resolved,
    and the message names the scenario's field (the systems only assert it)."""
    data = _reaching_dict()
    edit(data)
    with pytest.raises(ValueError, match=message):
        scenario_from_dict(data)


def test_a_goal_in_the_arms_base_is_refused() -> None:
    data = _reaching_dict()
    data["goals"][4]["position"] = [0.05, -0.05, 0.3]
    with pytest.raises(ValueError, match=r"scenario.goals\[4\].position: .* in or over the arm's base"):
        scenario_from_dict(data)


def _cli(*argv: str, timeout: float = 120) -> subprocess.CompletedProcess:
    env = {"PYTHONPATH": str(SRC), "PATH": "/usr/bin:/bin", "MPLBACKEND": "Agg"}
    return subprocess.run(
        [sys.executable, "-m", "drake_disamb.cli", *argv],
        capture_output=True,
        text=True,
        env=env,
        timeout=timeout,
    )


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["station-demo", "--duration", "1e12", "--no-meshcat"],
            "--duration: expected a number of seconds in",
        ),
        (["demo", "--no-meshcat", "--duration", "1e12", "--out", "{tmp}/d"], "--duration: expected a number"),
        (
            ["study", "ablate", "--quick", "--out", "{tmp}/a", "--switch", "inference.dft.tau1=0,4"],
            "--switch inference.dft.tau1=0: .*tau1: expected a finite number > 0",
        ),
        (
            [
                "study",
                "ablate",
                "--quick",
                "--out",
                "{tmp}/b",
                "--switch",
                "disambiguation.request_latency=1000000000.0",
            ],
            "request_latency: expected a number of seconds in",
        ),
        (  # 2e0 is a number (YAML 1.2; 1.1 reads a string): the first value passes, the second is named
            [
                "study",
                "ablate",
                "--quick",
                "--out",
                "{tmp}/c",
                "--switch",
                "disambiguation.request_latency=2e0,1e9",
            ],
            r"--switch disambiguation.request_latency=1000000000.0: .*expected a number of seconds in",
        ),
    ],
    ids=["station-demo-duration", "demo-duration", "switch-tau1", "switch-latency", "switch-exponent"],
)
def test_the_commands_use_the_same_bounds(argv: list[str], message: str, tmp_path: Path) -> None:
    res = _cli(*[a.format(tmp=tmp_path) for a in argv])
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr and res.stderr.strip().count("\n") == 0, res.stderr
    assert __import__("re").search(message, res.stderr), res.stderr


def test_demo_refuses_a_scenario_file_with_tau1_zero(tmp_path: Path) -> None:
    data = _reaching_dict()
    data.setdefault("inference", {})["dft"] = {"tau1": 0.0}
    path = tmp_path / "tau1.yaml"
    path.write_text(yaml.safe_dump(data))
    res = _cli("demo", "--no-meshcat", "--task", str(path), "--out", str(tmp_path / "d"))
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    assert "scenario.inference.dft.tau1: expected a finite number > 0" in res.stderr


def test_protocol_latency_and_duration_share_the_scenarios_bounds() -> None:
    data = yaml.safe_load(P.default_protocol_text())
    with pytest.raises(ValueError, match=r"protocol.request_latency\[1\]: expected a number of seconds in"):
        P.protocol_from_dict(dict(data, request_latency=[0.0, MAX_REQUEST_LATENCY + 1]))
    with pytest.raises(ValueError, match=r"protocol.duration: expected a number of seconds in"):
        P.protocol_from_dict(dict(data, duration=1e12))


def test_a_protocol_of_millions_of_trials_is_refused_before_expansion(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data = yaml.safe_load(P.default_protocol_text())
    data.update(subjects=999)
    for p in data["paradigms"]:
        p["trials"] = 1000
    path = tmp_path / "huge.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["study", "run", "--protocol", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "trials (subjects x interfaces x tasks x paradigms' trials), expected at most" in err
    assert not (tmp_path / "o").exists()


def test_an_ablation_past_the_trials_cap_is_refused_at_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """27,000 settings of the quick protocol's 12 trials: refused in one line before the settings are
    listed or any of the 90 values is checked (one, 1e9 s, is out of range: it is not the one named)."""
    values = ",".join(f"{0.1 + 0.01 * k:.2f}" for k in range(30))
    argv = ["study", "ablate", "--quick", "--out", str(tmp_path / "a")]
    for path in ("user.config.reaction_time", "inference.dft.tau1"):
        argv += ["--switch", f"{path}={values}"]
    argv += ["--switch", f"disambiguation.request_latency={values[:-4]}1e9"]
    start = time.perf_counter()
    assert main(argv) == 2
    elapsed = time.perf_counter() - start
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert "error: --switch: 324000 trials (27000 settings x 12 trials), expected at most 100000" in err, err
    assert elapsed < 10.0, f"took {elapsed:.1f} s"
    assert not (tmp_path / "a").exists()


def test_an_ablation_past_the_hours_cap_counts_a_switched_duration(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """50 settings of the paper's 416 trials: 20,800 trials, and at 3000 and 3600 s each (the
    switched durations, not the protocol's 180 s) 19,067 simulated hours. The scheduler cannot be
    reached: were the ablation taken, the command would stop there."""
    values = ",".join(f"{0.1 + 0.01 * k:.2f}" for k in range(25))
    argv = ["study", "ablate", "--out", str(tmp_path / "a"), "--scheduler", "tcp://127.0.0.1:9"]
    argv += ["--switch", "duration=3000,3600", "--switch", f"user.config.reaction_time={values}"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert (
        "error: --switch: up to 19067 h of simulated time (20800 trials x their duration), expected at most"
        in err
    )
    assert not (tmp_path / "a").exists()


def test_the_simulated_time_is_bounded_by_the_trials_durations() -> None:
    p = P.default_protocol()
    assert p.duration is not None and p.simulated_time_bound == pytest.approx(p.n_trials * p.duration)
    data = yaml.safe_load(P.default_protocol_text())
    data.pop("duration")  # each task's own (the embedded tasks: 60 s)
    assert P.protocol_from_dict(data).simulated_time_bound == pytest.approx(p.n_trials * 60.0)
    assert p.time_bound(3600.0) == pytest.approx(p.n_trials * 3600.0)  # a scenario override's
