"""``drake-disamb demo``: argument errors, a headless run, a Meshcat run with its recording, the plot,
``metrics.json``, an unusable ``--out`` and a run stopped by SIGINT / SIGTERM."""

from __future__ import annotations

import json
import signal
import time
from pathlib import Path

import numpy as np
import pytest
from support import cli_process, interrupt

from drake_disamb.cli import main
from drake_disamb.plotting import BeliefPlot, goal_probability_figure, nonzero_segments


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--task", "juggling"], "task: expected one of reaching, pouring"),
        (["--interface", "keyboard"], "interface: expected one of"),
        (["--paradigm", "auto"], "paradigm: expected one of"),
        (["--goal", "9"], "--goal: scenario.user.goals[0]: expected a goal index in [0, 4], got 9"),
        (["--scenario-text", "seed: [1"], "--scenario-text: malformed YAML"),
        (["--scenario-text", "{paradigm: auto}"], "--scenario-text: scenario.paradigm: expected one of"),
        (["--task", "/no/such/file.yaml"], "no such scenario file"),
        (["--live"], "--live needs Meshcat"),
        (["--duration", "0"], "--duration: expected a number of seconds in (0, 3600]"),
    ],
)
def test_bad_arguments_exit_2(argv: list[str], message: str, capsys, tmp_path: Path) -> None:
    assert main(["demo", *argv, "--no-meshcat", "--out", str(tmp_path)]) == 2
    assert message in capsys.readouterr().err


def test_malformed_yaml_exits_2(tmp_path: Path, capsys) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("goals: [\n")
    assert main(["demo", "--task", str(bad), "--no-meshcat", "--out", str(tmp_path)]) == 2
    assert "malformed YAML" in capsys.readouterr().err


def test_goal_on_the_start_position_exits_2(tmp_path: Path, capsys) -> None:
    from drake_disamb.config import embedded_scenario_text

    text = embedded_scenario_text("reaching").replace(
        "position: [0.328, -0.516, 0.100]", "position: [0.0, -0.35, 0.3]"
    )
    path = tmp_path / "start.yaml"
    path.write_text(text)
    assert main(["demo", "--task", str(path), "--no-meshcat", "--out", str(tmp_path)]) == 2
    assert "on top of the gripper's start position" in capsys.readouterr().err


