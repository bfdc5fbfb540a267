"""The hardware loop on loopback: status-to-command latency and missed periods of the station on LCM
against the simulated driver in its own process.

Usage: ``python benchmarks/bench_hardware_loop.py [--seconds 60] [--lcm-url URL]``. Starts
``drake-disamb mico-driver`` (status at 100 Hz), builds the station on the same bus, drives the
station-demo pattern (a square, a wrist roll, the gripper) for ``--seconds`` of the driver's clock,
and prints the latency from a status's receipt to the publication of the command answering it
(median, p99, max) and the missed periods (statuses the controller never answered: the gaps in
the ``utime`` of the statuses it used), counted from the loop's first tick on.
Targets: p99 under 3 ms (a third of the period), no missed period.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from _host import HostMeter

from drake_disamb.commands.station_demo import pattern, run_pattern, start_simulation
from drake_disamb.controller import build_controlled_station
from drake_disamb.station import StationConfig
from drake_disamb.station.backends import Lcm

SRC = Path(__file__).resolve().parents[1] / "src"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="length of the run (s)")
    parser.add_argument("--lcm-url", default="udpm://239.255.76.67:7691?ttl=0", help="the bus")
    args = parser.parse_args()
    env = dict(os.environ, PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    driver = subprocess.Popen(
        [sys.executable, "-m", "drake_disamb.cli", "mico-driver", "--lcm-url", args.lcm_url, "--quiet"],
        env=env,
    )
    try:
        station = Lcm(lcm_url=args.lcm_url, start_timeout=60.0).build(StationConfig())
        controlled = build_controlled_station(station)
        simulator = start_simulation(controlled)
        receiver = station.diagram.GetSubsystemByName("status_receiver")
        counts = receiver.GetOutputPort("status_count")
        rctx = receiver.GetMyContextFromRoot(simulator.get_mutable_context())
        simulator.AdvanceTo(0.0)  # the loop's first tick: it takes a fresh status, counting starts
        link = station.link
        link.latencies.clear()
        used0 = counts.Eval(rctx).copy()
        start_utime = receiver.last_utime(rctx)
        with HostMeter() as host:
            wall = time.perf_counter()
            run_pattern(controlled, simulator, args.seconds, pattern())
            wall = time.perf_counter() - wall
        used, dropped, missed = counts.Eval(rctx) - used0
        end_utime = receiver.last_utime(rctx)
        fault = int(controlled.diagram.GetOutputPort("fault").Eval(simulator.get_context())[0])
        link.stop_arm()
    finally:
        driver.terminate()
        driver.wait(timeout=30)
    period = station.config.control_period
    published = round((end_utime - start_utime) * 1e-6 / period)
    lat = np.array(link.latencies) * 1e3
    print(host.describe())
    print(f"run: {args.seconds:g} s at {1 / period:g} Hz on {args.lcm_url}, {wall:.1f} s wall, fault {fault}")
    print(
        f"status-to-command latency (ms): median {np.median(lat):.3f}, p99 {np.percentile(lat, 99):.3f}, "
        f"max {lat.max():.3f} over {lat.size} commands (target p99 < {period * 1e3 / 3:.2f})"
    )
    print(
        f"statuses: {published} published by the driver over the run, {int(used)} used; "
        f"missed periods {int(missed)}; dropped {int(dropped)}"
    )


if __name__ == "__main__":
    main()
