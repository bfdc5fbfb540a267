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
