"""Build the MICO station, simulate a short scripted pattern and write its Graphviz picture.

Usage: ``python diagrams/station.py [OUT_STEM]`` (default ``out/diagrams/station``); writes
``OUT_STEM.dot`` and, when Graphviz ``dot`` is installed, ``OUT_STEM.svg``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from drake_disamb.commands.station_demo import pattern, run_pattern, start_simulation
from drake_disamb.diagram_io import write_diagram_graph
from drake_disamb.station import build_station


def main(argv: list[str]) -> int:
    stem = Path(argv[0]) if argv else Path("out/diagrams/station")
    station = build_station()
    simulator = start_simulation(station)
    ctx = simulator.get_mutable_context()
    p0 = station.output_port("ee_pose").Eval(ctx).copy()
    run_pattern(station, simulator, 2.0, pattern())
    p1 = station.output_port("ee_pose").Eval(ctx)
    print(f"EE moved {np.round(p1[:3] - p0[:3], 4)} m in 2 s of the pattern")
    for path in write_diagram_graph(station.diagram, stem, max_depth=1):
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