def test_headless_run_prints_metrics_and_writes_figures(tmp_path: Path, capsys) -> None:
    code = main(["--no-meshcat", "--quiet", "--goal", "3", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert code == 0
    for key in (
        "success",
        "completion time (s)",
        "mode switches",
        "disambiguation requests",
        "button presses",
    ):
        assert key in out
    assert "yes" in out
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["interrupted"] is False and metrics["success"] is True
    assert (metrics["task"], metrics["interface"], metrics["paradigm"]) == (
        "reaching",
        "head_array",
        "disambiguation",
    )
    assert metrics["goal"] == [3] and isinstance(metrics["seed"], int)
    assert f"{metrics['time']:.2f}" in out and str(metrics["button_presses"]) in out
    png = tmp_path / "goal_probabilities.png"
    assert png.stat().st_size > 10_000 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    dot = (tmp_path / "diagram.dot").read_text()
    assert dot.startswith("digraph")
    # The station's inputs are joint-level; the IK and the gripper controller sit in front of it.
    assert "arm_velocity_command" in dot and "finger_velocity_command" in dot
    assert "diff_ik" in dot and "gripper_controller" in dot
    assert not (tmp_path / "recording.html").exists()


def test_meshcat_run_writes_recording(tmp_path: Path, capsys) -> None:
    code = main(
        ["demo", "--interface", "joystick", "--goal", "3", "--quiet", "--hold", "0", "--realtime-rate", "0",
         "--out", str(tmp_path)]
    )  # fmt: skip
    out = capsys.readouterr().out
    assert code == 0
    assert "Meshcat: http://localhost:" in out
    html = (tmp_path / "recording.html").read_text()
    assert "<html" in html.lower() and len(html) > 100_000


def test_nonzero_segments() -> None:
    t = np.arange(8) * 0.1
    u = np.zeros((8, 6))
    u[1:3, 0] = 0.1
    u[5, 4] = np.nan  # non-finite counts as zero
    u[6:, 2] = -0.2
    assert nonzero_segments(t, u) == [(0.1, pytest.approx(0.3)), (pytest.approx(0.6), pytest.approx(0.7))]
    assert nonzero_segments(t, np.zeros((8, 6))) == []


def test_plot_rejects_mismatched_shapes() -> None:
    with pytest.raises(ValueError, match="belief"):
        goal_probability_figure(BeliefPlot(np.arange(3), np.ones((4, 2))))
    with pytest.raises(ValueError, match="goal_names"):
        goal_probability_figure(BeliefPlot(np.arange(3), np.ones((3, 2)) / 2, goal_names=["a"]))


# ----------------------------------------------------------------------------------------------
# An unusable --out fails at once; SIGINT / SIGTERM stop the trial and keep its results.
# ----------------------------------------------------------------------------------------------


def _timed_main(argv: list[str]) -> tuple[int, float]:
    start = time.perf_counter()
    code = main(argv)
    return code, time.perf_counter() - start


@pytest.mark.parametrize("kind", ["file", "under_a_file"])
def test_out_that_is_a_file_fails_before_building(kind: str, tmp_path: Path, capsys) -> None:
    blocker = tmp_path / "taken"
    blocker.write_text("not a folder")
    out = blocker if kind == "file" else blocker / "sub"
    code, took = _timed_main(["demo", "--no-meshcat", "--quiet", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and took < 2.0
    assert err.count("\n") == 1 and "--out" in err and str(out) in err and "Traceback" not in err
    assert blocker.read_text() == "not a folder"


def test_read_only_out_fails_before_building(tmp_path: Path, capsys) -> None:
    out = tmp_path / "ro"
    out.mkdir()
    out.chmod(0o500)
    try:
        try:  # root (CI) writes through permission bits: then there is nothing to test here
            (out / "probe").write_text("x")
            (out / "probe").unlink()
            pytest.skip("permission bits do not stop this user from writing (running as root)")
        except PermissionError:
            pass
        code, took = _timed_main(["demo", "--no-meshcat", "--quiet", "--out", str(out / "deeper")])
        err = capsys.readouterr().err
        assert code == 2 and took < 2.0
        assert err.count("\n") == 1 and str(out / "deeper") in err and "Traceback" not in err
        code, took = _timed_main(["demo", "--no-meshcat", "--quiet", "--out", str(out)])
        err = capsys.readouterr().err
        assert code == 2 and took < 2.0 and "cannot write into the folder" in err
    finally:
        out.chmod(0o700)


def test_unwritable_out_fails_before_building(tmp_path: Path, capsys, monkeypatch) -> None:
    """Where permission bits cannot be used (root), a failing probe file stands for a read-only folder."""
    from drake_disamb.commands import _outputs

    def refuse(*args: object, **kwargs: object) -> None:
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(_outputs.tempfile, "mkstemp", refuse)
    code, took = _timed_main(["demo", "--no-meshcat", "--quiet", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == 2 and took < 2.0
    expected = f"--out: cannot write into the folder {tmp_path} (Permission denied)"
    assert err == f"drake-disamb demo: error: {expected}\n"
    assert not (tmp_path / "metrics.json").exists()


def test_bad_out_subprocess_is_fast_and_one_line(tmp_path: Path) -> None:
    """The whole process, interpreter start-up included, fails within 2 s and builds nothing."""
    blocker = tmp_path / "file.txt"
    blocker.write_text("")
    start = time.perf_counter()
    proc = cli_process("demo", "--no-meshcat", "--out", str(blocker))
    out, err = proc.communicate(timeout=30)
    assert time.perf_counter() - start < 2.0
    assert proc.returncode == 2
    assert err.strip().splitlines() == [
        f"drake-disamb demo: error: --out: {blocker} is a file, expected a folder"
    ]
    assert out == ""


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_signal_stops_the_trial_and_keeps_its_results(sig: signal.Signals, tmp_path: Path) -> None:
    # At half real time the default reaching trial (about 6 s simulated) cannot end by itself.
    proc = cli_process(
        "demo", "--no-meshcat", "--quiet", "--realtime-rate", "0.5", "--duration", "600",
        "--out", str(tmp_path),
    )  # fmt: skip
    out, err = interrupt(proc, sig)
    assert f"stopped by {sig.name}" in out
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["interrupted"] is True and metrics["success"] is False
    assert 0.5 < metrics["time"] < 6.0 and metrics["task"] == "reaching" and metrics["duration_limit"] == 600
    png = tmp_path / "goal_probabilities.png"
    assert png.stat().st_size > 10_000 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(tmp_path.glob(".*tmp*"))


@pytest.mark.parametrize(
    "mode",
    [
        ["--realtime-rate", "0.5"],  # with Meshcat: the recording so far is kept too
        ["--live"],  # a person ends a live trial with Ctrl-C: nothing of it may be lost
    ],
    ids=["meshcat", "live"],
)
def test_sigint_with_meshcat_keeps_metrics_figure_and_recording(mode: list[str], tmp_path: Path) -> None:
    proc = cli_process("demo", "--quiet", "--duration", "600", "--out", str(tmp_path), *mode)
    interrupt(proc, signal.SIGINT)
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["interrupted"] is True and metrics["time"] > 0.5
    assert (tmp_path / "goal_probabilities.png").stat().st_size > 10_000
    page = (tmp_path / "recording.html").read_text()
    assert "<html" in page.lower() and len(page) > 10_000


def test_stop_request_in_process_keeps_the_partial_trial(tmp_path: Path) -> None:
    """run_trial's stop_requested: the result covers the trial up to the stop, flagged interrupted."""
    from drake_disamb.commands.demo import metrics_dict
    from drake_disamb.config import load_scenario
    from drake_disamb.trial import run_trial

    result = run_trial(load_scenario("reaching"), progress=False, stop_requested=lambda: True)
    assert result.interrupted and not result.success and result.time < 0.05
    assert result.logs["belief"][1].shape[0] >= 1
    assert json.loads(json.dumps(metrics_dict(result)))["interrupted"] is True
