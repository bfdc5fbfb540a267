"""Intent-inference updates: field-theoretic (DFT), recursive Bayes and memory-based.

Every function here is pure numpy and broadcasts over any number of leading batch dimensions,
so the same update serves a single live step, a vectorised replay of hundreds of trials, and the
disambiguation forward projection of all probe directions at once.

Shapes (``...`` is any batch shape, ``n`` the number of goals):

- ``p``: belief, ``(..., n)``, a probability vector.
- ``u_h``: human command, ``(..., d)`` with ``d`` = 3 (``[vx, vy, vz]``, m/s) or 6
  (``[vx, vy, vz, wx, wy, wz]``, m/s and rad/s). Only the first three entries enter the
  directedness term; entries 3..5 enter the agreement term.
- ``x_r``: end-effector (robot) position, ``(..., 3)``, m.
- ``x_g``: goal positions, ``(..., n, 3)``, m.
- ``u_a``: per-goal autonomy commands, ``(..., n, 6)`` (only needed for the agreement term).

The DFT right-hand side is paper equation (dft_ii) with the time constant split in two, as in the
authors' code (FACTS section 1)::

    f(p) = -(1/tau1) P^T p + rest/tau2 + lambda @ sigma(xi),   sigma(xi) = 1/(1+exp(-xi)) - 0.5

Two integrations of it are offered:

- :func:`dft_euler_step`: the authors' discretisation (explicit Euler, clip entries <= 0 to the
  smallest positive double, renormalise). Used to replay published data.
- :func:`dft_mass_conserving_rhs`: ``f(p) - p * sum(f(p))``, the first-order equivalent whose
  flow keeps ``sum(p) = 1`` exactly under any explicit Runge-Kutta method. Drake integrates this
  as continuous state.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

TINY = np.finfo(float).tiny
"""Smallest positive normal double: what the authors' code clips non-positive entries to."""

BAYES_SIGMA = np.pi / 2.0
"""Standard deviation (rad) of the Gaussian angle likelihood of the recursive Bayes baseline."""


@dataclass(frozen=True)
class DFTParams:
    """Parameters of the field-theoretic update.

    Attributes:
        tau1: Time constant (s) of the goal-transition (decay) term ``-P^T p``.
        tau2: Time constant (s) of the rest-state term.
        lam: Excitation gain (1/s): a scalar (``lam * I``) or an ``n x n`` matrix.
        directedness: Include the directedness term ``(1 + eta_i)/2``.
        agreement: Include the agreement term (cosine between the rotational parts of the human
            command and of goal i's autonomy command; 0 when either is zero).
        proximity: Include the proximity term ``max(0, 1 - |x_g - x_r| / R)``.
        R: Proximity radius (m).
        transition: Goal-transition matrix ``P`` (row-stochastic, ``n x n``); ``None`` means I.
        rest: Rest state (task prior, a probability vector); ``None`` means uniform.
    """

    tau1: float = 10.0
    tau2: float = 10.0
    lam: float | NDArray[np.float64] = 200.0
    directedness: bool = True
    agreement: bool = False
    proximity: bool = False
    R: float = 0.2
    transition: NDArray[np.float64] | None = field(default=None, compare=False)
    rest: NDArray[np.float64] | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        for name in ("tau1", "tau2", "R"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"DFTParams.{name} must be a finite positive number, got {value!r}")
        lam = np.asarray(self.lam, dtype=float)
        if not np.all(np.isfinite(lam)):
            raise ValueError(f"DFTParams.lam must be finite, got {self.lam!r}")


# ----------------------------------------------------------------------------------------------
# Helpers
# ----------------------------------------------------------------------------------------------


def _safe_unit(v: NDArray[np.float64], axis: int = -1) -> NDArray[np.float64]:
    """Unit vectors along ``axis``; zero (and non-finite) vectors map to zero."""
    v = np.where(np.isfinite(v), v, 0.0)
    norm = np.linalg.norm(v, axis=axis, keepdims=True)
    return np.divide(v, norm, out=np.zeros_like(v), where=norm > 0)


def sanitize_command(u_h: ArrayLike) -> NDArray[np.float64]:
    """Return ``u_h`` as floats with every non-finite entry replaced by 0.

    The belief must stay a probability vector whatever the input: a NaN or infinite command
    carries no usable direction, so it is read as "no input" along that entry.
    """
    u = np.asarray(u_h, dtype=float)
    return np.where(np.isfinite(u), u, 0.0)


def transition_prior(p: NDArray[np.float64], transition: ArrayLike | None) -> NDArray[np.float64]:
    """``P^T p`` over the last axis (``P`` row-stochastic); identity when ``transition`` is None."""
    if transition is None:
        return p
    P = np.asarray(transition, dtype=float)
    return p @ P  # (p @ P)_j = sum_i p_i P_ij = (P^T p)_j


