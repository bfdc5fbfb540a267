"""What the control loop's event handlers share: the status they return when they write nothing
(built once), and reading a 0/1 flag input."""

from __future__ import annotations

from pydrake.systems.framework import Context, EventStatus, InputPort

__all__ = ["DID_NOTHING", "flag_set"]

DID_NOTHING = EventStatus.DidNothing()
"""``EventStatus.DidNothing()``, one instance for every handler: Drake copies the status a handler
returns, and building a new one per event would be paid by several handlers at every control tick
(``benchmarks/bench_loop_profile.py --by-method`` shows the callbacks' cost). Never modified."""


def flag_set(port: InputPort, context: Context) -> bool:
    """A flag input (1: a 0/1 level) is connected and above 0.5; unconnected reads as not set."""
    return port.HasValue(context) and float(port.Eval(context)[0]) > 0.5
