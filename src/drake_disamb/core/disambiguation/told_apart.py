"""Which goals a mode's motion tells apart, read from the forward projection every method scores.

Every mode-selection method scores the modes from one forward projection of the belief
(:func:`~drake_disamb.core.disambiguation.projection.forward_projection`: each probed dimension
``k`` moved ``+s e_k`` and ``-s e_k``). What a person needs to hear is not the score but what it
stands for: which goal moving one way would point at, and which the other way. :func:`told_apart`
reads that from the same projection (the request's own, run again: it is deterministic) for the
mode the method chose (or, when it kept the current mode, that one; its best mode if the current
one is not an arm mode): among the mode's
dimensions the one the method scored highest (a probe method's own ``dimension_scores``; for a
method without them, the dimension whose two probes' projected beliefs differ most), and for each
of its two directions the goal whose projected probability at ``t_b`` rises most above the belief
at the request.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drake_disamb.core.disambiguation.projection import forward_projection
from drake_disamb.core.disambiguation.request import DisambiguationRequest
from drake_disamb.core.disambiguation.selection import DisambiguationResult, ProbeResult

__all__ = ["ToldApart", "told_apart"]


@dataclass(frozen=True)
class ToldApart:
    """What one mode's motion does to the belief, as :func:`told_apart` reads it.

    Attributes:
        mode: The mode looked at (an index into the request's modes): the chosen one, or, when the
            current mode was kept, the current one (the best one if that is not an arm mode).
        dimension: The mode's dimension (0 = vx ... 5 = wz) whose motion the method scored highest.
        plus_goal, minus_goal: The goal whose projected probability rises most when moving
            ``+dimension`` / ``-dimension``, or ``None`` when no goal's rises.
        plus_gain, minus_gain: That rise (probability at ``t_b`` minus the belief at the request).
    """

    mode: int
    dimension: int
    plus_goal: int | None
    minus_goal: int | None
    plus_gain: float
    minus_gain: float

    @property
    def goals(self) -> tuple[int, ...]:
        """The distinct goals the two directions point at, ``+`` first."""
        found = [g for g in (self.plus_goal, self.minus_goal) if g is not None]
        return tuple(dict.fromkeys(found))


MIN_GAIN = 1e-4
"""A projected rise below this (probability) points at no goal."""


def told_apart(request: DisambiguationRequest, result: DisambiguationResult) -> ToldApart | None:
    """Which goals the chosen mode (or the kept one) tells apart (module docstring).

    Returns ``None`` when the mode has no probed dimension (the gripper mode, a mode outside
    ``config.dimensions``).
    """
    mode = result.mode
    if mode is None:
        current = result.current_mode
        mode = current if current is not None and current < len(request.modes) else result.best_mode
    probed = request.config.dimensions
    columns = [probed.index(k) for k in request.modes[mode] if k in probed]
    if not columns:
        return None
    projection = forward_projection(request)
    p_b = projection.p_b  # (2, n_k, n)
    if isinstance(result, ProbeResult):
        scores = np.asarray(result.dimension_scores, dtype=float)[columns]
    else:
        scores = np.abs(p_b[0, columns] - p_b[1, columns]).sum(axis=-1)
    column = columns[int(np.argmax(scores))]
    gains = p_b[:, column, :] - request.belief  # (2, n)
    picks: list[tuple[int | None, float]] = []
    for row in gains:
        best = int(np.argmax(row))
        picks.append((best if row[best] >= MIN_GAIN else None, float(row[best])))
    (plus, plus_gain), (minus, minus_gain) = picks
    return ToldApart(mode, probed[column], plus, minus, plus_gain, minus_gain)
