"""``drake-disamb station-demo``: bad arguments are one-line errors (exit 2); SIGINT stops it (exit 130)."""

from __future__ import annotations

import signal
import time
from pathlib import Path

import pytest
from support import cli_process, interrupt

from drake_disamb.cli import main


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--duration", "nan"], "--duration: expected a number of seconds in (0, 3600], got nan"),
        (["--duration", "-1"], "--duration: expected a number of seconds in"),
        (["--duration", "1e12"], "--duration: expected a number of seconds in (0, 3600], got 10000"),
        (["--hold", "inf"], "--hold: expected a number of seconds >= 0, got inf"),
        (["--speed", "5"], "--speed: expected a number in (0, 0.2] m/s, got 5.0"),
        (["--speed", "0"], "--speed: expected a number in (0, 0.2]"),
        (
            ["--time-step", "0.02"],
            "--time-step: scenario.plant_config.time_step: expected at most the control period (0.01 s), "
            "got 0.02",
        ),
        (["--time-step", "1e-9"], "--time-step: expected a number of seconds >= 0.001, got 1e-09"),
        (["--time-step", "nan"], "--time-step"),
        (["--meshcat-port", "70000"], "--meshcat-port: expected a port in 1..65535, got 70000"),
    ],
)
def test_bad_arguments_are_one_line_errors(argv: list[str], message: str, tmp_path: Path, capsys) -> None:
    start = time.perf_counter()
    assert main(["station-demo", "--no-meshcat", *argv, "--out", str(tmp_path / "o")]) == 2
    assert time.perf_counter() - start < 2.0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("drake-disamb station-demo: error: ")
    assert message in err
    if "0.02" not in argv:  # checked against the station's control period, after --out
        assert not (tmp_path / "o").exists()  # nothing created before the arguments are checked


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "plant_config: {time_step: 0.02}",
            "--scenario-text: scenario.plant_config.time_step: expected at most the control period (0.01 s)",
        ),
        ("station: !Lcm {lcm_url: nourl}", "--scenario-text: scenario.station.lcm_url: expected a URL"),
        ("station: !Ros {}", "--scenario-text: scenario.station: unknown tag '!Ros' (one of !Sim, !Lcm)"),
        ("{plant_config: [}", "--scenario-text: malformed YAML"),
    ],
)
def test_the_scenario_text_is_checked_as_a_layer(text: str, message: str, tmp_path: Path, capsys) -> None:
    assert main(["station-demo", "--no-meshcat", "--scenario-text", text, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err


def test_the_station_is_the_scenarios(tmp_path: Path, capsys) -> None:
    # A 20 ms control period takes a 20 ms plant step: the station is built from the scenario's.
    text = "{control_period: 0.02, plant_config: {time_step: 0.02}}"
    argv = [
        "station-demo",
        "--no-meshcat",
        "--duration",
        "0.2",
        "--scenario-text",
        text,
        "--out",
        str(tmp_path),
    ]
    assert main(argv) == 0, capsys.readouterr().err
    assert "simulated 0.20 s" in capsys.readouterr().out


def test_out_that_is_a_file_is_a_one_line_error(tmp_path: Path, capsys) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["station-demo", "--no-meshcat", "--out", str(blocker)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"--out: {blocker} is a file" in err


def test_sigint_stops_the_pattern(tmp_path: Path) -> None:
    proc = cli_process("station-demo", "--no-meshcat", "--duration", "3600", "--out", str(tmp_path))
    # "diagram: ..." is printed just before the simulation starts.
    out, _ = interrupt(proc, signal.SIGINT, ready="diagram:", after=1.5)
    assert "stopped by SIGINT" in out and "final EE displacement" in out
