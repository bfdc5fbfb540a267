"""``drake-disamb study report DIR [--compare OTHER_DIR]``: the paper's analysis of a study folder."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "Analyse a study folder as the paper did: metrics, tests, figures and an HTML report in DIR/report/."

EPILOG = """\
Reads DIR/trials.jsonl and DIR/traces/ (simulated, human or the authors' records, or a mix) and
writes only DIR/report/: index.html (self-contained), summary.json, stats.json and the figures as
PNG. With --compare also compare.json (the means side by side), paradigm_effect.json (the
Manual -> Disambiguation effect here and there) and per_goal.json (the means per intended goal of
the reaching task, here and there), whose tables are printed. A folder of sessions with people
(`study session`) that holds their questionnaires (DIR/surveys.jsonl) also gets survey.json, and
the questionnaire's table, beside the paper's, is printed. On an ablation folder
(DIR/ablation.json) it writes the combined ablation report.

examples (from the repository root):
  drake-disamb study report out/study
  drake-disamb study report out/study --compare out/authors   # simulated beside human means
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    parser.add_argument("dir", type=Path, metavar="DIR", help="study folder (or ablation folder)")
    parser.add_argument(
        "--compare", type=Path, metavar="OTHER_DIR", help="another study folder to set side by side"
    )
    parser.add_argument(
        "--no-mixed-model",
        action="store_true",
        help="skip the per-subject mixed model (about half a second per test); the signed-rank "
        "check on subject means is still made",
    )


def run(args: argparse.Namespace) -> int:
    import json
    import statistics

    from drake_disamb.study.analysis.per_goal import per_goal_text
    from drake_disamb.study.analysis.survey import survey_text
    from drake_disamb.study.report.effect_table import effect_text
    from drake_disamb.study.report.page import write_report

    try:
        files = write_report(args.dir, compare=args.compare, mixed_model=not args.no_mixed_model)
    except ValueError as err:  # RecordError is a ValueError
        print(f"drake-disamb study report: error: {err}", file=sys.stderr)
        return 2
    ended: dict[str, int] = {}
    ages: list[float] = []
    held: list[float] = []
    for row in json.loads(files.summary.read_text(encoding="utf-8")):
        for reason, n in row.get("end_reasons", {}).items():
            ended[reason] = ended.get(reason, 0) + n
        ages.extend(row.get("time_limit_progress_ages", []))
        held.extend(row.get("failed_ik_held", []))
    if ended:  # simulated trials: how they ended (people's records do not say)
        print("trials ended: " + ", ".join(f"{reason} {n}" for reason, n in sorted(ended.items())))
    if ages:
        print(
            f"trials at the time limit: {len(ages)} with the progress watch, their arm last came "
            f"closer to the goal {min(ages):.1f} to {max(ages):.1f} s before the end (still "
            "approaching; a stuck arm is given up on by the experimenter's rule)"
        )
    if held:
        print(
            f"failed trials held by the IK: {sum(h >= 0.5 for h in held)} of {len(held)} had the arm "
            "stopped or slowed at a singularity (ik_status STOPPED or SINGULAR) on at least half of "
            f"their last minute of commanding (median share {statistics.median(held):.2f})"
        )
    if files.survey is not None:
        print(survey_text(json.loads(files.survey.read_text(encoding="utf-8")), str(args.dir)))
    if files.paradigm_effect is not None:
        rows = json.loads(files.paradigm_effect.read_text(encoding="utf-8"))
        print(effect_text(rows, str(args.dir), str(args.compare)))
    if files.per_goal is not None:
        rows = json.loads(files.per_goal.read_text(encoding="utf-8"))
        if rows:
            print(per_goal_text(rows, str(args.dir), str(args.compare)))
    print(f"wrote {files.index} ({len(files.figures)} figures, {files.stats.name}, {files.summary.name})")
    return 0
