"""Tests of the robust differential IK (drake_disamb.ik), driven with fixed inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_disamb.ik import (
    IkParams,
    IkStatus,
    JointLimits,
    VelocityIkSolver,
    filtered_inverse,
    solve_velocity_ik,
    velocity_bounds,
)

DT = 0.01
LIMITS = JointLimits(
    lower=[-6.28, -0.75, 1.90, -6.28, -6.28, -6.28],
    upper=[6.28, 3.89, 7.52, 6.28, 6.28, 6.28],
    velocity=[0.628] * 3 + [0.838] * 3,
    acceleration=[20.0] * 6,
)
Q_MID = np.array([0.0, 1.5, 4.5, 0.0, 0.0, 0.0])


def _orthogonal(rng: np.random.Generator, n: int) -> np.ndarray:
    Q, R = np.linalg.qr(rng.normal(size=(n, n)))
    return Q * np.sign(np.diag(R))


def _jacobian(sigma, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """J = U diag(sigma) W^T with random orthogonal U, W (seeded)."""
    rng = np.random.default_rng(seed)
    U, W = _orthogonal(rng, 6), _orthogonal(rng, 6)
    return U @ np.diag(sigma) @ W.T, U, W


def _in_box(v: np.ndarray, q: np.ndarray, v_prev: np.ndarray) -> bool:
    lo, hi = velocity_bounds(q, v_prev, DT, LIMITS)
    return bool(np.all(v >= lo - 1e-12) and np.all(v <= hi + 1e-12))


# ----------------------------------------------------------------------------------------------
# A random reachable configuration: the exact inverse.
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_well_conditioned_command_is_tracked_exactly(seed: int) -> None:
    J, _, _ = _jacobian([1.7, 1.4, 1.1, 0.3, 0.2, 0.07], seed)
    rng = np.random.default_rng(seed)
    V = rng.normal(size=6) * 0.01
    v_prev = np.linalg.solve(J, V)  # already moving like that: no acceleration limit in the way
    sol = solve_velocity_ik(J, V, Q_MID, v_prev, DT, LIMITS)
    assert sol.status == IkStatus.OK
    np.testing.assert_allclose(J @ sol.v, V, atol=1e-12)
    assert sol.alpha == 1.0 and sol.error == 0.0 and sol.held_joints == ()


def test_zero_command_holds_still() -> None:
    J, _, _ = _jacobian([1.0, 1.0, 1.0, 0.5, 0.0, 0.0])
    sol = solve_velocity_ik(J, np.zeros(6), Q_MID, np.full(6, 0.3), DT, LIMITS, q_nominal=np.zeros(6))
    assert sol.status == IkStatus.OK and np.all(sol.v == 0)


def test_speed_limit_scales_and_keeps_direction() -> None:
    J, _, _ = _jacobian([1.7, 1.4, 1.1, 0.3, 0.2, 0.07])
    V = np.array([0.0, 0.0, 2.0, 0.0, 0.0, 0.0])  # far faster than the joints can go
    v_prev = np.linalg.solve(J, V)
    v_prev *= 0.99 * np.min(LIMITS.velocity / np.abs(v_prev))  # cruising at the speed limit
    sol = solve_velocity_ik(J, V, Q_MID, v_prev, DT, LIMITS)
    assert sol.status == IkStatus.LIMITED  # slowed, not stopped, although alpha is small
    assert 0 < sol.alpha < 0.5
    assert np.isclose(np.max(np.abs(sol.v) / LIMITS.velocity), 1.0)  # one joint at its speed limit
    JV = J @ sol.v
    assert JV @ V == pytest.approx(np.linalg.norm(JV) * np.linalg.norm(V), rel=1e-9)  # same direction


def test_acceleration_limits_ramp_along_the_command() -> None:
    J, _, _ = _jacobian([1.7, 1.4, 1.1, 0.3, 0.2, 0.07])
    V = np.array([0.05, -0.02, 0.03, 0.0, 0.1, 0.0])
    v_full = np.linalg.solve(J, V)
    assert np.max(np.abs(v_full)) > LIMITS.acceleration[0] * DT  # too fast to reach in one step
    sol = solve_velocity_ik(J, V, Q_MID, np.zeros(6), DT, LIMITS)
    assert np.all(np.abs(sol.v) <= LIMITS.acceleration * DT + 1e-12)
    np.testing.assert_allclose(sol.v / np.max(np.abs(sol.v)), v_full / np.max(np.abs(v_full)), atol=1e-9)
    assert sol.status == IkStatus.LIMITED
    # A sudden reversal: each joint changes speed by at most its limit, towards the new target.
    sol = solve_velocity_ik(J, -V, Q_MID, v_full, DT, LIMITS)
    assert np.all(np.abs(sol.v - v_full) <= LIMITS.acceleration * DT + 1e-12)
    assert np.all(np.sign(sol.v - v_full) == np.sign(-v_full))


# ----------------------------------------------------------------------------------------------
# A singular configuration.
# ----------------------------------------------------------------------------------------------
def test_exactly_singular_jacobian_tracks_the_achievable_part() -> None:
    J, U, _ = _jacobian([1.7, 1.4, 1.1, 0.3, 0.2, 0.0])
    good = U[:, :5] @ np.array([0.02, -0.01, 0.03, 0.01, 0.005])
    V = good + 0.05 * U[:, 5]  # plus a component along the lost direction
    solver = VelocityIkSolver(LIMITS, DT)
    v_prev = np.linalg.pinv(J) @ good
    sol = solver.solve(J, V, Q_MID, v_prev)
    assert np.all(np.isfinite(sol.v))
    assert sol.status == IkStatus.SINGULAR
    assert sol.sigma_min == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(J @ sol.v, good, atol=1e-12)  # the achievable part, exactly
    # The old behaviour (Drake's QP) was alpha = 0: the arm froze.
    assert sol.alpha == pytest.approx(float(good @ V) / float(V @ V))


def test_command_only_along_the_singular_direction_is_stopped() -> None:
    J, U, W = _jacobian([1.7, 1.4, 1.1, 0.3, 0.2, 0.0])
    V = 0.05 * U[:, 5]
    sol = solve_velocity_ik(J, V, Q_MID, np.zeros(6), DT, LIMITS)
    assert sol.status == IkStatus.STOPPED
    np.testing.assert_allclose(sol.v, 0.0, atol=1e-12)  # nothing achievable: no motion
    # With a nominal posture the joints drift towards it inside the singular direction only.
    q_nom = Q_MID + 0.3 * W[:, 5]
    sol = solve_velocity_ik(J, V, Q_MID, np.zeros(6), DT, LIMITS, q_nominal=q_nom)
    assert sol.status == IkStatus.STOPPED
    assert sol.v @ W[:, 5] > 0  # out of the singularity, towards the nominal posture
    np.testing.assert_allclose(J @ sol.v, 0.0, atol=1e-12)  # without moving the end effector


def test_damping_is_continuous_and_bounded_near_a_singularity() -> None:
    params = IkParams(singular_threshold=0.025, max_damping=0.025)
    rng = np.random.default_rng(3)
    U, W = _orthogonal(rng, 6), _orthogonal(rng, 6)
    V = U[:, 5] * 0.1
    speeds = []
    for s in [0.1, 0.05, 0.0251, 0.0249, 0.02, 0.01, 1e-3, 1e-6, 0.0]:
        J = U @ np.diag([1.7, 1.4, 1.1, 0.3, 0.2, s]) @ W.T
        g, d, singular_part, smin = filtered_inverse(J, V, params)
        v = g + d
        assert np.all(np.isfinite(v))
        speeds.append(np.linalg.norm(v))
        assert smin == pytest.approx(s, abs=1e-12)
        assert (np.linalg.norm(singular_part) > 0) == (s < 0.025)
    # Undamped 1/sigma above the threshold, continuous across it, then falling to 0.
    assert speeds[0] == pytest.approx(1.0) and speeds[1] == pytest.approx(2.0)
    assert speeds[2] == pytest.approx(speeds[3], rel=0.02)
    assert max(speeds) <= 0.1 / 0.025 * 1.01
    assert speeds[-1] < 1e-12 and speeds[-2] < 1e-3


# ----------------------------------------------------------------------------------------------
# A joint at its limit.
# ----------------------------------------------------------------------------------------------
def test_joint_at_its_limit_is_held_and_the_rest_keeps_moving() -> None:
    J, _, _ = _jacobian([1.7, 1.4, 1.1, 0.3, 0.2, 0.07], seed=4)
    q = Q_MID.copy()
    q[2] = LIMITS.lower[2]  # joint 3 on its lower limit
    V = J @ np.array([0.1, 0.0, -0.5, 0.0, 0.05, 0.0])  # needs joint 3 to go further down
    v_prev = np.linalg.lstsq(np.delete(J, 2, axis=1), V, rcond=None)[0]
    v_prev *= min(1.0, 0.5 * np.min(np.delete(LIMITS.velocity, 2) / np.abs(v_prev)))
    v_prev = np.insert(v_prev, 2, 0.0)
    sol = solve_velocity_ik(J, V, q, v_prev, DT, LIMITS)
    assert sol.held_joints == (2,)
    assert sol.v[2] == 0.0
    assert np.all(q + sol.v * DT >= LIMITS.lower) and np.all(q + sol.v * DT <= LIMITS.upper)
    assert sol.status == IkStatus.LIMITED
    JV = J @ sol.v
    assert JV @ V > 0.5 * np.linalg.norm(JV) * np.linalg.norm(V)  # still along the command
    # Away from the limit (the same command, pulling off it) nothing is held.
    sol = solve_velocity_ik(J, -V, q, np.zeros(6), DT, LIMITS)
    assert sol.held_joints == () and sol.v[2] > 0


def test_joint_next_to_its_limit_lands_on_it() -> None:
    J, _, _ = _jacobian([1.7, 1.4, 1.1, 0.3, 0.2, 0.07], seed=5)
    q = Q_MID.copy()
    q[1] = LIMITS.upper[1] - 1e-3  # 1 mrad below: at 0.3 rad/s it would cross within this step
    e = np.zeros(6)
    e[1] = 0.3
    V = J @ e
    sol = solve_velocity_ik(J, V, q, e, DT, LIMITS)
    assert sol.held_joints == (1,)
    assert q[1] + sol.v[1] * DT == pytest.approx(LIMITS.upper[1], abs=1e-12)


# ----------------------------------------------------------------------------------------------
# Never NaN, never outside the limits (random inputs, including rank-deficient Jacobians).
# ----------------------------------------------------------------------------------------------
@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), rank=st.integers(3, 6), scale=st.sampled_from([1e-3, 0.1, 5.0]))
def test_step_is_finite_and_inside_every_bound(seed: int, rank: int, scale: float) -> None:
    rng = np.random.default_rng(seed)
    sigma = np.sort(rng.uniform(0.0, 2.0, 6))[::-1]
    sigma[rank:] = 0.0
    J, _, _ = _jacobian(sigma, seed)
    u = rng.uniform(size=6)
    q = LIMITS.lower + u * (LIMITS.upper - LIMITS.lower)
    edge = rng.integers(0, 6)
    q[edge] = LIMITS.lower[edge] if rng.uniform() < 0.5 else LIMITS.upper[edge]
    v_prev = rng.uniform(-1, 1, 6) * LIMITS.velocity
    v_prev = np.clip(v_prev, velocity_bounds(q, np.zeros(6), DT, LIMITS)[0] - 0, LIMITS.velocity)
    V = rng.normal(size=6) * scale
    sol = solve_velocity_ik(J, V, q, v_prev, DT, LIMITS, q_nominal=Q_MID)
    assert np.all(np.isfinite(sol.v)) and math.isfinite(sol.alpha) and math.isfinite(sol.error)
    assert np.all(np.abs(sol.v) <= LIMITS.velocity + 1e-12)
    q_next = q + sol.v * DT
    assert np.all(q_next >= LIMITS.lower - 1e-12) and np.all(q_next <= LIMITS.upper + 1e-12)
    assert _in_box(sol.v, q, v_prev)
    assert sol.status in (IkStatus.OK, IkStatus.LIMITED, IkStatus.SINGULAR, IkStatus.STOPPED)
    if sol.status == IkStatus.OK:
        assert sol.alpha >= 0.95


def test_velocity_bounds() -> None:
    lims = JointLimits([-1.0, -1.0], [1.0, 1.0], [0.5, 0.5], [10.0, 10.0])
    lo, hi = velocity_bounds([0.0, 0.998], [0.0, 0.0], 0.01, lims)
    np.testing.assert_allclose(lo, [-0.1, -0.1])  # acceleration: 10 * 0.01
    np.testing.assert_allclose(hi, [0.1, 0.1])
    lo, hi = velocity_bounds([0.0, 0.998], [0.45, 0.45], 0.01, lims)
    np.testing.assert_allclose(lo, [0.35, 0.2])  # joint 2: must stop on its limit (0.2 rad/s)
    np.testing.assert_allclose(hi, [0.5, 0.2])
    lo, hi = velocity_bounds([0.0, 1.2], [0.0, 0.0], 0.01, lims)  # outside: back inside
    assert hi[1] <= 0 and lo[1] <= hi[1]


# ----------------------------------------------------------------------------------------------
# Bad input.
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"J": np.zeros((6, 5))}, r"solve_velocity_ik\.J: expected shape \(m, 6\)"),
        ({"J": np.full((6, 6), np.nan)}, r"solve_velocity_ik\.J: expected finite"),
        ({"V": [0.0] * 5}, r"solve_velocity_ik\.V: expected 6 numbers"),
        ({"V": [np.inf] + [0.0] * 5}, r"solve_velocity_ik\.V: expected finite"),
        ({"q": [0.0] * 7}, r"solve_velocity_ik\.q: expected 6 numbers"),
        ({"v_prev": "fast"}, r"solve_velocity_ik\.v_prev"),
        ({"dt": 0.0}, r"solve_velocity_ik\.dt: expected a finite positive number, got 0\.0"),
        ({"q_nominal": [np.nan] * 6}, r"q_nominal: expected finite"),
        ({"limits": None}, r"solve_velocity_ik\.limits"),
    ],
)
def test_bad_arguments(kwargs: dict, match: str) -> None:
    args = {"J": np.eye(6), "V": np.ones(6) * 0.01, "q": Q_MID, "v_prev": np.zeros(6), "dt": DT}
    args["limits"] = LIMITS
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        solve_velocity_ik(**args)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"lower": [0.0, 1.0], "upper": [1.0, 0.0]}, "JointLimits.upper"),
        ({"velocity": [0.5, 0.0]}, "JointLimits.velocity"),
        ({"velocity": [0.5, np.inf]}, "JointLimits.velocity"),
        ({"acceleration": [1.0]}, r"JointLimits.acceleration: expected 2 numbers"),
        ({"lower": [np.nan, 0.0]}, "JointLimits.lower"),
    ],
)
def test_bad_limits(kwargs: dict, match: str) -> None:
    args = {"lower": [-1.0, -1.0], "upper": [1.0, 1.0], "velocity": [0.5, 0.5], "acceleration": [1.0, 1.0]}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        JointLimits(**args)
    assert JointLimits([-1.0], [1.0], [0.5], [np.inf]).size == 1  # no acceleration limit is fine


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"singular_threshold": -0.1}, "IkParams.singular_threshold"),
        ({"max_damping": 0.0}, "IkParams.max_damping"),
        ({"nominal_gain": float("nan")}, "IkParams.nominal_gain"),
        ({"limited_alpha": 1.5}, "IkParams.limited_alpha"),
        ({"stopped_alpha": 0.99}, "IkParams.stopped_alpha"),
    ],
)
def test_bad_params(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        IkParams(**kwargs)
