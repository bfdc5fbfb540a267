"""Blending-based shared control (numpy, with a numba-compiled row kernel).

Paper, Section "Study Methods" (Shared Control), equation (sc) and the alpha rule after it::

    u = alpha * u_{a, g*} + (1 - alpha) * u_h,        g* = argmax_i p_i

    alpha = 0                                   if p(g*) <= rho1
          = rho3 (p(g*) - rho1) / (rho2 - rho1) if rho1 < p(g*) <= rho2
          = rho3                                if p(g*) > rho2

with ``rho_i`` in ``[0, 1]``, ``rho2 > rho1``, and in the paper's implementation
``rho1 = 1.2 / n_g``, ``rho2 = 1.4 / n_g``, ``rho3 = 0.7``. Commands are ``[vx, vy, vz, wx, wy, wz]``
(m/s, rad/s) in the world frame. Every function broadcasts over leading batch dimensions.

The law is written once, as scalar functions compiled with numba (``_alpha1``, ``_has_input1``,
``_blend_clamp1`` in :mod:`drake_disamb.core._kernels`); the array functions below call row
kernels built on them (a control loop blends one command per tick, where numpy's cost per call
would dominate).
"""

from __future__ import annotations

import functools
import math
import numbers
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core._kernels import _alpha_rows, _blend_rows, _has_input_rows, _shared_control_rows
from drake_disamb.core.rows import as_rows, batch_shape
from drake_disamb.core.validation import check_real_fields, is_real

RHO1_TIMES_N = 1.2
"""Paper default: ``rho1 = 1.2 / n_g``."""
RHO2_TIMES_N = 1.4
"""Paper default: ``rho2 = 1.4 / n_g``."""
RHO3_DEFAULT = 0.7
"""Paper default: the maximum share of the autonomy."""

NO_INPUT_TOLERANCE = 1e-9
"""A human command whose every entry is at most this (m/s or rad/s) in magnitude counts as no input."""


def resolve_rhos(
    n_goals: int, rho1: float | None = None, rho2: float | None = None, rho3: float = RHO3_DEFAULT
) -> tuple[float, float, float]:
    """The thresholds ``(rho1, rho2, rho3)``, with ``None`` replaced by the paper's defaults.

    Raises ``ValueError`` (naming the parameter and its value) unless every rho is in ``[0, 1]`` and
    ``rho2 > rho1``. With one goal the paper's defaults (1.2, 1.4) lie outside ``[0, 1]``, so
    ``rho1`` and ``rho2`` must then be given explicitly.
    """
    try:  # a control loop asks for the same few thresholds every tick: remembered once checked
        return _resolve_rhos_cached(n_goals, rho1, rho2, rho3)
    except TypeError:  # an unhashable argument: the checks below name it
        return _resolve_rhos(n_goals, rho1, rho2, rho3)


def _resolve_rhos(
    n_goals: int, rho1: float | None = None, rho2: float | None = None, rho3: float = RHO3_DEFAULT
) -> tuple[float, float, float]:
    """:func:`resolve_rhos` itself (the checks and the defaults)."""
    if not (isinstance(n_goals, numbers.Integral) and not isinstance(n_goals, bool) and n_goals >= 1):
        raise ValueError(f"n_goals: expected an integer >= 1, got {n_goals!r}")
    r1 = RHO1_TIMES_N / n_goals if rho1 is None else rho1
    r2 = RHO2_TIMES_N / n_goals if rho2 is None else rho2
    for name, value, given in (("rho1", r1, rho1), ("rho2", r2, rho2), ("rho3", rho3, rho3)):
        if not (is_real(value) and 0.0 <= value <= 1.0):
            hint = "" if given is not None else f" (paper default for n_goals={n_goals}; pass it explicitly)"
            raise ValueError(f"{name}: expected a number in [0, 1], got {value!r}{hint}")
    if not r2 > r1:
        raise ValueError(f"rho2: expected rho2 > rho1 = {r1!r}, got {r2!r}")
    return float(r1), float(r2), float(rho3)


# typed: 1 and True (or 0.5 and a numpy 0.5) are different keys, so a bool is still refused.
_resolve_rhos_cached = functools.lru_cache(maxsize=256, typed=True)(_resolve_rhos)


