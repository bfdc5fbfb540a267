"""The belief every inference method updates: probability-vector checks, the clip-and-normalise
projection onto the simplex, the goal-transition prior and the posterior recursion the two baselines
share.

Every function broadcasts over leading batch dimensions: ``p`` is ``(..., n)`` (``n`` goals) and a
goal-transition matrix ``P`` is ``(n, n)`` or batched ``(..., n, n)``, row-stochastic.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core._kernels import _normalize_rows
from drake_disamb.core.validation import all_finite

TINY = np.finfo(float).tiny
"""Smallest positive normal double: what the authors' code clips non-positive entries to."""


def check_probability_vector(p: ArrayLike, name: str) -> NDArray[np.float64]:
    """``p`` as a float array whose last axis is a probability vector, else ``ValueError``."""
    a = np.asarray(p, dtype=float)
    if a.ndim == 0 or a.shape[-1] < 1:
        raise ValueError(f"{name}: expected a probability vector, got {p!r}")
    if not np.all(np.isfinite(a)) or np.any(a < 0) or not np.allclose(a.sum(axis=-1), 1.0, atol=1e-9):
        raise ValueError(f"{name}: expected non-negative entries summing to 1, got {a.tolist()!r}")
    return a


def check_transition(P: ArrayLike, name: str) -> NDArray[np.float64]:
    """``P`` as a float array of square row-stochastic matrices (last two axes), else ``ValueError``."""
    a = np.asarray(P, dtype=float)
    if a.ndim < 2 or a.shape[-1] != a.shape[-2]:
        raise ValueError(f"{name}: expected a square (n, n) matrix, got shape {a.shape}")
    if not np.all(np.isfinite(a)) or np.any(a < 0):
        raise ValueError(f"{name}: expected finite non-negative entries, got {a.tolist()!r}")
    if not np.allclose(a.sum(axis=-1), 1.0, atol=1e-6):
        raise ValueError(f"{name}: rows must sum to 1 (row-stochastic), got row sums {a.sum(axis=-1)!r}")
    return a


def safe_unit(
    v: NDArray[np.float64], axis: int = -1, norm: NDArray[np.float64] | None = None
) -> NDArray[np.float64]:
    """Unit vectors along ``axis``; zero (and non-finite) vectors map to zero.

    Non-finite entries are read as 0, and huge (but finite) vectors are first divided by their
    largest absolute entry so that the norm does not overflow (only when the plain norm is not
    finite, so the common case costs one norm and one division). ``norm``, when given, must be
    ``_norm(v, axis)`` (a caller that already has it saves computing it again).
    """
    v = np.asarray(v, dtype=float)
    if norm is None:
        norm = _norm(v, axis)
    if not np.isfinite(np.add.reduce(norm, axis=None)):
        v = np.where(np.isfinite(v), v, 0.0)
        scale = np.max(np.abs(v), axis=axis, keepdims=True)
        v = np.divide(v, scale, out=np.zeros_like(v), where=scale > 0)
        norm = _norm(v, axis)
    return v / np.where(norm > 0, norm, np.inf)  # zero vectors: 0 / inf = 0


def squared_norm(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Squared Euclidean norm over the last axis (axis dropped)."""
    return np.einsum("...k,...k->...", v, v)


def _norm(v: NDArray[np.float64], axis: int = -1) -> NDArray[np.float64]:
    """Euclidean norm along ``axis`` with the axis kept (einsum: much faster on short axes)."""
    if axis == -1 or axis == v.ndim - 1:  # the common case: no axis moves (they cost more than the sum)
        return np.sqrt(np.einsum("...k,...k->...", v, v))[..., None]
    v = np.moveaxis(v, axis, -1)
    return np.moveaxis(np.sqrt(np.einsum("...k,...k->...", v, v))[..., None], -1, axis)


def sanitize_command(u_h: ArrayLike) -> NDArray[np.float64]:
    """Return ``u_h`` as floats, with every command that has a non-finite entry replaced by 0.

    The belief must stay a probability vector whatever the input: a command with a NaN or an
    infinite entry carries no usable direction, so the whole command (last axis) is read as
    "no input" (CONTRIBUTING: such commands are treated as zero).
    """
    u = np.asarray(u_h, dtype=float)
    if all_finite(u):
        return u
    return np.where(np.all(np.isfinite(u), axis=-1, keepdims=True), u, 0.0)


def transition_prior(p: NDArray[np.float64], transition: ArrayLike | None) -> NDArray[np.float64]:
    """``P^T p`` over the last axis (``P`` row-stochastic); identity when ``transition`` is None.

    ``transition`` may be one ``(n, n)`` matrix or a batch ``(..., n, n)`` broadcasting with the
    batch shape of ``p``.
    """
    if transition is None:
        return p
    # (P^T p)_j = sum_i p_i P_ij
    return np.einsum("...i,...ij->...j", p, np.asarray(transition, dtype=float))


def normalize_belief(p: ArrayLike) -> NDArray[np.float64]:
    """Clip entries <= 0 (and NaN ones) to :data:`TINY` and divide by the sum (last axis).

    This is the authors' projection back onto the simplex after each step. Should an entry be
    ``+inf`` (or the sum overflow), the mass goes uniformly to the infinite entries (or the vector
    is first scaled by its maximum), so the result is always a probability vector.
    """
    a = np.asarray(p, dtype=float)
    if a.ndim == 0:
        raise ValueError(f"p: expected shape (..., n), got a scalar {p!r}")
    if a.size == 0:
        return a.copy()
    rows = np.array(a.reshape(-1, a.shape[-1]), order="C")  # our own copy, normalised in place
    _normalize_rows(rows)
    return rows.reshape(a.shape)


def uniform_belief(n_goals: int, batch_shape: tuple[int, ...] = ()) -> NDArray[np.float64]:
    """The uniform belief over ``n_goals`` goals."""
    if n_goals < 1:
        raise ValueError(f"n_goals must be at least 1, got {n_goals}")
    return np.full((*batch_shape, n_goals), 1.0 / n_goals)


def rest_state(n_goals: int, rest: ArrayLike | None = None) -> NDArray[np.float64]:
    """The rest state: ``rest`` validated as a probability vector of ``n_goals`` entries, or uniform."""
    if rest is None:
        return uniform_belief(n_goals)
    r = check_probability_vector(rest, "rest")
    if r.shape[-1] != n_goals:
        raise ValueError(f"rest: expected {n_goals} entries (one per goal), got {r.shape[-1]}")
    return r


def has_command(u_h: NDArray[np.float64]) -> NDArray[np.bool_]:
    """True where the (sanitised) command is non-zero, shape ``(..., 1)``."""
    return np.logical_or.reduce(u_h != 0.0, axis=-1, keepdims=True)  # np.any, minus its wrapper


def posterior_update(
    p: ArrayLike, likelihood: ArrayLike, transition: ArrayLike | None = None
) -> NDArray[np.float64]:
    """Posterior proportional to ``likelihood * (P^T p)``, renormalised (clip as the DFT)."""
    p = np.asarray(p, dtype=float)
    return normalize_belief(np.asarray(likelihood, dtype=float) * transition_prior(p, transition))
