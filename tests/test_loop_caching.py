"""The control loop's systems compute each value once per change of what it depends on.

Each system is driven in isolation with a fixed-input context; a counting wrapper on its Python
calculation shows whether an evaluation recomputed or hit Drake's cache.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from drake_disamb.core.autonomy import PotentialFieldConfig
from drake_disamb.core.inference import DFTParams
from drake_disamb.interfaces import InterfaceConfig, InterfaceEvent
from drake_disamb.interfaces.system import EventLog, make_interface
from drake_disamb.systems.autonomy import PotentialFieldAutonomy
from drake_disamb.systems.blending import SharedControlBlender
from drake_disamb.systems.disambiguation import DisambiguationSystem
from drake_disamb.systems.inference import FieldTheoreticIntentInference
from drake_disamb.systems.loop import ControlLoop

IDENTITY = [1.0, 0.0, 0.0, 0.0]
GOALS = np.array([[0.3, -0.4, 0.1, *IDENTITY], [-0.2, -0.5, 0.2, 0.0, 1.0, 0.0, 0.0]])
EE_POSE = np.array([0.0, -0.35, 0.3, 0.0, 1.0, 0.0, 0.0])


def _count(obj: object, name: str) -> list[int]:
    """Wrap ``obj.name`` (an instance attribute shadowing the method) to count its calls."""
    calls = [0]
    method = getattr(obj, name)

    def counted(*args, **kwargs):  # type: ignore[no-untyped-def]
        calls[0] += 1
        return method(*args, **kwargs)

    setattr(obj, name, counted)
    return calls


def test_blender_computes_one_step_for_all_outputs() -> None:
    blender = SharedControlBlender(ControlLoop(2))
    calls = _count(blender, "_compute")
    ctx = blender.CreateDefaultContext()
    blender.GetInputPort("u_h").FixValue(ctx, [0.1, 0.0, 0.0, 0.0, 0.0, 0.0])
    blender.GetInputPort("belief").FixValue(ctx, [0.9, 0.1])
    blender.GetInputPort("u_a").FixValue(ctx, np.arange(12.0) / 100)
    u = blender.GetOutputPort("u").Eval(ctx).copy()
    alpha = blender.GetOutputPort("alpha").Eval(ctx)[0]
    assert blender.GetOutputPort("g_star").Eval(ctx)[0] == 0.0
    assert calls[0] == 1  # one step serves u, alpha and g_star
    assert alpha == pytest.approx(0.7) and np.all(np.isfinite(u))
    ctx.SetTime(1.0)  # time is no prerequisite
    blender.GetOutputPort("u").Eval(ctx)
    assert calls[0] == 1
    blender.GetInputPort("belief").FixValue(ctx, [0.5, 0.5])  # an input is
    assert blender.GetOutputPort("alpha").Eval(ctx)[0] == 0.0
    assert calls[0] == 2


def _counting(monkeypatch: pytest.MonkeyPatch, module: object, name: str) -> list[int]:
    """Replace ``module.name`` (a function the system calls) by a counting wrapper."""
    calls = [0]
    function = getattr(module, name)

    def counted(*args, **kwargs):  # type: ignore[no-untyped-def]
        calls[0] += 1
        return function(*args, **kwargs)

    monkeypatch.setattr(module, name, counted)
    return calls


def test_autonomy_depends_on_its_inputs_only(monkeypatch: pytest.MonkeyPatch) -> None:
    from drake_disamb.systems import autonomy as module

    calls = _counting(monkeypatch, module, "potential_field_commands_from_poses")
    autonomy = PotentialFieldAutonomy(ControlLoop(2), PotentialFieldConfig())
    ctx = autonomy.CreateDefaultContext()
    autonomy.GetInputPort("ee_pose").FixValue(ctx, EE_POSE)
    autonomy.GetInputPort("goal_poses").FixValue(ctx, GOALS.ravel())
    port = autonomy.GetOutputPort("u_a")
    first = port.Eval(ctx).copy()
    ctx.SetTime(3.0)  # neither time nor anything else but the two inputs is a prerequisite
    np.testing.assert_array_equal(port.Eval(ctx), first)
    assert calls[0] == 1
    moved = EE_POSE.copy()
    moved[0] += 0.05
    autonomy.GetInputPort("ee_pose").FixValue(ctx, moved)
    assert not np.array_equal(port.Eval(ctx), first)
    assert calls[0] == 2


def test_dft_drive_is_computed_once_per_input_change(monkeypatch: pytest.MonkeyPatch) -> None:
    from drake_disamb.systems import inference as module

    calls = _counting(monkeypatch, module, "dft_drive")
    system = FieldTheoreticIntentInference(ControlLoop(2, 0.01), DFTParams(agreement=True))
    ctx = system.CreateDefaultContext()
    system.GetInputPort("u_h").FixValue(ctx, [0.1, 0.0, 0.0, 0.0, 0.0, 0.05])
    system.GetInputPort("ee_pose").FixValue(ctx, EE_POSE)
    system.GetInputPort("goal_poses").FixValue(ctx, GOALS.ravel())
    system.GetInputPort("u_a").FixValue(ctx, np.linspace(-0.1, 0.1, 12))
    derivatives = system.AllocateTimeDerivatives()
    rates = []
    for p in ([0.5, 0.5], [0.7, 0.3]):  # two integrator stages: new time and state, same inputs
        ctx.SetContinuousState(p)
        ctx.SetTime(ctx.get_time() + 0.005)
        system.CalcTimeDerivatives(ctx, derivatives)
        rates.append(derivatives.CopyToVector())
    assert calls[0] == 1
    assert abs(sum(rates[0])) < 1e-12 and not np.allclose(rates[0], rates[1])
    system.GetInputPort("u_h").FixValue(ctx, [0.0, 0.1, 0.0, 0.0, 0.0, 0.0])  # an input changes
    system.CalcTimeDerivatives(ctx, derivatives)
    assert calls[0] == 2


def test_interface_outputs_are_state_and_follow_set_mode() -> None:
    interface = make_interface(InterfaceConfig(kind="head_array", initial_mode=0))
    ctx = interface.CreateDefaultContext()
    interface.GetInputPort("raw").FixValue(ctx, [1.0, 0.0, 0.0, 0.0])  # "left": + along the mode
    interface.GetInputPort("answer").FixValue(ctx, [0.0, -1.0])
    simulator = Simulator(interface, ctx)
    simulator.AdvanceTo(0.005)  # the update at t = 0
    np.testing.assert_allclose(interface.GetOutputPort("u_h").Eval(ctx), [0.1, 0, 0, 0, 0, 0])
    interface.set_mode(ctx, 4)  # wy: the outputs follow at once (they are copies of state)
    np.testing.assert_allclose(interface.GetOutputPort("u_h").Eval(ctx), [0, 0, 0, 0, 0.2, 0])
    assert interface.GetOutputPort("mode").Eval(ctx)[0] == 4.0
    # Periods with the same raw signal leave the state as it was (the update writes only changes).
    before = ctx.get_discrete_state().get_vector(0).CopyToVector()
    simulator.AdvanceTo(0.035)
    np.testing.assert_array_equal(ctx.get_discrete_state().get_vector(0).CopyToVector(), before)
    np.testing.assert_allclose(interface.GetOutputPort("u_h").Eval(ctx), [0, 0, 0, 0, 0.2, 0])


def test_interface_updates_once_per_change_of_its_inputs(monkeypatch: pytest.MonkeyPatch) -> None:
    """An update that changes the state also checks the next one with the same inputs; the updates
    that follow with those inputs compute and write nothing (what the context records, not a memo
    on the system). ``set_mode`` makes the next update compute again."""
    from drake_disamb.interfaces import system as module

    calls = _counting(monkeypatch, module, "interface_update")
    interface = make_interface(InterfaceConfig(kind="head_array", initial_mode=0))
    ctx = interface.CreateDefaultContext()
    raw = interface.GetInputPort("raw")
    raw.FixValue(ctx, [1.0, 0.0, 0.0, 0.0])
    simulator = Simulator(interface, ctx)
    simulator.AdvanceTo(0.005)  # t = 0: the held raw signal changes: the update and its check
    assert calls[0] == 2 and simulator.get_num_unrestricted_updates() == 1
    simulator.AdvanceTo(0.095)  # nine ticks with the same raw signal
    assert calls[0] == 2 and simulator.get_num_unrestricted_updates() == 1
    raw.FixValue(ctx, [0.0, 1.0, 0.0, 0.0])
    simulator.AdvanceTo(0.195)
    assert calls[0] == 4 and simulator.get_num_unrestricted_updates() == 2
    interface.set_mode(ctx, 3)
    simulator.AdvanceTo(0.295)  # one update finds the new state settled and records it
    assert calls[0] == 5 and simulator.get_num_unrestricted_updates() == 3
    np.testing.assert_allclose(interface.GetOutputPort("u_h").Eval(ctx), [0, 0, 0, -0.2, 0, 0])
    # A raw signal whose update does not settle at once (non-finite: counted at every update) is
    # computed at every tick.
    raw.FixValue(ctx, [np.nan, 0.0, 0.0, 0.0])
    with pytest.warns(RuntimeWarning, match="non-finite"):
        simulator.AdvanceTo(0.395)
    assert interface.GetOutputPort("nonfinite_count").Eval(ctx)[0] == 10


def test_event_log_is_shared_by_copies() -> None:
    log = EventLog((InterfaceEvent(0.5, "mode_switch", 0, 1),))
    assert copy.deepcopy(log) is log and copy.copy(log) is log
    assert log == (InterfaceEvent(0.5, "mode_switch", 0, 1),) and isinstance(log, tuple)


def test_disambiguation_state_is_numeric_and_written_once_per_request() -> None:
    from drake_disamb.systems.disambiguation import LatchedRequest

    system = DisambiguationSystem(ControlLoop(2, 0.01), [[0], [1], [2], [3], [4], [5]])
    ctx = system.CreateDefaultContext()
    assert ctx.num_abstract_states() == 0  # nothing to deep-copy at unrestricted updates
    request = system.GetInputPort("request")
    request.FixValue(ctx, LatchedRequest.none(2).to_vector())
    simulator = Simulator(system, ctx)
    simulator.AdvanceTo(0.015)
    assert simulator.get_num_discrete_updates() == 0  # no request: nothing written
    request.FixValue(ctx, LatchedRequest(1.0, np.array([0.5, 0.5]), EE_POSE, GOALS.ravel(), 0.0).to_vector())
    simulator.AdvanceTo(0.055)
    assert simulator.get_num_discrete_updates() == 1  # answered once, then nothing written
    assert system.GetOutputPort("answer").Eval(ctx)[0] == 1.0


def test_dft_belief_is_computed_once_per_tick(monkeypatch: pytest.MonkeyPatch) -> None:
    """Read before the tick's updates (a sampler) and after them (a logger): one calculation."""
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import LogVectorOutput, ZeroOrderHold

    from drake_disamb.systems import inference as module

    builder = DiagramBuilder()
    system = builder.AddSystem(FieldTheoreticIntentInference(ControlLoop(2, 0.01), DFTParams()))
    sampler = builder.AddSystem(ZeroOrderHold(0.01, 2))
    builder.Connect(system.GetOutputPort("belief"), sampler.get_input_port())
    LogVectorOutput(system.GetOutputPort("belief"), builder, 0.01)
    diagram = builder.Build()
    ctx = diagram.CreateDefaultContext()
    sub = system.GetMyMutableContextFromRoot(ctx)
    system.GetInputPort("u_h").FixValue(sub, [0.1, 0.0, 0.0, 0.0, 0.0, 0.0])
    system.GetInputPort("ee_pose").FixValue(sub, EE_POSE)
    system.GetInputPort("goal_poses").FixValue(sub, GOALS.ravel())
    simulator = Simulator(diagram, ctx)
    simulator.AdvanceTo(0.0051)
    calls = _counting(monkeypatch, module, "normalize_belief")
    simulator.AdvanceTo(0.1051)  # ten ticks
    assert calls[0] == 10
    p = sub.get_continuous_state_vector().CopyToVector()
    assert abs(p.sum() - 1.0) <= module.SIMPLEX_TOLERANCE and p[0] > 0.5  # moving towards goal 0


