"""Recursive Bayesian intent inference (the paper's baseline): the Gaussian angle likelihood and
the posterior step, and the ``bayes`` variant of the inference registry.

``u_h`` is ``(..., d >= 3)`` (``[vx, vy, vz, ...]``, m/s, world frame; only the translation
enters), ``x_r`` ``(..., 3)`` and ``x_g`` ``(..., n, 3)`` (m).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core.inference.belief import (
    check_transition,
    has_command,
    posterior_update,
    safe_unit,
    sanitize_command,
)
from drake_disamb.core.inference.methods import INFERENCE_METHODS, ProjectedInference

BAYES_SIGMA = np.pi / 2.0
"""Standard deviation (rad) of the Gaussian angle likelihood of the recursive Bayes baseline."""

BAYES_COS_DECIMALS = 5
"""The authors round the cosine to this many decimals before ``arccos``."""


def _round_half_away(x: NDArray[np.float64], decimals: int) -> NDArray[np.float64]:
    """MATLAB's ``round(x, decimals)``: ties go away from zero (numpy's round goes to even)."""
    scale = 10.0**decimals
    return np.sign(x) * np.floor(np.abs(x) * scale + 0.5) / scale


def bayes_likelihood(
    u_h: ArrayLike, x_r: ArrayLike, x_g: ArrayLike, sigma: float = BAYES_SIGMA
) -> NDArray[np.float64]:
    """Gaussian density (mean 0, std ``sigma``) of the angle between ``u_h[:3]`` and each goal.

    The cosine is rounded to 5 decimals (ties away from zero, as MATLAB) before ``arccos``
    (authors' code). A zero command gives a uniform likelihood. A goal at the robot's position
    has no direction: its angle is taken as pi/2 (neither towards nor away).
    Returns shape ``(..., n)``.
    """
    u_raw = sanitize_command(u_h)[..., :3]
    u = safe_unit(u_raw)
    d = safe_unit(np.asarray(x_g, dtype=float) - np.asarray(x_r, dtype=float)[..., None, :])
    cos = _round_half_away(np.einsum("...k,...nk->...n", u, d), BAYES_COS_DECIMALS)
    angle = np.arccos(np.clip(cos, -1.0, 1.0))
    lik = np.exp(-0.5 * (angle / sigma) ** 2) / (sigma * np.sqrt(2.0 * np.pi))
    return np.where(has_command(u_raw), lik, 1.0)


def bayes_step(
    p: ArrayLike,
    u_h: ArrayLike,
    x_r: ArrayLike,
    x_g: ArrayLike,
    transition: ArrayLike | None = None,
    sigma: float = BAYES_SIGMA,
) -> NDArray[np.float64]:
    """Posterior proportional to ``likelihood(u_h | g) * (P^T p)``, renormalised."""
    return posterior_update(p, bayes_likelihood(u_h, x_r, x_g, sigma), transition)


@INFERENCE_METHODS.register
@dataclass(frozen=True)
class BayesInference(ProjectedInference):
    """Recursive Bayesian inference: :func:`bayes_step` every control period (live), and the same
    step in the forward projection (likelihood :func:`bayes_likelihood`, recursion
    :func:`~drake_disamb.core.inference.belief.posterior_update`).

    Attributes:
        sigma: Standard deviation (rad) of the Gaussian angle likelihood.
        transition: Goal-transition matrix ``P`` (row-stochastic ``n x n``; ``None``: identity).
    """

    name: ClassVar[str] = "bayes"
    label: ClassVar[str] = "recursive Bayes"
    sigma: float = BAYES_SIGMA
    transition: NDArray[np.float64] | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        s = self.sigma
        if isinstance(s, bool) or not (isinstance(s, int | float | np.floating) and np.isfinite(s) and s > 0):
            raise ValueError(f"BayesInference.sigma: expected a finite positive angle (rad), got {s!r}")
        if self.transition is not None:
            object.__setattr__(
                self, "transition", check_transition(self.transition, "BayesInference.transition")
            )

    def evidence(
        self, u_h: ArrayLike, x_r: ArrayLike, x_g: ArrayLike, u_a: ArrayLike | None = None
    ) -> NDArray[np.float64]:
        return bayes_likelihood(u_h, x_r, x_g, self.sigma)

    def rollout(self, p: ArrayLike, evidence: ArrayLike, dt: float) -> NDArray[np.float64]:
        lik = np.asarray(evidence, dtype=float)
        belief = np.broadcast_to(np.asarray(p, dtype=float), lik.shape[1:])
        out = np.empty_like(lik)
        for s in range(lik.shape[0]):
            belief = out[s] = posterior_update(belief, lik[s], self.transition)
        return out

    def with_transition(self, transition: ArrayLike | None) -> BayesInference:
        return dataclasses.replace(self, transition=transition)

    def check_goal_count(self, n: int) -> None:
        P = self.transition
        if P is not None and np.shape(P) != (n, n):
            raise ValueError(
                f"transition: expected a {n}x{n} matrix (one row per goal), got shape {np.shape(P)}"
            )
