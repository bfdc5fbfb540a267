"""Every goal of the study tasks with the simulated user: success, time, presses.

Usage: ``python benchmarks/bench_tasks.py [--task reaching pouring] [--interface head_array
joystick] [--paradigm disambiguation]``

For each task, interface and intended goal (reaching: each of the 5 objects; pouring: each
(container, location) pair) it runs one trial of the embedded scenario with the default simulated
user (deterministic: the same command prints the same table) and prints whether it succeeded, the
completion time of each stage (simulated s), the mode switches and the disambiguation requests,
then the mean and the worst completion time per task and interface. It stops a trial at success or
at the scenario's 60 s limit. About 3 to 6 minutes for everything on the 2-core development
machine.
"""

from __future__ import annotations

import argparse
import itertools
import statistics
import time

from drake_disamb.config import load_scenario, with_overrides
from drake_disamb.trial import run_trial


def goal_choices(task: str) -> list[list[int]]:
    """The intended-goal lists to try: one per goal of each stage, all combinations."""
    scenario = load_scenario(task)
    counts = [len(scenario.stage_goal_poses(s)) for s in range(len(scenario.stages))]
    return [list(c) for c in itertools.product(*(range(n) for n in counts))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", nargs="+", default=["reaching", "pouring"], help="tasks to run")
    parser.add_argument(
        "--interface", nargs="+", default=["head_array", "joystick"], help="interfaces to run"
    )
    parser.add_argument("--paradigm", default="disambiguation", help="disambiguation or manual")
    args = parser.parse_args()

    header = ("task", "interface", "goal", "ok", "stage times (s)", "switches", "requests")
    print("{:<9} {:<11} {:<7} {:<4} {:<18} {:>8} {:>8}".format(*header))
    start = time.perf_counter()
    for task in args.task:
        for interface in args.interface:
            totals = []
            for goals in goal_choices(task):
                scenario = with_overrides(
                    load_scenario(task), interface=interface, paradigm=args.paradigm, goal=goals
                )
                r = run_trial(scenario, progress=False)
                stages = ", ".join(f"{t:.2f}" for t in r.stage_times)
                goal = ",".join(str(g) for g in goals)
                print(
                    f"{task:<9} {interface:<11} {goal:<7} {'yes' if r.success else 'NO':<4} {stages:<18} "
                    f"{r.mode_switches:>8} {r.requests:>8}",
                    flush=True,
                )
                totals.append(r.time)
            print(
                f"{task:<9} {interface:<11} mean completion {statistics.fmean(totals):.2f} s, "
                f"worst {max(totals):.2f} s over {len(totals)} trials",
                flush=True,
            )
    print(f"wall time {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