@pytest.mark.parametrize("discrete", [False, True])
def test_belief_outputs_share_one_projection(monkeypatch: pytest.MonkeyPatch, discrete: bool) -> None:
    """``belief``, ``g_star`` and ``p_star`` project the stored belief once per change of it (the
    belief output's cache entry, which the other two read), in every context."""
    from drake_disamb.systems import inference as module

    calls = _counting(monkeypatch, module, "normalize_belief")
    system = (
        module.RecursiveBayesIntentInference(ControlLoop(2))
        if discrete
        else FieldTheoreticIntentInference(ControlLoop(2), DFTParams())
    )
    contexts = [system.CreateDefaultContext() for _ in range(2)]
    for ctx, p in zip(contexts, ([0.6, 0.2], [0.1, 0.3]), strict=True):
        if discrete:
            ctx.SetDiscreteState(0, [*p, *GOALS.ravel()])
        else:
            ctx.SetContinuousState(p)
    for _ in range(2):
        for ctx in contexts:
            out = [system.GetOutputPort(name).Eval(ctx) for name in ("belief", "g_star", "p_star")]
    assert calls[0] == 2  # once per context
    np.testing.assert_allclose(np.concatenate(out), [0.25, 0.75, 1.0, 0.75], rtol=1e-15)


def test_blender_and_inference_keep_nothing_on_the_system() -> None:
    """Their values computed from a context live in that context (cache entries), not on the
    system object, where every context would share them."""
    blender = SharedControlBlender(ControlLoop(2))
    inference = FieldTheoreticIntentInference(ControlLoop(2), DFTParams())

    def attributes(system: object) -> dict[str, int]:  # identities only: no reference kept
        return {name: id(value) for name, value in vars(system).items()}

    before = [attributes(blender), attributes(inference)]
    for p in ([0.9, 0.1], [0.4, 0.6]):
        ctx = blender.CreateDefaultContext()
        blender.GetInputPort("u_h").FixValue(ctx, [0.1, 0.0, 0.0, 0.0, 0.0, 0.0])
        blender.GetInputPort("belief").FixValue(ctx, p)
        blender.GetInputPort("u_a").FixValue(ctx, np.arange(12.0) / 100)
        blender.GetOutputPort("u").Eval(ctx)
        ctx = inference.CreateDefaultContext()
        ctx.SetContinuousState(p)
        inference.GetOutputPort("belief").Eval(ctx)
    assert [attributes(blender), attributes(inference)] == before


