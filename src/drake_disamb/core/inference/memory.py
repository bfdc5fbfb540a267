"""Memory-based intent prediction (Dragan & Srinivasa 2013, as in the authors' code): the path-cost
likelihood and its recursive update, and the ``memory`` variant of the inference registry.

Positions are ``(..., 3)`` (m, world frame), goals ``(..., n, 3)``; the method reads the
end-effector path only, never the command.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core.inference.belief import check_transition, posterior_update, squared_norm
from drake_disamb.core.inference.methods import INFERENCE_METHODS, InferenceMethod, RecordedSamples


def memory_log_likelihood(
    cost: ArrayLike, x_cur: ArrayLike, x_start: ArrayLike, x_g: ArrayLike
) -> NDArray[np.float64]:
    """``log`` of the memory-based likelihood ``exp(-C - |x_cur - g|^2) / exp(-|x_start - g|^2)``.

    ``cost`` ``(...)`` is the running path cost C, ``x_cur`` ``(..., 3)`` the position the
    cost-to-go is measured from, ``x_start`` ``(..., 3)`` the trial's start. Shape ``(..., n)``.
    Non-finite positions are read as "no evidence" (log-likelihood 0 for every goal).
    """
    x_g = np.asarray(x_g, dtype=float)
    to_go = squared_norm(x_g - np.asarray(x_cur, dtype=float)[..., None, :])
    start = squared_norm(x_g - np.asarray(x_start, dtype=float)[..., None, :])
    log_lik = start - to_go - np.asarray(cost, dtype=float)[..., None]
    if np.isfinite(log_lik).all():
        return log_lik
    return np.where(np.all(np.isfinite(log_lik), axis=-1, keepdims=True), log_lik, 0.0)


def likelihood_from_log(log_lik: ArrayLike) -> NDArray[np.float64]:
    """``exp(log_lik)`` scaled by ``exp(-max)`` per row (same posterior, no overflow)."""
    log_lik = np.asarray(log_lik, dtype=float)
    return np.exp(log_lik - np.max(log_lik, axis=-1, keepdims=True))


def path_cost_increment(x_prev: ArrayLike, x_next: ArrayLike) -> NDArray[np.float64]:
    """``|x_next - x_prev|^2``, the memory-based running cost of one move (0 if non-finite)."""
    step = squared_norm(np.asarray(x_next, dtype=float) - np.asarray(x_prev, dtype=float))
    return np.where(np.isfinite(step), step, 0.0)


def memory_step(
    p: ArrayLike,
    cost: ArrayLike,
    x_prev: ArrayLike,
    x_next: ArrayLike,
    x_start: ArrayLike,
    x_g: ArrayLike,
    transition: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One memory-based update after the robot moved from ``x_prev`` to ``x_next``.

    ``cost`` (shape ``(...)``) is the running path cost ``C = sum |x_{t+1} - x_t|^2`` so far; it
    is first increased by ``|x_next - x_prev|^2``. As in the authors' code the cost-to-go is
    measured from ``x_prev`` (the position the step started from): the likelihood of goal g is
    ``exp(-C - |x_prev - g|^2) / exp(-|x_start - g|^2)``, applied recursively: posterior
    proportional to ``likelihood * (P^T p)``. A non-finite step adds no cost.

    Returns ``(p_new, cost_new)``.
    """
    cost_new = np.asarray(cost, dtype=float) + path_cost_increment(x_prev, x_next)
    lik = likelihood_from_log(memory_log_likelihood(cost_new, x_prev, x_start, x_g))
    return posterior_update(p, lik, transition), cost_new


@INFERENCE_METHODS.register
@dataclass(frozen=True)
class MemoryInference(InferenceMethod):
    """Memory-based prediction: :func:`memory_step` every control period on the end-effector path.
    It has no forward projection (its evidence is the path travelled, not a command).

    Attributes:
        transition: Goal-transition matrix ``P`` (row-stochastic ``n x n``; ``None``: identity).
    """

    name: ClassVar[str] = "memory"
    label: ClassVar[str] = "memory-based"
    transition: NDArray[np.float64] | None = field(default=None, compare=False)

    def recorded_evidence(self, samples: RecordedSamples, x_g: ArrayLike) -> NDArray[np.float64]:
        """The likelihood of each goal given the path so far (:func:`memory_log_likelihood`, the
        cost-to-go measured from the position the move started at, as in the authors' code)."""
        log_lik = memory_log_likelihood(samples.path_cost, samples.x_cur, samples.x_start, x_g)
        return likelihood_from_log(log_lik)

    def __post_init__(self) -> None:
        if self.transition is not None:
            object.__setattr__(
                self, "transition", check_transition(self.transition, "MemoryInference.transition")
            )
