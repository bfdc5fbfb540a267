"""The compiled row kernels of the core (numba), in one module.

Every algorithm of the core exists once. Where numpy's cost per call would dominate (a few numbers
per row, run every control tick or hundreds of times per disambiguation request) that one
implementation is a kernel here, and the array function of the algorithm's module (inference,
geometry, autonomy, blending) broadcasts, validates and lays out rows, then calls it. Kernels
loop over C-ordered rows (``rows.as_rows``) and address them by index (``a[r, j]``, not a
row view ``a[r]``: a view costs more than a row's arithmetic).

They live in one file on purpose: numba's on-disk cache (``cache=True``) is keyed on the file of
each kernel, not on the kernels it calls. With all of them here, any change to any kernel
invalidates every cached one, so no kernel ever runs a stale copy of another.
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

_TINY = float(np.finfo(float).tiny)
"""Smallest positive normal double (``inference.TINY``), a plain float for the kernels."""

_SMALL_ANGLE = 1e-8
"""Below this angle (rad) the series expansions of sin(a)/a are used instead of the quotient."""


# ----------------------------------------------------------------------------------------------
# Checks of a control tick's inputs (used by validation and geometry)
# ----------------------------------------------------------------------------------------------


@njit(cache=True)
def _all_finite_flat(a: NDArray[np.float64]) -> bool:  # pragma: no cover - compiled
    """True if every entry of the 1-D array ``a`` is finite (``x - x`` is NaN for NaN and inf)."""
    for i in range(a.shape[0]):
        x = a[i]
        if not x - x == 0.0:
            return False
    return True


@njit(cache=True)
def _usable_pose_rows(a: NDArray[np.float64], max_entry: float, min_norm2: float) -> bool:  # pragma: no cover
    """True if the poses ``[x, y, z, qw, qx, qy, qz]`` laid end to end in the 1-D ``a`` have every
    entry within ``+-max_entry`` (NaN is not) and every quaternion's squared norm ``>= min_norm2``."""
    for i in range(a.shape[0]):
        x = a[i]
        if not (x <= max_entry and x >= -max_entry):
            return False
    for r in range(a.shape[0] // 7):
        b = 7 * r + 3
        if not a[b] * a[b] + a[b + 1] * a[b + 1] + a[b + 2] * a[b + 2] + a[b + 3] * a[b + 3] >= min_norm2:
            return False
    return True


@njit(cache=True)
def _normalize_quaternion_rows(q: NDArray[np.float64], out: NDArray[np.float64]) -> None:  # pragma: no cover
    """``out[r] = q[r] / |q[r]|`` for the rows of ``(B, 4)`` arrays (norms summed in index order)."""
    for r in range(q.shape[0]):
        s = q[r, 0] * q[r, 0]
        for k in range(1, 4):
            s += q[r, k] * q[r, k]
        s = np.sqrt(s)
        for k in range(4):
            out[r, k] = q[r, k] / s


# ----------------------------------------------------------------------------------------------
# Quaternions, orientation errors, saturation (used by geometry, autonomy, blending)
# ----------------------------------------------------------------------------------------------


@njit(cache=True)
def _qmul(
    w1: float, x1: float, y1: float, z1: float, w2: float, x2: float, y2: float, z2: float
) -> tuple[float, float, float, float]:  # pragma: no cover - compiled
    """The Hamilton product ``q1 (x) q2``, term by term in the textbook order."""
    return (
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    )


@njit(cache=True)
def _rotvec(w: float, x: float, y: float, z: float) -> tuple[float, float, float]:  # pragma: no cover
    """Rotation vector of a unit quaternion, shortest path (angle in ``[0, pi]``)."""
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = np.sqrt(x * x + y * y + z * z)
    if s < 0.5 * _SMALL_ANGLE:
        scale = 2.0 / w  # angle / s by its series, w ~ 1 here
    else:
        scale = 2.0 * np.arctan2(s, w) / s
    return x * scale, y * scale, z * scale


@njit(cache=True)
def _orientation_error3(
    f0: float, f1: float, f2: float, f3: float, t0: float, t1: float, t2: float, t3: float
) -> tuple[float, float, float]:  # pragma: no cover - compiled
    """``rotvec(t (x) conj(f))`` for unit quaternions ``f`` (from) and ``t`` (to).

    Scalars, not array rows: a row view costs a kernel more than this arithmetic."""
    w, x, y, z = _qmul(t0, t1, t2, t3, f0, -f1, -f2, -f3)
    return _rotvec(w, x, y, z)


@njit(cache=True)
def _saturated(
    a0: float, a1: float, a2: float, max_norm: float
) -> tuple[float, float, float]:  # pragma: no cover
    """A 3-vector scaled down to at most ``max_norm`` (direction kept; used by the potential field
    and the blending law's speed limits)."""
    k = min(1.0, max_norm / max(np.sqrt(a0 * a0 + a1 * a1 + a2 * a2), 1e-300))
    return a0 * k, a1 * k, a2 * k


@njit(cache=True)
def _quat_multiply_rows(a, b, out):  # pragma: no cover - compiled
    for r in range(out.shape[0]):
        out[r, 0], out[r, 1], out[r, 2], out[r, 3] = _qmul(
            a[r, 0], a[r, 1], a[r, 2], a[r, 3], b[r, 0], b[r, 1], b[r, 2], b[r, 3]
        )


@njit(cache=True)
def _rotvec_rows(q, out):  # pragma: no cover - compiled
    for r in range(out.shape[0]):
        out[r, 0], out[r, 1], out[r, 2] = _rotvec(q[r, 0], q[r, 1], q[r, 2], q[r, 3])


@njit(cache=True)
def _orientation_error_rows(f, t, out):  # pragma: no cover - compiled
    for r in range(out.shape[0]):
        out[r, 0], out[r, 1], out[r, 2] = _orientation_error3(
            f[r, 0], f[r, 1], f[r, 2], f[r, 3], t[r, 0], t[r, 1], t[r, 2], t[r, 3]
        )


@njit(cache=True)
def _pose_error_rows(x, goals, dist, angle):  # pragma: no cover - compiled
    """Distance (m) and rotation angle (rad) from the pose ``x`` (7) to each goal pose (``(n, 7)``);
    quaternions are normalised first."""
    m = np.sqrt(x[3] * x[3] + x[4] * x[4] + x[5] * x[5] + x[6] * x[6])
    f0, f1, f2, f3 = x[3] / m, x[4] / m, x[5] / m, x[6] / m
    for i in range(goals.shape[0]):
        d0, d1, d2 = goals[i, 0] - x[0], goals[i, 1] - x[1], goals[i, 2] - x[2]
        dist[i] = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        t0, t1, t2, t3 = goals[i, 3], goals[i, 4], goals[i, 5], goals[i, 6]
        k = np.sqrt(t0 * t0 + t1 * t1 + t2 * t2 + t3 * t3)
        e0, e1, e2 = _orientation_error3(f0, f1, f2, f3, t0 / k, t1 / k, t2 / k, t3 / k)
        angle[i] = np.sqrt(e0 * e0 + e1 * e1 + e2 * e2)


# ----------------------------------------------------------------------------------------------
# Intent inference: xi, the DFT right-hand side and flow, the Euler update and rollout
# ----------------------------------------------------------------------------------------------


@njit(cache=True)
def _clip_normalize_row(v: NDArray[np.float64], r: int) -> None:  # pragma: no cover - compiled
    """Row ``r`` of ``v`` (``(rows, n)``), in place: the projection of :func:`normalize_belief`."""
    n = v.shape[1]
    total = 0.0
    for i in range(n):
        x = v[r, i]
        if not x >= _TINY:  # non-positive, tiny or NaN
            x = _TINY
            v[r, i] = x
        total += x
    if total < np.inf:  # finite (entries are >= TINY > 0, so 0 < total, never NaN)
        for i in range(n):
            v[r, i] /= total
        return
    # An infinite entry (its mass shared by all infinite entries) or an overflowing sum.
    n_inf = 0
    largest = 0.0
    for i in range(n):
        if v[r, i] == np.inf:
            n_inf += 1
        largest = max(largest, v[r, i])
    total = 0.0
    for i in range(n):
        if n_inf:
            x = 1.0 if v[r, i] == np.inf else _TINY
        else:
            x = max(v[r, i] / largest, _TINY)
        v[r, i] = x
        total += x
    for i in range(n):
        v[r, i] /= total


@njit(cache=True)
def _normalize_rows(v: NDArray[np.float64]) -> None:  # pragma: no cover - compiled
    for r in range(v.shape[0]):
        _clip_normalize_row(v, r)


@njit(cache=True)
def _unit3(a0: float, a1: float, a2: float) -> tuple[float, float, float, bool]:  # pragma: no cover
    """The unit vector of a finite 3-vector and whether it is non-zero (zero stays zero).

    ``hypot`` neither overflows nor underflows (a tiny command keeps its direction); a norm beyond
    DBL_MAX is measured after dividing by the largest component.
    """
    norm = np.hypot(np.hypot(a0, a1), a2)
    if not norm < np.inf:
        s = max(abs(a0), abs(a1), abs(a2))
        a0, a1, a2 = a0 / s, a1 / s, a2 / s
        norm = np.hypot(np.hypot(a0, a1), a2)
    if norm > 0.0:
        return a0 / norm, a1 / norm, a2 / norm, True
    return 0.0, 0.0, 0.0, False


@njit(cache=True)
def _cosine_to_unit(
    v0: float, v1: float, v2: float, w0: float, w1: float, w2: float
) -> tuple[float, float]:  # pragma: no cover - compiled
    """``((v / |v|) . w, |v|)`` for a unit (or zero) ``w``; 0 where ``v = 0``.

    As ``inference.belief.safe_unit``: when ``|v|`` is not finite, non-finite components of ``v`` are read as
    0 and ``v`` is first divided by its largest absolute component. The returned length is the
    plain one (``inf`` or NaN then).
    """
    length = np.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    norm = length
    if not norm < np.inf:
        v0 = v0 if np.isfinite(v0) else 0.0
        v1 = v1 if np.isfinite(v1) else 0.0
        v2 = v2 if np.isfinite(v2) else 0.0
        s = max(abs(v0), abs(v1), abs(v2))
        if s > 0.0:
            v0, v1, v2 = v0 / s, v1 / s, v2 / s
        norm = np.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    if norm > 0.0:
        return (v0 * w0 + v1 * w1 + v2 * w2) / norm, length
    return 0.0, length


@njit(cache=True)
def _finite_dot3(
    a0: float, a1: float, a2: float, b0: float, b1: float, b2: float
) -> float:  # pragma: no cover - compiled
    """``a . b`` over the components where both are finite (a non-finite one adds nothing)."""
    total = 0.0
    if np.isfinite(a0) and np.isfinite(b0):
        total += a0 * b0
    if np.isfinite(a1) and np.isfinite(b1):
        total += a1 * b1
    if np.isfinite(a2) and np.isfinite(b2):
        total += a2 * b2
    return total


@njit(cache=True)
def _xi_rows(u, x_r, x_g, u_a, directed, agree, agree_cosine, near, zero_excites, R, xi):  # pragma: no cover
    """``xi`` for every row ``r``: a sanitised command ``u[r]``, ``x_r[r]``, the goals ``x_g[r]``
    (or ``x_g[0]`` for every row when it has one) and ``u_a[r]``. The agreement term is the plain
    dot product of the rotational parts (``agree_cosine`` False, the paper) or their cosine."""
    B, n = xi.shape
    rotation = u.shape[1] >= 6
    for r in range(B):
        v0, v1, v2, moving = _unit3(u[r, 0], u[r, 1], u[r, 2])
        w0 = w1 = w2 = 0.0
        if rotation:
            w0, w1, w2, turning = _unit3(u[r, 3], u[r, 4], u[r, 5])
            moving = moving or turning
        g = r if x_g.shape[0] > 1 else 0  # one shared row for a fixed goal set
        for i in range(n):
            total = 0.0
            d0 = x_g[g, i, 0] - x_r[r, 0]
            d1 = x_g[g, i, 1] - x_r[r, 1]
            d2 = x_g[g, i, 2] - x_r[r, 2]
            cos, dist = _cosine_to_unit(d0, d1, d2, v0, v1, v2)
            if directed:
                total += 0.5 * (1.0 + cos)
            if agree and rotation:
                if agree_cosine:
                    total += _cosine_to_unit(u_a[r, i, 3], u_a[r, i, 4], u_a[r, i, 5], w0, w1, w2)[0]
                else:
                    total += _finite_dot3(u[r, 3], u[r, 4], u[r, 5], u_a[r, i, 3], u_a[r, i, 4], u_a[r, i, 5])
            if not zero_excites and not moving:
                total = 0.0
            if near and dist < np.inf:  # a non-finite distance gives no proximity
                total += max(1.0 - dist / R, 0.0)
            xi[r, i] = total


@njit(cache=True)
def _dft_rhs_row(p, pr, drive, dr, P, k, tau1, out, o):  # pragma: no cover - compiled
    """``out[o] = drive[dr] - P[k]^T p[pr] / tau1`` (rows of 2-D arrays; ``P`` empty: identity).

    Rows by index, not as views: a view costs a kernel more than a row's arithmetic."""
    n = p.shape[1]
    for j in range(n):
        if P.shape[0] == 0:
            prior = p[pr, j]
        else:
            prior = 0.0
            for i in range(n):
                prior += p[pr, i] * P[k, i, j]
        out[o, j] = drive[dr, j] - prior / tau1


@njit(cache=True)
def _euler_rate_factor(total: float, tau1: float, h: float) -> float:  # pragma: no cover - compiled
    """Rate factor that makes the mass-conserving flow over ``h`` equal the Euler map.

    With ``P = I`` the flow ``dp/dt = f - p S`` (``S = sum f``, constant in ``p``) relaxes to its
    fixed point at rate ``D = S + 1/tau1``, i.e. by ``exp(-D h)`` per step, while the Euler map
    ``(p + h f) / (1 + h S)`` contracts by ``(1 - h/tau1) / (1 + h S)``. Scaling the flow by
    ``log((1 + h S) / (1 - h / tau1)) / (h D)`` makes the two equal (same fixed point).
    """
    a = min(h / tau1, 0.9)
    hS = max(h * total, -0.9)
    x = hS + a  # h D
    if abs(x) < 1e-12:
        return 1.0 / (1.0 - a)
    return (np.log1p(hS) - np.log1p(-a)) / x


@njit(cache=True)
def _guard_floor(pj: float, guard_rate: float) -> float:  # pragma: no cover - compiled
    """Lowest rate of change the positivity guard lets an entry ``pj`` have (1/s)."""
    if pj <= 0.0:
        return 0.0
    return -guard_rate * pj if guard_rate > 0.0 else -np.inf


@njit(cache=True)
def _dft_flow_rows(p, drive, P, tau1, conserve, h, guard_rate, out):  # pragma: no cover - compiled
    """Per row: ``f(p)`` (``conserve`` False) or the mass-conserving flow ``f - p sum(f)`` with
    the Euler-equivalent rate factor (``h > 0``) and the positivity guard (``conserve`` True).

    The guard: an entry at (or below) zero may not decrease further, and with ``guard_rate`` ``g``
    > 0 (1/s) a positive entry may not decrease faster than ``g p`` (it decays towards zero with a
    time constant of at least ``1/g`` instead of reaching it in finite time), so that an explicit
    step of up to ``1/g`` never leaves the simplex. The mass a guarded entry would have lost is
    taken from the others in proportion to their mass."""
    B, n = out.shape
    for r in range(B):
        _dft_rhs_row(p, r, drive, r, P, r if P.shape[0] > 1 else 0, tau1, out, r)
        if not conserve:
            continue
        f = out[r]  # one view per row here: the flow's few passes over it are worth it
        total = 0.0
        for j in range(n):
            total += f[j]
        for j in range(n):
            f[j] = f[j] - p[r, j] * total
        if h > 0.0:
            factor = _euler_rate_factor(total, tau1, h)
            for j in range(n):
                f[j] = f[j] * factor
        _guard_row(p, r, guard_rate, f)


@njit(cache=True)
def _guard_row(p, r, guard_rate, f):  # pragma: no cover - compiled
    """The positivity guard on the flow ``f`` of row ``r``, in place (see :func:`_dft_flow_rows`).

    An entry falling faster than its floor is held at it; the mass it would have lost is taken
    from the free entries in proportion to their mass (or, if only entries at zero are free, from
    those rising, in proportion to their rate), which can push another one past its floor, so the
    pass repeats (at most ``n`` times: each pass holds one more entry)."""
    n = f.shape[0]
    held = np.zeros(n, dtype=np.bool_)
    for _ in range(n):
        excess = 0.0
        for j in range(n):
            if not held[j]:
                floor = _guard_floor(p[r, j], guard_rate)
                if f[j] < floor:
                    excess += f[j] - floor
                    f[j] = floor
                    held[j] = True
        if excess >= 0.0:
            return
        free_mass = 0.0
        for j in range(n):
            if not held[j]:
                free_mass += max(p[r, j], 0.0)
        if free_mass <= 0.0:
            # Only entries at zero are free: those rising rise less (by no more than they rise:
            # the sum of the flow was zero, so they rise by at least the excess in all).
            rising = 0.0
            for j in range(n):
                if not held[j]:
                    rising += max(f[j], 0.0)
            if rising > 0.0:
                for j in range(n):
                    if not held[j]:
                        f[j] = f[j] + max(f[j], 0.0) / rising * excess
            return
        share = excess / free_mass
        for j in range(n):
            if not held[j]:
                f[j] = f[j] + max(p[r, j], 0.0) * share


@njit(cache=True)
def _euler_rows(p, p0, drive, d0, P, tau1, dt, out, o0, B):  # pragma: no cover - compiled
    """``out[o0 + r] = normalize(p[p0 + r] + dt (drive[d0 + r] - P^T p[p0 + r] / tau1))`` for
    ``r < B`` (rows of 2-D arrays; ``P`` and ``dt`` per row or shared, see ``inference.dft._BeliefRows``)."""
    n = out.shape[1]
    for r in range(B):
        h = dt[r] if dt.shape[0] > 1 else dt[0]
        _dft_rhs_row(p, p0 + r, drive, d0 + r, P, r if P.shape[0] > 1 else 0, tau1, out, o0 + r)
        for j in range(n):
            out[o0 + r, j] = p[p0 + r, j] + h * out[o0 + r, j]
        _clip_normalize_row(out, o0 + r)


@njit(cache=True)
def _euler_rollout_rows(p, drives, P, tau1, dt, out):  # pragma: no cover - compiled
    """Step ``s`` of ``K``: rows ``s B .. s B + B - 1`` of ``out`` (``(K B, n)``) are the beliefs
    after update ``s`` (``drives`` rows alike), starting from ``p`` (``(B, n)``)."""
    B = p.shape[0]
    if B == 0:
        return
    _euler_rows(p, 0, drives, 0, P, tau1, dt, out, 0, B)
    for s in range(1, drives.shape[0] // B):
        _euler_rows(out, (s - 1) * B, drives, s * B, P, tau1, dt, out, s * B, B)


# ----------------------------------------------------------------------------------------------
# Potential-field autonomy
# ----------------------------------------------------------------------------------------------


@njit(cache=True)
def _field_rows(
    x, q, gx, gq, k_t, k_r, gain, radius, cap, v_max, w_max, translation, out
):  # pragma: no cover
    """Per-goal commands for every row ``r``: ``out[r, i] = [v_i, w_i]`` (``translation``) or
    ``out[r, i] = w_i`` (rotational part only, ``out`` ``(B, n, 3)``).

    ``x`` ``(B, 3)``, ``q`` ``(B, 4)``; ``gx`` ``(B | 1, n, 3)`` and ``gq`` ``(B | 1, n, 4)`` (one
    shared row for a fixed goal set).
    """
    B, n = out.shape[0], out.shape[1]
    o = 3 if translation else 0  # where w_i goes
    push = np.zeros((n, 3))  # per row: the repeller velocity of each goal (0 outside the radius)
    for r in range(B):
        g = r if gq.shape[0] > 1 else 0
        for i in range(n):
            e0, e1, e2 = _orientation_error3(
                q[r, 0], q[r, 1], q[r, 2], q[r, 3], gq[g, i, 0], gq[g, i, 1], gq[g, i, 2], gq[g, i, 3]
            )
            out[r, i, o], out[r, i, o + 1], out[r, i, o + 2] = _saturated(k_r * e0, k_r * e1, k_r * e2, w_max)
        if not translation:
            continue
        gp = r if gx.shape[0] > 1 else 0
        repel = n > 1 and gain > 0.0
        if repel:
            # Goal j pushes the robot away from it within the radius (a goal exactly at the robot
            # has no direction and pushes nothing): once per row, felt by every other goal's field.
            for j in range(n):
                d0 = gx[gp, j, 0] - x[r, 0]
                d1 = gx[gp, j, 1] - x[r, 1]
                d2 = gx[gp, j, 2] - x[r, 2]
                dist = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                speed = min(gain / dist, cap) if 0.0 < dist < radius else 0.0
                push[j, 0] = d0 / dist * speed if speed > 0.0 else 0.0
                push[j, 1] = d1 / dist * speed if speed > 0.0 else 0.0
                push[j, 2] = d2 / dist * speed if speed > 0.0 else 0.0
        for i in range(n):
            v0 = k_t * (gx[gp, i, 0] - x[r, 0])
            v1 = k_t * (gx[gp, i, 1] - x[r, 1])
            v2 = k_t * (gx[gp, i, 2] - x[r, 2])
            if repel:
                s0 = s1 = s2 = 0.0  # goal i feels every repeller but its own: an exact masked sum
                for j in range(n):
                    if j != i:
                        s0 -= push[j, 0]
                        s1 -= push[j, 1]
                        s2 -= push[j, 2]
                v0, v1, v2 = v0 + s0, v1 + s1, v2 + s2
            out[r, i, 0], out[r, i, 1], out[r, i, 2] = _saturated(v0, v1, v2, v_max)


@njit(cache=True)
def _field_one_pose(pose, goals, k_t, k_r, gain, radius, cap, v_max, w_max, out):  # pragma: no cover
    """:func:`_field_rows` (with translation) for one pose ``[x, y, z, qw, qx, qy, qz]`` (7) and
    goal poses ``(n, 7)``, their quaternions normalised first by :func:`_normalize_quaternion_rows`:
    the potential field of a control tick in one call (the same kernels on the same numbers as
    normalising and laying out the rows in numpy first). ``out`` is ``(1, n, 6)``."""
    n = goals.shape[0]
    x = np.empty((1, 3))
    raw = np.empty((1, 4))
    q = np.empty((1, 4))
    gx = np.empty((1, n, 3))
    graw = np.empty((n, 4))
    gq = np.empty((n, 4))
    for k in range(3):
        x[0, k] = pose[k]
    for k in range(4):
        raw[0, k] = pose[3 + k]
    for i in range(n):
        for k in range(3):
            gx[0, i, k] = goals[i, k]
        for k in range(4):
            graw[i, k] = goals[i, 3 + k]
    _normalize_quaternion_rows(raw, q)
    _normalize_quaternion_rows(graw, gq)
    _field_rows(x, q, gx, gq.reshape((1, n, 4)), k_t, k_r, gain, radius, cap, v_max, w_max, True, out)


# ----------------------------------------------------------------------------------------------
# The blending law
# ----------------------------------------------------------------------------------------------


@njit(cache=True)
def _alpha1(p: float, r1: float, r2: float, r3: float) -> float:  # pragma: no cover - compiled
    """The piecewise-linear alpha of one top belief (0 for a non-finite one)."""
    if not np.isfinite(p) or p <= r1:
        return 0.0
    if p <= r2:
        return r3 * (p - r1) / (r2 - r1)
    return r3


@njit(cache=True)
def _has_input1(u: NDArray[np.float64], tolerance: float) -> bool:  # pragma: no cover - compiled
    """Any entry of ``u`` larger than ``tolerance`` in magnitude (NaN is not)."""
    for k in range(u.shape[0]):
        if abs(u[k]) > tolerance:
            return True
    return False


@njit(cache=True)
def _blend_clamp1(u_h, u_a, alpha, v_max, w_max, out):  # pragma: no cover - compiled
    """``out = alpha u_a + (1 - alpha) u_h`` (6-vectors), each 3-vector part scaled down to its limit
    (``inf``: no limit)."""
    for k in range(6):
        out[k] = alpha * u_a[k] + (1.0 - alpha) * u_h[k]
    out[0], out[1], out[2] = _saturated(out[0], out[1], out[2], v_max)
    out[3], out[4], out[5] = _saturated(out[3], out[4], out[5], w_max)


@njit(cache=True)
def _alpha_rows(p, r1, r2, r3, out):  # pragma: no cover - compiled
    for r in range(out.shape[0]):
        out[r] = _alpha1(p[r], r1, r2, r3)


@njit(cache=True)
def _has_input_rows(u, tolerance, out):  # pragma: no cover - compiled
    for r in range(out.shape[0]):
        out[r] = _has_input1(u[r], tolerance)


@njit(cache=True)
def _blend_rows(u_h, u_a, alpha, v_max, w_max, out):  # pragma: no cover - compiled
    for r in range(out.shape[0]):
        _blend_clamp1(u_h[r], u_a[r], alpha[r], v_max, w_max, out[r])


@njit(cache=True)
def _shared_control_rows(
    u_h, p, u_a, r1, r2, r3, assist, tolerance, v_max, w_max, u, alpha, g_star
):  # pragma: no cover
    """The full step per row: ``g* = argmax p`` (the first maximum; a NaN counts as the maximum, as
    in ``np.argmax``), alpha, zero alpha without input unless ``assist``, blend and limits."""
    n = p.shape[1]
    for r in range(u.shape[0]):
        g = 0
        for i in range(1, n):
            if not np.isnan(p[r, g]) and (np.isnan(p[r, i]) or p[r, i] > p[r, g]):
                g = i
        a = _alpha1(p[r, g], r1, r2, r3)
        if not assist and not _has_input1(u_h[r], tolerance):
            a = 0.0
        _blend_clamp1(u_h[r], u_a[r, g], a, v_max, w_max, u[r])
        alpha[r] = a
        g_star[r] = g
