"""Meshcat options shared by the sub-commands that show the arm in a browser."""

from __future__ import annotations

import argparse
import contextlib
import logging
import socket
import sys
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

from drake_disamb.commands._signals import sigterm_ends_at_once


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

    Listening beyond this machine prints a warning with the address others reach it at
    (:func:`exposure_warning`; with ``args.live``, they can drive the arm). A ``--meshcat-port``
    that another program holds is named, with the next free port (``ValueError``).

    The host is resolved first, within :data:`RESOLVE_TIMEOUT` seconds (:func:`check_host`): Meshcat's
    constructor, which holds the interpreter, would spend minutes on a name that does not resolve.
    While the constructor runs, SIGTERM ends the process at once (:func:`sigterm_ends_at_once`).

    Drake's own "Meshcat listening for connections at URL" log line is held back: the command
    prints the URL itself, once, where the user needs it."""
    from pydrake.geometry import Meshcat, MeshcatParams

    host = args.meshcat_host
    check_host(host)
    params = MeshcatParams(host=host)
    port = args.meshcat_port
    if port is not None:
        if not 0 < port < 65536:
            raise ValueError(f"--meshcat-port: expected a port in 1..65535, got {port}")
        if not port_is_free(host, port):
            raise ValueError(_taken(host, port))
        params.port = port
    try:
        with _drake_info_held_back(), sigterm_ends_at_once():
            meshcat = Meshcat(params)
    except RuntimeError as exc:
        if port is not None:
            raise ValueError(_taken(host, port)) from None
        raise ValueError(f"--meshcat-host {host!r}: Meshcat cannot listen there ({exc})") from None
    warning = exposure_warning(host, meshcat.port(), live=bool(getattr(args, "live", False)))
    if warning is not None:
        print(warning, file=sys.stderr, flush=True)
    return meshcat


LOCAL_HOSTS = ("localhost", "127.0.0.1", "::1", "ip6-localhost")
"""Hosts that only this machine reaches."""

RESOLVE_TIMEOUT = 3.0
"""Seconds :func:`check_host` waits for a host name to resolve."""


def _bind_host(host: str) -> str:
    return "" if host in ("*", "0.0.0.0", "::") else host


def check_host(host: str, timeout: float = RESOLVE_TIMEOUT) -> None:
    """Resolve ``host`` (``--meshcat-host``) as a server's address, waiting at most ``timeout``
    seconds (the look-up runs in a daemon thread: a resolver that hangs is left behind); ``'*'`` and
    the any-addresses need none.

    Raises:
        ValueError: The name does not resolve, or not within ``timeout`` seconds (the message
            names ``--meshcat-host`` and the value).
    """
    name = _bind_host(host)
    if not name:
        return
    outcome: list[BaseException | None] = []

    def resolve() -> None:
        try:
            socket.getaddrinfo(name, None, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)
        except OSError as exc:
            outcome.append(exc)
        else:
            outcome.append(None)

    worker = threading.Thread(target=resolve, name="meshcat-host", daemon=True)
    worker.start()
    worker.join(timeout)
    if not outcome:
        raise ValueError(f"--meshcat-host {host!r}: the name did not resolve within {timeout:g} s")
    if outcome[0] is not None:
        reason = getattr(outcome[0], "strerror", None) or outcome[0]
        raise ValueError(f"--meshcat-host {host!r}: the name does not resolve ({reason})")


def port_is_free(host: str, port: int) -> bool:
    """Whether a server could listen on ``host``:``port`` now (a probe socket binds and closes)."""
    try:
        infos = socket.getaddrinfo(
            _bind_host(host) or None, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE
        )
    except OSError:
        return True  # an unknown host: check_host reports it
    for family, kind, proto, _, address in infos:
        with socket.socket(family, kind, proto) as probe:
            probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                probe.bind(address)
            except OSError:
                return False
    return True


def _taken(host: str, port: int) -> str:
    free = next((p for p in range(port + 1, min(port + 200, 65536)) if port_is_free(host, p)), None)
    hint = f"; the next free one is {free} (--meshcat-port {free})" if free else ""
    return f"--meshcat-port: port {port} on {host} is taken by another program{hint}"


def exposure_warning(host: str, port: int, live: bool, server: str = "Meshcat") -> str | None:
    """The warning for a server (``server``: Meshcat, or the operator page) that listens beyond this
    machine (None on localhost), with the address(es) others can open."""
    if host in LOCAL_HOSTS:
        return None
    if _bind_host(host) == "":
        names = {socket.gethostname()}
        with contextlib.suppress(OSError):
            names |= {i[4][0] for i in socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET)}
        where = "every network interface"
    else:
        names = {host}
        where = host
    urls = ", ".join(f"http://{n}:{port}" for n in sorted(names))
    what = (
        "can watch the arm AND DRIVE IT (--live: the page's controls move the arm)"
        if live
        else "can watch the arm (and the page's scene)"
    )
    return f"warning: {server} listens on {where}: anyone who can reach port {port} ({urls}) {what}"


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
    """Wait until a browser has the page open (Meshcat's or the operator page's:
    ``GetNumActiveConnections() > 0``), then
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
