"""Robust differential inverse kinematics: joint velocities for a commanded end-effector twist
that keep moving near singularities and joint limits (pure numpy, no pydrake).

The station's :class:`~drake_disamb.station.DifferentialIKIntegrator` calls
:func:`solve_velocity_ik` once per control tick with the Jacobian at the integrated set point.
Everything here works on plain arrays: ``J`` is any ``(m, n)`` Jacobian (the station passes the
6 x 6 MICO Jacobian in the paper's row order ``[v; w]``) and ``V`` the commanded twist in the same
row order and units (m/s, rad/s).

How a step is chosen
--------------------
1. **Fast path.** When ``J`` is square and invertible and ``v = J^-1 V`` satisfies every limit
   (position, velocity, acceleration) the command is tracked exactly: status ``OK``.
2. **Singular-value filtering.** Otherwise ``J = U diag(sigma) W^T`` is split into well-conditioned
   directions (``sigma >= singular_threshold``), inverted exactly, and near-singular ones, inverted
   with damped least squares: gain ``sigma / (sigma^2 + mu^2)`` with
   ``mu^2 = max_damping^2 (1 - (sigma / singular_threshold)^2)``, growing as sigma shrinks (no
   damping at the threshold, ``max_damping`` at sigma = 0, never a division by zero). In the damped
   directions the joints are also pulled towards a nominal posture (gain ``nominal_gain``,
   weighted by ``mu^2 / (sigma^2 + mu^2)``), which moves the arm away from the singularity
   instead of freezing on it.
3. **Position limits.** A joint within one full-speed step of a position limit whose step would
   cross it is held at the limit (its velocity lands it there) and the rest of the command is
   re-solved with the remaining joints (least squares over their columns); repeated until no free
   joint crosses. Joints farther away are slowed by step 4 as they approach.
4. **Velocity limits.** The well-conditioned part is scaled by the largest ``s1 in [0, 1]`` that
   keeps every joint inside its position and velocity bounds; then the damped part is added,
   scaled by the largest ``s2 in [0, 1]`` that still fits. Scaling keeps the direction of each
   part, and the well-conditioned directions get the joint-speed budget first.
5. **Acceleration limits.** The step is the fastest multiple of that target (at most 1) that also
   meets the acceleration bounds; when no multiple does (a sudden turn) each joint moves towards
   the target as fast as it may (per-joint clipping), reaching it within a few steps.

The result never has NaN, always respects the position limits (``q + v dt`` stays inside them,
given ``q`` inside) and the velocity limits; the acceleration limits are given up only where they
conflict with the position limits. Its status says how much of the command it achieved (see
:class:`IkStatus`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray


class IkStatus(IntEnum):
    """Outcome codes of a differential-IK step (also the station's ``ik_status`` port)."""

    OK = 0
    """The command was tracked at full speed (a zero command holds the arm still)."""
    STOPPED = 1
    """None of the command could be achieved: less than ``stopped_alpha`` of it along it, and the
    end effector (if it moves at all) moves more than 60 deg away from it. The joints may still move
    slowly towards the nominal posture, out of a singularity."""
    INVALID_COMMAND = 2
    """The command had a NaN or infinite entry and was replaced by zero."""
    LIMITED = 3
    """Only part of the command was achieved because of joint position, velocity or acceleration
    limits: the arm moved as well as it could (slower, or with limited joints held)."""
    RESEEDED = 4
    """The integrated set point had drifted from the measured joints (e.g. blocked by contact) and
    was reset to the measured position; the arm held still for this step."""
    SINGULAR = 5
    """The arm is near a singularity and part of the command lies along a near-singular direction:
    that part was damped, the rest was tracked."""


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


@dataclass(frozen=True)
class IkParams:
    """Settings of :func:`solve_velocity_ik`.

    Attributes:
        singular_threshold: Singular value of ``J`` below which a direction is damped (units of
            ``J``: m/rad for translation rows, 1 for rotation rows). The MICO's home pose has a
            smallest singular value of about 0.07, well above it.
        max_damping: Damping ``mu`` at sigma = 0 (same units); the largest joint-speed gain on a
            damped direction is about ``1 / singular_threshold``.
        nominal_gain: Pull (1/s) towards the nominal posture inside the damped directions.
        limited_alpha: Report ``OK`` only when at least this fraction of the command was achieved
            along it and the error is at most ``1 - limited_alpha`` of it.
        stopped_alpha: Report ``STOPPED`` when less than this fraction was achieved and the end
            effector's motion is more than 60 deg off the command.
    """

    singular_threshold: float = 0.025
    max_damping: float = 0.025
    nominal_gain: float = 0.5
    limited_alpha: float = 0.95
    stopped_alpha: float = 0.02

    def __post_init__(self) -> None:
        for name in ("singular_threshold", "max_damping", "nominal_gain"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise ValueError(f"IkParams.{name}: expected a finite number >= 0, got {v!r}")
        if self.singular_threshold > 0 and not self.max_damping > 0:
            raise ValueError(
                f"IkParams.max_damping: expected > 0 when singular_threshold > 0, got {self.max_damping!r}"
            )
        if not (0 < self.limited_alpha <= 1):
            raise ValueError(
                f"IkParams.limited_alpha: expected a number in (0, 1], got {self.limited_alpha!r}"
            )
        if not (0 <= self.stopped_alpha < self.limited_alpha):
            raise ValueError(
                f"IkParams.stopped_alpha: expected a number in [0, limited_alpha), got {self.stopped_alpha!r}"
            )


@dataclass(frozen=True)
class IkSolution:
    """One differential-IK step.

    Attributes:
        v: Joint velocities (n), inside every bound of :func:`velocity_bounds`.
        status: How much of the command was achieved (:class:`IkStatus`).
        alpha: Achieved fraction of the command along it, ``(J v) . V / |V|^2`` (1 for a zero command).
        error: Relative tracking error ``|J v - V| / |V|`` (0 for a zero command).
        sigma_min: Smallest singular value of ``J`` (NaN when the fast path skipped the SVD).
        held_joints: Joints held at a position limit (indices), empty when none.
    """

    v: NDArray[np.float64]
    status: IkStatus
    alpha: float
    error: float
    sigma_min: float
    held_joints: tuple[int, ...] = ()


def _vector(name: str, value: ArrayLike, n: int) -> NDArray[np.float64]:
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
    q: ArrayLike, v_prev: ArrayLike, dt: float, limits: JointLimits
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The box ``[lo, hi]`` of joint velocities allowed for one step of length ``dt``.

    It is the intersection of the position bounds (``q + v dt`` inside ``[lower, upper]``), the
    velocity bounds and the acceleration bounds (``|v - v_prev| <= acceleration * dt``). Where the
    acceleration interval misses the position/velocity interval of a joint (e.g. moving fast right
    next to a limit), the position/velocity bound nearest to it wins: ``lo = hi`` = that bound.
    ``q`` outside the position limits is treated as on them (the bound then moves it back inside).
    """
    n = limits.size
    q = _vector("velocity_bounds.q", q, n)
    v_prev = _vector("velocity_bounds.v_prev", v_prev, n)
    if not (math.isfinite(dt) and dt > 0):
        raise ValueError(f"velocity_bounds.dt: expected a finite positive number, got {dt!r}")
    return _bounds(q, v_prev, dt, limits)


def _bounds(
    q: NDArray[np.float64], v_prev: NDArray[np.float64], dt: float, limits: JointLimits
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    vmax = limits.velocity
    da = limits.acceleration * dt
    lo_pv = np.maximum((limits.lower - q) / dt, -vmax)
    hi_pv = np.minimum((limits.upper - q) / dt, vmax)
    lo = np.maximum(lo_pv, v_prev - da)
    hi = np.minimum(hi_pv, v_prev + da)
    if (lo > hi).any():  # rare: q outside its limits, or the acceleration interval misses
        lo_pv = np.minimum(lo_pv, vmax)
        hi_pv = np.maximum(np.maximum(hi_pv, -vmax), lo_pv)  # outside: both point back inside
        lo = np.maximum(lo_pv, v_prev - da)
        hi = np.minimum(hi_pv, v_prev + da)
        empty = lo > hi
        nearest = np.where(v_prev - da > hi_pv, hi_pv, lo_pv)
        lo = np.where(empty, nearest, lo)
        hi = np.where(empty, nearest, hi)
    return lo, hi


def _near_limit_bounds(
    q: NDArray[np.float64], dt: float, limits: JointLimits
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Position bounds on v that are tighter than the speed limit (else -inf / inf): a joint whose
    step goes past one is at its limit (within one step at full speed) and gets held there."""
    lo = (limits.lower - q) / dt
    hi = np.maximum((limits.upper - q) / dt, lo)
    vmax = limits.velocity
    return np.where(lo > -vmax, lo, -np.inf), np.where(hi < vmax, hi, np.inf)


def _largest_scale(
    base: NDArray[np.float64], d: NDArray[np.float64], lo: NDArray[np.float64], hi: NDArray[np.float64]
) -> float | None:
    """Largest s in [0, 1] with lo <= base + s d <= hi, or None when no s in [0, 1] fits."""
    s_lo, s_hi = 0.0, 1.0
    # A plain loop: for a handful of joints it is several times faster than numpy's ufuncs.
    for b_j, d_j, lo_j, hi_j in zip(base.tolist(), d.tolist(), lo.tolist(), hi.tolist(), strict=True):
        if d_j > 0.0:
            s_lo = max(s_lo, (lo_j - b_j) / d_j)
            s_hi = min(s_hi, (hi_j - b_j) / d_j)
        elif d_j < 0.0:
            s_lo = max(s_lo, (hi_j - b_j) / d_j)
            s_hi = min(s_hi, (lo_j - b_j) / d_j)
        elif b_j < lo_j or b_j > hi_j:
            return None
    if s_hi < s_lo - 1e-12:
        return None
    return max(s_hi, s_lo)


def filtered_inverse(
    J: NDArray[np.float64],
    V: NDArray[np.float64],
    params: IkParams,
    v_nominal: NDArray[np.float64] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], float]:
    """Singular-value-filtered inverse of ``J`` applied to ``V`` (step 2 of the module docstring).

    Args:
        J: ``(m, k)`` Jacobian (finite).
        V: ``(m,)`` twist in J's row order.
        params: Threshold and damping.
        v_nominal: ``(k,)`` joint velocity towards the nominal posture, added inside the damped
            directions only; ``None`` for none.

    Returns:
        ``(v_good, v_damped, singular_part, sigma_min)``: the joint velocity from the
        well-conditioned directions (exact inverse there), the one from the damped directions
        (damped inverse plus the nominal pull), the part of ``V`` along the damped directions
        (m-vector), and the smallest singular value of ``J`` (0 when ``k < m`` leaves a direction
        unreachable, which is not counted as singular: it is a held-joint limitation).
    """
    U, sigma, Wt = np.linalg.svd(J, full_matrices=False)
    c = U.T @ V
    eps = params.singular_threshold
    bad = sigma < eps
    k = sigma.size
    if not bad.any():
        v_good = Wt.T @ (c / sigma)
        return v_good, np.zeros(k), np.zeros_like(V), float(sigma[-1]) if k else 0.0
    good = ~bad
    v_good = Wt[good].T @ (c[good] / sigma[good]) if good.any() else np.zeros(k)
    sb = sigma[bad]
    mu2 = params.max_damping**2 * (1.0 - (sb / eps) ** 2)
    den = sb * sb + mu2
    gain = np.divide(sb, den, out=np.zeros_like(sb), where=den > 0)
    coeff = gain * c[bad]
    if v_nominal is not None and params.nominal_gain > 0:
        pull = np.divide(mu2, den, out=np.ones_like(sb), where=den > 0)
        coeff = coeff + pull * (Wt[bad] @ v_nominal)
    v_damped = Wt[bad].T @ coeff
    singular_part = U[:, bad] @ c[bad]
    return v_good, v_damped, singular_part, float(sigma[-1])


class VelocityIkSolver:
    """:func:`solve_velocity_ik` with its fixed settings bound once, for a per-tick loop.

    ``solve`` skips the argument checks of :func:`solve_velocity_ik` (the caller guarantees finite
    arrays of the right sizes), which keeps the fast path at a linear solve plus a bounds check.

    Args:
        limits: Joint limits (``n`` joints).
        dt: Step length (s) over which each answer is applied.
        params: Solver settings (defaults when ``None``).
        q_nominal: Nominal posture the damped directions pull towards; ``None`` for no pull.
    """

    def __init__(
        self,
        limits: JointLimits,
        dt: float,
        params: IkParams | None = None,
        q_nominal: ArrayLike | None = None,
    ) -> None:
        if not isinstance(limits, JointLimits):
            raise ValueError(f"VelocityIkSolver.limits: expected JointLimits, got {limits!r}")
        if not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
            raise ValueError(f"VelocityIkSolver.dt: expected a finite positive number, got {dt!r}")
        if params is not None and not isinstance(params, IkParams):
            raise ValueError(f"VelocityIkSolver.params: expected IkParams, got {params!r}")
        self.limits = limits
        self.dt = float(dt)
        self.params = params or IkParams()
        n = limits.size
        self.q_nominal = None if q_nominal is None else _vector("VelocityIkSolver.q_nominal", q_nominal, n)
        self._n = n

    def bounds(
        self, q: NDArray[np.float64], v_prev: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """:func:`velocity_bounds` for this solver's limits and step (unchecked)."""
        return _bounds(q, v_prev, self.dt, self.limits)

    def solve(
        self,
        J: NDArray[np.float64],
        V: NDArray[np.float64],
        q: NDArray[np.float64],
        v_prev: NDArray[np.float64],
    ) -> IkSolution:
        """One step: ``J`` (m, n), ``V`` (m,), ``q`` and ``v_prev`` (n,), all finite (unchecked)."""
        n = self._n
        nV2 = float(V @ V)
        if nV2 == 0.0:
            return IkSolution(np.zeros(n), IkStatus.OK, 1.0, 0.0, float("nan"))
        lo, hi = _bounds(q, v_prev, self.dt, self.limits)

        # 1. Fast path: the exact inverse, when it satisfies every bound (NaN fails the test).
        if J.shape[0] == n:
            try:
                v = np.linalg.solve(J, V)
            except np.linalg.LinAlgError:
                v = None
            if v is not None and (v >= lo).all() and (v <= hi).all():
                return IkSolution(v, IkStatus.OK, 1.0, 0.0, float("nan"))
        return self._robust(J, V, q, nV2, lo, hi)

    def _robust(
        self,
        J: NDArray[np.float64],
        V: NDArray[np.float64],
        q: NDArray[np.float64],
        nV2: float,
        lo: NDArray[np.float64],
        hi: NDArray[np.float64],
    ) -> IkSolution:
        n, params = self._n, self.params
        # 2 + 3. Filtered inverse over the free joints; hold joints at a position limit.
        plo, phi = _near_limit_bounds(q, self.dt, self.limits)
        v_nom_full = None if self.q_nominal is None else params.nominal_gain * (self.q_nominal - q)
        free = np.ones(n, dtype=bool)
        v_held = np.zeros(n)
        sigma_min = float("nan")
        v_good = np.zeros(n)
        v_damped = np.zeros(n)
        for _ in range(n):
            all_free = bool(free.all())
            if all_free:
                Jf, Vr, v_nom = J, V, v_nom_full
            else:
                Jf = J[:, free]
                Vr = V - J[:, ~free] @ v_held[~free]
                v_nom = None if v_nom_full is None else v_nom_full[free]
            g, d, singular_part, smin = filtered_inverse(Jf, Vr, params, v_nom)
            if all_free:
                sigma_min = smin
            v_good[:] = 0.0
            v_damped[:] = 0.0
            v_good[free] = g
            v_damped[free] = d
            step = v_good + v_damped
            cross = free & ((step > phi) | (step < plo))
            if not cross.any():
                break
            v_held[cross] = np.clip(step[cross], lo[cross], hi[cross])
            free &= ~cross
            if not free.any():
                v_good[:] = 0.0
                v_damped[:] = 0.0
                singular_part = np.zeros_like(V)
                break

        # 4. Scale into the velocity box: the well-conditioned part first, then the damped part.
        # (a) Target: inside the position and velocity box (which holds 0), scaled part by part.
        vmax = self.limits.velocity
        lo_pv = np.minimum(np.maximum((self.limits.lower - q) / self.dt, -vmax), vmax)
        hi_pv = np.maximum(np.minimum((self.limits.upper - q) / self.dt, vmax), lo_pv)
        base = np.where(free, 0.0, v_held)
        s1 = _largest_scale(base, v_good, lo_pv, hi_pv)
        v1 = base + s1 * v_good if s1 is not None else np.clip(base + v_good, lo_pv, hi_pv)
        s2 = _largest_scale(v1, v_damped, lo_pv, hi_pv) or 0.0
        target = v1 + s2 * v_damped
        # (b) Acceleration: the fastest speed along the target's direction that meets the bounds;
        # when none does (a sudden turn) each joint moves towards the target as fast as it may.
        s3 = _largest_scale(np.zeros(n), target, lo, hi)
        v = np.clip(s3 * target if s3 is not None else target, lo, hi)  # the clip: rounding only

        JV = J @ v
        alpha = float(JV @ V) / nV2
        error = math.sqrt(float((JV - V) @ (JV - V)) / nV2)
        held = tuple(int(i) for i in np.flatnonzero(~free))
        if alpha >= params.limited_alpha and error <= 1.0 - params.limited_alpha:
            status = IkStatus.OK
        elif alpha < params.stopped_alpha and 2.0 * alpha * nV2 < math.sqrt(float(JV @ JV) * nV2):
            # Under stopped_alpha of the command and the end effector, if it moves at all, moves
            # more than 60 deg away from it (a huge command merely slowed to the speed limits
            # keeps its direction: that is LIMITED).
            status = IkStatus.STOPPED
        elif float(singular_part @ singular_part) > (1.0 - params.limited_alpha) ** 2 * nV2:
            status = IkStatus.SINGULAR
        else:
            status = IkStatus.LIMITED
        return IkSolution(v, status, alpha, error, sigma_min, held)


def solve_velocity_ik(
    J: ArrayLike,
    V: ArrayLike,
    q: ArrayLike,
    v_prev: ArrayLike,
    dt: float,
    limits: JointLimits,
    params: IkParams | None = None,
    q_nominal: ArrayLike | None = None,
) -> IkSolution:
    """Joint velocities that achieve as much of the twist ``V`` as the arm can (module docstring).

    Args:
        J: ``(m, n)`` Jacobian at ``q``, finite; rows in the same order and units as ``V``.
        V: ``(m,)`` commanded twist (finite).
        q: ``(n,)`` current joint positions (the integrator's set point).
        v_prev: ``(n,)`` joint velocities of the previous step (for the acceleration limits).
        dt: Step length (s) over which ``v`` is applied.
        limits: Joint limits (``n`` joints).
        params: Solver settings (defaults when ``None``).
        q_nominal: Nominal posture the damped directions pull towards; ``None`` for no pull.

    Returns:
        The :class:`IkSolution`. A zero ``V`` gives ``v = 0`` and ``OK`` (the arm holds still).

    Raises:
        ValueError: A wrong size or a non-finite entry, naming the argument.
    """
    if not isinstance(limits, JointLimits):
        raise ValueError(f"solve_velocity_ik.limits: expected JointLimits, got {limits!r}")
    n = limits.size
    try:
        Ja = np.asarray(J, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"solve_velocity_ik.J: expected a matrix of numbers, got {J!r}") from None
    if Ja.ndim != 2 or Ja.shape[1] != n or Ja.shape[0] == 0:
        raise ValueError(f"solve_velocity_ik.J: expected shape (m, {n}), got shape {Ja.shape}")
    if not np.all(np.isfinite(Ja)):
        raise ValueError(f"solve_velocity_ik.J: expected finite numbers, got {Ja.tolist()}")
    Va = _vector("solve_velocity_ik.V", V, Ja.shape[0])
    qa = _vector("solve_velocity_ik.q", q, n)
    va = _vector("solve_velocity_ik.v_prev", v_prev, n)
    if not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
        raise ValueError(f"solve_velocity_ik.dt: expected a finite positive number, got {dt!r}")
    return VelocityIkSolver(limits, dt, params, q_nominal).solve(Ja, Va, qa, va)


__all__ = [
    "IkParams",
    "IkSolution",
    "IkStatus",
    "JointLimits",
    "VelocityIkSolver",
    "filtered_inverse",
    "solve_velocity_ik",
    "velocity_bounds",
]
