"""Every goal of the study tasks with the simulated user: success, time, presses.

Usage: ``python benchmarks/bench_tasks.py [--task reaching pouring] [--interface head_array
joystick] [--paradigm disambiguation] [--system mico] [--set inference.agreement=cosine ...]``

``--system NAME`` runs a named system (``mico``, the scenarios' own settings, the default;
``tnsre2020_study``, the system the study's people used, as the study protocol runs it), before
any ``--set``.

``--set PATH=VALUE`` sets a scenario field by its dotted path (``inference.goal_set=stage``,
``blending.assist_without_input=false``; the value is read as YAML), so one command measures a
deviation from the paper (docs/choices.md's table "Where we differ from the paper").

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

from drake_disamb.config import (
    Scenario,
    data_layer,
    load_layers,
    load_scenario,
    setting_layer,
    task_layer,
)
from drake_disamb.config.system_presets import SYSTEM_PRESETS, system_layer
from drake_disamb.trial import run_trial
from drake_disamb.yaml_safety import load_yaml_value


def setting_layers(settings: list[str]) -> list:
    """A layer per ``PATH=VALUE`` of ``settings`` (the value read as YAML)."""
    layers = []
    for item in settings:
        path, sep, text = item.partition("=")
        if not sep:
            raise SystemExit(f"--set: expected PATH=VALUE, got {item!r}")
        try:
            layers.append(setting_layer(path, load_yaml_value(text, f"--set {path}"), f"--set {item}"))
        except ValueError as exc:
            raise SystemExit(str(exc)) from None
    return layers


def with_settings(scenario: Scenario, settings: list[str]) -> Scenario:
    """``scenario`` with each ``PATH=VALUE`` of ``settings`` layered on it (validated)."""
    try:
        return load_layers(setting_layers(settings), base=scenario)
    except ValueError as exc:
        raise SystemExit(str(exc)) from None


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
    parser.add_argument(
        "--system", default="mico", choices=SYSTEM_PRESETS, help="the named system to run (default: mico)"
    )
    parser.add_argument(
        "--set", nargs="*", default=[], metavar="PATH=VALUE", help="scenario fields to set (dotted paths)"
    )
    args = parser.parse_args()
    if args.system != "mico" or args.set:
        print("settings: " + ", ".join([f"system {args.system}", *args.set]))

    header = ("task", "interface", "goal", "ok", "stage times (s)", "switches", "requests", "alpha")
    print("{:<9} {:<11} {:<7} {:<4} {:<18} {:>8} {:>8} {:>6}".format(*header))
    start = time.perf_counter()
    for task in args.task:
        for interface in args.interface:
            totals, successes, presses = [], 0, []
            for goals in goal_choices(task):
                trial = {"interface": interface, "paradigm": args.paradigm, "user": {"goals": list(goals)}}
                layers = [task_layer(task), system_layer(args.system), data_layer(trial, "the trial")]
                try:
                    scenario = load_layers([*layers, *setting_layers(args.set)])
                except ValueError as exc:
                    raise SystemExit(str(exc)) from None
                r = run_trial(scenario, progress=False)
                successes += r.success
                presses.append(r.button_presses)
                _, alpha = r.logs["alpha"]
                stages = ", ".join(f"{t:.2f}" for t in r.stage_times)
                goal = ",".join(str(g) for g in goals)
                print(
                    f"{task:<9} {interface:<11} {goal:<7} {'yes' if r.success else 'NO':<4} {stages:<18} "
                    f"{r.mode_switches:>8} {r.requests:>8} {float(alpha.mean()):>6.3f}",
                    flush=True,
                )
                totals.append(r.time)
            print(
                f"{task:<9} {interface:<11} success {successes}/{len(totals)}, mean completion "
                f"{statistics.fmean(totals):.2f} s, worst {max(totals):.2f} s, mean button presses "
                f"{statistics.fmean(presses):.1f} over {len(totals)} trials",
                flush=True,
            )
    print(f"wall time {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
