"""``study report DIR --compare OTHER``'s means per intended goal (``report/per_goal.json``, its
table in index.html and on stdout), on small synthetic folders whose answer is known."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from support import report_compared, study_trial

from drake_disamb.study.analysis.per_goal import per_goal
from drake_disamb.study.data.records import append_record


def _folder(path: Path, trials: list[tuple[str, str, int, int]]) -> Path:
    """A study folder of (interface, paradigm, goal, presses) reaching trials, one pouring trial
    (two stages: left out of the per-goal rows) and, last, one failed reaching trial to goal 4."""
    path.mkdir(parents=True)
    for n, (interface, paradigm, goal, presses) in enumerate(trials):
        record = study_trial(n, interface, "reaching", paradigm, presses)
        record.intended_goals = record.reached_goals = [goal]
        append_record(path / "trials.jsonl", record)
    append_record(path / "trials.jsonl", study_trial(len(trials), "joystick", "pouring", "manual", 5))
    failed = study_trial(len(trials) + 1, "joystick", "reaching", "manual", 40)
    failed.intended_goals, failed.success, failed.completion_time = [4], False, None
    append_record(path / "trials.jsonl", failed)
    return path


HERE = [("joystick", "manual", 0, 2), ("joystick", "manual", 0, 4), ("joystick", "manual", 2, 9)]
HERE += [("joystick", "disambiguation", 0, 1), ("head_array", "manual", 1, 12)]
THERE = [("joystick", "manual", 0, 6), ("joystick", "manual", 3, 1), ("joystick", "disambiguation", 2, 3)]


@pytest.fixture(scope="module")
def compared(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    root = tmp_path_factory.mktemp("per_goal")
    here, there = _folder(root / "here", HERE), _folder(root / "there", THERE)
    return here, report_compared(here, there)


def _rows(folder: Path) -> dict[tuple[str, str, int], dict]:
    rows = json.loads((folder / "report" / "per_goal.json").read_text())
    return {(r["interface"], r["paradigm"], r["goal"]): r for r in rows}


def test_the_means_per_goal_side_by_side(compared: tuple[Path, str]) -> None:
    here, _ = compared
    rows = _rows(here)
    # Only the joystick's reaching conditions are in both folders; the pouring trial names 2 goals.
    assert {r["task"] for r in rows.values()} == {"reaching"}
    assert set(rows) == {
        ("joystick", "manual", 0),
        ("joystick", "manual", 2),
        ("joystick", "manual", 3),
        ("joystick", "manual", 4),
        ("joystick", "disambiguation", 0),
        ("joystick", "disambiguation", 2),
    }
    r = rows[("joystick", "manual", 0)]
    assert (r["trials"], r["failed"], r["analysed"]) == (2, 0, 2)
    assert r["mode_switches"] == pytest.approx(3.0) and r["requests"] == pytest.approx(0.0)
    assert r["completion_time"] == pytest.approx(200.0)
    assert (r["other_trials"], r["other_mode_switches"]) == (1, pytest.approx(6.0))
    only_there = rows[("joystick", "disambiguation", 2)]
    assert only_there["trials"] == 0 and only_there["mode_switches"] is None
    assert only_there["other_mode_switches"] == pytest.approx(3.0)
    failed = rows[("joystick", "manual", 4)]  # counted, out of the means
    assert (failed["trials"], failed["failed"], failed["analysed"]) == (1, 1, 0)
    assert failed["mode_switches"] is None


def test_the_table_is_printed_and_on_the_page(compared: tuple[Path, str]) -> None:
    here, printed = compared
    assert "Per intended goal (single-stage tasks)" in printed
    line = next(x for x in printed.splitlines() if x.startswith("joystick") and "manual" in x and "  0 " in x)
    assert "2 (0)" in line and "3.00" in line and "6.00" in line
    assert "Per intended goal: this folder beside the other" in (here / "report" / "index.html").read_text()


def test_without_single_goal_tasks_there_are_no_rows(tmp_path: Path) -> None:
    a = [study_trial(0, "joystick", "pouring", "manual", 3)]
    assert per_goal(a, a) == []


def test_grouped_table_aligns_labels_left_numbers_right_in_groups() -> None:
    from drake_disamb.study.analysis.text_table import grouped_table, number

    body = [["x", number(1.5), number(None)], ["long", "10.25", "2"]]
    lines = grouped_table(["name", "a", "b"], body, (1, 2))
    assert lines == ["name |     a  b", "x    |  1.50  -", "long | 10.25  2"]
    assert number(float("nan")) == "-" and number(2.0, 1) == "2.0"
    with pytest.raises(ValueError, match="groups"):
        grouped_table(["a", "b"], [], (1, 2))
