"""The live page's deadman: no browser at the page for a set time -> every raw signal released.

A person drives a live trial from a page (the operator page, or Meshcat's: anything with
``GetNumActiveConnections``); when the arm is real, losing that page (the tab closed, the network
gone, the browser frozen) must not leave a joystick axis deflected or a switch closed.
:class:`PageDeadman` sits between the live input and the interface and passes the raw signal
through while at least one page is connected; once none has been for
``timeout`` seconds it outputs zeros (no deflection, no switch, no button), until a page connects
again. The builder puts it in front of the interface when a live input drives a station on a wire.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, EventStatus, LeafSystem

from drake_disamb.interfaces import RAW_SIZE

DEADMAN_TIMEOUT = 0.5
"""Seconds without a connected page before the raw signal is released (default)."""


class PageDeadman(LeafSystem):
    """Releases the raw signal when no page has been connected to Meshcat for ``timeout`` seconds.

    @system
    name: PageDeadman
    input_ports:
    - raw_in (4): the live input's raw signal
    output_ports:
    - raw (4): ``raw_in``, or zeros while the deadman is released
    - released (1): 1 while released, else 0
    @endsystem

    Discrete state: the time a page was last seen (s) and ``released`` (0/1), updated every ``period``
    from ``meshcat.GetNumActiveConnections()``; the first update counts as seeing a page.
    """

    def __init__(self, meshcat: Any, period: float, timeout: float = DEADMAN_TIMEOUT) -> None:
        super().__init__()
        if not (math.isfinite(timeout) and timeout > 0):
            raise ValueError(f"PageDeadman.timeout: expected a positive number of seconds, got {timeout!r}")
        self._meshcat = meshcat
        self._timeout = float(timeout)
        self._raw = self.DeclareVectorInputPort("raw_in", RAW_SIZE)
        self._seen = self.DeclareDiscreteState(np.array([-math.inf]))
        self._released = self.DeclareDiscreteState(np.zeros(1))
        self.DeclareVectorOutputPort(
            "raw",
            RAW_SIZE,
            self._calc_raw,
            prerequisites_of_calc={self._raw.ticket(), self.discrete_state_ticket(self._released)},
        )
        self.DeclareStateOutputPort("released", self._released)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        seen = context.get_discrete_state(self._seen).get_value()[0]
        now = context.get_time()
        if self._meshcat.GetNumActiveConnections() > 0 or seen == -math.inf:
            seen = now
        discrete_state.get_mutable_vector(self._seen).SetAtIndex(0, seen)
        discrete_state.get_mutable_vector(self._released).SetAtIndex(0, float(now - seen >= self._timeout))
        return EventStatus.Succeeded()

    def _calc_raw(self, context: Context, output: BasicVector) -> None:
        if context.get_discrete_state(self._released).get_value()[0]:
            output.SetFromVector(np.zeros(RAW_SIZE))
        else:
            output.SetFromVector(self._raw.Eval(context))