def blending_alpha(
    p_star: ArrayLike,
    n_goals: int,
    rho1: float | None = None,
    rho2: float | None = None,
    rho3: float = RHO3_DEFAULT,
) -> NDArray[np.float64] | float:
    """The piecewise-linear blending factor of the paper for the top belief ``p_star``.

    ``p_star`` may be a scalar or an array (elementwise). A non-finite ``p_star`` gives 0 (no
    confidence, no assistance). Returns a float for a scalar input, else an array.
    """
    r1, r2, r3 = resolve_rhos(n_goals, rho1, rho2, rho3)
    p = np.asarray(p_star, dtype=float)
    out = np.empty(p.size)
    _alpha_rows(np.ascontiguousarray(p.reshape(-1)), r1, r2, r3, out)
    return float(out[0]) if p.ndim == 0 else out.reshape(p.shape)


def blend(u_h: ArrayLike, u_a: ArrayLike, alpha: ArrayLike) -> NDArray[np.float64]:
    """``alpha * u_a + (1 - alpha) * u_h`` (broadcast; ``alpha`` has the batch shape, no command axis).

    ``u_h`` and ``u_a`` are 6-D commands; ``alpha`` must lie in ``[0, 1]``.
    """
    a = np.asarray(alpha, dtype=float)
    if not np.logical_and.reduce((a >= 0.0) & (a <= 1.0), axis=None):  # np.all, minus its wrapper
        raise ValueError(f"alpha: expected numbers in [0, 1], got {a.tolist()!r}")
    uh, ua = _commands(u_h, "u_h"), _commands(u_a, "u_a")
    batch = batch_shape(uh.shape[:-1], ua.shape[:-1], a.shape)
    out = np.empty((math.prod(batch), 6))
    rows = (as_rows(uh, batch, (6,)), as_rows(ua, batch, (6,)), as_rows(a, batch, ()))
    _blend_rows(*rows, np.inf, np.inf, out)
    return out.reshape(*batch, 6)


def clamp_speed(u: ArrayLike, max_linear_speed: float, max_angular_speed: float) -> NDArray[np.float64]:
    """Scale the translational and rotational parts of 6-D commands down to the given norms.

    Each part keeps its direction; a part already within its limit is unchanged.
    """
    v = _commands(u, "u")
    rows = as_rows(v, v.shape[:-1], (6,))
    out = np.empty_like(rows)
    # The blending kernel's own limits on a blend with alpha = 0 (the command itself): one limiter.
    _blend_rows(rows, rows, np.zeros(rows.shape[0]), float(max_linear_speed), float(max_angular_speed), out)
    return out.reshape(v.shape)


def has_input(u_h: ArrayLike, tolerance: float = NO_INPUT_TOLERANCE) -> NDArray[np.bool_] | bool:
    """True where the human command has any entry larger than ``tolerance`` in magnitude."""
    u = np.asarray(u_h, dtype=float)
    rows = as_rows(u, u.shape[:-1], u.shape[-1:])
    out = np.empty(rows.shape[0], dtype=np.bool_)
    _has_input_rows(rows, float(tolerance), out)
    return bool(out[0]) if u.ndim == 1 else out.reshape(u.shape[:-1])


def _commands(u: ArrayLike, name: str) -> NDArray[np.float64]:
    v = np.asarray(u, dtype=float)
    if v.ndim == 0 or v.shape[-1] != 6:
        raise ValueError(f"{name}: expected shape (..., 6), got {v.shape}")
    return v


