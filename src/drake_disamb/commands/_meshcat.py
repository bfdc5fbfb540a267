"""Meshcat options shared by the sub-commands that show the arm in a browser."""

from __future__ import annotations

import argparse
from typing import Any


def add_meshcat_arguments(parser: argparse.ArgumentParser) -> None:
    """Register ``--meshcat-host`` (default ``localhost``) and ``--meshcat-port``."""
    parser.add_argument(
        "--meshcat-host",
        default="localhost",
        help="address the Meshcat server listens on (default: localhost; '*' for every interface)",
    )
    parser.add_argument(
        "--meshcat-port",
        type=int,
        default=None,
        help="Meshcat port (default: the first free port from 7000)",
    )


def start_meshcat(args: argparse.Namespace) -> Any:
    """A Meshcat server on ``args.meshcat_host`` (localhost unless the user asked for more)."""
    from pydrake.geometry import Meshcat, MeshcatParams

    params = MeshcatParams(host=args.meshcat_host)
    if args.meshcat_port is not None:
        if not 0 < args.meshcat_port < 65536:
            raise ValueError(f"--meshcat-port: expected a port in 1..65535, got {args.meshcat_port}")
        params.port = args.meshcat_port
    return Meshcat(params)
