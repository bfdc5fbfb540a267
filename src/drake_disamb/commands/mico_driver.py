"""``drake-disamb mico-driver``: the simulated MICO behind a Kinova Gen2 arm's LCM messages, in its
own process.

It publishes ``lcmt_jaco_status`` at 100 Hz and obeys only ``lcmt_jaco_command`` joint
velocities; when commands stop coming the arm stops (:mod:`drake_disamb.station.lcm.driver`).
Start it, then a controller against the same bus: ``drake-disamb demo --station lcm --lcm-url URL``.

Exit status: 0 after ``--duration`` or on Ctrl-C (SIGINT) / SIGTERM, 2 bad arguments.
"""

from __future__ import annotations

import argparse
import math
import sys

from drake_disamb.commands._meshcat import add_meshcat_arguments, start_meshcat
from drake_disamb.commands._signals import StopRequest

HELP = "Run the simulated MICO behind Kinova's LCM messages (status at 100 Hz, joint-velocity commands)."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options."""
    parser.add_argument(
        "--lcm-url",
        default=None,
        metavar="URL",
        help="the LCM bus (default udpm://239.255.76.67:7667?ttl=0, this machine only)",
    )
    parser.add_argument("--status-channel", default=None, help="status channel (default KINOVA_JACO_STATUS)")
    parser.add_argument(
        "--command-channel", default=None, help="command channel (default KINOVA_JACO_COMMAND)"
    )
    parser.add_argument(
        "--duration", type=float, default=None, help="stop after this many simulated seconds (default: run)"
    )
    parser.add_argument("--meshcat", action="store_true", help="draw the simulated arm in Meshcat")
    add_meshcat_arguments(parser)
    parser.add_argument("--quiet", action="store_true", help="print nothing but errors")


def _error(message: object) -> int:
    print(f"drake-disamb mico-driver: error: {message}", file=sys.stderr)
    return 2


def run(args: argparse.Namespace) -> int:
    """Run the driver until ``--duration``, Ctrl-C or SIGTERM."""
    if args.duration is not None and not (math.isfinite(args.duration) and args.duration > 0):
        return _error(f"--duration: expected a positive number of seconds, got {args.duration!r}")
    from pydrake.lcm import DrakeLcm

    from drake_disamb.station.backends.lcm import Lcm
    from drake_disamb.station.lcm.driver import SimulatedDriver

    settings = Lcm()
    for option, name in (
        ("lcm_url", "lcm_url"),
        ("status_channel", "status_channel"),
        ("command_channel", "command_channel"),
    ):
        if getattr(args, option) is not None:
            setattr(settings, name, getattr(args, option))
    try:
        settings.check()
    except ValueError as exc:
        return _error(str(exc).replace("station.lcm_url", "--lcm-url").replace("station.", "--"))
    meshcat = None
    if args.meshcat:
        try:
            meshcat = start_meshcat(args)
        except (ValueError, RuntimeError) as exc:
            return _error(exc)
        print(f"Meshcat: {meshcat.web_url()}", flush=True)
    try:
        lcm = DrakeLcm(settings.lcm_url)
    except RuntimeError as exc:
        return _error(f"--lcm-url: {exc}")
    driver = SimulatedDriver(
        lcm, status_channel=settings.status_channel, command_channel=settings.command_channel, meshcat=meshcat
    )

    def announce() -> None:  # once ready: a controller started on this line finds status flowing
        if not args.quiet:
            print(
                f"mico-driver: {settings.status_channel} at {1 / driver.period:g} Hz, obeying "
                f"{settings.command_channel}, on {settings.lcm_url} (Ctrl-C stops)",
                flush=True,
            )

    with StopRequest() as stop:
        try:
            late = driver.run(stop, args.duration, on_start=announce)
        except KeyboardInterrupt:
            late = -1
    if not args.quiet:
        print(
            f"mico-driver: stopped after {driver.statuses} statuses, {driver.commands} commands "
            f"({driver.dropped} dropped){'' if late < 0 else f', {late} late periods'}",
            flush=True,
        )
    return 0
