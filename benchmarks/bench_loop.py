"""Real-time rate of the full shared-control reaching loop (simulated head-array user, no Meshcat).

Usage: ``python benchmarks/bench_loop.py [--seconds 8] [--time-step 0.01 0.001] [--interface
head_array] [--repeats 9] [--profile]``. For each MultibodyPlant time step it builds the reaching
diagram (the default scenario: disambiguation paradigm, goal 0), simulates ``--seconds`` of
simulated time without stopping at success (after a 0.2 s warm-up trial that is not timed), and
prints simulated seconds per wall second and per CPU second (the machine may be shared).
``--profile`` adds a cProfile table of the components that dominate.

``--repeats N`` measures the loop and its station N times each, alternately (each loop run, then the
station replaying that run's command), and reports the best rate of each (what ``timeit`` reports:
other processes only ever slow a run down) and the ratio of every pair, measured within the same
few seconds, with their median: the figure to compare with the 50 % target. On a shared virtual
machine the speed drifts between runs (``_host``), which a ratio of two bests taken minutes apart
does not cancel.

Each row also measures the *station floor*: the MICO station alone behind its controllers (the same
MultibodyPlant, scene objects, differential IK and gripper controller, at the same time step)
replaying the blended command ``u`` that the loop logged, through a C++ zero-order-hold source,
with its ``ee_pose`` output read every control period (logged), as the loop reads it: the
station's job is to take the command and report the pose, and computing the pose is its own
Python (about 30 us a tick). The full loop cannot run faster than its station; the difference is
the cost of the shared-control systems (user, interface, inference, autonomy, blending,
disambiguation, task manager) and their
loggers. The ratio against a station whose pose is never read is printed too.
"""

from __future__ import annotations

import argparse
import copy
import cProfile
import dataclasses
import io
import pstats
import statistics
import time

import numpy as np
from _host import HostMeter
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from drake_disamb.builder import build_shared_control_diagram
from drake_disamb.config import Scenario, load_scenario, resolve_scenario
from drake_disamb.controller import build_controlled_station
from drake_disamb.station import build_station
from drake_disamb.trial import run_trial


def station_floor(
    scenario: Scenario, times: np.ndarray, u: np.ndarray, read_pose: bool = True
) -> tuple[float, float]:
    """``(wall rate, cpu rate)`` of the station alone replaying the command ``u`` (T, 6) at ``times``.

    ``read_pose``: the station's ``ee_pose`` output is read every control period (logged), as the
    loop reads it (its pose sampler and logger); False: never read (a station nobody watches).
    """
    builder = DiagramBuilder()
    station = builder.AddSystem(
        build_controlled_station(build_station(resolve_scenario(scenario).station)).diagram
    )
    command = PiecewisePolynomial.ZeroOrderHold(times, u.T)
    source = builder.AddSystem(TrajectorySource(command))
    builder.Connect(source.get_output_port(), station.GetInputPort("ee_velocity_command"))
    gripper = builder.AddSystem(ConstantVectorSource([0.0]))
    builder.Connect(gripper.get_output_port(), station.GetInputPort("gripper_command"))
    if read_pose:
        LogVectorOutput(station.GetOutputPort("ee_pose"), builder, scenario.control_period)
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    wall, cpu = time.perf_counter(), time.process_time()
    simulator.AdvanceTo(float(times[-1]))
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    return float(times[-1]) / wall, float(times[-1]) / cpu


def measure(
    seconds: float, time_step: float, interface: str, profile: bool
) -> tuple[float, float, str, tuple[float, float]]:
    """``(wall rate, cpu rate, profile table, station floor rates)`` of ``seconds`` of the reaching loop."""
    scenario = load_scenario("reaching", {"interface": interface})
    plant_config = copy.copy(scenario.plant_config)
    plant_config.time_step = time_step
    scenario = dataclasses.replace(scenario, duration=seconds, plant_config=plant_config)
    # Warm-up: a short trial of the same scenario first, so that the measured one runs at its
    # steady rate (numba loads its compiled kernels on their first call, about a second).
    run_trial(build_shared_control_diagram(dataclasses.replace(scenario, duration=0.2)), progress=False)
    handles = build_shared_control_diagram(scenario)
    profiler = cProfile.Profile() if profile else None
    cpu = time.process_time()
    if profiler is not None:
        profiler.enable()
    result = run_trial(handles, progress=False, stop_at_success=False)
    if profiler is not None:
        profiler.disable()
    cpu = time.process_time() - cpu
    table = ""
    if profiler is not None:
        out = io.StringIO()
        pstats.Stats(profiler, stream=out).sort_stats("cumulative").print_stats(r"drake_disamb", 25)
        table = out.getvalue()
    times, u = result.logs["u"]
    floors = (station_floor(scenario, times, u), station_floor(scenario, times, u, read_pose=False))
    return result.realtime_rate, result.time / cpu, table, floors


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=8.0, help="simulated seconds per run")
    parser.add_argument(
        "--time-step", type=float, nargs="+", default=[0.01, 0.001], help="plant time steps (s)"
    )
    parser.add_argument("--interface", default="head_array", help="head_array or joystick")
    parser.add_argument("--profile", action="store_true", help="print a cProfile table per run")
    parser.add_argument("--repeats", type=int, default=9, help="loop and station runs per time step")
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error(f"--repeats: expected an integer >= 1, got {args.repeats}")
    print(
        f"reaching loop, {args.interface}, disambiguation paradigm, no Meshcat, "
        f"{args.seconds:g} s simulated, {args.repeats} runs each"
    )
    for ts in args.time_step:
        runs = []
        with HostMeter() as host:
            for _ in range(args.repeats):
                runs.append(measure(args.seconds, ts, args.interface, args.profile))
        wall_rate = max(r[0] for r in runs)
        cpu_rate = max(r[1] for r in runs)
        floor = (max(r[3][0][0] for r in runs), max(r[3][0][1] for r in runs))
        bare = max(r[3][1][1] for r in runs)
        ratios = [r[1] / r[3][0][1] for r in runs]  # each loop run against its own station runs
        bare_ratios = [r[1] / r[3][1][1] for r in runs]
        print(
            f"plant time step {ts:g} s: loop {wall_rate:6.2f}x real time (wall), {cpu_rate:6.2f}x (CPU); "
            f"station alone {floor[0]:6.2f}x (wall), {floor[1]:6.2f}x (CPU), never read {bare:6.2f}x (CPU) "
            f"(the best runs); {host.describe()}\n"
            f"  loop / station per CPU second, run by run: {', '.join(f'{x:.0%}' for x in ratios)}; "
            f"median {statistics.median(ratios):.0%}\n"
            f"  loop / station never read: {', '.join(f'{x:.0%}' for x in bare_ratios)}; "
            f"median {statistics.median(bare_ratios):.0%}"
        )
        for r in runs:
            if r[2]:
                print(r[2])


if __name__ == "__main__":
    main()
