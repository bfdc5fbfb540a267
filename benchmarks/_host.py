"""What the host was doing while a benchmark ran (imported by the benchmark scripts).

Wall-clock figures on a shared virtual machine depend on more than the code: other processes
(the load average) and the hypervisor running other guests on our CPUs (*steal* time, the 8th
column of the ``cpu`` line of ``/proc/stat``). Steal counts as our own CPU time from inside the
guest, so per-CPU-second figures do not remove it. Neither explains everything: on the 2-core
development machine the same code has run up to 1.6x slower from one session to the next with no
steal and no other load. Every benchmark prints the steal share and the load average of its run so
that a reader can discount disturbed runs; compare versions in the same minute.

The machine's speed itself is measured by :func:`speed_gauge`: the cost of one numpy call on a small
array (the unit of work the project's core is made of). On the development machine it reads about
0.5-0.6 us in its usual state and about 0.8-1.0 us in its slow spells, which slow every benchmark
here by the same factor; ``HostMeter`` reads it before and after each measured block.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np

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


def speed_gauge(calls: int = 2000, batches: int = 5) -> float:
    """Microseconds per numpy call on a small array (``a + b``, 60 doubles); median of batches.

    A fixed unit of work: its cost tracks the machine's speed for the project's numpy-bound code,
    so figures measured at different gauge readings can be compared (see the module docstring).
    """
    a = np.linspace(0.0, 1.0, 60).reshape(12, 5)
    b = a[::-1].copy()
    add = np.add
    per_call = []
    for _ in range(batches):
        start = time.perf_counter()
        for _ in range(calls):
            add(a, b)
        per_call.append((time.perf_counter() - start) / calls * 1e6)
    return float(np.median(per_call))


class HostMeter:
    """Measures the steal share, the load average and the machine's speed over a ``with`` block.

    ``steal`` is the fraction of all CPU ticks stolen during the block (``None`` where
    ``/proc/stat`` is missing or too little time passed to tell); ``gauge`` is the mean of the
    :func:`speed_gauge` readings just before and just after the block (us per small numpy call);
    ``describe()`` formats them.
    """

    def __init__(self) -> None:
        self.steal: float | None = None
        self.gauge: float = float("nan")
        self._start: tuple[int, int] | None = None
        self._gauge_before = float("nan")

    def __enter__(self) -> HostMeter:
        self._gauge_before = speed_gauge()
        self._start = _cpu_ticks()
        return self

    def __exit__(self, *exc: object) -> None:
        end = _cpu_ticks()
        if self._start is not None and end is not None and end[1] > self._start[1]:
            self.steal = (end[0] - self._start[0]) / (end[1] - self._start[1])
        self.gauge = 0.5 * (self._gauge_before + speed_gauge())

    def describe(self) -> str:
        steal = "n/a" if self.steal is None else f"{100 * self.steal:.0f} %"
        return (
            f"hypervisor steal {steal}, load average {os.getloadavg()[0]:.2f}, "
            f"speed gauge {self.gauge:.2f} us"
        )


def host_summary() -> str:
    """One line: CPU count and the load average now."""
    return f"host: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}"
