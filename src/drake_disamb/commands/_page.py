"""The operator page the commands start beside Meshcat (docs/operator_page.md): its option and its
start, on the host Meshcat listens on."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from drake_disamb.commands._meshcat import exposure_warning


def add_page_arguments(parser: argparse.ArgumentParser) -> None:
    """Register ``--page-port``."""
    parser.add_argument(
        "--page-port",
        type=int,
        default=None,
        help="port of the operator page (the scene with the panel; default: the first free port from 7100); "
        "it listens where Meshcat does (--meshcat-host)",
    )


def start_page(args: argparse.Namespace, meshcat: Any, title: str = "") -> Any:
    """The operator page showing ``meshcat``'s scene, on ``args.meshcat_host`` (localhost unless the
    user asked for more; beyond this machine a warning names who can reach it).

    Raises:
        ValueError: ``--page-port`` out of range or taken (names it and the port).
    """
    from drake_disamb.operator_page.server import OperatorPage

    port = getattr(args, "page_port", None)
    if port is not None and not 0 < port < 65536:
        raise ValueError(f"--page-port: expected a port in 1..65535, got {port}")
    page = OperatorPage(args.meshcat_host, port, meshcat_port=meshcat.port(), title=title)
    live = bool(getattr(args, "live", True))
    warning = exposure_warning(args.meshcat_host, page.port(), live=live, server="the operator page")
    if warning is not None:
        print(warning, file=sys.stderr, flush=True)
    return page


def print_page_address(page: Any, live: bool) -> None:
    """The page's address, on a line of its own after the line that says what it is."""
    what = "to drive the arm" if live else "to watch"
    print(f"operator page (the scene with the panel), open it in a browser {what}:", flush=True)
    print(page.web_url(), flush=True)