def normalize_belief(p: NDArray[np.float64]) -> NDArray[np.float64]:
    """Clip entries <= 0 (and non-finite ones) to :data:`TINY` and divide by the sum.

    This is the authors' projection back onto the simplex after each step.
    """
    p = np.where(np.isfinite(p) & (p > 0), p, TINY)
    return p / p.sum(axis=-1, keepdims=True)


def uniform_belief(n_goals: int, batch_shape: tuple[int, ...] = ()) -> NDArray[np.float64]:
    """The uniform belief over ``n_goals`` goals."""
    if n_goals < 1:
        raise ValueError(f"n_goals must be at least 1, got {n_goals}")
    return np.full((*batch_shape, n_goals), 1.0 / n_goals)


# ----------------------------------------------------------------------------------------------
# Field-theoretic (DFT) inference
# ----------------------------------------------------------------------------------------------


def directedness(u_h: ArrayLike, x_r: ArrayLike, x_g: ArrayLike) -> NDArray[np.float64]:
    """``(1 + eta_i) / 2`` with ``eta_i`` the cosine between ``u_h[:3]`` and ``x_g_i - x_r``.

    A zero command, or a goal at the robot's position, gives ``eta_i = 0`` (the authors'
    convention: the normalised zero vector is zero), i.e. a directedness of 0.5.
    Returns shape ``(..., n)``.
    """
    u = _safe_unit(sanitize_command(u_h)[..., :3])
    d = _safe_unit(np.asarray(x_g, dtype=float) - np.asarray(x_r, dtype=float)[..., None, :])
    eta = np.einsum("...k,...nk->...n", u, d)
    return 0.5 * (1.0 + eta)


def agreement(u_h: ArrayLike, u_a: ArrayLike) -> NDArray[np.float64]:
    """Cosine between the rotational parts of ``u_h`` and of each goal's autonomy command.

    Zero when the human gives no rotation, when ``u_h`` has only 3 entries, or when a goal's
    autonomy command has no rotation. Returns shape ``(..., n)``.
    """
    u = sanitize_command(u_h)
    ua = np.asarray(u_a, dtype=float)
    if u.shape[-1] < 6:
        return np.zeros(ua.shape[:-1])
    uh_rot = _safe_unit(u[..., 3:6])
    ua_rot = _safe_unit(ua[..., 3:6])
    return np.einsum("...k,...nk->...n", uh_rot, ua_rot)


def proximity(x_r: ArrayLike, x_g: ArrayLike, R: float) -> NDArray[np.float64]:
    """``max(0, 1 - |x_g_i - x_r| / R)`` (positions only). Returns shape ``(..., n)``."""
    dist = np.linalg.norm(np.asarray(x_g, dtype=float) - np.asarray(x_r, dtype=float)[..., None, :], axis=-1)
    return np.maximum(0.0, 1.0 - dist / R)


