"""Shared code of the named shared-control diagram scripts (``reaching.py``, ``pouring.py``)."""

from __future__ import annotations

import argparse
from pathlib import Path

from drake_disamb.builder import build_shared_control_diagram
from drake_disamb.config import load_scenario, merge_layers, task_layer
from drake_disamb.diagram_io import write_diagram_graph
from drake_disamb.trial import run_trial


def main(task: str, argv: list[str] | None = None) -> int:
    """Build the ``task`` diagram, simulate one trial, print its metrics, write its picture."""
    parser = argparse.ArgumentParser(
        description=f"Build, simulate and draw the {task} shared-control diagram."
    )
    parser.add_argument("--interface", default=None, help="head_array or joystick (default: the scenario's)")
    parser.add_argument("--paradigm", default=None, help="disambiguation or manual (default: the scenario's)")
    parser.add_argument("--goal", type=int, default=None, help="intended goal index (every stage)")
    parser.add_argument("--duration", type=float, default=None, help="simulated-time limit (s)")
    parser.add_argument("--out", type=Path, default=Path("out/diagrams"), help="output folder")
    parser.add_argument("--max-depth", type=int, default=1, help="nested diagrams to expand in the picture")
    args = parser.parse_args(argv)
    fields = {"interface": args.interface, "paradigm": args.paradigm}
    layer = {name: value for name, value in fields.items() if value is not None}
    if args.goal is not None:
        layer["user"] = {"goals": [args.goal] * merge_layers([task_layer(task)]).n_stages}
    scenario = load_scenario(task, layer)
    if args.duration is not None:  # cut short on purpose, below the hold times
        import dataclasses

        scenario = dataclasses.replace(scenario, duration=args.duration)
    handles = build_shared_control_diagram(scenario)
    result = run_trial(handles, progress=False)
    print(
        f"{task} ({scenario.interface}, {scenario.paradigm}): success={result.success} "
        f"time={result.time:.2f} s stages={[round(t, 2) for t in result.stage_times]} "
        f"mode_switches={result.mode_switches} requests={result.requests} "
        f"real-time rate={result.realtime_rate:.2f}x"
    )
    stem = args.out / f"{task}_{scenario.interface}_{scenario.paradigm}"
    for path in write_diagram_graph(handles.diagram, stem, max_depth=args.max_depth):
        print(f"wrote {path}")
    return 0
