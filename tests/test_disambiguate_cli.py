"""``drake-disamb disambiguate``: JSON in, pure JSON out, per-case errors, --explain."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

from drake_disamb.commands import disambiguate as command
from drake_disamb.core.disambiguation import disambiguate, preset

Y_SCENE = {
    "belief": [0.5, 0.5],
    "position": [0.0, 0.0, 0.1],
    "goals": [[0.2, -0.25, 0.1], [0.2, 0.25, 0.1]],
    "modes": [[0], [1], [2], [3], [4], [5]],
    "current_mode": 0,
}
ROTATION_SCENE = {
    "belief": [0.5, 0.5],
    "position": [0.0, -0.3, 0.2],
    "orientation": [1.0, 0.0, 0.0, 0.0],
    "goals": [
        [0.3, -0.3, 0.2, 0.955336, 0.0, 0.0, 0.295520],
        [0.3, -0.3, 0.2, 0.955336, 0.0, 0.0, -0.295520],
    ],
    "modes": [[0, 1], [0, 2], [3, 5], [4]],
    "current_mode": 4,
}


def _run(tmp_path: Path, cases: object, *extra: str) -> int:
    """Parse and run exactly as ``cli.py`` does for this sub-command."""
    path = tmp_path / "cases.json"
    path.write_text(json.dumps(cases), encoding="utf-8")
    parser = argparse.ArgumentParser(prog="drake-disamb disambiguate")
    command.add_arguments(parser)
    args = parser.parse_args(["--cases", str(path), *extra])
    return command.run(args)


def test_valid_cases_print_pure_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    r3 = dict(
        Y_SCENE, preset="authors-r3", modes=[[0], [1], [2]], transition_matrix=[[0.99, 0.01], [0.02, 0.98]]
    )
    code = _run(tmp_path, [Y_SCENE, ROTATION_SCENE, r3])
    out = capsys.readouterr()
    assert code == 0
    results = json.loads(out.out)  # stdout is exactly one JSON document
    assert [r["mode"] for r in results] == [1, 2, 1]
    # Same numbers as the core.
    core = disambiguate(Y_SCENE["belief"], Y_SCENE["position"], np.array(Y_SCENE["goals"]), Y_SCENE["modes"],
                        preset("mico"), current_mode=0)  # fmt: skip
    np.testing.assert_allclose(results[0]["mode_scores"], core.mode_scores, rtol=1e-12)
    np.testing.assert_allclose(results[0]["dimension_scores"]["plus"], core.scores_plus, rtol=1e-12)
    assert set(results[0]["features"]) == {"gamma", "omega", "lambda", "upsilon"}
    assert len(results[2]["dimension_scores"]["minus"]) == 3
    assert "explanation" not in results[0]


def test_kept_mode_is_null(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    case = dict(Y_SCENE, current_mode=1)
    code = _run(tmp_path, [case])
    assert code == 0
    assert json.loads(capsys.readouterr().out)[0]["mode"] is None


def test_invalid_cases_get_errors_in_place(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cases = [
        Y_SCENE,
        dict(Y_SCENE, belief=[0.5, 0.6]),  # does not sum to 1
        dict(Y_SCENE, belief=[1.0]),  # wrong length
        dict(Y_SCENE, goals=[[0.2, -0.25], [0.2, 0.25, 0.1]]),
        dict(Y_SCENE, modes=[[0], [8]]),
        dict(Y_SCENE, preset="fast"),
        dict(Y_SCENE, transition_matrix=[[0.5, 0.6], [0.0, 1.0]]),
        dict(Y_SCENE, orientation=[0, 0, 0, 0]),
        dict(Y_SCENE, current_mode=-2),
        {k: v for k, v in Y_SCENE.items() if k != "position"},
        dict(Y_SCENE, speed=3),
        "not an object",
        ROTATION_SCENE,
    ]
    code = _run(tmp_path, cases)
    results = json.loads(capsys.readouterr().out)
    assert code == 1
    assert len(results) == len(cases)
    assert results[0]["mode"] == 1 and results[-1]["mode"] == 2
    expected_fields = ["belief", "belief", "goals[0]", "modes", "preset", "transition_matrix", "orientation",
                       "current_mode", "position", "speed", "case"]  # fmt: skip
    for i, field in enumerate(expected_fields, start=1):
        assert set(results[i]) == {"error"}
        assert results[i]["error"].startswith(f"case {i}: field '{field}'"), results[i]["error"]


def test_explain(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = _run(tmp_path, [ROTATION_SCENE], "--explain")
    out = capsys.readouterr()
    assert code == 0
    result = json.loads(out.out)[0]
    assert "Chose mode 2 {wx, wz}" in result["explanation"]
    assert "--- case 0 ---" in out.err and "Chose mode 2" in out.err


def test_default_preset_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    case = dict(Y_SCENE, modes=[[0], [1], [2]])
    _run(tmp_path, [case], "--preset", "authors-r3")
    result = json.loads(capsys.readouterr().out)[0]
    assert result["dimensions"] == [0, 1, 2]


def test_unreadable_file_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    parser = argparse.ArgumentParser()
    command.add_arguments(parser)
    assert command.run(parser.parse_args(["--cases", str(tmp_path / "missing.json")])) == 2
    bad = tmp_path / "bad.json"
    bad.write_text('{"belief": []}', encoding="utf-8")
    assert command.run(parser.parse_args(["--cases", str(bad)])) == 2
    out = capsys.readouterr()
    assert out.out == "" and "expected a JSON list" in out.err


def test_registered_in_cli() -> None:
    from drake_disamb.cli import COMMANDS

    assert COMMANDS["disambiguate"] == "disambiguate"
    assert command.HELP and callable(command.add_arguments) and callable(command.run)
