"""``drake-disamb station-demo``: the MICO station, behind its controllers (the differential IK and
the gripper's), tracing a scripted end-effector velocity pattern.

With Meshcat it runs at real time when started from a terminal, and as fast as it can from a script
(standard input not a terminal).

``--station lcm --lcm-url URL`` drives an arm behind an LCM driver instead (a Kinova Gen2 arm's, or
``drake-disamb mico-driver``). The station is the scenario's part that makes it (its ``station``
backend, ``plant_config`` and ``control_period``): the schema's defaults with each
``--scenario-text YAML`` layered on them, then the shorthands ``--station``, ``--lcm-url`` and
``--time-step`` (``plant_config: {time_step: ...}``), as ``demo`` takes them.

Exit status: 0 done, 2 bad arguments (one line on stderr naming the option and value, checked
before anything is built, ``--out`` included), 3 a station fault (the arm on the wire was commanded
to stop), 130 stopped by Ctrl-C (SIGINT) or SIGTERM, which end the simulation between steps and
still print where the arm got to.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drake_disamb.commands._meshcat import add_meshcat_arguments, attended, start_meshcat
from drake_disamb.commands._outputs import check_output_dir
from drake_disamb.commands._signals import EXIT_INTERRUPTED, StopRequest
from drake_disamb.commands._station import (
    EXIT_STATION_FAULT,
    add_scenario_text_argument,
    add_station_arguments,
    scenario_text_layers,
    station_layers,
)

MIN_TIME_STEP = 1e-3
"""Smallest ``--time-step`` (s): finer plant steps make a demo take hours for no visible gain."""

HELP = "Drive the MICO (simulated, or on LCM) through a scripted Cartesian velocity pattern."


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
    """A Simulator of ``station.diagram`` (a station behind its controllers,
    :class:`~drake_disamb.controller.ControlledStation`), initialised at rest (zero commands on
    both inputs)."""
    from pydrake.systems.analysis import Simulator

    simulator = Simulator(station.diagram)
    simulator.set_target_realtime_rate(realtime_rate)
    ctx = simulator.get_mutable_context()
    station.diagram.GetInputPort("ee_velocity_command").FixValue(ctx, np.zeros(6))
    station.diagram.GetInputPort("gripper_command").FixValue(ctx, [0.0])
    simulator.Initialize()
    return simulator


def run_pattern(
    station: Any,
    simulator: Any,
    duration: float,
    segments: list[Segment],
    stop_requested: Callable[[], bool] | None = None,
) -> bool:
    """Advance ``simulator`` (whose root system is ``station.diagram``, a
    :class:`~drake_disamb.controller.ControlledStation`'s) for ``duration`` s through ``segments``,
    repeating them as needed; the commands are fixed on its ``ee_velocity_command`` and
    ``gripper_command`` inputs.

    ``stop_requested`` is checked after every simulator step (through the simulator's monitor,
    which this replaces); once it returns True the pattern ends there. Returns True if it was
    stopped that way, False if it ran the whole ``duration``. The commands are zero afterwards.
    """
    if not (np.isfinite(duration) and duration >= 0):
        raise ValueError(f"run_pattern.duration: expected a finite number >= 0, got {duration!r}")
    if stop_requested is not None:
        from pydrake.systems.framework import EventStatus

        def monitor(context: Any) -> Any:
            if stop_requested():
                return EventStatus.ReachedTermination(station.diagram, "stop requested")
            return EventStatus.DidNothing()

        simulator.set_monitor(monitor)
    ctx = simulator.get_mutable_context()
    t_end = ctx.get_time() + duration
    k = 0
    stopped = False
    while ctx.get_time() < t_end - 1e-12:
        if stop_requested is not None and stop_requested():
            stopped = True
            break
        seg = segments[k % len(segments)]
        station.diagram.GetInputPort("ee_velocity_command").FixValue(
            ctx, np.asarray(seg.velocity, dtype=float)
        )
        station.diagram.GetInputPort("gripper_command").FixValue(ctx, [seg.gripper])
        simulator.AdvanceTo(min(t_end, ctx.get_time() + seg.duration))
        k += 1
    station.diagram.GetInputPort("ee_velocity_command").FixValue(ctx, np.zeros(6))
    station.diagram.GetInputPort("gripper_command").FixValue(ctx, [0.0])
    return stopped


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the ``station-demo`` options."""
    parser.add_argument(
        "--duration", type=float, default=13.0, help="simulated seconds (default 13: one pattern)"
    )
    parser.add_argument(
        "--speed", type=float, default=0.05, help="translation speed, m/s, in (0, 0.2] (default 0.05)"
    )
    parser.add_argument("--no-meshcat", action="store_true", help="run without Meshcat (as fast as possible)")
    add_meshcat_arguments(parser)
    parser.add_argument(
        "--hold", type=float, default=0.0, help="keep Meshcat serving this many seconds at the end"
    )
    parser.add_argument(
        "--out", type=Path, default=Path("out/station"), help="folder for the diagram picture"
    )
    parser.add_argument(
        "--time-step",
        type=float,
        default=None,
        help=f"plant time step, s, from {MIN_TIME_STEP:g} to the control period (default: the scenario's)",
    )
    add_scenario_text_argument(parser)
    add_station_arguments(parser)


def _error(message: object) -> int:
    print(f"drake-disamb station-demo: error: {message}", file=sys.stderr)
    return 2


def _check_arguments(args: argparse.Namespace) -> None:
    """Validate the options (``ValueError`` naming the option and value), before anything is built."""
    from drake_disamb.config.checks import check_duration

    check_duration(args.duration, "--duration")
    if not (math.isfinite(args.hold) and args.hold >= 0):
        raise ValueError(f"--hold: expected a number of seconds >= 0, got {args.hold!r}")
    if not (math.isfinite(args.speed) and 0 < args.speed <= 0.2):
        raise ValueError(f"--speed: expected a number in (0, 0.2] m/s, got {args.speed!r}")
    if args.meshcat_port is not None and not 0 < args.meshcat_port < 65536:
        raise ValueError(f"--meshcat-port: expected a port in 1..65535, got {args.meshcat_port}")
    if args.time_step is not None and not (math.isfinite(args.time_step) and args.time_step >= MIN_TIME_STEP):
        raise ValueError(
            f"--time-step: expected a number of seconds >= {MIN_TIME_STEP:g}, got {args.time_step!r}"
        )


def _station_scenario(args: argparse.Namespace) -> Any:
    """The scenario of ``--scenario-text`` and the shorthands, its station's part checked
    (:func:`~drake_disamb.config.validation.check_station`; ``ValueError`` naming the layer)."""
    from drake_disamb.config import data_layer, load_layers
    from drake_disamb.config.validation import check_station

    layers = scenario_text_layers(args)
    layers += station_layers(args, layers)
    if args.time_step is not None:
        layers.append(data_layer({"plant_config": {"time_step": args.time_step}}, "--time-step"))
    return load_layers(layers, check=check_station)


def run(args: argparse.Namespace) -> int:
    """Run the pattern: 0 done, 2 bad arguments, 130 stopped by SIGINT or SIGTERM."""
    with StopRequest() as stop:
        try:
            return _run(args, stop)
        except KeyboardInterrupt:
            print(f"drake-disamb station-demo: interrupted ({stop.signal_name or 'SIGINT'})", file=sys.stderr)
            return EXIT_INTERRUPTED


def _run(args: argparse.Namespace, stop: StopRequest) -> int:
    try:  # the cheap checks first, before Drake is imported
        _check_arguments(args)
        segments = pattern(args.speed)
        out = check_output_dir(args.out, "--out")
        scenario = _station_scenario(args)
    except ValueError as exc:
        return _error(exc)

    from drake_disamb.controller import build_controlled_station
    from drake_disamb.diagram_io import write_diagram_graph
    from drake_disamb.station import StationConfig
    from drake_disamb.station.backends import make_station

    config = StationConfig(plant_config=scenario.plant_config, control_period=scenario.control_period)
    meshcat = None
    if not args.no_meshcat:
        try:
            meshcat = start_meshcat(args)
        except (ValueError, RuntimeError) as exc:
            return _error(exc)
        print(f"Meshcat: {meshcat.web_url()}", flush=True)
    try:
        station = make_station(scenario.station, config, meshcat=meshcat)
    except RuntimeError as exc:
        return _error(exc)
    controlled = build_controlled_station(station)
    if meshcat is not None:
        from drake_disamb.systems.visualization import frame_workspace, illustration_bounds

        frame_workspace(
            meshcat,
            *illustration_bounds(station.plant, station.scene_graph),
            work_height=station.geometry.table_top,
        )
    try:
        written = write_diagram_graph(controlled.diagram, out / "station")
    except OSError as exc:
        return _error(f"--out: writing into {out} failed ({exc})")
    print("diagram: " + ", ".join(str(p) for p in written), flush=True)

    # Real time when someone may watch (Meshcat, from a terminal); from a script, as fast as it can.
    simulator = start_simulation(controlled, realtime_rate=1.0 if meshcat is not None and attended() else 0.0)
    diagram = controlled.diagram
    ctx = simulator.get_mutable_context()
    p0 = diagram.GetOutputPort("ee_pose").Eval(ctx).copy()
    t0 = ctx.get_time()
    wall = time.perf_counter()
    try:
        stopped = run_pattern(controlled, simulator, args.duration, segments, stop_requested=stop)
    except KeyboardInterrupt:
        stopped = True
    finally:
        if station.link is not None:  # on a wire: the zero command, several times
            station.link.stop_arm()
    wall = time.perf_counter() - wall
    simulated = ctx.get_time() - t0
    if stopped:
        print(f"stopped by {stop.signal_name or 'KeyboardInterrupt'} at {simulated:.2f} s", flush=True)
    p1 = diagram.GetOutputPort("ee_pose").Eval(ctx).copy()
    status = int(diagram.GetOutputPort("ik_status").Eval(ctx)[0])
    np.set_printoptions(precision=4, suppress=True)
    print(f"start EE position  {p0[:3]} m, final {p1[:3]} m")
    print(
        f"final EE displacement {p1[:3] - p0[:3]} m (|d| = {np.linalg.norm(p1[:3] - p0[:3]) * 1000:.1f} mm)"
    )
    print(
        f"gripper opening {diagram.GetOutputPort('gripper_opening').Eval(ctx)[0] * 1000:.1f} mm, "
        f"ik_status {status}"
    )
    rate = f"{simulated / wall:.2f}" if wall > 0 else "inf"
    print(f"simulated {simulated:.2f} s in {wall:.2f} s wall: real-time rate {rate}")
    if "fault" in station.outputs and diagram.GetOutputPort("fault").Eval(ctx)[0]:
        from drake_disamb.station.lcm.faults import Fault

        fault = Fault(int(diagram.GetOutputPort("fault").Eval(ctx)[0]))
        print(f"station fault: {fault.reason}", file=sys.stderr, flush=True)
        return EXIT_STATION_FAULT
    if stopped:
        return EXIT_INTERRUPTED
    if meshcat is not None and args.hold > 0 and not stop:
        print(f"holding Meshcat for {args.hold:g} s (Ctrl-C to quit) ...", flush=True)
        end = time.monotonic() + args.hold
        while not stop and time.monotonic() < end:
            time.sleep(min(0.1, max(0.0, end - time.monotonic())))
    return 0
