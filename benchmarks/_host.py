"""What the host was doing while a benchmark ran (imported by the benchmark scripts).

Wall-clock figures on a shared virtual machine depend on more than the code: other processes
(the load average) and the hypervisor running other guests on our CPUs (*steal* time, the 8th
column of the ``cpu`` line of ``/proc/stat``). Steal counts as our own CPU time from inside the
guest, so per-CPU-second figures do not remove it. Neither explains everything: on the 2-core
development machine the same code has run up to 1.6x slower from one session to the next with no
steal and no other load. Every benchmark prints the steal share and the load average of its run so
that a reader can discount disturbed runs; compare versions in the same minute.
"""

from __future__ import annotations

import os
from pathlib import Path

_PROC_STAT = Path("/proc/stat")


def _cpu_ticks() -> tuple[int, int] | None:
    """``(steal ticks, all ticks)`` over all CPUs since boot, or ``None`` where unavailable."""
    try:
        fields = _PROC_STAT.read_text().splitlines()[0].split()
    except OSError:
        return None
    if not fields or fields[0] != "cpu" or len(fields) < 9:
        return None
    ticks = [int(v) for v in fields[1:]]
    # guest and guest_nice (fields 9, 10) are already included in user and nice.
    return ticks[7], sum(ticks[:8])


class HostMeter:
    """Measures the hypervisor's steal share and the load average over a ``with`` block.

    ``steal`` is the fraction of all CPU ticks stolen during the block (``None`` where
    ``/proc/stat`` is missing or too little time passed to tell); ``describe()`` formats it.
    """

    def __init__(self) -> None:
        self.steal: float | None = None
        self._start: tuple[int, int] | None = None

    def __enter__(self) -> HostMeter:
        self._start = _cpu_ticks()
        return self

    def __exit__(self, *exc: object) -> None:
        end = _cpu_ticks()
        if self._start is not None and end is not None and end[1] > self._start[1]:
            self.steal = (end[0] - self._start[0]) / (end[1] - self._start[1])

    def describe(self) -> str:
        steal = "n/a" if self.steal is None else f"{100 * self.steal:.0f} %"
        return f"hypervisor steal {steal}, load average {os.getloadavg()[0]:.2f}"


def host_summary() -> str:
    """One line: CPU count and the load average now."""
    return f"host: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}"
