"""The status the control loop's event handlers return when they write nothing, built once."""

from __future__ import annotations

from pydrake.systems.framework import EventStatus

DID_NOTHING = EventStatus.DidNothing()
"""``EventStatus.DidNothing()``, one instance for every handler: Drake copies the status a handler
returns, and building a new one per event would be paid by several handlers at every control tick
(``benchmarks/bench_loop_profile.py --by-method`` shows the callbacks' cost). Never modified."""
