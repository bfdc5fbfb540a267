"""``drake-disamb study rerun DIR TRIAL_ID``: run one simulated trial again from its record alone.

Every record keeps the scenario its trial ran (``extra.scenario``, the YAML ``demo
--dump-scenario`` writes), so the trial runs again from that record alone (no protocol, no
``study.yaml``: :func:`~drake_disamb.study.run.runner.rerun_trial`). The command compares the new
record (all but ``wall_time``) and trace with those in ``DIR`` and prints either that they are the
same or each field and trace array that differs. Nothing is written. To run the trial another way
(watched in Meshcat, another interface), save its scenario to a file and give it to ``demo --task
FILE``: the scenario loads back, alone, to the one that ran.

Exit status: 0 the same record and trace; 1 they differ; 2 bad input (no such folder, record or
trial; a record without a scenario, of an older drake-disamb or the authors' logs; a person's
trial, whose commands are not in its scenario); 130 stopped by SIGINT or SIGTERM.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "Run one simulated trial of a study folder again from its record alone and compare."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the ``study rerun`` options."""
    parser.add_argument("folder", type=Path, metavar="DIR", help="a study folder (trials.jsonl, traces/)")
    parser.add_argument("trial_id", metavar="TRIAL_ID", help="the trial's trial_id in DIR/trials.jsonl")
    parser.add_argument("--quiet", action="store_true", help="no progress display")


def differences(old: dict, new: dict, prefix: str = "") -> list[str]:
    """``field: old -> new`` of every field (nested in ``extra``) that differs between two records'
    fields (``dataclasses.asdict``)."""
    lines = []
    for key in sorted(set(old) | set(new)):
        a, b = old.get(key), new.get(key)
        if isinstance(a, dict) and isinstance(b, dict):
            lines += differences(a, b, f"{prefix}{key}.")
        elif a != b:
            lines.append(f"{prefix}{key}: {str(a)[:80]} -> {str(b)[:80]}")
    return lines


def _error(message: object) -> int:
    print(f"drake-disamb study rerun: error: {message}", file=sys.stderr)
    return 2


def run(args: argparse.Namespace) -> int:
    """``study rerun``: 0 the same, 1 different, 2 bad input."""
    import numpy as np

    from drake_disamb.study.data.folder import StudyFolder
    from drake_disamb.study.run.runner import records_by_id, rerun_trial

    folder = StudyFolder(args.folder)
    try:
        if not folder.records_path.is_file():
            raise ValueError(f"{folder.records_path}: no such file (not a study folder)")
        records = {r.trial_id: r for r in folder.read_records()}
        record = records.get(args.trial_id)
        if record is None:
            raise ValueError(f"{folder.records_path}: no trial {args.trial_id!r}")
        source = f"{folder.records_path}: {args.trial_id}"
        print(f"rerunning {args.trial_id} from its record in {folder.records_path}", flush=True)
        new, trace = rerun_trial(record, source, progress=not args.quiet)
    except ValueError as exc:
        return _error(exc)
    lines = differences(*(records_by_id([r])[r.trial_id] for r in (record, new)))
    try:
        old_trace = folder.read_trace(args.trial_id)
    except ValueError as exc:
        lines.append(f"trace: {exc}")
        old_trace = {}
    for name in sorted(set(old_trace) | set(trace)) if old_trace else ():
        a, b = old_trace.get(name), trace.get(name)
        if a is None or b is None or a.shape != b.shape or not np.array_equal(a, b, equal_nan=True):
            lines.append(f"trace {name}: differs")
    outcome = f"success {'yes' if new.success else 'no'}, {new.duration:g} s, {new.button_presses} presses"
    if lines:
        print(f"the rerun differs from the record ({outcome}):")
        print("\n".join(f"  {line}" for line in lines))
        return 1
    print(f"the same record and trace ({outcome})")
    return 0
