"""Ctrl-C (SIGINT) and SIGTERM as a stop request that a command can finish cleanly.

While a :class:`StopRequest` is installed, the first SIGINT or SIGTERM only sets a flag: the
simulation loop checks it between steps (``run_trial(stop_requested=...)``, a simulator monitor),
stops, and the command writes what it has and exits with :data:`EXIT_INTERRUPTED`. A second signal
raises ``KeyboardInterrupt`` at once, for a user who does not want to wait for the writing.
"""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import signal
import sys
import threading
from collections.abc import Iterator
from types import FrameType, TracebackType
from typing import Any

EXIT_INTERRUPTED = 130
"""Exit status of a command stopped by SIGINT or SIGTERM (128 + SIGINT, the shell's convention)."""

_SIGNALS = (signal.SIGINT, signal.SIGTERM)


class StopRequest:
    """A context manager that turns SIGINT and SIGTERM into a flag (see the module docstring).

    ``bool(stop)`` / ``stop()`` tell whether a signal arrived; ``stop.signal_name`` names it.
    Outside the main thread (where Python cannot install handlers) it installs nothing and the
    flag stays false; the previous handlers are restored on exit.
    """

    def __init__(self) -> None:
        self.signum: int | None = None
        self._previous: dict[int, Any] = {}

    def __call__(self) -> bool:
        return self.signum is not None

    def __bool__(self) -> bool:
        return self.signum is not None

    @property
    def signal_name(self) -> str:
        """``"SIGINT"``, ``"SIGTERM"`` or ``""`` when no signal arrived."""
        return "" if self.signum is None else signal.Signals(self.signum).name

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.signum is not None:
            raise KeyboardInterrupt
        self.signum = signum

    def __enter__(self) -> StopRequest:
        if threading.current_thread() is threading.main_thread():
            for sig in _SIGNALS:
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)
        self._previous.clear()


@contextlib.contextmanager
def _sigterm_handled_by(handler: Any) -> Iterator[None]:
    """While inside, SIGTERM's handler is ``handler``; outside the main thread, a no-op."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        if previous is not None:  # None: a handler set outside Python, which cannot be put back
            signal.signal(signal.SIGTERM, previous)


def sigterm_as_sigint() -> contextlib.AbstractContextManager[None]:
    """While inside, SIGTERM does what SIGINT does (for work that cannot look at a
    :class:`StopRequest`, such as checking a study's scenarios): SIGINT's handler (the command
    line's, or Python's, which raises ``KeyboardInterrupt``); outside the main thread, a no-op."""
    handler = signal.getsignal(signal.SIGINT)
    if not callable(handler):  # ignored, the default action, or not set from Python
        handler = signal.default_int_handler
    return _sigterm_handled_by(handler)


def sigterm_ends_at_once() -> contextlib.AbstractContextManager[None]:
    """While inside, SIGTERM has its default action: the kernel ends the process at once, without a
    line (exit status 143 as a shell shows it). For a compiled call that holds the interpreter and
    may block, such as Meshcat's constructor: Python runs no signal handler until it returns, so a
    handler would leave SIGTERM unanswered meanwhile. Outside the main thread, a no-op."""
    return _sigterm_handled_by(signal.SIG_DFL)


def worker_init() -> None:
    """Initializer of the study's worker processes: ignore SIGINT (a terminal's Ctrl-C reaches the
    whole process group; the parent stops the run and ends the workers, which then print nothing),
    and on Linux ask the kernel to kill the worker when its parent dies (``PR_SET_PDEATHSIG``), so
    no worker outlives the run, however the parent ends."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if sys.platform.startswith("linux"):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)


_PR_SET_PDEATHSIG = 1
"""``prctl`` option: the signal a process gets when its parent ends (``linux/prctl.h``)."""

END_WAIT = 2.0
"""Seconds :func:`end_workers` waits for the terminated workers before killing them."""


def end_workers() -> None:
    """End the worker processes this process started (SIGTERM, then SIGKILL after :data:`END_WAIT` s)."""
    children = multiprocessing.active_children()
    for child in children:
        child.terminate()
    for child in children:
        child.join(END_WAIT)
        if child.is_alive():
            child.kill()
            child.join(END_WAIT)
