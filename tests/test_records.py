"""Trial records: round trip, append-only writing, the half-written last line, clear errors."""

from __future__ import annotations

import dataclasses
import json

import pytest

from drake_disamb.study.data.records import FORMAT, RecordError, TrialRecord, append_record, read_records


def _record(trial_id: str = "t0", **changes) -> TrialRecord:
    values = dict(
        trial_id=trial_id,
        subject="S01",
        interface="head_array",
        task="reaching",
        paradigm="disambiguation",
        disambiguation_method="algorithm1",
        repetition=0,
        seed=7,
        start_pose=1,
        initial_mode="vx",
        intended_goals=[2],
        reached_goals=[2],
        success=True,
        done=True,
        duration=31.5,
        completion_time=31.5,
        mode_switches=2,
        requests=1,
        automatic_switches=0,
        button_presses=3,
        request_times=[1.2],
        mode_switch_times=[4.0, 9.5],
        mode_switch_modes=["vy", "vz"],
        automatic_switch_times=[],
        mean_alpha=0.3,
        assistance_onset=5.0,
        wall_time=2.5,
    )
    values.update(changes)
    return TrialRecord(**values)


def test_round_trip_and_append(tmp_path):
    path = tmp_path / "trials.jsonl"
    append_record(path, _record("a"))
    append_record(path, _record("b", seed=8))
    records = read_records(path)
    assert [r.trial_id for r in records] == ["a", "b"]
    assert records[0] == _record("a")
    assert json.loads(path.read_text().splitlines()[1])["format"] == FORMAT


def test_half_written_last_line_is_cut_only_on_repair(tmp_path):
    path = tmp_path / "trials.jsonl"
    append_record(path, _record("a"))
    with open(path, "a") as f:
        f.write(_record("b").to_json()[:40])
    with pytest.raises(RecordError, match=r"trials.jsonl:2: the last line is incomplete"):
        read_records(path)
    assert [r.trial_id for r in read_records(path, repair=True)] == ["a"]
    assert path.read_text() == _record("a").to_json() + "\n"


@pytest.mark.parametrize(
    ("line", "match"),
    [
        ("{not json", r"trials.jsonl:2: not a JSON record"),
        ("[1, 2]", r"trials.jsonl:2: expected a JSON object"),
        (json.dumps({**dataclasses.asdict(_record("x")), "format": 0}), r"trials.jsonl:2: record format 0"),
        (json.dumps({**dataclasses.asdict(_record("x")), "colour": 1}), r"unknown \['colour'\]"),
        (_record("a").to_json(), r"trials.jsonl:2: trial_id 'a' appears twice"),
        ("", r"trials.jsonl:2: empty line"),
    ],
)
def test_malformed_lines_name_file_and_line(tmp_path, line, match):
    path = tmp_path / "trials.jsonl"
    append_record(path, _record("a"))
    with open(path, "a") as f:
        f.write(line + "\n")
    before = path.read_bytes()
    with pytest.raises(RecordError, match=match):
        read_records(path, repair=True)
    assert path.read_bytes() == before


def test_inconsistent_counts_are_refused():
    with pytest.raises(RecordError, match="button_presses"):
        _record(button_presses=4)
    with pytest.raises(RecordError, match="mode_switch_times"):
        _record(mode_switch_times=[1.0])
    with pytest.raises(RecordError, match="source"):
        _record(source="robot")
    with pytest.raises(RecordError, match="duration"):
        _record(duration=float("nan"))


@pytest.mark.parametrize(
    "task, intended, reached, message",
    [
        ("reaching", [99], [99], r"field intended_goals: expected indices of the reaching task's goals "
         r"\(5 goals: 0 to 4\), got \[99\]"),
        ("reaching", [5], None, r"field intended_goals: .*\(5 goals: 0 to 4\), got \[5\]"),
        ("reaching", [4], [5], r"field reached_goals: .*\(5 goals: 0 to 4 or -1\), got \[5\]"),
        ("pouring", [0, 2], [0, 1], r"field intended_goals: .*pouring task's goals \(per stage: 0 to 1, "
         r"0 to 1\), got \[0, 2\]"),
        ("pouring", [4], None, r"field intended_goals: .*\(4 goals: 0 to 3\), got \[4\]"),
        ("pouring", [0, 1, 0], None, r"field intended_goals: expected one goal index per stage of the "
         r"pouring task \(2\) or one index into its 4 goals"),
    ],
)  # fmt: skip
def test_a_goal_that_is_not_one_of_the_tasks_is_refused(task, intended, reached, message):
    with pytest.raises(RecordError, match=message):
        _record(task=task, intended_goals=intended, reached_goals=reached)


def test_the_goals_of_every_task_are_accepted():
    for goal in range(5):
        _record(intended_goals=[goal], reached_goals=[-1])
    for goals in ([0, 0], [1, 1], [1, 0]):
        _record(task="pouring", intended_goals=goals, reached_goals=[goals[0], -1])
    for goal in range(4):  # the people's pouring logs name one of the task's 4 goals
        _record(task="pouring", intended_goals=[goal], reached_goals=None)


def test_a_reader_without_the_lock_reads_past_a_half_written_line_and_leaves_it(tmp_path) -> None:  # noqa: ANN001
    path = tmp_path / "trials.jsonl"
    append_record(path, _record("t0"))
    with open(path, "a", encoding="utf-8") as f:
        f.write(_record("t1").to_json()[:40])  # what a killed writer leaves
    before = path.read_bytes()
    with pytest.raises(RecordError, match="the last line is incomplete"):
        read_records(path)
    assert [r.trial_id for r in read_records(path, skip_incomplete=True)] == ["t0"]
    assert path.read_bytes() == before  # nothing written
    assert [r.trial_id for r in read_records(path, repair=True, skip_incomplete=True)] == ["t0"]
    assert path.read_bytes() == before[: before.index(b"\n") + 1]  # the repair still cuts it
