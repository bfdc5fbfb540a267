"""Readying a process for a control loop on a wire (the controller's and the drivers').

A loop on a wire must answer every 10 ms, and three things in a Python process stall it far
longer than its work (about 1-2 ms a period), each measured by ``benchmarks/bench_hardware_loop.py``:

- a kernel of the core loaded on first use (0.5-0.8 s for the first in a process): all are loaded
  beforehand (:func:`~drake_disamb.core.warmup.warm_up`);
- a full garbage collection of a built diagram (70-90 ms): what was built is moved out of the
  collector's reach (``gc.freeze``), so a collection scans only what the loop made;
- multi-threaded BLAS: OpenBLAS's worker threads spin after the small products of a tick and take
  the cores the other process needs (with both processes on a two-core machine, status gaps of
  20-40 ms and watchdog faults; with one thread, none): BLAS is held to one thread
  (``threadpoolctl``), as a real-time loop's process should be.
"""

from __future__ import annotations

import gc

from threadpoolctl import threadpool_limits

from drake_disamb.core.warmup import warm_up

_LIMITS: list[object] = []  # the BLAS limit stays in force for the life of the process


def prepare_loop(kernels: bool = True) -> None:
    """Load the kernels (unless ``kernels`` is false: a loop that runs none, as Kinova's SDK
    driver), freeze what exists for the garbage collector, hold BLAS to one thread. Call once
    everything the loop uses is built, just before it starts."""
    if kernels:
        warm_up()
    if not _LIMITS:
        _LIMITS.append(threadpool_limits(limits=1, user_api="blas"))
    gc.collect()
    gc.freeze()


__all__ = ["prepare_loop"]
