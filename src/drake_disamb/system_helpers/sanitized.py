"""What the systems share about unusable run-time inputs: the check and the count.

A command or pose that arrives at run time with a NaN, an infinity or an out-of-range value never
reaches the arm: the system that reads it replaces it (a zero command, the mode kept, the user
letting go). That one expected case is detected with an explicit check *before* the core is called
(:func:`usable_poses`); any other error (a shape bug, a core failure) propagates.

Each such system counts the control ticks at which it sanitised an input in its own discrete state
(:class:`SanitizedInputCounter`): the state output port ``sanitized_input_count`` (1), deterministic,
reset with the context (the interface's ``nonfinite_count`` is the same idea). A warning names the
system and the input, at most once per ``WARN_INTERVAL`` seconds of simulated time per context (the
time of the last warning is state too, so two contexts or two simulations never share it).
"""

from __future__ import annotations

import warnings

import numpy as np
from numpy.typing import NDArray
from pydrake.systems.framework import Context, DiscreteValues, LeafSystem

from drake_disamb.core.geometry import poses_usable
from drake_disamb.core.validation import is_real

__all__ = [
    "MAX_POSE_ENTRY",
    "MIN_QUATERNION_NORM",
    "SANITIZED_INPUT_COUNT",
    "WARN_INTERVAL",
    "SanitizedInputCounter",
    "usable_poses",
]

SANITIZED_INPUT_COUNT = "sanitized_input_count"
"""Name of the output port that counts the ticks with a sanitised input."""

MIN_QUATERNION_NORM = 1e-12
"""Smallest usable quaternion norm (the core's quaternion check raises below it)."""

MAX_POSE_ENTRY = 1e150
"""Largest usable ``|entry|`` of a pose (m or quaternion units): beyond it a quaternion's squared
norm can overflow (normalised, it would be zeros) and distances lose all meaning."""

WARN_INTERVAL = 1.0
"""Minimum simulated time (s) between two warnings of one system in one context."""


def usable_poses(*poses: NDArray[np.float64]) -> bool:
    """True if every pose ``[x, y, z, qw, qx, qy, qz]`` (or every row of a flat ``n * 7`` vector)
    is in range: no NaN, no entry beyond :data:`MAX_POSE_ENTRY` in magnitude (infinities
    included), and each quaternion's norm at least :data:`MIN_QUATERNION_NORM`
    (:func:`~drake_disamb.core.geometry.poses_usable` on each)."""
    for pose in poses:  # (a loop, not all() over a generator: checked twice per control tick)
        if not poses_usable(pose, MAX_POSE_ENTRY, MIN_QUATERNION_NORM):
            return False
    return True


class SanitizedInputCounter:
    """The running count of sanitised inputs of one system, in that system's discrete state.

    Declares on ``system`` two discrete groups: ``[count]``, exposed as the state output port
    ``sanitized_input_count`` (1), and ``[time of the last warning (s), count at it]`` (``-inf``
    and 0 before any). Both start at their defaults in every new context, so two contexts or two
    simulations never share a warning's timing. :meth:`record` is called from the system's
    discrete or unrestricted update with the values it writes.
    """

    def __init__(self, system: LeafSystem, warn_interval: float = WARN_INTERVAL) -> None:
        if not (is_real(warn_interval) and warn_interval >= 0):
            raise ValueError(f"warn_interval: expected a finite number >= 0, got {warn_interval!r}")
        self._system = system
        self._warn_interval = float(warn_interval)
        self._count_index = system.DeclareDiscreteState(np.zeros(1))
        self._warned_index = system.DeclareDiscreteState(np.array([-np.inf, 0.0]))
        self.port = system.DeclareStateOutputPort(SANITIZED_INPUT_COUNT, self._count_index)

    def count(self, context: Context) -> int:
        """The count in ``context``."""
        return int(context.get_discrete_state(self._count_index).get_value()[0])

    def record(self, context: Context, discrete_state: DiscreteValues, message: str) -> None:
        """Add one to the count in ``discrete_state`` and warn unless a warning came less than
        ``warn_interval`` seconds (simulated time) ago in ``context``."""
        count = context.get_discrete_state(self._count_index).get_value()[0] + 1.0
        discrete_state.get_mutable_vector(self._count_index).SetAtIndex(0, count)
        time = context.get_time()
        warned_at, count_then = context.get_discrete_state(self._warned_index).get_value()
        if time - warned_at < self._warn_interval:
            return
        discrete_state.get_mutable_vector(self._warned_index).SetFromVector([time, count])
        name = self._system.get_name() or type(self._system).__name__
        suppressed = int(count - count_then - 1) if count_then > 0 else 0
        extra = f"{suppressed} similar warnings suppressed; " if suppressed else ""
        warnings.warn(
            f"{name} at t = {time:.3f} s: {message} ({extra}{int(count)} sanitised so far; "
            f"warned at most once per {self._warn_interval:g} s)",
            RuntimeWarning,
            stacklevel=3,
        )
