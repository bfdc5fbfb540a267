"""Build the MICO station behind its controllers, simulate a short scripted pattern and write the
pictures: the station alone (its joint-level inputs, the plant, its PD set points and gravity
compensation) and the station with the differential IK and the gripper controller in front of it.

Usage: ``python diagrams/station.py [--out DIR] [--max-depth N]``; writes ``DIR/station.dot`` (the
station) and ``DIR/controlled_station.dot`` (default ``out/diagrams``) and, when Graphviz ``dot``
is installed, the ``.svg`` of each.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from drake_disamb.commands.station_demo import pattern, run_pattern, start_simulation
from drake_disamb.controller import build_controlled_station
from drake_disamb.diagram_io import write_diagram_graph
from drake_disamb.station import build_station


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/diagrams"), help="output folder")
    parser.add_argument("--max-depth", type=int, default=1, help="nested diagrams to expand in the picture")
    args = parser.parse_args(argv)
    controlled = build_controlled_station(build_station())
    simulator = start_simulation(controlled)
    ctx = simulator.get_mutable_context()
    p0 = controlled.diagram.GetOutputPort("ee_pose").Eval(ctx).copy()
    run_pattern(controlled, simulator, 2.0, pattern())
    p1 = controlled.diagram.GetOutputPort("ee_pose").Eval(ctx)
    print(f"EE moved {np.round(p1[:3] - p0[:3], 4)} m in 2 s of the pattern")
    for diagram, stem in (
        (controlled.station.diagram, "station"),
        (controlled.diagram, "controlled_station"),
    ):
        for path in write_diagram_graph(diagram, args.out / stem, max_depth=args.max_depth):
            print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
