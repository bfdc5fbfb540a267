"""Seeded random samplers shared by the simulated users (pure numpy): the truncated lognormal of
human waits and Wood's von Mises-Fisher sampler of directions about a mean."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

__all__ = ["lognormal", "sample_von_mises_fisher"]


def lognormal(median: float, log_sd: float, rng: np.random.Generator | None) -> float:
    """``median * exp(log_sd * z)``, ``z`` standard normal from ``rng`` truncated to ``[-2, 2]`` (no
    minute-long waits from the tail); ``median`` if ``log_sd`` is 0."""
    if log_sd == 0 or rng is None:
        return float(median)
    return float(median * math.exp(log_sd * min(max(rng.standard_normal(), -2.0), 2.0)))


def sample_von_mises_fisher(
    mu: NDArray[np.float64], kappa: float, rng: np.random.Generator
) -> NDArray[np.float64]:
    """Unit vectors from von Mises-Fisher distributions with mean directions ``mu`` ``(..., d)``.

    Wood's (1994) rejection sampler, vectorised: draw the component ``w`` along the mean
    direction, a uniform direction in the orthogonal complement, and reflect ``e_d`` onto the mean
    direction (Householder). ``mu`` need not be normalised; zero rows give zero vectors.
    """
    mu = np.asarray(mu, dtype=float)
    if not (np.isfinite(kappa) and kappa > 0):
        raise ValueError(f"kappa: expected a finite positive concentration, got {kappa!r}")
    shape, d = mu.shape[:-1], mu.shape[-1]
    if d < 2:
        raise ValueError(f"mu: expected directions with at least 2 components, got shape {mu.shape}")
    flat = mu.reshape(-1, d)
    count = flat.shape[0]
    m1 = d - 1.0
    # b = (-2k + sqrt(4k^2 + m1^2)) / m1, written without cancellation for large kappa.
    b = m1 / (2.0 * kappa + np.sqrt(4.0 * kappa**2 + m1**2))
    x0 = (1.0 - b) / (1.0 + b)
    one_minus_x0_sq = 4.0 * b / (1.0 + b) ** 2
    c = kappa * x0 + m1 * np.log(one_minus_x0_sq)
    w = np.empty(count)
    todo = np.arange(count)
    while todo.size:
        z = rng.beta(m1 / 2.0, m1 / 2.0, size=todo.size)
        cand = (1.0 - (1.0 + b) * z) / (1.0 - (1.0 - b) * z)
        u = rng.random(todo.size)
        accept = kappa * cand + m1 * np.log(1.0 - x0 * cand) - c >= np.log(u)
        w[todo[accept]] = cand[accept]
        todo = todo[~accept]
    v = rng.standard_normal((count, d - 1))
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    sample = np.concatenate([np.sqrt(np.clip(1.0 - w**2, 0.0, None))[:, None] * v, w[:, None]], axis=-1)
    # Householder reflection H = I - 2 h h^T / |h|^2 with h = e_d - mu_hat maps e_d to mu_hat.
    norm = np.linalg.norm(flat, axis=-1, keepdims=True)
    mu_hat = np.divide(flat, norm, out=np.zeros_like(flat), where=norm > 0)
    h = -mu_hat
    h[:, -1] += 1.0
    hh = np.sum(h * h, axis=-1, keepdims=True)
    proj = np.sum(h * sample, axis=-1, keepdims=True)
    out = sample - 2.0 * np.divide(proj, hh, out=np.zeros_like(proj), where=hh > 1e-300) * h
    out = np.where(norm > 0, out, 0.0)
    return out.reshape(*shape, d)
