"""The ``--station sim|lcm`` and ``--lcm-url URL`` options the commands share, and the exit status
of a trial that a station fault stopped."""

from __future__ import annotations

import argparse
from typing import Any

EXIT_STATION_FAULT = 3
"""Exit status when a station on a wire latched a fault (the arm was commanded to stop)."""

STATION_CHOICES = ("sim", "lcm")
"""The ``--station`` choices: the registered backends' names (kept here so that parsing the options
imports no Drake; a test holds it equal to the registry)."""


def add_station_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--station`` and ``--lcm-url``."""
    parser.add_argument(
        "--station",
        choices=STATION_CHOICES,
        default="sim",
        help="the arm: sim (default, simulated in this process) or lcm (an arm behind an LCM driver: "
        "a Kinova Gen2 arm's, or drake-disamb mico-driver)",
    )
    parser.add_argument(
        "--lcm-url",
        default=None,
        metavar="URL",
        help="the LCM bus of --station lcm (default udpm://239.255.76.67:7667?ttl=0, this machine only)",
    )


def station_backend(args: argparse.Namespace) -> Any:
    """The backend of ``--station`` / ``--lcm-url`` (``ValueError`` naming the option)."""
    from drake_disamb.station.backends import backend_named

    backend = backend_named(args.station)
    if args.lcm_url is not None:
        if not hasattr(backend, "lcm_url"):
            raise ValueError(f"--lcm-url: the {args.station} station has no bus (add --station lcm)")
        backend.lcm_url = args.lcm_url
        try:
            backend.check()
        except ValueError as exc:
            raise ValueError(f"--lcm-url: {exc}") from None
    return backend
