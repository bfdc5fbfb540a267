"""Joint limits and the box of joint velocities they allow in one step (position, velocity, acceleration).

:class:`JointLimits` holds the per-joint limits; :func:`velocity_bounds` gives the box ``[lo, hi]``
of joint velocities one step of the differential IK (:mod:`drake_disamb.ik`) may take: the joints
brake towards their position limits at their acceleration limits and never pass them. Plain numpy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray


@dataclass(frozen=True)
class JointLimits:
    """Per-joint limits, ``n`` joints.

    Attributes:
        lower, upper: Position limits (rad or m), ``lower <= upper``.
        velocity: Speed limits (rad/s or m/s), positive; the velocity box is ``[-velocity, velocity]``.
        acceleration: Acceleration limits (rad/s^2 or m/s^2), positive; ``inf`` disables them.
    """

    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    velocity: NDArray[np.float64]
    acceleration: NDArray[np.float64]

    def __post_init__(self) -> None:
        arrays = {}
        for name in ("lower", "upper", "velocity", "acceleration"):
            value = getattr(self, name)
            try:
                a = np.array(value, dtype=float).reshape(-1)
            except (TypeError, ValueError):
                raise ValueError(f"JointLimits.{name}: expected numbers, got {value!r}") from None
            arrays[name] = a
        n = arrays["lower"].size
        if n == 0:
            raise ValueError("JointLimits.lower: expected at least one joint, got []")
        for name, a in arrays.items():
            if a.size != n:
                raise ValueError(f"JointLimits.{name}: expected {n} numbers, got {a.tolist()}")
            if np.any(np.isnan(a)):
                raise ValueError(f"JointLimits.{name}: expected numbers, got {a.tolist()}")
        if np.any(arrays["lower"] > arrays["upper"]):
            raise ValueError(
                f"JointLimits.upper: expected >= lower {arrays['lower'].tolist()}, "
                f"got {arrays['upper'].tolist()}"
            )
        for name in ("velocity", "acceleration"):
            a = arrays[name]
            if np.any(~(a > 0)) or (name == "velocity" and not np.all(np.isfinite(a))):
                kind = "finite positive" if name == "velocity" else "positive"
                raise ValueError(f"JointLimits.{name}: expected {kind} numbers, got {a.tolist()}")
        for name, a in arrays.items():
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @property
    def size(self) -> int:
        """Number of joints."""
        return int(self.lower.size)


def finite_vector(name: str, value: ArrayLike, n: int) -> NDArray[np.float64]:
    """``value`` as ``n`` finite floats; a ``ValueError`` naming ``name`` and the value otherwise."""
    try:
        a = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected {n} numbers, got {value!r}") from None
    if a.size != n:
        raise ValueError(f"{name}: expected {n} numbers, got {a.tolist()}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}: expected finite numbers, got {a.tolist()}")
    return a


def velocity_bounds(
    q: ArrayLike, v_prev: ArrayLike, dt: float, limits: JointLimits, speed_factor: float = 1.0
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The box ``[lo, hi]`` of joint velocities allowed for one step of length ``dt``.

    It is the intersection of the position bounds, the velocity bounds (``speed_factor`` times
    ``limits.velocity``; a joint already faster than that slows to it at its acceleration limit)
    and the acceleration bounds (``|v - v_prev| <= acceleration * dt``). The
    position bounds brake: towards a limit a joint may go no faster than it can still stop on it at
    its acceleration limit (``v <= -a dt / 2 + sqrt((a dt / 2)^2 + 2 a d)`` for a distance ``d``),
    and never past it (``q + v dt`` inside ``[lower, upper]``). Where the acceleration interval
    misses the position/velocity interval of a joint (e.g. moving fast right next to a limit), the
    position/velocity bound nearest to it wins: ``lo = hi`` = that bound. ``q`` outside the
    position limits is treated as on them (the bound then moves it back inside).
    """
    n = limits.size
    q = finite_vector("velocity_bounds.q", q, n)
    v_prev = finite_vector("velocity_bounds.v_prev", v_prev, n)
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"velocity_bounds.dt: expected a finite positive number, got {dt!r}")
    if not (isinstance(speed_factor, int | float) and 0 < speed_factor <= 1):
        raise ValueError(f"velocity_bounds.speed_factor: expected a number in (0, 1], got {speed_factor!r}")
    return step_bounds(q, v_prev, dt, limits, float(speed_factor))


def _position_velocity_bounds(
    q: NDArray[np.float64],
    dt: float,
    limits: JointLimits,
    speed_factor: float,
    v_prev: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The braking position bounds and the velocity bounds (no acceleration bounds). They hold 0
    when ``q`` is inside its limits; outside them ``lo = hi`` points back inside. The reduced
    speed limit ``speed_factor * velocity`` is soft: a joint faster than it (``v_prev``) slows
    down to it at its acceleration limit, not in one step."""
    vmax = limits.velocity * speed_factor
    if speed_factor < 1.0 and v_prev is not None:
        ramp = np.abs(v_prev) - np.minimum(limits.acceleration, 1e12) * dt
        vmax = np.minimum(limits.velocity, np.maximum(vmax, ramp))
    ad = np.minimum(limits.acceleration, 1e12) * dt * 0.5
    up = np.maximum(limits.upper - q, 0.0)
    down = np.maximum(q - limits.lower, 0.0)
    brake_up = np.sqrt(ad * ad + 4.0 * ad / dt * up) - ad  # sqrt((a dt/2)^2 + 2 a d) - a dt/2
    brake_down = np.sqrt(ad * ad + 4.0 * ad / dt * down) - ad
    hi = np.minimum(np.minimum(brake_up, up / dt), vmax)
    lo = np.maximum(np.maximum(-brake_down, -down / dt), -vmax)
    back_up = q < limits.lower  # outside a limit: head straight back, as fast as allowed
    back_down = q > limits.upper
    lo = np.where(back_up, np.minimum((limits.lower - q) / dt, vmax), lo)
    hi = np.where(back_up, lo, hi)
    hi = np.where(back_down, np.maximum((limits.upper - q) / dt, -vmax), hi)
    lo = np.where(back_down, hi, lo)
    return lo, hi


def step_bounds(
    q: NDArray[np.float64],
    v_prev: NDArray[np.float64],
    dt: float,
    limits: JointLimits,
    speed_factor: float = 1.0,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`velocity_bounds` without its checks (the solver's per-tick path: its inputs are checked)."""
    lo_pv, hi_pv = _position_velocity_bounds(q, dt, limits, speed_factor, v_prev)
    da = limits.acceleration * dt
    lo = np.maximum(lo_pv, v_prev - da)
    hi = np.minimum(hi_pv, v_prev + da)
    empty = lo > hi
    if empty.any():  # the acceleration interval misses: the nearest position/velocity bound wins
        nearest = np.where(v_prev - da > hi_pv, hi_pv, lo_pv)
        lo = np.where(empty, nearest, lo)
        hi = np.where(empty, nearest, hi)
    return lo, hi


__all__ = ["JointLimits", "finite_vector", "step_bounds", "velocity_bounds"]