def dft_xi(
    u_h: ArrayLike,
    x_r: ArrayLike,
    x_g: ArrayLike,
    params: DFTParams,
    u_a: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """The input nonlinearity ``xi`` of equation (dft_ii), shape ``(..., n)``."""
    x_g = np.asarray(x_g, dtype=float)
    batch = np.broadcast_shapes(np.shape(x_r)[:-1], x_g.shape[:-2])
    xi = np.zeros((*batch, x_g.shape[-2]))
    if params.directedness:
        xi = xi + directedness(u_h, x_r, x_g)
    if params.agreement:
        if u_a is None:
            raise ValueError("DFTParams.agreement is on but no per-goal autonomy commands u_a given")
        xi = xi + agreement(u_h, u_a)
    if params.proximity:
        xi = xi + proximity(x_r, x_g, params.R)
    return xi


def biased_sigmoid(xi: ArrayLike) -> NDArray[np.float64]:
    """``sigma(xi) = 1 / (1 + exp(-xi)) - 0.5``."""
    return 1.0 / (1.0 + np.exp(-np.asarray(xi, dtype=float))) - 0.5


def dft_rhs(
    p: ArrayLike,
    u_h: ArrayLike,
    x_r: ArrayLike,
    x_g: ArrayLike,
    params: DFTParams,
    u_a: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """Right-hand side ``f(p)`` of the DFT ODE (1/s), shape ``(..., n)``."""
    p = np.asarray(p, dtype=float)
    n = p.shape[-1]
    rest = np.full(n, 1.0 / n) if params.rest is None else np.asarray(params.rest, dtype=float)
    s = biased_sigmoid(dft_xi(u_h, x_r, x_g, params, u_a))
    lam = np.asarray(params.lam, dtype=float)
    excitation = lam * s if lam.ndim == 0 else s @ lam.T
    return -transition_prior(p, params.transition) / params.tau1 + rest / params.tau2 + excitation


def dft_mass_conserving_rhs(
    p: ArrayLike,
    u_h: ArrayLike,
    x_r: ArrayLike,
    x_g: ArrayLike,
    params: DFTParams,
    u_a: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """``f(p) - p * sum(f(p))``: the DFT flow projected so that ``sum(p)`` is conserved.

    To first order in the step this equals the authors' "Euler step then renormalise". Entries
    that have reached zero are not driven further negative (positivity guard), and the removed
    mass is taken proportionally from the others so the sum is still conserved.
    """
    p = np.asarray(p, dtype=float)
    f = dft_rhs(p, u_h, x_r, x_g, params, u_a)
    g = f - p * f.sum(axis=-1, keepdims=True)
    # Positivity guard: an entry at (or below) zero may not decrease further.
    blocked = (p <= 0.0) & (g < 0.0)
    if np.any(blocked):
        excess = np.where(blocked, g, 0.0).sum(axis=-1, keepdims=True)  # <= 0
        g = np.where(blocked, 0.0, g)
        free_mass = np.where(blocked, 0.0, np.maximum(p, 0.0)).sum(axis=-1, keepdims=True)
        share = np.divide(np.maximum(p, 0.0), free_mass, out=np.zeros_like(p), where=free_mass > 0)
        g = g + np.where(blocked, 0.0, share * excess)
    return g


def dft_euler_step(
    p: ArrayLike,
    u_h: ArrayLike,
    x_r: ArrayLike,
    x_g: ArrayLike,
    params: DFTParams,
    dt: float,
    u_a: ArrayLike | None = None,
) -> NDArray[np.float64]:
    """One step of the authors' discretisation: ``normalize(p + dt * f(p))``."""
    p = np.asarray(p, dtype=float)
    return normalize_belief(p + dt * dft_rhs(p, u_h, x_r, x_g, params, u_a))


# ----------------------------------------------------------------------------------------------
# Recursive Bayesian update
# ----------------------------------------------------------------------------------------------


def bayes_likelihood(
    u_h: ArrayLike, x_r: ArrayLike, x_g: ArrayLike, sigma: float = BAYES_SIGMA
) -> NDArray[np.float64]:
    """Gaussian density (mean 0, std ``sigma``) of the angle between ``u_h[:3]`` and each goal.

    The cosine is rounded to 5 decimals before ``arccos`` (authors' code). A zero command gives a
    uniform likelihood. A goal at the robot's position has no direction: its angle is taken as
    pi/2 (neither towards nor away). Returns shape ``(..., n)``.
    """
    u_raw = sanitize_command(u_h)[..., :3]
    u = _safe_unit(u_raw)
    d = _safe_unit(np.asarray(x_g, dtype=float) - np.asarray(x_r, dtype=float)[..., None, :])
    cos = np.round(np.einsum("...k,...nk->...n", u, d), 5)
    angle = np.arccos(np.clip(cos, -1.0, 1.0))
    lik = np.exp(-0.5 * (angle / sigma) ** 2) / (sigma * np.sqrt(2.0 * np.pi))
    no_input = np.linalg.norm(u_raw, axis=-1, keepdims=True) == 0
    return np.where(no_input, 1.0, lik)


def bayes_step(
    p: ArrayLike,
    u_h: ArrayLike,
    x_r: ArrayLike,
    x_g: ArrayLike,
    transition: ArrayLike | None = None,
    sigma: float = BAYES_SIGMA,
) -> NDArray[np.float64]:
    """Posterior proportional to ``likelihood(u_h | g) * (P^T p)``, renormalised."""
    p = np.asarray(p, dtype=float)
    return normalize_belief(bayes_likelihood(u_h, x_r, x_g, sigma) * transition_prior(p, transition))


# ----------------------------------------------------------------------------------------------
# Memory-based prediction (Dragan & Srinivasa 2013, as in the authors' code)
# ----------------------------------------------------------------------------------------------


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

    ``cost`` (shape ``(...)``) is the running path cost ``C = sum |x_{t+1} - x_t|^2`` so far. The
    likelihood of goal g is ``exp(-C - |x_next - g|^2) / exp(-|x_start - g|^2)``, applied
    recursively: posterior proportional to ``likelihood * (P^T p)``.

    Returns ``(p_new, cost_new)``.
    """
    p = np.asarray(p, dtype=float)
    x_prev = np.asarray(x_prev, dtype=float)
    x_next = np.asarray(x_next, dtype=float)
    x_g = np.asarray(x_g, dtype=float)
    cost_new = np.asarray(cost, dtype=float) + np.sum((x_next - x_prev) ** 2, axis=-1)
    to_go = np.sum((x_g - x_next[..., None, :]) ** 2, axis=-1)
    start = np.sum((x_g - np.asarray(x_start, dtype=float)[..., None, :]) ** 2, axis=-1)
    log_lik = -cost_new[..., None] - to_go + start
    # Subtracting the per-row max leaves the normalised posterior unchanged and avoids overflow.
    lik = np.exp(log_lik - np.max(log_lik, axis=-1, keepdims=True))
    return normalize_belief(lik * transition_prior(p, transition)), cost_new
