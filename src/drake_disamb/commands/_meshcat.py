"""Meshcat options shared by the sub-commands that show the arm in a browser."""

from __future__ import annotations

import argparse
import contextlib
import logging
import sys
import time
from collections.abc import Callable, Iterator
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
    """A Meshcat server on ``args.meshcat_host`` (localhost unless the user asked for more).

    Drake's own "Meshcat listening for connections at URL" log line is held back: the command
    prints the URL itself, once, where the user needs it."""
    from pydrake.geometry import Meshcat, MeshcatParams

    params = MeshcatParams(host=args.meshcat_host)
    if args.meshcat_port is not None:
        if not 0 < args.meshcat_port < 65536:
            raise ValueError(f"--meshcat-port: expected a port in 1..65535, got {args.meshcat_port}")
        params.port = args.meshcat_port
    with _drake_info_held_back():
        return Meshcat(params)


@contextlib.contextmanager
def _drake_info_held_back() -> Iterator[None]:
    """Drop the ``drake`` logger's INFO records (Drake forwards its log to Python's logging)."""
    logger = logging.getLogger("drake")
    level = logger.level
    logger.setLevel(max(level, logging.WARNING))
    try:
        yield
    finally:
        logger.setLevel(level)


def attended() -> bool:
    """Whether a person runs the command from a terminal (standard input is one). From a script
    the commands neither wait for a browser nor hold Meshcat, and run as fast as they can."""
    isatty = getattr(sys.stdin, "isatty", None)
    try:
        return bool(isatty and isatty())
    except (OSError, ValueError):  # a closed or detached stdin
        return False


WAIT_FOR_BROWSER = 30.0
"""Seconds a command waits for a browser to open its Meshcat page (``--no-wait`` skips it)."""


def add_wait_argument(parser: argparse.ArgumentParser) -> None:
    """Register ``--no-wait``."""
    parser.add_argument(
        "--no-wait",
        action="store_true",
        help=f"with Meshcat from a terminal: start at once instead of waiting up to {WAIT_FOR_BROWSER:g} s "
        "for a browser to open the page",
    )


def wait_for_browser(
    meshcat: Any,
    timeout: float = WAIT_FOR_BROWSER,
    stop: Callable[[], bool] = lambda: False,
    settle: float = 1.0,
) -> bool:
    """Wait until a browser has the Meshcat page open (``GetNumActiveConnections() > 0``), then
    ``settle`` seconds more for the page to draw the scene. Returns whether one connected within
    ``timeout`` seconds; ``stop()`` ends the wait early."""
    deadline = time.monotonic() + timeout
    while meshcat.GetNumActiveConnections() == 0:
        if stop() or time.monotonic() >= deadline:
            return False
        time.sleep(0.1)
    end = time.monotonic() + settle
    while not stop() and time.monotonic() < end:
        time.sleep(0.05)
    return True
