"""``drake-disamb study calibrate DATA_DIR``: the behaviour estimates behind the simulated population."""

from __future__ import annotations

import argparse
import sys

HELP = "Estimate the simulated users' behaviour parameters from the authors' human logs and print them."

DESCRIPTION = """\
Reads the per-trial logs of the paper's human subjects (DATA_DIR as ../shared/data/
tnsre2020_human_study: H<s>/*.mat and trial_order_testing_8.mat) and prints what they show of
behaviour: the start delay, the press interval within a mode change, the time from a mode switch to
the next command, pauses (runs of zero command), joystick deflection and direction spread, presses
per mode change, how often and when requests were made and whether the mode a request chose was
kept. user_vel has no timestamps: its samples are spread evenly over total_time. Then the authors'
metrics per interface, task and paradigm (for comparison with the simulated population; never used
to set it). docs/population.md maps each estimate to the population's distributions.

With --simulated STUDY_DIR (a folder of `study run`), the same estimates are measured on the
simulated trials there (Manual and Disambiguation, those that did not fail) and printed after the
people's: the check that the population behaves as it was drawn to.

Exit status: 0 on success, 2 when DATA_DIR holds no usable logs or STUDY_DIR no usable records.
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = DESCRIPTION
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument("data_dir", metavar="DATA_DIR", help="folder of the authors' logs")
    parser.add_argument(
        "--simulated",
        metavar="STUDY_DIR",
        help="also measure the simulated trials of this study folder (trials.jsonl and traces/)",
    )


def run(args: argparse.Namespace) -> int:
    from drake_disamb.study.data.authors import LOG_INTERFACES, read_trials
    from drake_disamb.study.data.folder import StudyFolder
    from drake_disamb.study.measures.calibration import (
        estimate_behaviour,
        format_condition_means,
        format_estimates,
    )
    from drake_disamb.study.measures.metrics import summarize

    try:
        trials = read_trials(args.data_dir)
        estimates = estimate_behaviour(trials)
        simulated = None
        if args.simulated is not None:
            simulated = StudyFolder(args.simulated).read_trials()
            simulated_estimates = estimate_behaviour(simulated)
    except (ValueError, OSError) as exc:
        print(f"drake-disamb study calibrate: {exc}", file=sys.stderr)
        return 2
    print(f"Behaviour estimates from {len(trials)} trial files in {args.data_dir}")
    print(format_estimates(estimates))
    print()
    print("The authors' metrics per condition (valid trials; a check, not an input):")
    print(format_condition_means(summarize([t.record for t in trials])))
    if simulated is not None:
        print()
        print(f"The same estimates from the {len(simulated)} simulated trials in {args.simulated}")
        others = sorted({t.record.interface for t in simulated} - set(LOG_INTERFACES))
        if others:
            n = sum(t.record.interface in others for t in simulated)
            print(
                f"({n} trials of {', '.join(others)} left out: the logs have only "
                f"{' and '.join(LOG_INTERFACES)})"
            )
        print(format_estimates(simulated_estimates))
    return 0
