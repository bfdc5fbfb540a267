"""``drake-disamb mico-driver``: a MICO behind a Kinova Gen2 arm's LCM messages, in its own process:
the simulated one, or with ``--kinova-sdk LIB`` a real arm through Kinova's Gen2 SDK.

Simulated, it publishes ``lcmt_jaco_status`` at 100 Hz and obeys only ``lcmt_jaco_command`` joint
velocities; when commands stop coming the arm stops (:mod:`drake_disamb.station.lcm.driver`).
With ``--kinova-sdk`` it loads Kinova's command layer (``Kinova.API.USBCommandLayerUbuntu.so``,
or the Ethernet one with ``--kinova-local-ip``), drives the first arm it lists if that is a 6-joint
MICO, and publishes and obeys the same messages at the period the link holds (100 Hz on a fast
one), with its own safety (:mod:`drake_disamb.station.kinova.driver`). Start it, then a
controller against the same bus: ``drake-disamb demo --station lcm --lcm-url URL``.

Exit status: 0 after ``--duration`` or on Ctrl-C (SIGINT) / SIGTERM; 2 bad arguments, a library
that is not Kinova's command layer, no arm found, or an arm that is not a 6-joint MICO (nothing
sent to it); 3 an SDK call failed (named with its code; the arm was stopped and the session
closed first).
"""

from __future__ import annotations

import argparse
import math
import sys
from typing import Any

from drake_disamb.commands._meshcat import add_meshcat_arguments, start_meshcat
from drake_disamb.commands._signals import StopRequest

HELP = (
    "Run a MICO behind Kinova's LCM messages (statuses, joint-velocity commands): the simulated one "
    "at 100 Hz, or a real arm through Kinova's SDK (--kinova-sdk)."
)
EXIT_SDK_FAILED = 3
"""Exit status when an SDK call failed (a station fault on the wire)."""


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
        "--duration",
        type=float,
        default=None,
        help="stop after this many seconds (simulated; with --kinova-sdk, of wall-clock time; default: run)",
    )
    parser.add_argument(
        "--kinova-sdk",
        default=None,
        metavar="LIB",
        help="drive a real arm through Kinova's Gen2 SDK command layer LIB "
        "(Kinova.API.USBCommandLayerUbuntu.so, or the Ethernet one); default: the simulated arm",
    )
    parser.add_argument(
        "--kinova-local-ip",
        default=None,
        metavar="IP",
        help="with the Ethernet command layer: this computer's address on the arm's network",
    )
    parser.add_argument(
        "--kinova-robot-ip",
        default=None,
        metavar="IP",
        help="with the Ethernet command layer: the arm's address (default Kinova's, 192.168.100.11)",
    )
    parser.add_argument(
        "--kinova-velocity-factor",
        type=float,
        default=None,
        metavar="F",
        help="multiply the joint velocities the SDK reports by F (default 2: Gen2 firmware reports "
        "them at half their value; docs/real_arm.md)",
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
    if args.kinova_sdk is None:
        for option in ("kinova_local_ip", "kinova_robot_ip", "kinova_velocity_factor"):
            if getattr(args, option) is not None:
                return _error(f"--{option.replace('_', '-')}: only with --kinova-sdk (a real arm)")
    elif args.meshcat:
        return _error(
            "--meshcat draws the simulated arm: not with --kinova-sdk (the demo draws the real one)"
        )
    from drake_disamb.station.backends.lcm import Lcm

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
    if args.kinova_sdk is not None:
        return _run_on_the_arm(args, settings)
    from pydrake.lcm import DrakeLcm

    from drake_disamb.station.lcm.driver import SimulatedDriver

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


def _run_on_the_arm(args: argparse.Namespace, settings: Any) -> int:
    """``--kinova-sdk``: the driver on a real arm until ``--duration``, Ctrl-C or SIGTERM."""
    from drake_disamb.station.kinova.driver import GEN2_VELOCITY_FACTOR, serve
    from drake_disamb.station.kinova.sdk import (
        ArmRefused,
        EthernetSettings,
        KinovaArm,
        KinovaSdk,
        SdkCallError,
        SdkLibraryError,
    )

    factor = GEN2_VELOCITY_FACTOR if args.kinova_velocity_factor is None else args.kinova_velocity_factor
    if not (math.isfinite(factor) and 0 < factor <= 4):
        return _error(f"--kinova-velocity-factor: expected a number in (0, 4], got {factor!r}")
    try:
        sdk = KinovaSdk(args.kinova_sdk)
    except SdkLibraryError as exc:
        return _error(f"--kinova-sdk: {exc}")
    ethernet = None
    if sdk.ethernet:
        if args.kinova_local_ip is None:
            return _error(
                f"--kinova-local-ip: {args.kinova_sdk} is Kinova's Ethernet command layer: give this "
                "computer's address on the arm's network"
            )
        ethernet = EthernetSettings(args.kinova_local_ip)
        if args.kinova_robot_ip is not None:
            ethernet = EthernetSettings(args.kinova_local_ip, args.kinova_robot_ip)
        try:
            ethernet.config()
        except ValueError as exc:
            return _error(f"--kinova-{str(exc).replace('_', '-', 1)}")
    else:
        for option in ("--kinova-local-ip", "--kinova-robot-ip"):
            if getattr(args, option[2:].replace("-", "_")) is not None:
                return _error(
                    f"{option}: {args.kinova_sdk} is Kinova's USB command layer: no address to give"
                )
    from pydrake.lcm import DrakeLcm

    try:
        lcm = DrakeLcm(settings.lcm_url)
    except RuntimeError as exc:
        return _error(f"--lcm-url: {exc}")

    def announce(driver: Any, arm: str) -> None:  # once ready: a controller started now finds statuses
        if not args.quiet:
            print(
                f"mico-driver: {arm} through Kinova's SDK: {settings.status_channel} at "
                f"{1 / driver.period:.1f} Hz (period {driver.period * 1000:.0f} ms; an SDK call takes "
                f"{driver.call_time * 1000:.2f} ms), obeying {settings.command_channel}, on "
                f"{settings.lcm_url} (Ctrl-C stops)",
                flush=True,
            )

    def slowed(driver: Any) -> None:
        if not args.quiet:
            print(
                f"mico-driver: the link to the arm slowed down: period now {driver.period * 1000:.0f} ms "
                f"({1 / driver.period:.1f} Hz)",
                flush=True,
            )

    arm = KinovaArm(sdk)
    with StopRequest() as stop:
        try:
            driver = serve(
                arm,
                lcm,
                stop,
                ethernet=ethernet,
                status_channel=settings.status_channel,
                command_channel=settings.command_channel,
                velocity_factor=factor,
                duration=args.duration,
                on_start=announce,
                on_period=slowed,
            )
        except ArmRefused as exc:
            return _error(exc)
        except SdkCallError as exc:
            notes = "".join(f"; {note}" for note in getattr(exc, "__notes__", ()))
            print(f"drake-disamb mico-driver: {exc}{notes}; the arm was stopped", file=sys.stderr, flush=True)
            return EXIT_SDK_FAILED
    if not args.quiet:
        rate = driver.statuses / driver.elapsed if driver.elapsed > 0 else 0.0
        halts = driver.halts
        print(
            f"mico-driver: stopped after {driver.statuses} statuses ({rate:.1f} Hz) and {driver.commands} "
            f"commands ({driver.dropped} malformed), {arm.points} velocity points sent; halts: "
            f"{halts['no fresh command']} for no fresh command, {halts['a malformed command']} for a "
            f"malformed one; {driver.late} late periods; the session was closed",
            flush=True,
        )
    return 0