def test_dft_projection_writes_only_when_the_belief_left_the_simplex() -> None:
    from pydrake.systems.framework import EventStatus

    system = FieldTheoreticIntentInference(ControlLoop(2, 0.01), DFTParams())
    ctx = system.CreateDefaultContext()
    system.GetInputPort("goal_poses").FixValue(ctx, GOALS.ravel())
    state = ctx.get_mutable_state()
    system.ExecuteInitializationEvents(ctx)
    for p, writes in (([0.3, 0.7], False), ([0.7, 0.4], True), ([1.0 + 1e-3, -1e-3], True)):
        ctx.SetContinuousState(p)
        status = system._periodic_update(ctx, state)
        assert (status.severity() == EventStatus.Severity.kDidNothing) == (not writes)
        out = ctx.get_continuous_state_vector().CopyToVector()
        if writes:
            assert abs(out.sum() - 1.0) < 1e-15 and np.all(out > 0)
        else:
            np.testing.assert_array_equal(out, p)


def _count_methods(monkeypatch: pytest.MonkeyPatch, **methods: tuple[type, str]) -> dict[str, int]:
    """Wrap each ``(class, method name)`` of ``methods`` to count its calls under its key."""
    counts = dict.fromkeys(methods, 0)

    def wrap(key: str, cls: type, name: str) -> None:
        method = getattr(cls, name)

        def counted(self, *args):  # type: ignore[no-untyped-def]
            counts[key] += 1
            return method(self, *args)

        monkeypatch.setattr(cls, name, counted)

    for key, (cls, name) in methods.items():
        wrap(key, cls, name)
    return counts


