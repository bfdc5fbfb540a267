"""Drake inference systems: ports, fixed-input contexts, simplex invariants, resets, Euler agreement."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from drake_disamb.comparison.replay import authors_dft_params, replay_trials
from drake_disamb.comparison.trial_files import load_trial_mat
from drake_disamb.core.inference import (
    BayesInference,
    DFTParams,
    MemoryInference,
    bayes_step,
    dft_mass_conserving_rhs,
    memory_step,
)
from drake_disamb.systems.inference import (
    FieldTheoreticIntentInference,
    MemoryBasedIntentInference,
    RecursiveBayesIntentInference,
)
from drake_disamb.systems.loop import ControlLoop

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "tnsre2018_simulated_trajectories"

SYSTEMS = {
    "dft": lambda n, params=None, control_period=0.01, **kw: FieldTheoreticIntentInference(
        ControlLoop(n, control_period), DFTParams(**(params or {})), **kw
    ),
    "bayes": lambda n, transition=None, control_period=0.01, **kw: RecursiveBayesIntentInference(
        ControlLoop(n, control_period), BayesInference(transition=transition), **kw
    ),
    "memory": lambda n, transition=None, control_period=0.01, **kw: MemoryBasedIntentInference(
        ControlLoop(n, control_period), MemoryInference(transition=transition), **kw
    ),
}


def poses(positions: np.ndarray) -> np.ndarray:
    """Flat ``[x, y, z, 1, 0, 0, 0]`` poses of an ``(n, 3)`` array."""
    out = np.zeros((len(positions), 7))
    out[:, :3] = positions
    out[:, 3] = 1.0
    return out.ravel()


def fix_inputs(system, context, u_h, ee, goals, u_a=None) -> None:  # noqa: ANN001
    system.GetInputPort("u_h").FixValue(context, np.asarray(u_h, dtype=float))
    system.GetInputPort("ee_pose").FixValue(context, poses(np.asarray(ee, dtype=float)[None])[:7])
    system.GetInputPort("goal_poses").FixValue(context, poses(np.asarray(goals, dtype=float)))
    if u_a is not None:
        system.GetInputPort("u_a").FixValue(context, np.asarray(u_a, dtype=float).ravel())


def outputs(system, context) -> tuple[np.ndarray, int, float]:  # noqa: ANN001
    b = system.GetOutputPort("belief").Eval(context)
    return (
        b,
        int(system.GetOutputPort("g_star").Eval(context)[0]),
        float(system.GetOutputPort("p_star").Eval(context)[0]),
    )


@pytest.mark.parametrize("kind", list(SYSTEMS))
def test_ports_and_no_direct_feedthrough(kind: str) -> None:
    system = SYSTEMS[kind](3)
    sizes = {"u_h": 6, "ee_pose": 7, "goal_poses": 21, "u_a": 18}
    for name, size in sizes.items():
        assert system.GetInputPort(name).size() == size
    for name, size in {"belief": 3, "g_star": 1, "p_star": 1}.items():
        assert system.GetOutputPort(name).size() == size
    assert not system.HasAnyDirectFeedthrough()


@pytest.mark.parametrize("kind", list(SYSTEMS))
def test_initial_belief_is_the_rest_state(kind: str) -> None:
    rest = np.array([0.2, 0.5, 0.3])
    system = SYSTEMS[kind](3, rest=rest)
    simulator = Simulator(system)
    fix_inputs(system, simulator.get_mutable_context(), np.zeros(6), np.zeros(3), np.eye(3))
    simulator.Initialize()
    b, g, p = outputs(system, simulator.get_context())
    np.testing.assert_allclose(b, rest)
    assert (g, p) == (1, pytest.approx(0.5))


def test_dft_derivative_is_the_core_flow() -> None:
    rng = np.random.default_rng(0)
    n = 4
    P = np.eye(n) + rng.uniform(0, 0.01, (n, n))
    P /= P.sum(axis=1, keepdims=True)
    params = DFTParams(transition=P, agreement=True, proximity=True, R=0.5)
    system = FieldTheoreticIntentInference(ControlLoop(n), params)
    context = system.CreateDefaultContext()
    goals, x, u, u_a = (
        rng.uniform(-0.5, 0.5, (n, 3)),
        rng.uniform(-0.5, 0.5, 3),
        rng.normal(size=6),
        rng.normal(size=(n, 6)),
    )
    fix_inputs(system, context, u, x, goals, u_a)
    p = rng.dirichlet(np.ones(n))
    context.SetContinuousState(p)
    derivatives = system.EvalTimeDerivatives(context).CopyToVector()
    # The core flow with the system's positivity guard: no entry falls faster than p / period.
    flow = dft_mass_conserving_rhs(p, u, x, goals, params, u_a, guard_time=system.control_period)
    np.testing.assert_allclose(derivatives, flow, rtol=1e-12)
    assert abs(derivatives.sum()) < 1e-12
    assert np.all(p + system.control_period * derivatives >= -1e-15)  # a period's Euler step stays >= 0


def _advance_one_period(system, u, x0, x1, goals, P, rest=None):  # noqa: ANN001, ANN202
    """Initialise at x0, then move the end effector to x1 and run one periodic update."""
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    fix_inputs(system, context, u, x0, goals)
    simulator.Initialize()
    simulator.AdvanceTo(0.5 * system.control_period)  # the periodic update at t = 0 sees x0
    fix_inputs(system, context, u, x1, goals)
    simulator.AdvanceTo(1.5 * system.control_period)  # the one at t = period sees x1
    return outputs(system, simulator.get_context())[0]


def test_discrete_updates_are_the_core_steps() -> None:
    rng = np.random.default_rng(1)
    n = 3
    P = np.eye(n) * 0.97 + 0.01
    goals, x0, u = rng.uniform(-0.5, 0.5, (n, 3)), rng.uniform(-0.5, 0.5, 3), rng.normal(size=6)
    x1 = x0 + 0.01
    uniform = np.full(n, 1 / n)
    # Bayes: the update at t = 0 uses x0, the one at t = period x1.
    got = _advance_one_period(SYSTEMS["bayes"](n, transition=P), u, x0, x1, goals, P)
    want = bayes_step(bayes_step(uniform, u, x0, goals, P), u, x1, goals, P)
    np.testing.assert_allclose(got, want, rtol=1e-12)
    # Memory: at t = 0 no move from the start; at t = period the move x0 -> x1.
    got = _advance_one_period(SYSTEMS["memory"](n, transition=P), u, x0, x1, goals, P)
    p, cost = memory_step(uniform, 0.0, x0, x0, x0, goals, P)
    want, _ = memory_step(p, cost, x0, x1, x0, goals, P)
    np.testing.assert_allclose(got, want, rtol=1e-12)


@pytest.mark.parametrize("kind", list(SYSTEMS))
def test_goal_change_resets_the_belief(kind: str) -> None:
    goals = np.array([[0.5, 0.0, 0.0], [0.0, 0.5, 0.0]])
    system = SYSTEMS[kind](2, control_period=0.01)
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    fix_inputs(system, context, [1, 0, 0, 0, 0, 0], [0.0, 0, 0], goals)
    simulator.Initialize()
    for k in range(1, 20):  # move toward goal 0 so the memory-based method has a path too
        fix_inputs(system, context, [1, 0, 0, 0, 0, 0], [0.01 * k, 0, 0], goals)
        simulator.AdvanceTo(0.01 * k)
    b, g, _ = outputs(system, context)
    assert g == 0 and b[0] > 0.6
    new_goals = goals[::-1] + 0.1  # the next stage of a multi-step task
    fix_inputs(system, context, [1, 0, 0, 0, 0, 0], [0.19, 0, 0], new_goals)
    simulator.AdvanceTo(0.19 + 1e-7)  # just past the periodic update at t = 0.19
    np.testing.assert_allclose(outputs(system, context)[0], [0.5, 0.5], atol=1e-12 if kind != "dft" else 1e-4)


@settings(max_examples=12, deadline=None)
@given(
    kind=st.sampled_from(list(SYSTEMS)),
    n=st.integers(1, 5),
    seed=st.integers(0, 2**31),
    special=st.sampled_from([None, np.nan, np.inf, 0.0, 1e200]),
    on_top=st.booleans(),
)
def test_belief_stays_on_the_simplex_in_simulation(kind, n, seed, special, on_top) -> None:  # noqa: ANN001
    rng = np.random.default_rng(seed)
    goals = rng.uniform(-0.5, 0.5, (n, 3))
    x = rng.uniform(-0.5, 0.5, 3)
    if on_top:
        goals[0] = x
    P = np.eye(n) + rng.uniform(0, 0.01, (n, n))
    P /= P.sum(axis=1, keepdims=True)
    if kind == "dft":
        params = {"transition": P, "agreement": True, "proximity": True, "lam": 500.0}
        system = SYSTEMS[kind](n, params=params, control_period=0.02)
    else:
        system = SYSTEMS[kind](n, transition=P, control_period=0.02)
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    u = rng.normal(size=6) * 3
    if special is not None:
        u[rng.integers(6)] = special
    fix_inputs(system, context, u, x, goals, rng.normal(size=(n, 6)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        simulator.Initialize()
        for t in np.linspace(0.013, 0.2, 6):
            x = x + rng.normal(size=3) * 0.02
            fix_inputs(system, context, u, x, goals, rng.normal(size=(n, 6)))
            simulator.AdvanceTo(t)
            b, g, p = outputs(system, context)
            assert np.all(np.isfinite(b)) and np.all(b >= 0)
            assert abs(b.sum() - 1.0) < 1e-9
            assert b[g] == p == b.max()


@pytest.mark.parametrize("kind", list(SYSTEMS))
def test_non_finite_input_is_sanitised_and_counted(kind: str) -> None:
    system = SYSTEMS[kind](2)
    count = system.GetOutputPort("sanitized_input_count")
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    u_h, ee = [0.1, 0, 0, 0, 0, 0], np.zeros(3)
    if kind == "memory":  # it reads the end-effector path, never u_h
        ee = np.array([np.nan, 0.0, 0.0])
    else:
        u_h = [np.nan, 0, 0, 0, 0, np.inf]
    fix_inputs(system, context, u_h, ee, np.eye(2, 3), np.zeros((2, 6)))
    assert count.Eval(context)[0] == 0
    with pytest.warns(RuntimeWarning, match="non-finite") as record:
        simulator.Initialize()
        simulator.AdvanceTo(0.045)  # ticks at 0, 0.01, ..., 0.04
    assert len(record) == 1  # at most once per second of simulated time
    assert count.Eval(context)[0] == 5
    b, g, p = outputs(system, context)
    assert np.all(np.isfinite(b)) and np.all(b >= 0) and abs(b.sum() - 1.0) < 1e-12
    np.testing.assert_allclose(b, [0.5, 0.5], atol=1e-12)  # read as no command / no move
    # The count lives in the context: a new one starts at zero, and warns again.
    fresh = Simulator(system)
    fix_inputs(system, fresh.get_mutable_context(), u_h, ee, np.eye(2, 3), np.zeros((2, 6)))
    assert count.Eval(fresh.get_context())[0] == 0
    with pytest.warns(RuntimeWarning, match="non-finite"):
        fresh.AdvanceTo(0.005)
    assert count.Eval(fresh.get_context())[0] == 1


@pytest.mark.parametrize(
    "kind, core", [("dft", "dft_drive"), ("bayes", "bayes_step"), ("memory", "memory_step")]
)
@pytest.mark.parametrize("error", [ValueError("x_g: expected shape (n, 3)"), RuntimeError("bug")])
def test_errors_of_the_core_propagate(
    monkeypatch: pytest.MonkeyPatch, kind: str, core: str, error: Exception
) -> None:
    from drake_disamb.systems import inference as module

    def broken(*args: object) -> None:
        raise error

    system = SYSTEMS[kind](2)
    simulator = Simulator(system)
    fix_inputs(system, simulator.get_mutable_context(), [0.1, 0, 0, 0, 0, 0], np.zeros(3), np.eye(2, 3))
    simulator.Initialize()
    monkeypatch.setattr(module, core, broken)
    with pytest.raises(type(error), match=re.escape(str(error))):
        simulator.AdvanceTo(0.025)


def test_bad_constructor_arguments() -> None:
    # The configs' own checks; the sizes are the resolved scenario's (tests/test_bounds.py), asserted.
    with pytest.raises(ValueError, match="rest"):
        FieldTheoreticIntentInference(ControlLoop(2), rest=[0.2, 0.2])
    with pytest.raises(ValueError, match="sigma"):
        RecursiveBayesIntentInference(ControlLoop(2), BayesInference(sigma=-1.0))
    with pytest.raises(AssertionError):
        MemoryBasedIntentInference(ControlLoop(3), MemoryInference(transition=np.eye(2)))
    with pytest.raises(AssertionError):
        FieldTheoreticIntentInference(ControlLoop(3), DFTParams(transition=np.eye(2)))


def test_simulated_published_trial_agrees_with_the_euler_replay() -> None:
    """Trial 1 played through the continuous-state system vs the core's Euler replay."""
    path = DATA / "trajectory_1.mat"
    if not path.is_file():
        pytest.skip(f"published trajectories not found at {DATA} (the shared data folder beside the repo)")
    tr = load_trial_mat(path)
    L, n, dt = tr.n_steps, tr.n_goals, tr.dt
    reference = replay_trials([tr], methods=("dft",))["dft"][0]

    builder = DiagramBuilder()
    params = authors_dft_params(transition=tr.transition, euler_equivalent_step=dt)
    system = builder.AddSystem(FieldTheoreticIntentInference(ControlLoop(n, dt), params))
    times = np.arange(L + 1) * dt
    u = np.zeros((6, L + 1))
    u[:3, :L] = tr.u_h.T  # command j holds over [j dt, (j + 1) dt)
    pose = np.zeros((7, L + 1))
    pose[:3] = tr.traj.T
    pose[3] = 1.0
    u_src = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(times, u)))
    pose_src = builder.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(times, pose)))
    goal_src = builder.AddSystem(ConstantVectorSource(poses(tr.goals)))
    builder.Connect(u_src.get_output_port(), system.GetInputPort("u_h"))
    builder.Connect(pose_src.get_output_port(), system.GetInputPort("ee_pose"))
    builder.Connect(goal_src.get_output_port(), system.GetInputPort("goal_poses"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    ResetIntegratorFromFlags(simulator, "runge_kutta3", dt)
    context = system.GetMyContextFromRoot(simulator.get_mutable_context())
    simulator.Initialize()
    beliefs = np.empty((L + 1, n))
    beliefs[0] = system.GetOutputPort("belief").Eval(context)
    for j in range(1, L + 1):
        simulator.AdvanceTo(j * dt)
        beliefs[j] = system.GetOutputPort("belief").Eval(context)
    np.testing.assert_allclose(beliefs.sum(axis=1), 1.0, atol=1e-12)
    agreement = np.mean(np.argmax(beliefs, axis=1) == np.argmax(reference, axis=1))
    assert agreement >= 0.99
    assert np.abs(beliefs - reference).max() < 0.01


@pytest.mark.parametrize("kind", list(SYSTEMS))
def test_paused_input_holds_the_belief_and_releasing_it_resumes(kind: str) -> None:
    """``paused`` above 0.5 (the study's system while it computes a request): the belief stays where
    it is whatever the command and the motion; below it, the method updates again; unconnected:
    never held."""
    n = 3
    goals = np.array([[0.3, 0.0, 0.1], [-0.3, 0.0, 0.1], [0.0, 0.3, 0.1]])
    u = np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.0])  # toward goal 0
    no_u_a = np.zeros((n, 6))
    system = SYSTEMS[kind](n)
    assert system.GetInputPort("paused").size() == 1
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    fix_inputs(system, context, u, np.zeros(3), goals, no_u_a)
    system.GetInputPort("paused").FixValue(context, [0.0])
    simulator.Initialize()
    fix_inputs(system, context, u, [0.02, 0.0, 0.0], goals, no_u_a)  # it moved toward goal 0
    simulator.AdvanceTo(0.035)
    moving = outputs(system, context)[0].copy()
    assert moving[0] > moving[1] + 1e-9
    system.GetInputPort("paused").FixValue(context, [1.0])
    fix_inputs(system, context, -u, [-0.05, 0.0, 0.0], goals, no_u_a)  # now toward goal 1: held
    simulator.AdvanceTo(0.5)
    np.testing.assert_array_equal(outputs(system, context)[0], moving)
    system.GetInputPort("paused").FixValue(context, [0.0])
    simulator.AdvanceTo(0.6)
    assert outputs(system, context)[0][1] > moving[1] + 1e-9
