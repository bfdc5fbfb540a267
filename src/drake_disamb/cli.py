"""The ``drake-disamb`` command line: one sub-command per module in :mod:`drake_disamb.commands`.

:func:`main` first takes SIGINT and SIGTERM and Python's warnings, before anything heavy is
imported: a signal that comes before a command takes it over (while the sub-commands and their
imports load, or in a command that does not take signals) ends the command with one line,
``drake-disamb: stopped by SIGINT`` (exit status 130), never a traceback, and a warning prints as
one line, ``drake-disamb: warning: <message>``, without our source paths. A library user who
imports the package keeps Python's own behaviour.
"""

from __future__ import annotations

import os
import signal
import sys
import warnings
from types import FrameType
from typing import TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:
    import argparse

# Sub-command name -> module in drake_disamb.commands. The first one is the main job.
COMMANDS: dict[str, str] = {
    "demo": "demo",
    "station-demo": "station_demo",
    "mico-driver": "mico_driver",
    "inference-benchmark": "inference_benchmark",
    "disambiguate": "disambiguate",
    "study": "study",
}

EXIT_INTERRUPTED = 130
"""Exit status of a command stopped by SIGINT or SIGTERM (128 + SIGINT, as the commands use)."""

_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM, raised in the main thread by :func:`main`'s handler (a ``KeyboardInterrupt``,
    so the code that cleans up after Ctrl-C does so after SIGTERM too)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signal_name = signal.Signals(signum).name


def _stopped_line(signal_name: str) -> str:
    return f"drake-disamb: stopped by {signal_name}\n"


def _interrupt(signum: int, frame: FrameType | None) -> None:
    """The handler while a command runs: raise :class:`Interrupted`; a second signal ends the
    process at once (:func:`_exit_now`). A signal that lands in an import ends it at once too: a
    compiled module whose initialisation is interrupted fails with ``ImportError: initialization
    failed`` (pybind11, pydrake), a traceback instead of a stop."""
    if _importing(frame):
        _exit_now(signum, frame)
    for sig in _SIGNALS:
        signal.signal(sig, _exit_now)
    raise Interrupted(signum)


def _importing(frame: FrameType | None) -> bool:
    """Whether ``frame`` runs inside an import (Python's import machinery is on its stack)."""
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib."):
            return True
        frame = frame.f_back
    return False


def _exit_now(signum: int, frame: FrameType | None) -> None:
    """The handler once the command is ending (a second signal, the interpreter's exit): flush what
    was printed, print the one line and exit with :data:`EXIT_INTERRUPTED` at once (what is left
    to run is the interpreter's own clean-up: a traceback from it would be all the user sees)."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe or stream: nothing more to show there
            pass
    try:
        os.write(2, _stopped_line(signal.Signals(signum).name).encode())
    finally:
        os._exit(EXIT_INTERRUPTED)


def _show_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: TextIO | None = None,
    line: str | None = None,
) -> None:
    """``warnings.showwarning`` of the command line: one line, ``drake-disamb: warning: <message>``
    (the source file and line are for developers, who run the code as a library)."""
    text = " ".join(part.strip() for part in str(message).splitlines() if part.strip())
    stream = sys.stderr if file is None else file
    try:
        stream.write(f"drake-disamb: warning: {text}\n")
        stream.flush()
    except (OSError, ValueError):  # as Python's own: a warning never fails the command
        pass


def build_parser() -> argparse.ArgumentParser:
    """Build the argument parser with every registered sub-command."""
    import argparse
    import importlib

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
    """Entry point (the console script's and ``python -m drake_disamb.cli``'s). With no sub-command,
    runs the main job (``demo``) with its defaults.

    SIGINT and SIGTERM end the command with one line and exit status 130 (a command that takes
    them over, to stop cleanly, prints its own); warnings print as one line (module docstring).
    Called without ``argv`` it owns the process: a signal after the command has returned, while the
    interpreter exits, also gives the one line. Called with ``argv`` (from Python), the previous
    signal handlers and ``warnings.showwarning`` are restored on return.
    """
    try:
        previous = {sig: signal.signal(sig, _interrupt) for sig in _SIGNALS}
    except ValueError:  # not the main thread, where Python runs signal handlers: keep them
        previous = {}
    show_warning = warnings.showwarning
    warnings.showwarning = _show_warning
    try:
        return _run(list(sys.argv[1:] if argv is None else argv))
    except KeyboardInterrupt as exc:
        if previous:
            for sig in _SIGNALS:
                signal.signal(sig, _exit_now)
        name = exc.signal_name if isinstance(exc, Interrupted) else "SIGINT"
        sys.stderr.write(_stopped_line(name))
        return EXIT_INTERRUPTED
    finally:
        _hand_back(previous, show_warning, owner=argv is None)


def _hand_back(previous: dict[int, Any], show_warning: Any, owner: bool) -> None:
    """After :func:`main`: the process's owner keeps one-line signals (:func:`_exit_now`) and
    warnings for the interpreter's exit; a caller from Python gets its own back."""
    if owner:
        if previous:
            for sig in _SIGNALS:
                signal.signal(sig, _exit_now)
        return
    for sig, handler in previous.items():
        signal.signal(sig, handler)
    warnings.showwarning = show_warning


def _run(argv: list[str]) -> int:
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
