"""Progress of a simulation in simulated time, for people watching a terminal or a log.

A trial ends when the task is done, usually long before its time limit, so its length is not known
in advance: :class:`SimulationProgress` shows the simulated time reached without a false total (the
limit is named as a limit). On a terminal it is a ``tqdm`` line that updates in place; elsewhere
(a log, a pipe, CI) it writes one plain line per ``interval`` seconds of wall time.
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO


class SimulationProgress:
    """Reports the simulated time of a running simulation.

    Args:
        limit: The simulated-time limit (s), named in the display (never used as a total).
        stream: Where to write (default: ``sys.stderr``).
        interactive: A terminal (an in-place ``tqdm`` line) or not (a line per ``interval``);
            default: whether ``stream`` is a terminal.
        interval: Wall-clock seconds between the lines when not interactive.
        label: What runs, at the start of each line.
    """

    def __init__(
        self,
        limit: float,
        stream: TextIO | None = None,
        interactive: bool | None = None,
        interval: float = 1.0,
        label: str = "simulated",
    ) -> None:
        if not (isinstance(interval, int | float) and interval > 0):
            raise ValueError(f"interval: expected a number of seconds > 0, got {interval!r}")
        self._stream = sys.stderr if stream is None else stream
        self._limit = float(limit)
        self._interval = float(interval)
        self._label = label
        tty = getattr(self._stream, "isatty", None)
        self._interactive = bool(tty and tty()) if interactive is None else bool(interactive)
        self._start = time.monotonic()
        self._next_line = self._start + self._interval
        self._time = 0.0
        self._bar: Any = None
        if self._interactive:
            from tqdm import tqdm

            self._bar = tqdm(
                total=None,
                file=self._stream,
                leave=False,
                unit=" sim s",
                bar_format=f"{label} {{n:.1f}} s (limit {self._limit:g} s) [{{elapsed}} wall, {{rate_fmt}}]",
            )

    @property
    def interactive(self) -> bool:
        """Whether the display is an in-place terminal line."""
        return self._interactive

    def update(self, t: float) -> None:
        """The simulation reached ``t`` (s); cheap enough to call after every simulator step."""
        if not t > self._time:
            return
        if self._bar is not None:
            if t - self._time >= 0.1:
                self._bar.update(t - self._time)
                self._time = t
            return
        self._time = t
        now = time.monotonic()
        if now >= self._next_line:
            self._next_line = now + self._interval
            self.write(f"{self._label} {t:.1f} s (limit {self._limit:g} s), {now - self._start:.0f} s wall")

    def write(self, text: str) -> None:
        """Write a line without breaking the in-place display."""
        if self._bar is not None:
            self._bar.write(text, file=self._stream)
        else:
            print(text, file=self._stream, flush=True)

    def close(self) -> None:
        """Remove the in-place display (no further output)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
