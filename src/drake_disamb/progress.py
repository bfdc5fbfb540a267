"""Progress displays for people watching a terminal or a log.

Both are a ``tqdm`` line that updates in place on a terminal and, elsewhere (a log, a pipe, CI),
one plain line per ``interval`` seconds of wall time (:class:`_Display`):

- :class:`SimulationProgress`, the simulated time of one simulation. A trial ends when the task is
  done, usually long before its time limit, so its length is not known in advance: it shows the
  simulated time reached without a false total (the limit is named as a limit).
- :class:`TrialProgress`, the trials of a study: done, unsuccessful, errors and an ETA.
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO


class _Display:
    """A ``tqdm`` bar on a terminal (made by the subclass), else a line per ``interval`` seconds."""

    def __init__(self, stream: TextIO | None, interactive: bool | None, interval: float) -> None:
        if not (isinstance(interval, int | float) and interval > 0):
            raise ValueError(f"interval: expected a number of seconds > 0, got {interval!r}")
        self._stream = sys.stderr if stream is None else stream
        self._interval = float(interval)
        tty = getattr(self._stream, "isatty", None)
        self._interactive = bool(tty and tty()) if interactive is None else bool(interactive)
        self._start = time.monotonic()
        self._next_line = self._start + self._interval
        self._bar: Any = None

    @property
    def interactive(self) -> bool:
        """Whether the display is an in-place terminal line."""
        return self._interactive

    def _line_due(self, now: float, force: bool = False) -> bool:
        """Whether a plain line is due at ``now`` (and start the next interval if so)."""
        if force or now >= self._next_line:
            self._next_line = now + self._interval
            return True
        return False

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


class SimulationProgress(_Display):
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
        super().__init__(stream, interactive, interval)
        self._limit = float(limit)
        self._label = label
        self._time = 0.0
        if self._interactive:
            from tqdm import tqdm

            self._bar = tqdm(
                total=None,
                file=self._stream,
                leave=False,
                unit=" sim s",
                bar_format=f"{label} {{n:.1f}} s (limit {self._limit:g} s) [{{elapsed}} wall, {{rate_fmt}}]",
            )

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
        if self._line_due(now):
            self.write(f"{self._label} {t:.1f} s (limit {self._limit:g} s), {now - self._start:.0f} s wall")


class TrialProgress(_Display):
    """The trials of a study: done, unsuccessful, errors and an ETA.

    Args:
        total: Trials to run.
        stream, interactive, interval: As :class:`SimulationProgress` (a line every ``interval``
            seconds, 10 by default, and at the end).
        quiet: Show nothing but errors.
    """

    def __init__(
        self,
        total: int,
        stream: TextIO | None = None,
        quiet: bool = False,
        interval: float = 10.0,
        interactive: bool | None = None,
    ) -> None:
        super().__init__(stream, interactive, interval)
        self.total = total
        self.done = 0
        self.unsuccessful = 0
        self.errors = 0
        self._quiet = quiet
        if self._interactive and not quiet:
            from tqdm import tqdm

            self._bar = tqdm(total=total, file=self._stream, unit="trial", dynamic_ncols=True)
            self._bar.set_postfix(unsuccessful=0, errors=0)

    def update(self, record: Any, error: str | None) -> None:
        """One trial finished (``record``, anything with a ``success`` attribute), or raised
        (``error``, its message)."""
        self.done += 1
        if error is not None:
            self.errors += 1
            self.write(f"error: {error}")
        elif not record.success:
            self.unsuccessful += 1
        if self._bar is not None:
            self._bar.update(1)
            self._bar.set_postfix(unsuccessful=self.unsuccessful, errors=self.errors)
            return
        now = time.monotonic()
        if not self._quiet and self._line_due(now, force=self.done == self.total):
            self.write(self.line(now))

    def line(self, now: float | None = None) -> str:
        """The plain progress line."""
        elapsed = (time.monotonic() if now is None else now) - self._start
        eta = elapsed / self.done * (self.total - self.done) if self.done else float("nan")
        eta_text = f", ETA {eta:.0f} s" if self.done < self.total and self.done else ""
        return (
            f"trials {self.done}/{self.total}, {self.unsuccessful} unsuccessful, {self.errors} errors, "
            f"{elapsed:.0f} s{eta_text}"
        )

    def write(self, text: str) -> None:
        """Write a line (with ``quiet``, errors only)."""
        if self._quiet and not text.startswith("error"):
            return
        super().write(text)