def test_full_loop_blends_and_projects_about_once_per_tick(monkeypatch: pytest.MonkeyPatch) -> None:
    """In the whole reaching diagram (station, loggers and all), a tick at which no state changes
    but the arm's and the belief's must not recompute the blending step or the belief. Twice per
    tick is what an unrestricted update that writes at every tick (a sampled-port plant, a
    snapshot kept in state, a projection of a belief that Euler pushed below zero) causes."""
    import dataclasses

    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.systems import blending, inference
    from drake_disamb.trial import run_trial

    counts = _count_methods(
        monkeypatch,
        step=(blending.SharedControlBlender, "_calc_step"),
        belief=(inference.FieldTheoreticIntentInference, "_calc_belief"),
    )
    scenario = dataclasses.replace(load_scenario("reaching"), duration=3.0)
    result = run_trial(build_shared_control_diagram(scenario), progress=False, stop_at_success=False)
    ticks = round(result.time / scenario.control_period)
    assert counts["step"] <= 1.15 * ticks and counts["belief"] <= 1.15 * ticks, (counts, ticks)


def test_belief_over_the_task_computes_its_drive_once_per_tick(monkeypatch: pytest.MonkeyPatch) -> None:
    """The pouring task with one belief over all its goals (``inference.goal_set: task``, the
    study system's): the goal set is a fixed source whose output depends on nothing, so the belief's
    drive and the autonomy's commands are computed once per tick (with Drake's ConstantVectorSource,
    whose output depends on time, they were computed twice)."""
    import dataclasses

    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.systems import autonomy, inference
    from drake_disamb.trial import run_trial

    counts = _count_methods(
        monkeypatch,
        drive=(inference.FieldTheoreticIntentInference, "_calc_drive"),
        u_a=(autonomy.PotentialFieldAutonomy, "_calc_u_a"),
    )
    scenario = load_scenario("pouring")
    scenario = dataclasses.replace(
        scenario, duration=3.0, inference=dataclasses.replace(scenario.inference, goal_set="task")
    )
    assert scenario.n_stages > 1
    result = run_trial(build_shared_control_diagram(scenario), progress=False, stop_at_success=False)
    ticks = round(result.time / scenario.control_period)
    assert counts["drive"] <= 1.15 * ticks and counts["u_a"] <= 1.15 * ticks, (counts, ticks)


