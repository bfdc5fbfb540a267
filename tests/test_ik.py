"""Tests of the direction-preserving differential IK (drake_disamb.ik), driven with fixed inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_disamb.ik import IkParams, IkStatus, VelocityIkSolver, solve_velocity_ik
from drake_disamb.joint_limits import JointLimits, velocity_bounds

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


def _assert_along(J: np.ndarray, v: np.ndarray, V: np.ndarray, rel: float = 1e-9) -> None:
    """J v is a non-negative multiple of V: the end effector moves along the command or not at all."""
    JV = J @ v
    alpha = float(JV @ V) / float(V @ V)
    assert alpha >= -rel
    assert np.linalg.norm(JV - alpha * V) <= rel * np.linalg.norm(V) + 1e-15


# ----------------------------------------------------------------------------------------------
# A random reachable configuration: the exact inverse.
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_well_conditioned_command_is_tracked_exactly(seed: int) -> None:
    J, _, _ = _jacobian([1.7, 1.4, 1.1, 0.9, 0.6, 0.3], seed)
    V = np.random.default_rng(seed).normal(size=6) * 0.02
    v_prev = np.linalg.solve(J, V)
    sol = solve_velocity_ik(J, V, Q_MID, v_prev, DT, LIMITS)
    assert sol.status == IkStatus.OK
    np.testing.assert_allclose(J @ sol.v, V, atol=1e-12)
    assert sol.alpha == pytest.approx(1.0) and sol.error < 1e-12 and sol.limiting_joints == ()


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
    assert len(sol.limiting_joints) == 1
    _assert_along(J, sol.v, V)


def test_huge_command_keeps_its_direction_without_overflow() -> None:
    J, _, _ = _jacobian([1.7, 1.4, 1.1, 0.3, 0.2, 0.07])
    V = np.array([1e300, -1e300, 0.0, 0.0, 0.0, 1e299])
    with np.errstate(over="raise", divide="raise", invalid="raise"):
        sol = solve_velocity_ik(J, V, Q_MID, np.zeros(6), DT, LIMITS)
    assert np.all(np.isfinite(sol.v)) and sol.status == IkStatus.LIMITED  # moving: not STOPPED
    assert np.max(np.abs(sol.v)) > 0.1
    _assert_along(J, sol.v, V / 1e300)


def test_acceleration_limits_ramp_along_the_command() -> None:
    J, _, _ = _jacobian([1.7, 1.4, 1.1, 0.3, 0.2, 0.07])
    V = np.array([0.05, -0.02, 0.03, 0.0, 0.1, 0.0])
    v_full = np.linalg.solve(J, V)
    assert np.max(np.abs(v_full)) > LIMITS.acceleration[0] * DT  # too fast to reach in one step
    sol = solve_velocity_ik(J, V, Q_MID, np.zeros(6), DT, LIMITS)
    assert np.all(np.abs(sol.v) <= LIMITS.acceleration * DT + 1e-12)
    np.testing.assert_allclose(sol.v / np.max(np.abs(sol.v)), v_full / np.max(np.abs(v_full)), atol=1e-9)
    assert sol.status == IkStatus.LIMITED
    # A sudden reversal: no point of the new line meets the acceleration bounds, so the set point
    # turns at once (the direction wins) and takes the slowest speed along it: it stops.
    sol = solve_velocity_ik(J, -V, Q_MID, v_full, DT, LIMITS)
    _assert_along(J, sol.v, -V)
    np.testing.assert_allclose(sol.v, 0.0, atol=1e-12)


def test_a_turn_while_moving_keeps_the_new_direction() -> None:
    J, _, _ = _jacobian([1.7, 1.4, 1.1, 0.9, 0.6, 0.3], seed=7)
    v_prev = np.linalg.solve(J, [0.1, 0, 0, 0, 0, 0])
    v_prev *= 0.9 * np.min(LIMITS.velocity / np.abs(v_prev))
    V = np.array([0.07, 0.07, 0.0, 0.0, 0.0, 0.0])  # 45 degrees off the current motion
    sol = solve_velocity_ik(J, V, Q_MID, v_prev, DT, LIMITS)
    _assert_along(J, sol.v, V)
    assert sol.alpha > 0  # still moving, along the new command


# ----------------------------------------------------------------------------------------------
# Singular configurations: slowed along the command, or refused; never bent.
# ----------------------------------------------------------------------------------------------
def test_command_with_a_part_along_a_lost_direction_is_refused() -> None:
    J, U, _ = _jacobian([1.7, 1.4, 1.1, 0.3, 0.2, 0.0])
    good = U[:, :5] @ np.array([0.02, -0.01, 0.03, 0.01, 0.005])
    V = good + 0.05 * U[:, 5]  # plus a component along the lost direction
    sol = VelocityIkSolver(LIMITS, DT).solve(J, V, Q_MID, np.zeros(6))
    assert sol.status == IkStatus.STOPPED
    assert sol.sigma_min == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_allclose(sol.v, 0.0, atol=1e-12)  # not its achievable part: nothing
    # The achievable part alone is tracked.
    sol = VelocityIkSolver(LIMITS, DT).solve(J, good, Q_MID, np.linalg.pinv(J) @ good)
    _assert_along(J, sol.v, good)
    assert sol.alpha > 0.5


def test_null_space_pull_does_not_move_the_end_effector() -> None:
    J, U, W = _jacobian([1.7, 1.4, 1.1, 0.3, 0.2, 0.0])
    V = 0.05 * U[:, 5]
    q_nom = Q_MID + 0.3 * W[:, 5]
    sol = solve_velocity_ik(J, V, Q_MID, np.zeros(6), DT, LIMITS, q_nominal=q_nom)
    assert sol.status == IkStatus.SINGULAR and sol.alpha == pytest.approx(0.0, abs=1e-12)
    assert sol.v @ W[:, 5] > 0  # out of the singularity, towards the nominal posture
    np.testing.assert_allclose(J @ sol.v, 0.0, atol=1e-12)  # without moving the end effector


@pytest.mark.parametrize("sigma", [0.1, 0.03, 0.02, 0.01, 1e-3, 1e-5])
def test_near_a_singularity_the_arm_slows_along_the_command(sigma: float) -> None:
    J, U, _ = _jacobian([1.7, 1.4, 1.1, 0.3, 0.2, sigma], seed=3)
    V = 0.1 * (U[:, 5] + U[:, 0]) / math.sqrt(2)
    sol = solve_velocity_ik(
        J,
        V,
        Q_MID,
        np.zeros(6),
        DT,
        JointLimits(LIMITS.lower, LIMITS.upper, LIMITS.velocity, np.full(6, np.inf)),
    )
    _assert_along(J, sol.v, V, rel=1e-7)
    params = IkParams()
    factor = max(params.singular_speed_floor, min(1.0, sigma / params.singular_threshold))
    assert np.all(np.abs(sol.v) <= factor * LIMITS.velocity + 1e-12)  # joints slow down too
    if sigma < params.singular_threshold:
        assert sol.status in (IkStatus.SINGULAR, IkStatus.STOPPED)
    if sigma <= 1e-3:
        assert sol.alpha < 0.05


def _barrier_case(q5: float) -> tuple[np.ndarray, np.ndarray, VelocityIkSolver, object]:
    """A Jacobian whose smallest singular value is ``|q[5]|`` (joint 5 alone, along the task's
    last direction): a command along that direction drives the arm into the singularity at
    ``q[5] = 0`` or out of it."""
    J0, U, W = _jacobian([1.7, 1.4, 1.1, 0.3, 0.2, 1.0], seed=5)

    def jac(q: np.ndarray) -> np.ndarray:
        return U @ np.diag([1.7, 1.4, 1.1, 0.3, 0.2, abs(q[5])]) @ W.T

    def sigma_at(q: np.ndarray) -> float:
        return float(np.linalg.svd(jac(q), compute_uv=False)[-1])

    q = Q_MID.copy()
    q[5] = q5
    limits = JointLimits(LIMITS.lower, LIMITS.upper, LIMITS.velocity, np.full(6, np.inf))
    return jac(q), q, VelocityIkSolver(limits, DT), (U, W, sigma_at)


def test_the_singular_barrier_stops_the_arm_at_it_and_lets_it_back_out() -> None:
    barrier = IkParams().singular_barrier
    J, q, solver, (U, W, sigma_at) = _barrier_case(0.012)
    into = 0.1 * U[:, 5] * np.sign(W[5, 5])  # along +W[:, 5] in joint space: q[5] grows ...
    # ... so command the sign that shrinks q[5] (drives it toward 0, the singularity)
    deeper = into if (np.linalg.solve(J, into) @ np.eye(6)[5]) < 0 else -into
    free = solver.solve(J, deeper, q, np.zeros(6))
    held = solver.solve(J, deeper, q, np.zeros(6), sigma_at=sigma_at)
    _assert_along(J, held.v, deeper, rel=1e-7)  # shortened along the command, never bent
    assert sigma_at(q + DT * free.v) < barrier  # without the barrier the step crosses it
    assert sigma_at(q + DT * held.v) >= barrier - 1e-9 and held.alpha > 0.0  # it ends at it
    assert held.status == IkStatus.SINGULAR
    # At the barrier: deeper is refused, the way back is not held back at all.
    J, q, solver, (U, W, sigma_at) = _barrier_case(barrier)
    refused = solver.solve(J, deeper, q, np.zeros(6), sigma_at=sigma_at)
    assert np.allclose(refused.v, 0.0) and refused.status == IkStatus.STOPPED
    back = solver.solve(J, -deeper, q, np.zeros(6), sigma_at=sigma_at)
    np.testing.assert_allclose(back.v, solver.solve(J, -deeper, q, np.zeros(6)).v)
    assert sigma_at(q + DT * back.v) > barrier and back.alpha > 0.0
    # Far from the singularity (above singular_threshold) nothing is checked.
    J, q, solver, (_, _, sigma_at) = _barrier_case(0.5)
    calls = []
    solver.solve(J, deeper, q, np.zeros(6), sigma_at=lambda x: calls.append(x) or sigma_at(x))
    assert calls == []
    # Without a barrier (0) the step is the free one.
    J, q, _, (_, _, sigma_at) = _barrier_case(0.012)
    limits = JointLimits(LIMITS.lower, LIMITS.upper, LIMITS.velocity, np.full(6, np.inf))
    none = VelocityIkSolver(limits, DT, IkParams(singular_barrier=0.0))
    np.testing.assert_allclose(none.solve(J, deeper, q, np.zeros(6), sigma_at=sigma_at).v, free.v)


# ----------------------------------------------------------------------------------------------
# A joint at its limit: the command stops (or slows), it is not carried on by the other joints.
# ----------------------------------------------------------------------------------------------
def test_joint_at_its_limit_stops_the_command_that_needs_it() -> None:
    J, _, _ = _jacobian([1.7, 1.4, 1.1, 0.3, 0.2, 0.07], seed=4)
    q = Q_MID.copy()
    q[2] = LIMITS.lower[2]  # joint 3 on its lower limit
    V = J @ np.array([0.1, 0.0, -0.5, 0.0, 0.05, 0.0])  # needs joint 3 to go further down
    sol = solve_velocity_ik(J, V, q, np.zeros(6), DT, LIMITS)
    assert sol.status == IkStatus.STOPPED and sol.limiting_joints == (2,)
    np.testing.assert_allclose(sol.v, 0.0, atol=1e-12)
    # The opposite command pulls off the limit and is tracked.
    sol = solve_velocity_ik(J, -V, q, np.zeros(6), DT, LIMITS)
    assert sol.v[2] > 0
    _assert_along(J, sol.v, -V)


def test_joint_approaching_its_limit_brakes_and_lands_on_it() -> None:
    lims = JointLimits(LIMITS.lower, LIMITS.upper, LIMITS.velocity, LIMITS.acceleration)
    J, _, _ = _jacobian([1.7, 1.4, 1.1, 0.9, 0.6, 0.3], seed=5)
    e = np.zeros(6)
    e[1] = 0.5
    V = J @ e
    q, v = Q_MID.copy(), np.zeros(6)
    q[1] = LIMITS.upper[1] - 0.05
    speeds = []
    for _ in range(300):
        sol = solve_velocity_ik(J, V, q, v, DT, lims)
        _assert_along(J, sol.v, V)
        # Braking, not a jolt: the last step onto the limit may take up to twice the limit.
        assert np.all(np.abs(sol.v - v) <= 2 * lims.acceleration * DT + 1e-9)
        v = sol.v
        q = q + v * DT
        assert q[1] <= LIMITS.upper[1] + 1e-12
        speeds.append(v[1])
    assert q[1] == pytest.approx(LIMITS.upper[1], abs=1e-3)
    assert speeds[-1] == pytest.approx(0.0, abs=1e-6)


def test_workspace_bound_stops_along_the_command() -> None:
    J, _, _ = _jacobian([1.7, 1.4, 1.1, 0.9, 0.6, 0.3], seed=6)
    solver = VelocityIkSolver(LIMITS, DT)
    V = np.array([0.05, 0.0, -0.1, 0.0, 0.0, 0.0])
    rows = np.array([[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]])  # the vertical speed
    sol = solver.solve(J, V, Q_MID, np.linalg.solve(J, V), rows, np.array([-0.02]))  # near the floor
    assert sol.status == IkStatus.WORKSPACE
    assert sol.alpha == pytest.approx(0.2)
    _assert_along(J, sol.v, V)
    on_floor = np.array([0.0])  # downward commands stop, upward ones are free
    assert solver.solve(J, V, Q_MID, np.zeros(6), rows, on_floor).alpha == 0.0
    assert solver.solve(J, -V, Q_MID, np.zeros(6), rows, on_floor).status in (IkStatus.OK, IkStatus.LIMITED)
    # A point 0.1 m off the origin along x goes down when turning about y: the turn is slowed too.
    rows = np.array([[0.0, 0.0, 1.0, 0.0, -0.1, 0.0]])
    W = np.array([0.0, 0.0, 0.0, 0.0, 0.5, 0.0])
    sol = solver.solve(J, W, Q_MID, np.linalg.solve(J, W), rows, np.array([-0.01]))
    assert sol.status == IkStatus.WORKSPACE and sol.alpha == pytest.approx(0.2)


# ----------------------------------------------------------------------------------------------
# Never NaN, never outside the limits, never off the command (random inputs, rank-deficient J).
# ----------------------------------------------------------------------------------------------
@settings(max_examples=200, deadline=None, derandomize=True)
@given(seed=st.integers(0, 2**32 - 1), rank=st.integers(3, 6), scale=st.sampled_from([1e-3, 0.1, 5.0, 1e200]))
def test_step_is_finite_inside_every_bound_and_along_the_command(seed: int, rank: int, scale: float) -> None:
    rng = np.random.default_rng(seed)
    sigma = np.sort(rng.uniform(0.0, 2.0, 6))[::-1]
    sigma[rank:] = 0.0
    J, _, _ = _jacobian(sigma, seed)
    u = rng.uniform(size=6)
    q = LIMITS.lower + u * (LIMITS.upper - LIMITS.lower)
    edge = rng.integers(0, 6)
    q[edge] = LIMITS.lower[edge] if rng.uniform() < 0.5 else LIMITS.upper[edge]
    v_prev = rng.uniform(-1, 1, 6) * LIMITS.velocity
    lo_pv, hi_pv = velocity_bounds(
        q, np.zeros(6), DT, JointLimits(LIMITS.lower, LIMITS.upper, LIMITS.velocity, np.full(6, np.inf))
    )
    v_prev = np.clip(v_prev, lo_pv, hi_pv)
    V = rng.normal(size=6) * scale
    sol = solve_velocity_ik(J, V, q, v_prev, DT, LIMITS, q_nominal=Q_MID)
    assert np.all(np.isfinite(sol.v)) and math.isfinite(sol.alpha) and math.isfinite(sol.error)
    assert np.all(np.abs(sol.v) <= LIMITS.velocity + 1e-12)
    q_next = q + sol.v * DT
    assert np.all(q_next >= LIMITS.lower - 1e-12) and np.all(q_next <= LIMITS.upper + 1e-12)
    d = V / np.max(np.abs(V))
    _assert_along(J, sol.v, d, rel=1e-6)  # null-space pull only where J is (numerically) zero
    assert sol.error <= 1e-6
    assert sol.status in (IkStatus.OK, IkStatus.LIMITED, IkStatus.SINGULAR, IkStatus.STOPPED)
    if sol.status == IkStatus.OK:
        assert sol.alpha >= 0.95
    lo, hi = velocity_bounds(q, v_prev, DT, LIMITS)
    on_line = _in_box(sol.v, q, v_prev)
    # The acceleration bounds hold unless no point of the commanded line meets them.
    assert on_line or not np.all((lo <= 0) & (hi >= 0)) or sol.alpha < 1.0


def test_velocity_bounds() -> None:
    lims = JointLimits([-1.0, -1.0], [1.0, 1.0], [0.5, 0.5], [10.0, 10.0])
    lo, hi = velocity_bounds([0.0, 0.998], [0.0, 0.0], 0.01, lims)
    np.testing.assert_allclose(lo, [-0.1, -0.1])  # acceleration: 10 * 0.01
    np.testing.assert_allclose(hi, [0.1, 0.1])
    lo, hi = velocity_bounds([0.0, 0.998], [0.45, 0.45], 0.01, lims)
    # Joint 2, 2 mm from its limit, must brake to sqrt(0.05^2 + 0.04) - 0.05 = 0.156 rad/s at once
    # (the position bound wins over the acceleration bound).
    brake = math.sqrt(0.05**2 + 0.04) - 0.05
    np.testing.assert_allclose(lo, [0.35, brake])
    np.testing.assert_allclose(hi, [0.5, brake])
    # Braking: 0.02 rad from the limit at 10 rad/s^2 allows sqrt(0.05^2 + 0.4) - 0.05 = 0.583 -> 0.5.
    lo, hi = velocity_bounds([0.0, 0.98], [0.45, 0.45], 0.01, lims)
    assert hi[1] == pytest.approx(0.5)
    lo, hi = velocity_bounds([0.0, 0.99], [0.45, 0.45], 0.01, lims)  # 0.01 rad: brake at 0.40
    assert hi[1] == pytest.approx(math.sqrt(0.05**2 + 0.2) - 0.05)
    lo, hi = velocity_bounds([0.0, 1.2], [0.0, 0.0], 0.01, lims)  # outside: back inside
    assert hi[1] <= 0 and lo[1] <= hi[1]
    lo, hi = velocity_bounds([0.0, 0.0], [0.0, 0.0], 0.01, lims, speed_factor=0.1)
    np.testing.assert_allclose(hi, [0.05, 0.05])


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
        ({"null_threshold": 0.5}, "IkParams.null_threshold"),
        ({"singular_speed_floor": 0.0}, "IkParams.singular_speed_floor"),
        ({"nominal_gain": float("nan")}, "IkParams.nominal_gain"),
        ({"limited_alpha": 1.5}, "IkParams.limited_alpha"),
        ({"stopped_alpha": 0.99}, "IkParams.stopped_alpha"),
        ({"singular_barrier": 0.05}, "IkParams.singular_barrier"),
        ({"singular_barrier": -1e-3}, "IkParams.singular_barrier"),
    ],
)
def test_bad_params(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        IkParams(**kwargs)
