"""The experimenter's rule (``success.give_up_after``): a trial with no progress toward the intended
goal for that long ends there as a failure, and every trial says how it ended."""

from __future__ import annotations

import dataclasses
import math

import pytest
from support import study_trial

from drake_disamb.config import load_scenario, scenario_from_dict, scenario_to_dict
from drake_disamb.study.measures.metrics import summarize
from drake_disamb.study.run.outcome import ik_held_share, trace_arrays
from drake_disamb.trial import GiveUpWatch, run_trial


def _stuck(give_up_after: float | None):  # noqa: ANN202
    # From the left container to the low right platform the elbow reaches its limit, and a user
    # that never backs off (backoff_time 0) keeps pushing: no progress from about 15 s on.
    scenario = load_scenario("pouring", {"interface": "head_array", "user": {"goals": [1, 0]}})
    scenario.inference.goal_set = "stage"
    scenario.user.config.backoff_time = 0.0
    scenario.success.give_up_after = give_up_after
    return run_trial(dataclasses.replace(scenario, duration=60.0), progress=False)


class _Task:
    """What the watch reads of a task manager: the stage and the goal error (tolerance units)."""

    def __init__(self) -> None:
        self.now_stage, self.error = 0, 10.0

    def stage(self, context: object) -> int:
        return self.now_stage

    def goal_error(self, context: object, goal: int) -> float:
        return self.error


def test_the_watch_looks_every_half_second_and_counts_a_whole_unit_or_a_new_stage_as_progress() -> None:
    task = _Task()
    watch = GiveUpWatch(task, None, [0, 1], give_up_after=2.0)  # type: ignore[arg-type]
    assert not watch.hopeless(0.0) and (watch.best, watch.since, watch.stage) == (10.0, 0.0, 0)
    task.error = 9.5  # less than a unit closer: no progress
    assert not watch.hopeless(0.3) and watch.next_look == 0.5  # between looks: not even read
    assert not watch.hopeless(1.0) and watch.since == 0.0
    task.error = 8.9  # a whole unit closer: progress
    assert not watch.hopeless(1.5) and (watch.best, watch.since) == (8.9, 1.5)
    assert not watch.hopeless(3.0) and watch.hopeless(3.5)  # 2 s without progress
    task.now_stage = 1  # a new stage is progress, whatever its error
    task.error = 50.0
    assert not watch.hopeless(4.0) and (watch.stage, watch.since) == (1, 4.0)
    task.now_stage = 2  # past the last stage (done): never hopeless
    assert not watch.hopeless(10.0)


@pytest.mark.slow
def test_a_stuck_trial_is_given_up_and_a_free_one_is_not() -> None:
    stuck = _stuck(10.0)
    assert stuck.end_reason == "given up" and not stuck.success
    # ... held by the IK: the elbow on its limit, every command of the no-progress window STOPPED
    trace = trace_arrays(stuck)
    assert ik_held_share(trace, window=10.0) == pytest.approx(1.0)
    assert 0.2 < ik_held_share(trace) < 0.8  # the whole trial: free before ~15 s
    assert 20.0 < stuck.time < 40.0, stuck.time  # stuck from ~15 s, given up 10 s later
    assert stuck.progress_age == pytest.approx(10.0, abs=0.5)  # the watch looks every 0.5 s
    limit = _stuck(None)
    assert limit.end_reason == "time limit" and limit.time == pytest.approx(60.0)
    assert math.isnan(limit.progress_age)  # no watch without the rule
    watched = _stuck(50.0)  # the watch on, the rule too late to fire: it says the arm was stuck
    assert watched.end_reason == "time limit" and 35.0 < watched.progress_age < 50.0, watched.progress_age
    done = run_trial(load_scenario("reaching"), progress=False)
    assert done.end_reason == "done" and done.success


def test_give_up_after_is_checked() -> None:
    plain = scenario_to_dict(load_scenario("reaching"))
    for bad in (0.0, -1.0, 1e9):
        plain["success"]["give_up_after"] = bad
        with pytest.raises(
            ValueError, match=r"scenario\.success\.give_up_after: expected a number of seconds"
        ):
            scenario_from_dict(plain)


def test_the_protocol_gives_up_after_a_minute_and_records_say_how_trials_ended(tmp_path) -> None:  # noqa: ANN001
    import json
    import subprocess
    import sys

    from drake_disamb.study.design.protocol import default_protocol, default_protocol_text, protocol_from_yaml

    assert default_protocol().give_up_after == 60.0
    with pytest.raises(ValueError, match=r"protocol\.give_up_after: expected a number of seconds"):
        protocol_from_yaml(default_protocol_text().replace("give_up_after: 60.0", "give_up_after: -5"))
    out = tmp_path / "q"
    run = [
        sys.executable,
        "-m",
        "drake_disamb.cli",
        "study",
        "run",
        "--quick",
        "--subjects",
        "1",
        "--out",
        str(out),
    ]
    assert subprocess.run(run, capture_output=True, text=True, timeout=900).returncode == 0
    records = [json.loads(line) for line in (out / "trials.jsonl").read_text().splitlines()]
    assert records and all(r["extra"]["end_reason"] in ("done", "given up", "time limit") for r in records)
    assert all((r["extra"]["end_reason"] == "done") == r["done"] for r in records)
    # Every protocol trial has the experimenter's watch: how long before the end the arm last came
    # closer to its goal (under a minute, else the trial was given up on).
    ages = [r["extra"]["progress_age"] for r in records]
    assert all(isinstance(a, float) and 0.0 <= a for a in ages), ages
    watched = [a for r, a in zip(records, ages, strict=True) if r["extra"]["end_reason"] != "given up"]
    assert all(a < 60.0 + 0.5 for a in watched), watched
    report = subprocess.run(
        [sys.executable, "-m", "drake_disamb.cli", "study", "report", str(out)],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert report.returncode == 0 and "trials ended: done" in report.stdout


def test_the_summary_lists_how_much_the_ik_held_each_failed_trial() -> None:
    records = []
    for n, (success, held) in enumerate([(True, 0.9), (False, 0.7), (False, 0.1), (False, None)]):
        r = study_trial(n, "joystick", "reaching", "manual", presses=2)
        records.append(dataclasses.replace(r, success=success, extra={**r.extra, "ik_held": held}))
    (row,) = summarize(records)
    assert row["failed_ik_held"] == [0.1, 0.7]  # failed trials only, those that logged it
