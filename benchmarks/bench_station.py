"""Real-time rate of the MICO station behind its controllers (simulated seconds per wall second) under
commanded motion.

Usage: ``python benchmarks/bench_station.py [--seconds 10] [--time-step 0.002 ...]``. No Meshcat.
Prints one line per plant time step; CPU-time rates are printed too because the machine may be shared.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
from _host import HostMeter

from drake_disamb.commands.station_demo import pattern, run_pattern, start_simulation
from drake_disamb.controller import build_controlled_station
from drake_disamb.station import StationConfig, build_station, default_plant_config


def measure(seconds: float, time_step: float) -> tuple[float, float, float]:
    """(wall s, cpu s, EE path length m) for ``seconds`` of the station-demo pattern."""
    station = build_controlled_station(
        build_station(StationConfig(plant_config=default_plant_config(time_step)))
    )
    simulator = start_simulation(station)
    ctx = simulator.get_mutable_context()
    p0 = station.diagram.GetOutputPort("ee_pose").Eval(ctx).copy()
    wall, cpu = time.perf_counter(), time.process_time()
    run_pattern(station, simulator, seconds, pattern())
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    p1 = station.diagram.GetOutputPort("ee_pose").Eval(ctx)
    return wall, cpu, float(np.linalg.norm(p1[:3] - p0[:3]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--time-step", type=float, nargs="+", default=[0.002, 0.001])
    args = parser.parse_args()
    print(
        f"station benchmark: {args.seconds:g} s of the station-demo pattern, "
        f"load average {os.getloadavg()[0]:.2f}"
    )
    for ts in args.time_step:
        with HostMeter() as host:
            wall, cpu, _ = measure(args.seconds, ts)
        print(
            f"time_step {ts * 1000:.1f} ms: real-time rate {args.seconds / wall:6.2f} (wall {wall:.2f} s), "
            f"{args.seconds / cpu:6.2f} by CPU time; {host.describe()}"
        )


if __name__ == "__main__":
    main()
