"""The ``drake-disamb`` command line: one sub-command per module in :mod:`drake_disamb.commands`."""

from __future__ import annotations

import argparse
import importlib
import os
import sys

# Sub-command name -> module in drake_disamb.commands. The first one is the main job.
COMMANDS: dict[str, str] = {
    "demo": "demo",
    "station-demo": "station_demo",
    "mico-driver": "mico_driver",
    "inference-benchmark": "inference_benchmark",
    "disambiguate": "disambiguate",
    "study": "study",
}


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser with every registered sub-command."""
    parser = argparse.ArgumentParser(
        prog="drake-disamb",
        description="Shared control with active intent disambiguation on a simulated Kinova MICO.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(f"drake_disamb.commands.{module_name}")
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point. With no sub-command, runs the main job (``demo``) with its defaults."""
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    if not argv or (argv[0].startswith("-") and argv[0] not in ("-h", "--help")):
        argv = ["demo", *argv]
    args = parser.parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except BrokenPipeError:
        # The reader went away (``drake-disamb disambiguate ... | head``): not a failure to report
        # with a traceback. Point stdout at devnull so the interpreter's final flush stays quiet,
        # and exit like a process ended by SIGPIPE.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 128 + 13


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
