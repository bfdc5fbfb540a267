"""``drake-disamb demo``: argument errors, a headless run, a Meshcat run with its recording, the plot."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from drake_disamb.cli import main
from drake_disamb.plotting import nonzero_segments, plot_goal_probabilities


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--task", "juggling"], "task: expected one of reaching, pouring"),
        (["--interface", "keyboard"], "interface: expected one of"),
        (["--paradigm", "auto"], "paradigm: expected one of"),
        (["--goal", "9"], "goal: expected an index in [0, 4]"),
        (["--task", "/no/such/file.yaml"], "no such scenario file"),
        (["--live"], "--live needs Meshcat"),
        (["--duration", "0"], "--duration: expected a number > 0"),
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
    from drake_disamb.scenarios import embedded_scenario_text

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
    png = tmp_path / "goal_probabilities.png"
    assert png.stat().st_size > 10_000 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (tmp_path / "diagram.dot").read_text().startswith("digraph")
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


def test_plot_rejects_mismatched_shapes(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="belief"):
        plot_goal_probabilities(np.arange(3), np.ones((4, 2)), tmp_path / "x.png")
    with pytest.raises(ValueError, match="goal_names"):
        plot_goal_probabilities(np.arange(3), np.ones((3, 2)) / 2, tmp_path / "x.png", goal_names=["a"])
