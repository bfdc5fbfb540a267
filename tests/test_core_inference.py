"""The numpy inference core: simplex invariants, relaxation, equivariance, discretisations."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from drake_disamb.core.inference import (
    TINY,
    DFTParams,
    bayes_likelihood,
    bayes_step,
    dft_drive,
    dft_euler_rollout,
    dft_euler_step,
    dft_euler_update,
    dft_mass_conserving_rhs,
    dft_mass_conserving_rhs_from_drive,
    dft_rhs,
    directedness,
    memory_step,
    normalize_belief,
    posterior_update,
    sanitize_command,
    transition_prior,
)

SPECIAL = [np.nan, np.inf, -np.inf, 0.0, 1e300, -1e300, 1e-300]


def assert_simplex(p: np.ndarray) -> None:
    assert np.all(np.isfinite(p)), p
    assert np.all(p >= 0.0), p
    np.testing.assert_allclose(p.sum(axis=-1), 1.0, atol=1e-9)


@st.composite
def scenes(draw):  # noqa: ANN201
    """Random goals, robot position, belief and a command that may be NaN, zero or huge."""
    n = draw(st.integers(1, 6))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    goals = rng.uniform(-1, 1, (n, 3))
    x_r = rng.uniform(-1, 1, 3)
    if draw(st.booleans()):
        goals[rng.integers(n)] = x_r  # a goal on top of the robot
    u = rng.normal(size=6) * 10.0 ** rng.integers(-3, 3)
    kind = draw(st.sampled_from(["normal", "zero", "special", "huge"]))
    if kind == "zero":
        u[:] = 0.0
    elif kind == "special":
        u[rng.integers(6)] = SPECIAL[rng.integers(len(SPECIAL))]
    elif kind == "huge":
        u *= 1e300
    p = rng.dirichlet(np.ones(n))
    if draw(st.booleans()):
        p[rng.integers(n)] = 0.0
        p = p / p.sum() if p.sum() > 0 else np.full(n, 1.0 / n)
    P = np.eye(n) + rng.uniform(0, 1, (n, n)) / 100
    P /= P.sum(axis=1, keepdims=True)
    return n, goals, x_r, u, p, P, rng


@settings(max_examples=150, deadline=None)
@given(scenes())
def test_every_update_stays_on_the_simplex(scene) -> None:  # noqa: ANN001
    n, goals, x_r, u, p, P, rng = scene
    params = DFTParams(transition=P, agreement=True, proximity=True, lam=rng.uniform(0, 500))
    u_a = rng.normal(size=(n, 6))
    for dt in (1e-3, 0.1, 10.0):  # including a step far too large for Euler
        assert_simplex(dft_euler_step(p, u, x_r, goals, params, dt, u_a))
    assert_simplex(bayes_step(p, u, x_r, goals, P))
    x_next = x_r + rng.normal(size=3) * 0.01
    p_mem, cost = memory_step(p, 0.3, x_r, x_next, x_r, goals, P)
    assert_simplex(p_mem)
    assert np.isfinite(cost)
    # The mass-conserving flow has zero total derivative and never pushes a zero entry negative.
    g = dft_mass_conserving_rhs(p, u, x_r, goals, params, u_a)
    assert np.all(np.isfinite(g))
    assert abs(g.sum()) < 1e-9 * max(1.0, np.abs(g).max())
    assert np.all(g[p <= 0] >= 0)


@settings(max_examples=20, deadline=None)
@given(scenes())
def test_mass_conserving_flow_integrates_on_the_simplex(scene) -> None:  # noqa: ANN001
    n, goals, x_r, u, p, P, _ = scene
    params = DFTParams(transition=P)

    def f(_t: float, y: np.ndarray) -> np.ndarray:
        return dft_mass_conserving_rhs(y, u, x_r, goals, params)

    sol = solve_ivp(f, (0.0, 0.5), p, method="RK45", rtol=1e-8, atol=1e-11)
    assert sol.success
    ends = sol.y.T
    np.testing.assert_allclose(ends.sum(axis=1), 1.0, atol=1e-9)
    assert ends.min() > -1e-9


def test_non_finite_or_huge_commands() -> None:
    goals = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    x = np.zeros(3)
    # A command with any non-finite entry carries no direction: the same as no command.
    for bad in ([np.nan, 1, 0], [np.inf, 0, 0], [1, -np.inf, 0]):
        np.testing.assert_array_equal(sanitize_command(bad), 0.0)
        np.testing.assert_allclose(directedness(bad, x, goals), 0.5)
        np.testing.assert_allclose(bayes_likelihood(bad, x, goals), 1.0)
    # A huge but finite command keeps its direction.
    np.testing.assert_allclose(directedness([1e300, 0, 0], x, goals), [1.0, 0.5])
    # So does a tiny one whose squared norm underflows (the cosine does not depend on the scale).
    np.testing.assert_allclose(directedness([1e-300, 0, 0], x, goals), [1.0, 0.5])
    np.testing.assert_allclose(directedness([0, 1e-300, 1e-300], x, goals), [0.5, 0.5 + 0.5 / np.sqrt(2)])


def _relax(p: np.ndarray, params: DFTParams, goals: np.ndarray, steps: int, dt: float) -> np.ndarray:
    for _ in range(steps):
        p = dft_euler_step(p, np.zeros(6), np.zeros(3), goals, params, dt)
    return p


@pytest.mark.parametrize("seed", range(3))
def test_zero_input_relaxes_to_the_rest_state(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 6))
    goals = rng.uniform(-0.5, 0.5, (n, 3))
    p0 = rng.dirichlet(np.ones(n) * 0.3)
    # Paper / authors' convention, uniform rest state: uniform.
    p = _relax(p0, DFTParams(), goals, 400, 0.01)
    np.testing.assert_allclose(p, np.full(n, 1.0 / n), atol=1e-9)
    # A task prior as rest state, with a zero command adding no excitation: the prior.
    rest = rng.dirichlet(np.ones(n))
    params = DFTParams(tau1=1.0, tau2=1.0, rest=rest, zero_command_excitation=False)
    p = _relax(p0, params, goals, 600, 0.05)
    np.testing.assert_allclose(p, rest, atol=1e-6)
    # Same for the continuous flow.
    sol = solve_ivp(
        lambda _t, y: dft_mass_conserving_rhs(y, np.zeros(6), np.zeros(3), goals, params),
        (0.0, 30.0),
        p0,
        rtol=1e-10,
        atol=1e-12,
    )
    np.testing.assert_allclose(sol.y[:, -1], rest, atol=1e-6)
    # With the authors' convention, a zero command excites every goal equally: near uniform.
    p = _relax(p0, DFTParams(rest=rest), goals, 400, 0.01)
    assert np.abs(p - 1.0 / n).max() < np.abs(rest - 1.0 / n).max() / 10


@settings(max_examples=60, deadline=None)
@given(scenes())
def test_permuting_goals_permutes_the_belief(scene) -> None:  # noqa: ANN001
    n, goals, x_r, u, p, P, rng = scene
    perm = rng.permutation(n)
    Pp = P[np.ix_(perm, perm)]
    u_a = rng.normal(size=(n, 6))
    params = DFTParams(transition=P, agreement=True, proximity=True)
    params_p = DFTParams(transition=Pp, agreement=True, proximity=True)
    a = dft_euler_step(p, u, x_r, goals, params, 0.01, u_a)
    b = dft_euler_step(p[perm], u, x_r, goals[perm], params_p, 0.01, u_a[perm])
    np.testing.assert_allclose(b, a[perm], rtol=1e-9, atol=1e-15)
    a = dft_mass_conserving_rhs(p, u, x_r, goals, params, u_a)
    b = dft_mass_conserving_rhs(p[perm], u, x_r, goals[perm], params_p, u_a[perm])
    np.testing.assert_allclose(b, a[perm], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(
        bayes_step(p[perm], u, x_r, goals[perm], Pp), bayes_step(p, u, x_r, goals, P)[perm], rtol=1e-9
    )
    x1 = x_r + 0.01
    a, _ = memory_step(p, 0.1, x_r, x1, x_r - 0.2, goals, P)
    b, _ = memory_step(p[perm], 0.1, x_r, x1, x_r - 0.2, goals[perm], Pp)
    np.testing.assert_allclose(b, a[perm], rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("with_transition", [False, True])
@pytest.mark.parametrize("per_row_dt", [False, True])
def test_euler_rollout_is_the_iterated_update(with_transition: bool, per_row_dt: bool) -> None:
    """dft_euler_rollout runs dft_euler_update's kernel K times: the same numbers, bit for bit,
    including steps that clip (negative drives push small entries below zero)."""
    rng = np.random.default_rng(11)
    K, B, n = 20, 6, 5
    p = rng.dirichlet(np.ones(n), size=B)
    drives = rng.uniform(-1.5, 2.0, (K, B, n))
    P = None
    if with_transition:
        P = np.eye(n) + rng.uniform(0, 0.05, (B, n, n))
        P /= P.sum(axis=-1, keepdims=True)
    params = DFTParams(tau1=4.0, transition=P)
    dt = rng.uniform(0.05, 0.1, (B, 1)) if per_row_dt else 0.1
    out = dft_euler_rollout(p, drives, params, dt)
    assert out.shape == (K, B, n)
    q = p
    clipped = False
    for s in range(K):
        clipped |= bool(np.any(q + np.asarray(dt) * (drives[s] - transition_prior(q, P) / 4.0) <= 0))
        q = dft_euler_update(q, drives[s], params, dt)
        np.testing.assert_array_equal(out[s], q)
        assert_simplex(out[s])
    assert clipped  # the scene exercises the clip


def test_euler_update_broadcasts_and_names_bad_shapes() -> None:
    rng = np.random.default_rng(12)
    p = rng.dirichlet(np.ones(3))
    drive = rng.normal(size=(4, 2, 3))
    out = dft_euler_update(p, drive, DFTParams(), 0.01)
    assert out.shape == (4, 2, 3)
    np.testing.assert_array_equal(out[3, 1], dft_euler_update(p, drive[3, 1], DFTParams(), 0.01))
    with pytest.raises(ValueError, match="drive: expected 3 entries"):
        dft_euler_update(p, np.zeros(4), DFTParams(), 0.01)
    with pytest.raises(ValueError, match=r"dt: expected a scalar or shape \(\.\.\., 1\)"):
        dft_euler_update(np.tile(p, (3, 1)), np.zeros((3, 3)), DFTParams(), np.full(3, 0.01))
    with pytest.raises(ValueError, match="drives: expected shape|drive: expected shape"):
        dft_euler_rollout(p, np.zeros((0, 3)), DFTParams(), 0.01)


def test_batched_calls_equal_single_calls() -> None:
    rng = np.random.default_rng(3)
    B, n = 7, 4
    p = rng.dirichlet(np.ones(n), size=B)
    u = rng.normal(size=(B, 6))
    x = rng.uniform(-0.5, 0.5, (B, 3))
    goals = rng.uniform(-0.5, 0.5, (B, n, 3))
    P = np.eye(n) + rng.uniform(0, 0.01, (B, n, n))
    P /= P.sum(axis=-1, keepdims=True)
    dt = rng.uniform(0.001, 0.01, (B, 1))
    batched = DFTParams(transition=P)
    drive = dft_drive(u, x, goals, batched)
    out = dft_euler_update(p, drive, batched, dt)
    for b in range(B):
        single = DFTParams(transition=P[b])
        np.testing.assert_allclose(
            out[b], dft_euler_step(p[b], u[b], x[b], goals[b], single, dt[b, 0]), rtol=1e-13
        )
        np.testing.assert_allclose(transition_prior(p, P)[b], P[b].T @ p[b], rtol=1e-13)
        lik = bayes_likelihood(u[b], x[b], goals[b])
        np.testing.assert_allclose(
            posterior_update(p, bayes_likelihood(u, x, goals), P)[b],
            bayes_step(p[b], u[b], x[b], goals[b], P[b]),
        )
        np.testing.assert_allclose(
            bayes_step(p[b], u[b], x[b], goals[b], P[b]), normalize_belief(lik * (P[b].T @ p[b]))
        )


def test_dft_step_matches_the_written_formula() -> None:
    """One Euler step against equation (dft_ii) written out by hand (authors' settings)."""
    n = 3
    goals = np.array([[0.3, 0.0, 0.0], [0.0, 0.4, 0.0], [0.0, 0.0, -0.2]])
    x = np.array([0.05, 0.02, 0.0])
    u = np.array([0.6, -0.1, 0.2])
    p = np.array([0.5, 0.3, 0.2])
    P = np.array([[0.98, 0.01, 0.01], [0.02, 0.97, 0.01], [0.0, 0.01, 0.99]])
    params = DFTParams(tau1=10, tau2=10, lam=200, transition=P)
    d = (goals - x) / np.linalg.norm(goals - x, axis=1, keepdims=True)
    eta = d @ (u / np.linalg.norm(u))
    sigma = 1 / (1 + np.exp(-(1 + eta) / 2)) - 0.5
    f = -(P.T @ p) / 10 + np.full(n, 1 / n) / 10 + 200 * sigma
    np.testing.assert_allclose(dft_rhs(p, u, x, goals, params), f, rtol=1e-13)
    q = p + 0.002 * f
    np.testing.assert_allclose(dft_euler_step(p, u, x, goals, params, 0.002), q / q.sum(), rtol=1e-13)
    # The lambda matrix form with lam * I is the same.
    params_m = DFTParams(tau1=10, tau2=10, lam=200 * np.eye(n), transition=P)
    np.testing.assert_allclose(dft_rhs(p, u, x, goals, params_m), f, rtol=1e-13)


def test_each_xi_term_can_be_switched() -> None:
    goals = np.array([[0.1, 0.0, 0.0], [0.0, 1.0, 0.0]])
    x = np.zeros(3)
    u = np.array([1.0, 0, 0, 0, 0, 1.0])
    u_a = np.array([[0, 0, 0, 0, 0, 1.0], [0, 0, 0, 0, 0, -1.0]])
    base = {"lam": 1.0, "tau2": 1e9, "tau1": 1e9}

    def drive(**terms: bool) -> np.ndarray:
        return dft_drive(u, x, goals, DFTParams(**base, **terms), u_a) - 1e-9 / 2

    s = lambda xi: 1 / (1 + np.exp(-np.asarray(xi))) - 0.5  # noqa: E731
    np.testing.assert_allclose(drive(directedness=True), s([1.0, 0.5]), atol=1e-12)
    np.testing.assert_allclose(drive(directedness=False, agreement=True), s([1.0, -1.0]), atol=1e-12)
    np.testing.assert_allclose(drive(directedness=False, proximity=True), s([0.5, 0.0]), atol=1e-12)
    np.testing.assert_allclose(drive(directedness=False), 0.0, atol=1e-12)
    with pytest.raises(ValueError, match="u_a"):
        dft_drive(u, x, goals, DFTParams(agreement=True))


def test_euler_equivalent_flow_reproduces_the_euler_map() -> None:
    """With euler_equivalent_step = h, integrating the flow over h gives the authors' Euler step."""
    rng = np.random.default_rng(0)
    n, h = 4, 0.002
    goals = rng.uniform(-0.5, 0.5, (n, 3))
    x = rng.uniform(-0.5, 0.5, 3)
    u = rng.normal(size=3)
    p = rng.dirichlet(np.ones(n))
    euler = dft_euler_step(p, u, x, goals, DFTParams(), h)

    def flow(params: DFTParams) -> np.ndarray:
        sol = solve_ivp(
            lambda _t, y: dft_mass_conserving_rhs(y, u, x, goals, params), (0, h), p, rtol=1e-12, atol=1e-14
        )
        return sol.y[:, -1]

    matched = flow(DFTParams(euler_equivalent_step=h))
    plain = flow(DFTParams())
    np.testing.assert_allclose(matched, euler, atol=1e-10)
    assert np.abs(plain - euler).max() > 100 * np.abs(matched - euler).max()


def test_normalize_belief_edge_cases() -> None:
    np.testing.assert_allclose(normalize_belief(np.array([0.0, 0.0])), [0.5, 0.5])
    np.testing.assert_allclose(normalize_belief(np.array([np.nan, 1.0])), [TINY, 1.0])
    np.testing.assert_allclose(
        normalize_belief(np.array([np.inf, 1.0, np.inf])), [0.5, TINY / 2, 0.5], atol=1e-300
    )
    np.testing.assert_allclose(normalize_belief(np.array([1e308, 1e308])), [0.5, 0.5])
    np.testing.assert_allclose(normalize_belief(np.array([-1.0, 3.0])), [TINY / 3, 1.0])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"tau1": 0.0}, "tau1"),
        ({"tau2": float("nan")}, "tau2"),
        ({"R": -1.0}, "R"),
        ({"lam": float("inf")}, "lam"),
        ({"lam": np.ones((2, 3))}, "lam"),
        ({"transition": np.array([[0.5, 0.6], [0.5, 0.5]])}, "transition"),
        ({"transition": np.ones(3)}, "transition"),
        ({"rest": np.array([0.5, 0.6])}, "rest"),
        ({"rest": np.array([-0.5, 1.5])}, "rest"),
        ({"euler_equivalent_step": 0.0}, "euler_equivalent_step"),
    ],
)
def test_bad_params_name_the_field(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        DFTParams(**kwargs)


def test_rest_of_wrong_size_is_rejected() -> None:
    with pytest.raises(ValueError, match="rest"):
        dft_drive(np.zeros(3), np.zeros(3), np.ones((3, 3)), DFTParams(rest=np.array([0.5, 0.5])))


@settings(max_examples=60, deadline=None)
@given(scenes())
def test_guard_time_keeps_an_euler_step_of_that_length_on_the_simplex(scene) -> None:  # noqa: ANN001
    n, goals, x_r, u, p, P, rng = scene
    params = DFTParams(transition=P, agreement=True, proximity=True)
    u_a = rng.normal(size=(n, 6))
    free = dft_mass_conserving_rhs(p, 20.0 * u, x_r, goals, params, u_a)  # fast: entries cross zero
    guarded = dft_mass_conserving_rhs(p, 20.0 * u, x_r, goals, params, u_a, guard_time=0.01)
    assert abs(guarded.sum()) < 1e-9 * max(1.0, np.abs(free).max())  # mass is still conserved
    assert np.all(p + 0.01 * guarded >= -1e-12)  # one 10 ms Euler step stays >= 0
    assert np.all(guarded >= np.minimum(free, -p / 0.01) - 1e-9)  # never falls faster than p / T
    if np.all(p + 0.01 * free >= 0.0):  # nothing to guard: the flow is unchanged
        np.testing.assert_allclose(guarded, free, rtol=1e-12, atol=1e-12)


def test_guard_time_zero_is_the_plain_flow_and_bad_values_are_named() -> None:
    p, drive = np.array([0.01, 0.49, 0.5]), np.array([-5.0, 2.0, 3.0])  # the first goal's share falls fast
    params = DFTParams()
    plain = dft_mass_conserving_rhs_from_drive(p, drive, params)
    assert plain[0] < -p[0] / 0.01  # it would cross zero within 10 ms
    np.testing.assert_array_equal(dft_mass_conserving_rhs_from_drive(p, drive, params, 0.0), plain)
    guarded = dft_mass_conserving_rhs_from_drive(p, drive, params, 0.01)
    assert guarded[0] == pytest.approx(-p[0] / 0.01) and guarded.sum() == pytest.approx(0.0, abs=1e-12)
    # The mass it did not lose is taken from the others in proportion to their mass.
    np.testing.assert_allclose(plain[1:] - guarded[1:], (plain[0] - guarded[0]) * p[1:] / p[1:].sum() * -1.0)
    for bad in (-0.01, np.nan, np.inf, "0.01"):
        with pytest.raises(ValueError, match="guard_time: expected a finite number >= 0"):
            dft_mass_conserving_rhs_from_drive(p, drive, params, bad)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "params",
    [
        DFTParams(),
        DFTParams(tau1=4.0, tau2=4.0, lam=3.0, agreement=True, agreement_measure="cosine", proximity=True),
        DFTParams(agreement=True, zero_command_excitation=False, euler_equivalent_step=0.01, R=0.3),
        DFTParams(
            lam=np.array([[2.0, 0.5, 0.0], [0.0, 3.0, 1.0], [0.2, 0.0, 1.0]]),
            transition=np.array([[0.8, 0.1, 0.1], [0.0, 1.0, 0.0], [0.3, 0.3, 0.4]]),
            rest=np.array([0.5, 0.3, 0.2]),
            proximity=True,
        ),
    ],
)
def test_dft_row_is_the_array_functions(params: DFTParams) -> None:
    """DFTRow (the control loop's prepared DFT) gives exactly the numbers of dft_drive and
    dft_mass_conserving_rhs_from_drive for one belief, command and pose; dft_drive hands it its rows."""
    from drake_disamb.core.inference import DFTRow

    rng = np.random.default_rng(11)
    n = 3
    for guard_time in (0.0, 0.01):
        row = DFTRow(params, n, guard_time)
        for _ in range(20):
            u = rng.normal(scale=0.2, size=6) * rng.integers(0, 2, size=6)
            x_r, x_g = rng.normal(scale=0.3, size=3), rng.normal(scale=0.3, size=(7, n))[:3].T
            u_a = rng.normal(scale=0.2, size=(n, 6))
            p = rng.dirichlet(np.ones(n))
            expected = dft_drive(u, x_r, x_g, params, u_a)
            got = row.drive(u, x_r, x_g, u_a.ravel())
            np.testing.assert_array_equal(got, expected)
            np.testing.assert_array_equal(dft_drive(u, x_r, x_g, row, u_a), expected)
            np.testing.assert_array_equal(
                row.mass_conserving_rhs(p, got),
                dft_mass_conserving_rhs_from_drive(p, expected, params, guard_time),
            )
    with pytest.raises(ValueError, match="guard_time"):
        DFTRow(params, n, -1.0)
    with pytest.raises(ValueError, match="n_goals"):
        DFTRow(params, 0)
    with pytest.raises(ValueError, match="transition"):
        DFTRow(DFTParams(transition=np.eye(2)), 3)
    with pytest.raises(ValueError, match="u_a"):
        DFTRow(DFTParams(agreement=True), 3).drive(np.ones(6), np.zeros(3), np.ones((3, 3)))
