"""Per intended goal, one study folder beside another's: where a cell's mean comes from.

:func:`per_goal` is ``study report DIR --compare OTHER``'s ``per_goal.json``. A cell mean (interface,
task, paradigm) mixes the goals its trials drew, and a protocol draws them at random, as the paper's
study did: a goal that is much harder for one population than for the other moves the cell by as
much as the share of its trials. The rows set the two folders side by side per goal, for the tasks
whose records all name a single intended goal (reaching; a multi-step task's records of people name
one goal where the simulated ones name one per stage, so they do not pair), and for the conditions
(interface, task, paradigm) both folders hold.

One object per interface, task, paradigm and goal (of either folder), with the keys ``interface``,
``task``, ``paradigm``, ``goal`` (0-based index) and, for ``DIR`` and (prefixed ``other_``) for
``OTHER``: ``trials`` (records), ``failed`` (of them: unsuccessful, or for people's logs the
authors' excluded trials), ``analysed`` (neither: the trials of the means), and ``mode_switches``,
``requests`` and ``completion_time`` (means over the analysed trials after the authors' cleaning,
as the report's summary computes them; None where none).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from drake_disamb.study.analysis.text_table import grouped_table, number
from drake_disamb.study.data.records import TrialRecord
from drake_disamb.study.measures.metrics import TrialMetrics, trial_metrics

__all__ = ["GOAL_METRICS", "SIDE_KEYS", "per_goal", "per_goal_text"]

GOAL_METRICS = ("mode_switches", "requests", "completion_time")
"""The means of each side of a row."""
SIDE_KEYS = ("trials", "failed", "analysed", *GOAL_METRICS)
"""The keys of one side of a row (``other_<key>`` for ``OTHER``)."""


def _multi_stage(records: Sequence[TrialRecord]) -> set[str]:
    """The tasks of which some record names other than one intended goal (or none)."""
    return {r.task for r in records if r.intended_goals is None or len(r.intended_goals) != 1}


def _group(
    records: Sequence[TrialRecord], skip: set[str]
) -> dict[tuple[str, str, str, int], list[TrialMetrics]]:
    groups: dict[tuple[str, str, str, int], list[TrialMetrics]] = {}
    for r in records:
        if r.task not in skip and r.intended_goals is not None:
            key = (r.interface, r.task, r.paradigm, int(r.intended_goals[0]))
            groups.setdefault(key, []).append(trial_metrics(r))
    return groups


def _side(metrics: Sequence[TrialMetrics]) -> dict[str, Any]:
    analysed = [m for m in metrics if m.analysed]
    side: dict[str, Any] = {
        "trials": len(metrics),
        "failed": sum(m.success is False for m in metrics),
        "analysed": len(analysed),
    }
    for name in GOAL_METRICS:
        values = [v for v in (m.value(name) for m in analysed) if v is not None]
        side[name] = sum(values) / len(values) if values else None
    return side


def per_goal(records: Sequence[TrialRecord], other: Sequence[TrialRecord]) -> list[dict[str, Any]]:
    """The rows of ``per_goal.json`` (module docstring), sorted by interface, task, paradigm, goal."""
    skip = _multi_stage(records) | _multi_stage(other)
    mine, theirs = _group(records, skip), _group(other, skip)
    # Only the conditions both folders hold (a paradigm one of them did not run pairs with nothing).
    both = {k[:3] for k in mine} & {k[:3] for k in theirs}
    rows = []
    for key in sorted(k for k in {*mine, *theirs} if k[:3] in both):
        here, there = _side(mine.get(key, [])), _side(theirs.get(key, []))
        rows.append(
            {
                "interface": key[0],
                "task": key[1],
                "paradigm": key[2],
                "goal": key[3],
                **here,
                **{f"other_{k}": v for k, v in there.items()},
            }
        )
    return rows


def per_goal_text(rows: Sequence[dict[str, Any]], here: str, there: str) -> str:
    """``rows`` as the compact table ``study report --compare`` prints (``here`` / ``there`` name
    the folders): per goal, trials (failed), switches, requests and completion time on each side."""
    header = ["interface", "task", "paradigm", "goal", "n", "switches", "requests", "time s"]
    header += ["n", "switches", "requests", "time s"]
    body = []
    for r in rows:
        line = [r["interface"], r["task"], r["paradigm"], str(r["goal"])]
        for p in ("", "other_"):
            line += [
                f"{r[p + 'trials']} ({r[p + 'failed']})",
                number(r[p + "mode_switches"], 2),
                number(r[p + "requests"], 2),
                number(r[p + "completion_time"], 1),
            ]
        body.append(line)
    title = [
        "Per intended goal (single-stage tasks): trials (failed), then means over the analysed trials",
        f"left: {here}; right: {there}",
    ]
    return "\n".join([*title, *grouped_table(header, body, (4, 4, 4))])
