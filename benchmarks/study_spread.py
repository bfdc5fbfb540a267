"""Several study folders (seeds) beside the people: how much of a check is the draw.

Usage::

    python benchmarks/study_spread.py out/study out/study-seed1 out/study-seed2 --compare out/authors

A study of 8 simulated subjects with 3 Manual and 5 Disambiguation trials per condition has a wide
spread between seeds: each folder is one draw of subjects, goals, starts and latencies. For each
folder (a ``study run`` or ``python benchmarks/bench_study.py --seed S --out DIR``) this prints,
against the ``--compare`` folder (the people's records, ``study import-authors``), the checks of
the simulated population as ``study report --compare`` makes them:

- the conditions (interface, task; Manual and Disambiguation) whose mean user mode switches,
  requests or completion time is more than :data:`WITHIN` off the people's (ratio simulated /
  people; requests in Disambiguation only);
- the success rate per paradigm (all trials) and the share of the Manual and Disambiguation
  failures that are in the multi-step task;
- the paradigm effect per interface (both tasks; Manual -> Disambiguation relative change of button
  presses and of user mode switches, the ratio to the people's and whether it is within a factor of
  2 in the same direction), from :func:`drake_disamb.study.analysis.effect.paradigm_effect`;

then, per effect, its range over the folders and how many pass. The means are the report's (failed
trials left out, after the authors' cleaning). Nothing is written.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from drake_disamb.study.analysis.effect import FACTOR, paradigm_effect
from drake_disamb.study.analysis.findings import compare_summaries
from drake_disamb.study.data.records import RecordError, TrialRecord
from drake_disamb.study.measures.metrics import summarize
from drake_disamb.study.report.page import load_study

WITHIN = 0.35
"""A condition's mean is off when ``|ratio - 1|`` exceeds this (the issue's criterion)."""

CHECKED = (
    ("mean_mode_switches", "switches"),
    ("mean_requests", "requests"),
    ("mean_completion_time", "time"),
)
"""The means whose ratio is checked, and their short names."""

PARADIGMS = ("manual", "disambiguation")


def off_cells(records: list[TrialRecord], people: list[TrialRecord]) -> list[str]:
    """The conditions' means more than :data:`WITHIN` off the people's, as ``name ratio`` strings."""
    rows = compare_summaries(summarize(records), summarize(people))
    out = []
    for r in rows:
        if r["paradigm"] not in PARADIGMS:
            continue
        for key, short in CHECKED:
            if key == "mean_requests" and r["paradigm"] != "disambiguation":
                continue
            ratio = r[f"ratio_{key}"]
            if ratio is not None and abs(ratio - 1.0) > WITHIN:
                out.append(f"{r['interface']} {r['task']} {r['paradigm']} {short} {ratio:.2f}")
    return out


def success(records: list[TrialRecord]) -> tuple[dict[str, float], int, int]:
    """Success rate per paradigm, and (failures in the multi-step task, failures) of the Manual and
    Disambiguation trials."""
    rates = {}
    for paradigm in sorted({r.paradigm for r in records}):
        trials = [r for r in records if r.paradigm == paradigm and r.success is not None]
        if trials:
            rates[paradigm] = sum(bool(r.success) for r in trials) / len(trials)
    failed = [r for r in records if r.paradigm in PARADIGMS and r.success is False]
    multi_step = sum(len(r.intended_goals or []) > 1 for r in failed)  # a goal per stage
    return rates, multi_step, len(failed)


def effects(records: list[TrialRecord], people: list[TrialRecord]) -> dict[tuple[str, str], dict]:
    """The paradigm effect per (interface, metric), both tasks together."""
    return {(r["interface"], r["metric"]): r for r in paradigm_effect(records, people) if r["task"] == "all"}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="+", type=Path, help="study folders (one per seed)")
    parser.add_argument("--compare", type=Path, required=True, help="the people's records")
    args = parser.parse_args()
    try:
        people = load_study(args.compare)
        studies = [(folder, load_study(folder)) for folder in args.folders]
    except (RecordError, OSError, ValueError) as err:
        print(f"study_spread: {err}", file=sys.stderr)
        return 2
    table: dict[tuple[str, str], list[dict]] = {}
    for folder, records in studies:
        rates, in_pouring, failed = success(records)
        print(f"{folder}: {len(records)} trials")
        off = off_cells(records, people)
        print(f"  conditions off by more than {WITHIN:.0%}: {len(off)}" + "".join(f"\n    {c}" for c in off))
        print(
            "  success "
            + ", ".join(f"{p} {100 * v:.1f} %" for p, v in rates.items())
            + f"; Manual and Disambiguation failures in pouring: {in_pouring} of {failed}"
        )
        for key, row in sorted(effects(records, people).items()):
            table.setdefault(key, []).append(row)
            change, theirs, ratio = row["relative_change"], row["other_relative_change"], row["ratio"]
            print(
                f"  effect {key[0]} {key[1].replace('_', ' ')}: "
                + ("-" if change is None else f"{100 * change:+.0f} %")
                + " (people "
                + ("-" if theirs is None else f"{100 * theirs:+.0f} %")
                + "), ratio "
                + ("n/a" if ratio is None else f"{ratio:.2f}")
                + (" ok" if row["check"] else " OUT")
            )
    print("spread over the folders:")
    for key, rows in sorted(table.items()):
        changes = [r["relative_change"] for r in rows if r["relative_change"] is not None]
        passed = sum(bool(r["check"]) for r in rows)
        span = f"{100 * min(changes):+.0f} % to {100 * max(changes):+.0f} %" if changes else "-"
        name = f"{key[0]} {key[1].replace('_', ' ')}"
        print(f"  {name}: {span}; within a factor of {FACTOR:g}: {passed} of {len(rows)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
