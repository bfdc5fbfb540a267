"""The scripts in ``diagrams/``: each builds its diagram, simulates it and writes its picture."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import pytest

DIAGRAMS = Path(__file__).resolve().parent.parent / "diagrams"


def _run(script: str, argv: list[str], monkeypatch: pytest.MonkeyPatch) -> int:
    monkeypatch.setattr(sys, "argv", [str(DIAGRAMS / script), *argv])
    with pytest.raises(SystemExit) as exit_info:
        runpy.run_path(str(DIAGRAMS / script), run_name="__main__")
    return exit_info.value.code


@pytest.mark.parametrize(
    ("script", "argv", "picture"),
    [
        ("reaching.py", ["--interface", "joystick", "--paradigm", "manual", "--duration", "0.5"],
         "reaching_joystick_manual.dot"),
        ("pouring.py", ["--duration", "0.5"], "pouring_head_array_disambiguation.dot"),
        ("station.py", [], "station.dot"),
    ],
)  # fmt: skip
def test_script_writes_its_picture(
    script: str, argv: list[str], picture: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys
) -> None:
    assert _run(script, [*argv, "--out", str(tmp_path)], monkeypatch) == 0
    dot = tmp_path / picture
    assert dot.is_file() and dot.read_text().lstrip().startswith("digraph")
    assert f"wrote {dot}" in capsys.readouterr().out
    if script == "station.py":  # the station's inputs are joint-level; the IK sits in front of it
        text = dot.read_text()
        assert "arm_velocity_command" in text and "finger_velocity_command" in text
        assert "ee_velocity_command" not in text and "diff_ik" not in text
        assert "diff_ik" in (tmp_path / "controlled_station.dot").read_text()


def test_station_script_rejects_a_stray_argument(monkeypatch: pytest.MonkeyPatch) -> None:
    assert _run("station.py", ["--help-me"], monkeypatch) == 2
