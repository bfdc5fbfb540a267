"""Direction-preserving differential IK: the end effector moves along the commanded twist or not at all.

Joint velocities for a commanded end-effector twist that move the end effector along that twist and
nowhere else (pure numpy, no pydrake).

The controller's :class:`~drake_disamb.controller.DifferentialIKIntegrator` calls
:meth:`VelocityIkSolver.solve` once per control tick with the Jacobian at the integrated set point.
Everything here works on plain arrays: ``J`` is any ``(m, n)`` Jacobian (the controller passes the
6 x 6 MICO Jacobian in the paper's row order ``[v; w]``) and ``V`` the commanded twist in the same
row order and units (m/s, rad/s).

The joint limits and the box of joint velocities they allow in one step are
:mod:`drake_disamb.joint_limits`; this module chooses the step inside that box.

The safety contract
-------------------
An assistive arm moves next to a person, so the step never trades the command's direction for
progress: **the end effector moves along the commanded twist, slower, or not at all.** Formally
the joint velocity is ``v = t * v_V + v_N`` where

- ``J v_V = V / |V|_inf`` exactly (up to floating-point rounding, checked to a relative residual of
  ``1e-9``), and ``t in [0, |V|_inf]`` is the largest speed along the command that every joint
  limit allows; the achieved fraction ``alpha = t / |V|_inf`` is reported, never silently bent;
- ``v_N`` is the nominal-posture pull, projected onto the joint directions whose singular value is
  at most ``IkParams.null_threshold`` (the null space of the task). It moves the end effector at
  most ``null_threshold * |v_N|``: with the defaults (1e-4 m/rad and joint speeds under 1 rad/s)
  **under 0.2 mm/s**, whatever the command. For the non-redundant MICO away from an exact
  singularity that space is empty and ``v_N = 0``.

So the end effector's motion outside the commanded direction per step is bounded by that pull plus
rounding; a zero command gives ``v = 0`` (the arm holds still). What is left is the physical arm's
tracking of these set points (the station's PD), which the station's tests bound on the real
plant: at most 2 cm and 1 cm/s off the command over 10 s of any single-axis command from any
tested posture, singular and joint-limited ones included.

How a step is chosen
--------------------
1. **Fast path.** When ``J`` is square and ``np.linalg.solve`` gives ``v_V`` with a residual under
   ``1e-9`` (a near-singular ``J`` gives a huge but exact ``v_V``), the speed ``t`` is the largest
   in ``[0, |V|_inf]`` for which ``t v_V`` meets every bound of
   :func:`~drake_disamb.joint_limits.velocity_bounds` (position, velocity, acceleration). Near a
   singularity ``v_V`` grows like ``1 / sigma_min``, so the arm slows smoothly to a stop as it
   approaches it instead of being pushed through it.
2. **Rank-deficient or non-square ``J``.** An SVD splits ``J``: directions with singular value
   above ``null_threshold`` are inverted exactly; if the command has a component outside their
   span (more than ``1e-6`` of it) no joint motion produces it and ``t = 0``: the command is
   refused (``STOPPED``), it is not replaced by its achievable part. The remaining joint
   directions form the null space where the posture pull acts.
3. **Acceleration limits give way to direction.** When no point of the commanded line meets the
   acceleration bounds (a sudden turn while moving fast), the step takes the point of the line
   inside the position and velocity bounds that is nearest to the previous velocity (weighted by
   the acceleration limits): the set point changes direction at once instead of curving through
   directions nobody commanded. Position and velocity limits always hold.
4. **A singular barrier.** Below ``IkParams.singular_threshold``, with the smallest singular value
   at the step's end known (``sigma_at``), a step that would take it below
   ``IkParams.singular_barrier`` is shortened along the command to end at the barrier, and a step
   deeper from the barrier is refused (``STOPPED``); a step that raises it is not held back. The
   slowdown of step 1 alone lets a long push creep ever deeper, until every command that needs
   the singular direction, the way back included, is slowed to nothing.

Why not Drake's ``DoDifferentialInverseKinematics``
---------------------------------------------------
Drake's function poses the same core problem as a quadratic program (maximise the fraction
``alpha`` of the command subject to ``J v = alpha V`` and box constraints on position, velocity and
acceleration, plus a null-space posture cost) and hands it to a solver on every call. It is
direction-preserving too, and it costs about as much per tick as this module
(``benchmarks/bench_ik.py`` prints both on the MICO). We keep our own because the safety contract
above needs behaviour that program does not have:

- it **brakes** towards a joint's position limit at the acceleration limit; Drake's program only
  keeps the next step inside the limit, so a joint arrives at full speed and stops in one step,
  a jolt whose tracking transient moves the physical end effector off the command;
- it **slows the joints near a singularity** (the speed factor above), not only the end effector,
  and keeps the arm out of the singularity's depth (the barrier);
- it keeps the **direction when the acceleration bounds cannot be met** (a sudden turn while
  moving fast): Drake's program is then infeasible and returns no step at all;
- it applies **task-space bounds** (the floor above the table) along the same line;
- it says **why** a step was slowed (:class:`IkStatus`: joint limit, singularity, workspace,
  refused direction), which the controller reports on ``ik_status``;
- it is plain numpy, so every rule above is tested in isolation without building a plant.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.joint_limits import JointLimits, finite_vector, step_bounds

_RANGE_TOL = 1e-6
"""Relative part of a command outside the span of J beyond which the command is refused."""


class IkStatus(IntEnum):
    """Outcome codes of a differential-IK step (also the controller's ``ik_status`` port)."""

    OK = 0
    """The command was tracked at (at least ``limited_alpha`` of) full speed; a zero command holds
    the arm still."""
    STOPPED = 1
    """Less than ``stopped_alpha`` of the command can be achieved along it, and every joint moves
    at less than that fraction of its speed limit (a joint on its limit, an exact singularity, or
    a direction no joint motion produces): the end effector stays still, apart from the bounded
    null-space pull."""
    INVALID_COMMAND = 2
    """The command had a NaN or infinite entry and was replaced by zero."""
    LIMITED = 3
    """The command was slowed along its own direction by joint position, velocity or acceleration
    limits."""
    RESEEDED = 4
    """The integrated set point had drifted from the measured joints (e.g. blocked by contact) and
    was reset to the measured position; the arm held still for this step."""
    SINGULAR = 5
    """The arm is near a singularity (smallest singular value under ``singular_threshold``) and the
    command was slowed along its own direction because it needs the near-singular direction."""
    WORKSPACE = 6
    """The command was slowed or stopped along its own direction at the edge of the allowed
    workspace (the station's floor above the table top)."""


@dataclass(frozen=True)
class IkParams:
    """Settings of :func:`solve_velocity_ik`.

    Attributes:
        singular_threshold: Smallest singular value of ``J`` (m/rad for translation rows, 1 for
            rotation rows) below which the arm is near a singularity: the joint speed limits shrink
            in proportion (``sigma_min / singular_threshold``, at least ``singular_speed_floor``),
            so the joints slow down with the end effector instead of whirling at full speed while
            it barely moves (the physical arm's lag behind such a fast set point is what would
            move it off the command), and a slowed step is reported ``SINGULAR``. The MICO's home
            pose has a smallest singular value of about 0.07, above the default.
        singular_speed_floor: Smallest fraction of the joint speed limits near a singularity, so
            that commands leading out of it still move the arm.
        singular_barrier: Smallest singular value a step may bring the arm to (at most
            ``singular_threshold``; 0 for none). A step that would lower ``sigma_min`` below it is
            shortened along the command to end there, and refused once the arm is there: deep in a
            singularity every command that needs the singular direction is slowed to nothing, the
            way back included (a trap). Commands that raise ``sigma_min`` are never held back.
            Needs the smallest singular value at the step's end (``VelocityIkSolver.solve``'s
            ``sigma_at``); without it there is no barrier.
        null_threshold: Singular value at or below which a joint direction counts as the task's
            null space (same units): the command is never sent along it, and the posture pull
            acts only there. It bounds the end-effector speed the pull can cause
            (``null_threshold`` times the pull's joint speed).
        nominal_gain: Pull (1/s) towards the nominal posture inside the null space.
        limited_alpha: Report ``OK`` only when at least this fraction of the command was achieved.
        stopped_alpha: Report ``STOPPED`` when less than this fraction was achieved.
    """

    singular_threshold: float = 0.025
    singular_speed_floor: float = 0.1
    singular_barrier: float = 0.01
    null_threshold: float = 1e-4
    nominal_gain: float = 0.5
    limited_alpha: float = 0.95
    stopped_alpha: float = 0.02

    def __post_init__(self) -> None:
        for name in ("singular_threshold", "null_threshold", "nominal_gain"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v >= 0):
                raise ValueError(f"IkParams.{name}: expected a finite number >= 0, got {v!r}")
        if not (isinstance(self.singular_speed_floor, int | float) and 0 < self.singular_speed_floor <= 1):
            raise ValueError(
                "IkParams.singular_speed_floor: expected a number in (0, 1], "
                f"got {self.singular_speed_floor!r}"
            )
        b = self.singular_barrier
        if not (isinstance(b, int | float) and not isinstance(b, bool) and 0 <= b <= self.singular_threshold):
            raise ValueError(
                "IkParams.singular_barrier: expected a number in [0, singular_threshold = "
                f"{self.singular_threshold!r}], got {b!r}"
            )
        if not self.null_threshold <= 1e-2:
            raise ValueError(
                f"IkParams.null_threshold: expected at most 0.01 (it bounds uncommanded motion), "
                f"got {self.null_threshold!r}"
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
        v: Joint velocities (n), inside the position and velocity bounds of
            :func:`~drake_disamb.joint_limits.velocity_bounds` (and inside the acceleration bounds
            too unless the commanded line misses them).
        status: How much of the command was achieved and why not all of it (:class:`IkStatus`).
        alpha: Achieved fraction of the command along it, ``(J v) . V / |V|^2`` (1 for a zero command).
        error: Relative tracking error ``|J v - alpha V| / |V|``: the motion outside the command's
            direction, relative to the command (0 up to rounding and the null-space pull).
        sigma_min: Smallest singular value of ``J`` (NaN when the fast path skipped the SVD).
        limiting_joints: Joints whose bound set the speed along the command (indices), empty when
            the full command was achieved.
    """

    v: NDArray[np.float64]
    status: IkStatus
    alpha: float
    error: float
    sigma_min: float
    limiting_joints: tuple[int, ...] = ()


def _speed_interval(
    base: NDArray[np.float64], d: NDArray[np.float64], lo: NDArray[np.float64], hi: NDArray[np.float64]
) -> tuple[float, float, int, int] | None:
    """The interval ``[t_lo, t_hi]`` of ``t >= 0`` with ``lo <= base + t d <= hi``, and the joints
    that set its ends (-1 for none); ``None`` when it is empty."""
    t_lo, t_hi, j_lo, j_hi = 0.0, math.inf, -1, -1
    # A plain loop: for a handful of joints it is several times faster than numpy's ufuncs.
    for j, (b_j, d_j, lo_j, hi_j) in enumerate(
        zip(base.tolist(), d.tolist(), lo.tolist(), hi.tolist(), strict=True)
    ):
        if d_j > 0.0:
            a, b = (lo_j - b_j) / d_j, (hi_j - b_j) / d_j
        elif d_j < 0.0:
            a, b = (hi_j - b_j) / d_j, (lo_j - b_j) / d_j
        elif lo_j - 1e-12 <= b_j <= hi_j + 1e-12:
            continue
        else:
            return None
        if a > t_lo:
            t_lo, j_lo = a, j
        if b < t_hi:
            t_hi, j_hi = b, j
    if t_hi < t_lo - 1e-12 * max(1.0, abs(t_lo)):
        return None
    return t_lo, max(t_hi, t_lo), j_lo, j_hi


def _task_cap(rate: NDArray[np.float64], lower: NDArray[np.float64]) -> float:
    """Largest ``t >= 0`` with ``t * rate >= lower`` row by row (a bound above 0 counts as 0)."""
    down = rate < 0.0
    if not down.any():
        return math.inf
    return float(np.min(np.minimum(lower[down], 0.0) / rate[down]))


class VelocityIkSolver:
    """:func:`solve_velocity_ik` with its fixed settings bound once, for a per-tick loop.

    ``solve`` skips the argument checks of :func:`solve_velocity_ik` (the caller guarantees finite
    arrays of the right sizes), which keeps the fast path at a linear solve plus a bounds check.

    Args:
        limits: Joint limits (``n`` joints).
        dt: Step length (s) over which each answer is applied.
        params: Solver settings (defaults when ``None``).
        q_nominal: Nominal posture the null-space pull goes towards; ``None`` for no pull.
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
        self.q_nominal = (
            None if q_nominal is None else finite_vector("VelocityIkSolver.q_nominal", q_nominal, n)
        )
        self._n = n
        # The limits as Python floats, for the per-joint loops of a step (an infinite acceleration
        # limit counts as 1e12; the weight of the nearest-point fallback is 1 / acceleration^2).
        acc = np.minimum(limits.acceleration, 1e12)
        self._lower = limits.lower.tolist()
        self._upper = limits.upper.tolist()
        self._vmax = limits.velocity.tolist()
        self._acc = acc.tolist()
        self._weight = (1.0 / acc**2).tolist()

    def solve(
        self,
        J: NDArray[np.float64],
        V: NDArray[np.float64],
        q: NDArray[np.float64],
        v_prev: NDArray[np.float64],
        task_rows: NDArray[np.float64] | None = None,
        task_lower: NDArray[np.float64] | None = None,
        sigma_at: Callable[[NDArray[np.float64]], float] | None = None,
    ) -> IkSolution:
        """One step: ``J`` (m, n), ``V`` (m,), ``q`` and ``v_prev`` (n,), all finite (unchecked).

        ``sigma_at``, optional, gives the smallest singular value of the Jacobian at a joint
        position: near a singularity the step is checked against ``IkParams.singular_barrier`` at
        its end (called at most twice per step, and only below ``singular_threshold``).

        ``task_rows`` (k, m) and ``task_lower`` (k,), optional, are workspace bounds on the
        end-effector twist: ``task_rows @ (J v) >= task_lower`` (e.g. a floor: row i gives the
        vertical speed of a gripper point, bounded below by ``-(its height above the floor) / tau``).
        A bound above zero is taken as zero (the command stops rather than being pushed). Like the
        joint limits they only shorten the step along the command: a step they limit is reported
        ``WORKSPACE``.
        """
        n = self._n
        scale = float(np.max(np.abs(V))) if V.size else 0.0
        if scale == 0.0:
            return IkSolution(np.zeros(n), IkStatus.OK, 1.0, 0.0, float("nan"))
        d = V / scale  # the direction, |d|_inf = 1: nothing below overflows for a huge command
        v_dir, v_null, sigma_min = self._decompose(J, d, q)
        params = self.params
        factor = 1.0
        if sigma_min < params.singular_threshold:
            factor = max(params.singular_speed_floor, sigma_min / params.singular_threshold)
        t_cap = scale
        if task_rows is not None and task_lower is not None and len(task_lower):
            t_cap = min(scale, _task_cap(task_rows @ d, task_lower))
        if v_dir is None:  # the command's direction is out of reach: refuse it, hold still
            v = self._fit_pull(np.zeros(n), v_null, q, v_prev)
            return self._solution(J, d, scale, v, sigma_min, (), factor)
        t, limiting = self._speed_along(v_dir, q, v_prev, min(scale, t_cap), factor)
        if sigma_at is not None and sigma_min < params.singular_threshold and t > 0.0:
            t = self._barrier(t, v_dir, q, sigma_min, sigma_at)
        v = self._fit_pull(t * v_dir, v_null, q, v_prev)
        sol = self._solution(J, d, scale, v, sigma_min, limiting, factor)
        if t_cap < scale and sol.status != IkStatus.OK and t >= t_cap * (1 - 1e-9):
            return IkSolution(sol.v, IkStatus.WORKSPACE, sol.alpha, sol.error, sol.sigma_min, ())
        return sol

    def _barrier(
        self,
        t: float,
        v_dir: NDArray[np.float64],
        q: NDArray[np.float64],
        sigma_min: float,
        sigma_at: Callable[[NDArray[np.float64]], float],
    ) -> float:
        """The speed ``t`` along ``v_dir`` shortened so that the step does not take the smallest
        singular value below ``singular_barrier`` (``IkParams.singular_barrier``): a step that
        raises it, or stays above the barrier, is kept; one that would cross it ends at it (to
        first order, checked once more); one that goes deeper from the barrier or below it is
        refused (``t = 0``)."""
        barrier = self.params.singular_barrier
        if barrier <= 0.0:
            return t
        after = float(sigma_at(q + (t * self.dt) * v_dir))
        if after >= barrier or after >= sigma_min:
            return t
        if sigma_min <= barrier:
            return 0.0
        t *= (sigma_min - barrier) / (sigma_min - after)
        if float(sigma_at(q + (t * self.dt) * v_dir)) < barrier:
            return 0.0
        return t

    def _speed_along(
        self,
        v_dir: NDArray[np.float64],
        q: NDArray[np.float64],
        v_prev: NDArray[np.float64],
        t_max: float,
        factor: float,
    ) -> tuple[float, tuple[int, ...]]:
        """The speed ``t`` in ``[0, t_max]`` along the joint direction ``v_dir`` (module docstring).

        Everything is worked out on the line itself, so the joints slow down together: the line
        can decelerate by ``a_t dt`` per step, ``a_t = min_j acceleration_j / |v_dir_j|``, and it
        brakes for the nearest position limit, and for the reduced speed near a singularity, at
        that rate. Hard bounds: the velocity limits, the position limits (never crossed) and
        ``t_max``. Soft ones, given up only to the hard ones: the acceleration bounds, the braking
        and the reduced speed.
        """
        dt = self.dt
        # Plain float loops: for a handful of joints they are several times faster than numpy.
        a_t = math.inf  # the line's acceleration limit (t units)
        t_hard, j_hard = math.inf, -1  # velocity limits, and landing on (never crossing) a limit
        room_min, j_brake = math.inf, -1  # the nearest position limit ahead, in t units
        v_over = math.inf  # the speed limit in t units (for the reduced speed near a singularity)
        t_acc_lo, t_acc_hi = 0.0, math.inf  # within each joint's acceleration bound of v_prev
        vv = vp = ww = wp = 0.0  # v_dir.v_dir, v_dir.v_prev and their acceleration-weighted forms
        acc_ok = True
        for j, (d_j, q_j, p_j, lo_j, hi_j, vmax_j, a_j, w_j) in enumerate(self._joint_rows(v_dir, q, v_prev)):
            vv += d_j * d_j
            vp += d_j * p_j
            ww += d_j * d_j * w_j
            wp += d_j * p_j * w_j
            da = a_j * dt
            if d_j == 0.0:
                if abs(p_j) > da:  # this joint cannot stop within the step: no point of the line fits
                    acc_ok = False
                continue
            mag = abs(d_j)
            a_t = min(a_t, a_j / mag)
            room = max((hi_j - q_j) if d_j > 0.0 else (q_j - lo_j), 0.0)
            hard = min(vmax_j, room / dt) / mag
            if hard < t_hard:
                t_hard, j_hard = hard, j
            if room / mag < room_min:
                room_min, j_brake = room / mag, j
            v_over = min(v_over, vmax_j / mag)
            lo_t, hi_t = (p_j - da) / d_j, (p_j + da) / d_j
            if d_j < 0.0:
                lo_t, hi_t = hi_t, lo_t
            t_acc_lo, t_acc_hi = max(t_acc_lo, lo_t), min(t_acc_hi, hi_t)
        if j_hard < 0:
            return t_max, ()
        t_hard = min(t_max, t_hard)
        # Soft: brake for the nearest limit at the line's deceleration, and the reduced speed near a
        # singularity, reached at that deceleration from the current speed along the line.
        half = 0.5 * a_t * dt
        t_brake = math.sqrt(half * half + 2.0 * a_t * room_min) - half
        t_prev = max(0.0, vp / vv)
        t_factor = max(factor * v_over, t_prev - a_t * dt) if factor < 1.0 else math.inf
        t = min(t_hard, t_brake, t_factor)
        # Acceleration: stay within each joint's bound of its previous velocity where the line can.
        if acc_ok and t_acc_lo <= t_acc_hi + 1e-12 * max(1.0, t_acc_lo):
            t = min(max(t, t_acc_lo), t_acc_hi)
        else:  # no point of the line is within reach: the nearest one (weighted) to v_prev
            t = min(t, max(0.0, wp / ww))
        t = max(0.0, min(t, t_hard))
        if t >= t_max * (1 - 1e-12):
            return t, ()
        if t >= t_hard * (1 - 1e-9):
            return t, (j_hard,)
        return t, (j_brake,) if t >= t_brake * (1 - 1e-9) else ()

    def _joint_rows(
        self, v_dir: NDArray[np.float64], q: NDArray[np.float64], v_prev: NDArray[np.float64]
    ) -> zip:
        return zip(
            v_dir.tolist(),
            q.tolist(),
            v_prev.tolist(),
            self._lower,
            self._upper,
            self._vmax,
            self._acc,
            self._weight,
            strict=True,
        )

    def _fit_pull(
        self,
        v: NDArray[np.float64],
        v_null: NDArray[np.float64],
        q: NDArray[np.float64],
        v_prev: NDArray[np.float64],
    ) -> NDArray[np.float64]:
        """``v`` plus as much of the null-space pull as fits every joint bound (it never costs the
        command its speed or direction)."""
        if not v_null.any():
            return v
        lo, hi = step_bounds(q, v_prev, self.dt, self.limits)
        interval = _speed_interval(v, v_null, lo, hi)
        if interval is None or interval[0] > 1.0:
            return v
        return v + min(1.0, interval[1]) * v_null

    def _decompose(
        self, J: NDArray[np.float64], d: NDArray[np.float64], q: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64] | None, NDArray[np.float64], float]:
        """The exact joint direction for ``d`` (None when ``d`` leaves J's span), the null-space
        pull, and the smallest of J's ``min(m, n)`` singular values."""
        m, n = J.shape
        thr = self.params.null_threshold
        if m == n:  # the common case: a square J well away from an exact singularity
            sigma = np.linalg.svd(J, compute_uv=False)
            if sigma[-1] > thr:  # no null space: the exact inverse, no pull
                return np.linalg.solve(J, d), np.zeros(n), float(sigma[-1])
        U, sigma, Wt = np.linalg.svd(J, full_matrices=True)
        sigma_min = float(sigma[-1]) if sigma.size else 0.0
        r = int(np.count_nonzero(sigma > thr))
        c = U[:, :r].T @ d
        outside = d - U[:, :r] @ c
        v_dir = None
        if float(np.max(np.abs(outside))) <= _RANGE_TOL:
            v_dir = Wt[:r].T @ (c / sigma[:r])
        v_null = np.zeros(n)
        if r < n and self.q_nominal is not None and self.params.nominal_gain > 0:
            # Weight 1 on the exact null space, fading to 0 at null_threshold: no switching chatter.
            s_all = np.zeros(n)
            s_all[: sigma.size] = sigma
            w = (1.0 - s_all[r:] / thr) if thr > 0 else np.ones(n - r)
            N = Wt[r:]
            v_null = N.T @ (w * (N @ (self.params.nominal_gain * (self.q_nominal - q))))
        return v_dir, v_null, sigma_min

    def _solution(
        self,
        J: NDArray[np.float64],
        d: NDArray[np.float64],
        scale: float,
        v: NDArray[np.float64],
        sigma_min: float,
        limiting: tuple[int, ...],
        factor: float = 1.0,
    ) -> IkSolution:
        params = self.params
        Jd = (J @ v) / scale  # the achieved twist over |V|_inf: comparable with d
        dd = float(d @ d)
        alpha = float(Jd @ d) / dd
        off = Jd - alpha * d
        error = math.sqrt(float(off @ off) / dd)
        if alpha >= params.limited_alpha:
            status = IkStatus.OK
        elif alpha < params.stopped_alpha and float(np.max(np.abs(v) / self.limits.velocity)) < (
            params.stopped_alpha * factor
        ):  # the joints hardly move (a huge command slowed to the joint limits is LIMITED)
            status = IkStatus.STOPPED
        else:
            if math.isnan(sigma_min):
                sigma_min = float(np.linalg.svd(J, compute_uv=False)[-1])
            status = IkStatus.SINGULAR if sigma_min < params.singular_threshold else IkStatus.LIMITED
        limiting = tuple(j for j in limiting if j >= 0)
        return IkSolution(v, status, alpha, error, sigma_min, limiting)


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
    """Joint velocities that move the end effector along the twist ``V``, as fast as the joint limits
    allow up to ``V`` itself (module docstring).

    Args:
        J: ``(m, n)`` Jacobian at ``q``, finite; rows in the same order and units as ``V``.
        V: ``(m,)`` commanded twist (finite).
        q: ``(n,)`` current joint positions (the integrator's set point).
        v_prev: ``(n,)`` joint velocities of the previous step (for the acceleration limits).
        dt: Step length (s) over which ``v`` is applied.
        limits: Joint limits (``n`` joints).
        params: Solver settings (defaults when ``None``).
        q_nominal: Nominal posture the null-space pull goes towards; ``None`` for no pull.

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
    Va = finite_vector("solve_velocity_ik.V", V, Ja.shape[0])
    qa = finite_vector("solve_velocity_ik.q", q, n)
    va = finite_vector("solve_velocity_ik.v_prev", v_prev, n)
    if not (isinstance(dt, int | float) and math.isfinite(dt) and dt > 0):
        raise ValueError(f"solve_velocity_ik.dt: expected a finite positive number, got {dt!r}")
    return VelocityIkSolver(limits, dt, params, q_nominal).solve(Ja, Va, qa, va)


__all__ = [
    "IkParams",
    "IkSolution",
    "IkStatus",
    "VelocityIkSolver",
    "solve_velocity_ik",
]