@dataclass(frozen=True)
class BlendingConfig:
    """Settings of the shared-control blender.

    Attributes:
        rho1: Belief at or below which the autonomy gets no share; ``None`` = ``1.2 / n_goals``.
        rho2: Belief above which the autonomy gets ``rho3``; ``None`` = ``1.4 / n_goals``.
        rho3: Maximum autonomy share (paper 0.7).
        assist_without_input: If True, blend even when the user gives no command (the paper's
            law taken literally: a stationary user is driven toward ``g*`` at up to
            ``rho3 * |u_a|``). If False (default), the autonomy only assists while the user
            commands the arm; with no input the blended command is zero. See
            :class:`drake_disamb.systems.blending.SharedControlBlender` for why; measured with
            the simulated user (``benchmarks/bench_tasks.py --set
            blending.assist_without_input=true``), the paper's law fails reaching trials the
            default completes (docs/choices.md, "Where we differ from the paper").
        max_linear_speed: Limit (m/s) on the norm of the blended translation. The default is the
            largest blended translation seen in the study logs (docs/facts.md section 6).
        max_angular_speed: Limit (rad/s) on the norm of the blended rotation; default the largest
            joystick rotation in the logs.
        rho1_above_uniform: With ``rho1`` left out, ``rho1 = 1 / n_goals + rho1_above_uniform``
            instead of the paper's ``1.2 / n_goals`` (the study's system: 0.05, which its logs show
            for 4 and 5 goals; ``drake-disamb study identify``). ``None``: the paper's.
        rho2_above_uniform: The same for ``rho2`` (the study's system: 0.10).
    """

    rho1: float | None = None
    rho2: float | None = None
    rho3: float = RHO3_DEFAULT
    assist_without_input: bool = False
    max_linear_speed: float = 0.26
    max_angular_speed: float = 0.67
    rho1_above_uniform: float | None = None
    rho2_above_uniform: float | None = None

    def __post_init__(self) -> None:
        check_real_fields(self, ("max_linear_speed", "max_angular_speed"))
        for name, explicit in (("rho1", self.rho1), ("rho2", self.rho2)):
            margin = getattr(self, f"{name}_above_uniform")
            if margin is None:
                continue
            if not (is_real(margin) and -1.0 <= margin <= 1.0):
                raise ValueError(
                    f"BlendingConfig.{name}_above_uniform: expected a number in [-1, 1], got {margin!r}"
                )
            if explicit is not None:
                raise ValueError(
                    f"BlendingConfig.{name}_above_uniform: give {name} or {name}_above_uniform, not both "
                    f"(got {name}={explicit!r} and {name}_above_uniform={margin!r})"
                )
        if not isinstance(self.assist_without_input, bool):
            raise ValueError(
                "BlendingConfig.assist_without_input: expected True or False, "
                f"got {self.assist_without_input!r}"
            )

    def rhos(self, n_goals: int) -> tuple[float, float, float]:
        """``(rho1, rho2, rho3)`` for ``n_goals`` goals (validated), the ``*_above_uniform``
        margins written out as ``1 / n_goals + margin``."""
        r1, r2 = self.rho1, self.rho2
        if self.rho1_above_uniform is not None or self.rho2_above_uniform is not None:
            resolve_rhos(n_goals, 0.0, 1.0)  # checks n_goals before dividing by it
        if self.rho1_above_uniform is not None:
            r1 = 1.0 / n_goals + self.rho1_above_uniform
        if self.rho2_above_uniform is not None:
            r2 = 1.0 / n_goals + self.rho2_above_uniform
        return resolve_rhos(n_goals, r1, r2, self.rho3)


def shared_control(
    u_h: ArrayLike, belief: ArrayLike, u_a: ArrayLike, config: BlendingConfig
) -> tuple[NDArray[np.float64], NDArray[np.float64] | float, NDArray[np.int64] | int]:
    """The full blending step: ``g*``, ``alpha``, the blended and speed-limited command.

    Args:
        u_h: Human commands ``(..., 6)``.
        belief: Beliefs ``(..., n)`` (``g* = argmax``, ties to the lowest index).
        u_a: Per-goal autonomy commands ``(..., n, 6)``.
        config: Blending settings.

    Returns:
        ``(u, alpha, g_star)``. ``alpha`` is the share actually applied: 0 where the user gives no
        input unless ``config.assist_without_input``.
    """
    uh = _commands(u_h, "u_h")
    p = np.asarray(belief, dtype=float)
    ua = _commands(u_a, "u_a")
    if p.ndim == 0 or ua.ndim < 2 or ua.shape[-2] != p.shape[-1]:
        raise ValueError(
            f"belief/u_a: expected shapes (..., n) and (..., n, 6), got {p.shape} and {ua.shape}"
        )
    n = p.shape[-1]
    r1, r2, r3 = config.rhos(n)
    if uh.ndim == 1 and p.ndim == 1 and ua.ndim == 2:  # one step (a control tick): one row each
        batch: tuple[int, ...] = ()
        rows = (
            np.ascontiguousarray(uh).reshape(1, 6),
            np.ascontiguousarray(p).reshape(1, n),
            np.ascontiguousarray(ua).reshape(1, n, 6),
        )
    else:
        batch = batch_shape(uh.shape[:-1], p.shape[:-1], ua.shape[:-2])
        rows = (as_rows(uh, batch, (6,)), as_rows(p, batch, (n,)), as_rows(ua, batch, (n, 6)))
    size = math.prod(batch)
    u, alpha, g_star = np.empty((size, 6)), np.empty(size), np.empty(size, dtype=np.int64)
    _shared_control_rows(
        *rows,
        r1,
        r2,
        r3,
        config.assist_without_input,
        NO_INPUT_TOLERANCE,
        float(config.max_linear_speed),
        float(config.max_angular_speed),
        u,
        alpha,
        g_star,
    )
    if not batch:
        return u[0], float(alpha[0]), int(g_star[0])
    return u.reshape(*batch, 6), alpha.reshape(batch), g_star.reshape(batch)