def test_station_at_rest_writes_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """With no command the controllers' and the station's updates return before writing (most ticks
    of a trial are so) and the set points stay where they are; a command is still followed at once."""
    from pydrake.systems.framework import EventStatus

    from drake_disamb.controller import DifferentialIKIntegrator, GripperController, build_controlled_station
    from drake_disamb.station import JointVelocityIntegrator, build_station

    writes = dict.fromkeys(("ik", "gripper", "station"), 0)

    def wrap(key: str, cls: type) -> None:
        update = cls._update

        def counted(self, context, discrete_state):  # type: ignore[no-untyped-def]
            status = update(self, context, discrete_state)
            writes[key] += status.severity() != EventStatus.Severity.kDidNothing
            return status

        monkeypatch.setattr(cls, "_update", counted)

    for key, cls in (
        ("ik", DifferentialIKIntegrator),
        ("gripper", GripperController),
        ("station", JointVelocityIntegrator),
    ):
        wrap(key, cls)
    diagram = build_controlled_station(build_station()).diagram
    ctx = diagram.CreateDefaultContext()
    command = diagram.GetInputPort("ee_velocity_command")
    command.FixValue(ctx, np.zeros(6))
    gripper = diagram.GetInputPort("gripper_command")
    gripper.FixValue(ctx, [0.0])
    simulator = Simulator(diagram, ctx)
    simulator.Initialize()
    opening = diagram.GetOutputPort("gripper_opening").Eval(ctx)[0]
    simulator.AdvanceTo(1.0)  # 100 ticks
    assert max(writes.values()) <= 2, writes
    assert diagram.GetOutputPort("gripper_opening").Eval(ctx)[0] == pytest.approx(opening, abs=1e-4)
    before = diagram.GetOutputPort("ee_pose").Eval(ctx).copy()
    command.FixValue(ctx, [0.05, 0.0, 0.0, 0.0, 0.0, 0.0])
    gripper.FixValue(ctx, [0.02])
    simulator.AdvanceTo(1.5)
    # (the station from the next tick on: it integrates what the controllers output at the last one)
    assert writes["ik"] >= 50 and writes["station"] >= 49 and writes["gripper"] >= 1, writes
    assert diagram.GetOutputPort("ee_pose").Eval(ctx)[0] > before[0] + 0.01
    assert diagram.GetOutputPort("gripper_opening").Eval(ctx)[0] > opening + 0.005
