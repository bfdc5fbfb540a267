"""``drake-disamb study identify DATA_DIR``: the study's system as its logs show it."""

from __future__ import annotations

import argparse
import json
import sys

HELP = "Identify the study's system (belief update, decay, alpha law, request time, mode map) from its logs."

DESCRIPTION = """\
Reads the per-trial logs of the paper's human subjects (DATA_DIR as ../shared/data/
tnsre2020_human_study: H<s>/*.mat and trial_order_testing_8.mat; any subset of subjects) and
prints what they show of the system the people used, each value with its evidence (rows, updates
or requests counted, residuals): the belief's update period, its decay with no command (the time
constant of an explicit Euler step), rest state and zero-command excitation; the alpha law
(thresholds per goal count, its maximum, 0 during a request); the request time; the mode-id to
dimension map of each interface and whether each request's mode is the argmax of the logged
scores; and, where DATA_DIR/known_path/test_data.mat and trial H3PH1REHAT10 are there, the
end-effector path solved from the autonomy's commands, the blend law and the DFT gain that replays
the logged belief (beside the mico preset's update without its agreement term). The study's goal
positions are the embedded reaching task's. drake_disamb.study.identify documents each measurement.

Exit status: 0 on success, 2 when DATA_DIR holds no usable logs.
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = DESCRIPTION
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument("data_dir", metavar="DATA_DIR", help="folder of the authors' logs")
    parser.add_argument("--json", metavar="FILE", help="also write the identified values to FILE (JSON)")


def run(args: argparse.Namespace) -> int:
    import dataclasses

    from drake_disamb.core.disambiguation import MICO_DFT
    from drake_disamb.study.identify import format_identification, identify

    other = ("mico without agreement", dataclasses.replace(MICO_DFT, agreement=False))
    try:
        ident = identify(args.data_dir, other=other)
    except (ValueError, OSError) as exc:
        print(f"drake-disamb study identify: {exc}", file=sys.stderr)
        return 2
    print(f"The study's system from the logs in {args.data_dir}")
    print(format_identification(ident))
    if args.json is not None:
        try:
            with open(args.json, "w", encoding="utf-8") as f:
                json.dump(ident.to_json(), f, indent=2)
                f.write("\n")
        except OSError as exc:
            print(f"drake-disamb study identify: --json {args.json}: {exc.strerror or exc}", file=sys.stderr)
            return 2
        print(f"Wrote {args.json}")
    return 0
