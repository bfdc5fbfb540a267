"""What the systems of the shared-control loop share: the belief's size and the control tick."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

__all__ = ["ControlLoop"]


@dataclass(frozen=True)
class ControlLoop:
    """The shape of one shared-control loop, given to each of its belief-sized systems (the
    autonomy, the inference, the blender, the disambiguation system and the automatic trigger).

    :func:`~drake_disamb.config.resolve_scenario` makes it from a checked scenario
    (:attr:`~drake_disamb.config.TrialConfig.loop`); the systems assert what they rely on.

    Attributes:
        n_goals: The number of goals the belief is over (an integer >= 1): the size of the belief,
            and the number of goal poses and per-goal commands on the systems' ports.
        control_period: Period (s, > 0) of the systems' periodic updates; 0.01 s = 100 Hz, the
            MICO's Cartesian velocity interface.
    """

    n_goals: int
    control_period: float = 0.01

    def __post_init__(self) -> None:
        n, period = self.n_goals, self.control_period
        assert isinstance(n, numbers.Integral) and not isinstance(n, bool) and n >= 1, n
        assert isinstance(period, numbers.Real) and math.isfinite(period) and period > 0, period
        object.__setattr__(self, "n_goals", int(n))
        object.__setattr__(self, "control_period", float(period))
