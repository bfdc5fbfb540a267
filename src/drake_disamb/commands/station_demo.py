"""``drake-disamb station-demo``: the MICO station tracing a scripted end-effector velocity pattern."""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drake_disamb.commands._meshcat import add_meshcat_arguments, start_meshcat

HELP = "Drive the simulated MICO through a scripted Cartesian velocity pattern (square, wrist roll, gripper)."


@dataclass(frozen=True)
class Segment:
    """One leg of the pattern: hold ``velocity`` (paper order, W) and ``gripper`` (m/s) for ``duration`` s."""

    duration: float
    velocity: tuple[float, float, float, float, float, float]
    gripper: float = 0.0


def pattern(speed: float = 0.05, roll_rate: float = 0.3) -> list[Segment]:
    """A 10 cm-side square in the xy plane, a wrist roll there and back, then open and close the gripper."""
    if not (np.isfinite(speed) and 0 < speed <= 0.2):
        raise ValueError(f"pattern.speed: expected a number in (0, 0.2] m/s, got {speed!r}")
    if not (np.isfinite(roll_rate) and 0 < roll_rate <= 0.8):
        raise ValueError(f"pattern.roll_rate: expected a number in (0, 0.8] rad/s, got {roll_rate!r}")
    leg = 0.1 / speed
    return [
        Segment(leg, (speed, 0, 0, 0, 0, 0)),
        Segment(leg, (0, speed, 0, 0, 0, 0)),
        Segment(leg, (-speed, 0, 0, 0, 0, 0)),
        Segment(leg, (0, -speed, 0, 0, 0, 0)),
        Segment(1.5, (0, 0, 0, 0, 0, roll_rate)),
        Segment(1.5, (0, 0, 0, 0, 0, -roll_rate)),
        Segment(1.0, (0, 0, 0, 0, 0, 0), 0.03),
        Segment(1.0, (0, 0, 0, 0, 0, 0), -0.03),
    ]


def start_simulation(station: Any, realtime_rate: float = 0.0) -> Any:
    """A Simulator of ``station.diagram``, initialised at rest (zero commands on both inputs)."""
    from pydrake.systems.analysis import Simulator

    simulator = Simulator(station.diagram)
    simulator.set_target_realtime_rate(realtime_rate)
    ctx = simulator.get_mutable_context()
    station.input_port("ee_velocity_command").FixValue(ctx, np.zeros(6))
    station.input_port("gripper_command").FixValue(ctx, [0.0])
    simulator.Initialize()
    return simulator


def run_pattern(station: Any, simulator: Any, duration: float, segments: list[Segment]) -> None:
    """Advance ``simulator`` (whose root system is ``station.diagram``) for ``duration`` s through
    ``segments``, repeating them as needed; the commands are fixed on the station's input ports."""
    if not (np.isfinite(duration) and duration >= 0):
        raise ValueError(f"run_pattern.duration: expected a finite number >= 0, got {duration!r}")
    ctx = simulator.get_mutable_context()
    t_end = ctx.get_time() + duration
    k = 0
    while ctx.get_time() < t_end - 1e-12:
        seg = segments[k % len(segments)]
        station.input_port("ee_velocity_command").FixValue(ctx, np.asarray(seg.velocity, dtype=float))
        station.input_port("gripper_command").FixValue(ctx, [seg.gripper])
        simulator.AdvanceTo(min(t_end, ctx.get_time() + seg.duration))
        k += 1
    station.input_port("ee_velocity_command").FixValue(ctx, np.zeros(6))
    station.input_port("gripper_command").FixValue(ctx, [0.0])


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--duration", type=float, default=13.0, help="simulated seconds (default 13: one pattern)"
    )
    parser.add_argument("--speed", type=float, default=0.05, help="translation speed, m/s (default 0.05)")
    parser.add_argument("--no-meshcat", action="store_true", help="run without Meshcat (as fast as possible)")
    add_meshcat_arguments(parser)
    parser.add_argument(
        "--hold", type=float, default=0.0, help="keep Meshcat serving this many seconds at the end"
    )
    parser.add_argument(
        "--out", type=Path, default=Path("out/station"), help="folder for the diagram picture"
    )
    parser.add_argument(
        "--time-step", type=float, default=None, help="plant time step, s (default: StationConfig)"
    )


def run(args: argparse.Namespace) -> int:

    from drake_disamb.diagram_io import write_diagram_graph
    from drake_disamb.station import StationConfig, build_station

    if not (np.isfinite(args.duration) and args.duration > 0):
        raise ValueError(f"--duration: expected a positive number of seconds, got {args.duration!r}")
    if not (np.isfinite(args.hold) and args.hold >= 0):
        raise ValueError(f"--hold: expected a number of seconds >= 0, got {args.hold!r}")
    segments = pattern(args.speed)
    config = StationConfig() if args.time_step is None else StationConfig(time_step=args.time_step)
    meshcat = None
    if not args.no_meshcat:
        meshcat = start_meshcat(args)
        print(f"Meshcat: {meshcat.web_url()}", flush=True)
    station = build_station(config, meshcat=meshcat)
    written = write_diagram_graph(station.diagram, Path(args.out) / "station")
    print("diagram: " + ", ".join(str(p) for p in written))

    simulator = start_simulation(station, realtime_rate=1.0 if meshcat is not None else 0.0)
    ctx = simulator.get_mutable_context()
    p0 = station.output_port("ee_pose").Eval(ctx).copy()
    wall = time.perf_counter()
    run_pattern(station, simulator, args.duration, segments)
    wall = time.perf_counter() - wall
    p1 = station.output_port("ee_pose").Eval(ctx).copy()
    status = int(station.output_port("ik_status").Eval(ctx)[0])
    np.set_printoptions(precision=4, suppress=True)
    print(f"start EE position  {p0[:3]} m, final {p1[:3]} m")
    print(
        f"final EE displacement {p1[:3] - p0[:3]} m (|d| = {np.linalg.norm(p1[:3] - p0[:3]) * 1000:.1f} mm)"
    )
    print(
        f"gripper opening {station.output_port('gripper_opening').Eval(ctx)[0] * 1000:.1f} mm, "
        f"ik_status {status}"
    )
    print(f"simulated {args.duration:.2f} s in {wall:.2f} s wall: real-time rate {args.duration / wall:.2f}")
    if meshcat is not None and args.hold > 0:
        print(f"holding Meshcat for {args.hold:.0f} s ...", flush=True)
        time.sleep(args.hold)
    return 0
