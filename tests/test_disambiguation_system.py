"""DisambiguationSystem: in isolation with a fixed request, and wired to the head-array interface."""

from __future__ import annotations

import re

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from drake_disamb.core.disambiguation import DisambiguationResult, disambiguate, preset
from drake_disamb.systems.disambiguation import DisambiguationSystem, LastResult, LatchedRequest
from drake_disamb.systems.loop import ControlLoop

HEAD_ARRAY_ARM_MODES = [[0], [1], [2], [3], [4], [5]]
IDENTITY = [1.0, 0.0, 0.0, 0.0]
# Two goals that differ only along y: the answer is the vy mode (index 1).
GOAL_POSES = np.array([[0.2, -0.25, 0.1, *IDENTITY], [0.2, 0.25, 0.1, *IDENTITY]])
EE_POSE = np.array([0.0, 0.0, 0.1, *IDENTITY])


def _request(belief, current_mode: float = 0.0, request_id: float = 1.0, **changes) -> LatchedRequest:  # type: ignore[no-untyped-def]
    values = {"belief": np.asarray(belief, dtype=float), "ee_pose": EE_POSE, "goal_poses": GOAL_POSES.ravel()}
    values.update({name: np.asarray(value, dtype=float) for name, value in changes.items()})
    return LatchedRequest(request_id, values["belief"], values["ee_pose"], values["goal_poses"], current_mode)


def _answer(system: DisambiguationSystem, request: LatchedRequest, context=None):  # type: ignore[no-untyped-def]
    """``(answer, context)`` after one update of ``system`` with ``request`` on its input."""
    context = system.CreateDefaultContext() if context is None else context
    system.GetInputPort("request").FixValue(context, request.to_vector())
    simulator = Simulator(system, context)
    simulator.AdvanceTo(context.get_time() + 0.005)
    return system.GetOutputPort("answer").Eval(context).tolist(), context


def test_ports_and_feedthrough() -> None:
    system = DisambiguationSystem(ControlLoop(2), HEAD_ARRAY_ARM_MODES)
    assert system.num_input_ports() == 1 and system.GetInputPort("request").size() == 9 + 8 * 2
    assert system.GetOutputPort("answer").size() == 2
    system.GetOutputPort("last_result")  # exists (abstract)
    for i in range(system.num_output_ports()):  # every output comes from state
        assert not system.HasDirectFeedthrough(0, i)
    context = system.CreateDefaultContext()
    assert system.GetOutputPort("answer").Eval(context).tolist() == [0.0, -1.0]  # nothing answered yet


def test_latched_request_round_trip() -> None:
    request = _request([0.25, 0.75], current_mode=3.0, request_id=7.0)
    vector = request.to_vector()
    assert vector.shape == (LatchedRequest.size(2),) and vector[0] == 7.0 and vector[-1] == 3.0
    back = LatchedRequest.from_vector(vector, 2)
    np.testing.assert_array_equal(back.to_vector(), vector)
    assert LatchedRequest.none(2).id == 0.0 and np.isnan(LatchedRequest.none(2).belief).all()
    with pytest.raises(ValueError, match=r"request: expected 25 numbers"):
        LatchedRequest.from_vector(vector[:-1], 2)


def test_answer_matches_core() -> None:
    system = DisambiguationSystem(ControlLoop(2), HEAD_ARRAY_ARM_MODES, preset("mico"))
    assert _answer(system, _request([0.5, 0.5], current_mode=0))[0] == [1.0, 1.0]
    # Already in the vy mode: kept (-1).
    assert _answer(system, _request([0.5, 0.5], current_mode=1, request_id=4.0))[0] == [4.0, -1.0]
    # Same as the core on a random scene, with a non-identity end-effector orientation.
    rng = np.random.default_rng(0)
    goals = np.hstack([rng.uniform(-0.4, 0.4, (3, 3)), rng.normal(size=(3, 4))])
    goals[:, 3:] /= np.linalg.norm(goals[:, 3:], axis=1, keepdims=True)
    pose = np.array([0.0, -0.3, 0.3, 0.9, 0.1, -0.2, 0.1])
    pose[3:] /= np.linalg.norm(pose[3:])
    system3 = DisambiguationSystem(ControlLoop(3), HEAD_ARRAY_ARM_MODES)
    request = LatchedRequest(1.0, np.array([0.2, 0.5, 0.3]), pose, goals.ravel(), 6.0)  # the gripper mode
    core = disambiguate([0.2, 0.5, 0.3], pose[:3], goals[:, :3], HEAD_ARRAY_ARM_MODES, orientation=pose[3:],
                        goal_orientations=goals[:, 3:], current_mode=6)  # fmt: skip
    expected = -1.0 if core.mode is None else float(core.mode)
    assert _answer(system3, request)[0] == [1.0, expected]


def test_each_request_is_solved_once_in_the_update(monkeypatch: pytest.MonkeyPatch) -> None:
    """The update solves a request when its id is new, once; its answer and the stored request
    (``last_result``) stay until the next one, whatever else happens."""
    system = DisambiguationSystem(ControlLoop(2, control_period=0.01), HEAD_ARRAY_ARM_MODES)
    calls = [0]
    select = system.method.select

    def counted(request):  # type: ignore[no-untyped-def]
        calls[0] += 1
        return select(request)

    monkeypatch.setattr(system.method, "select", counted)
    context = system.CreateDefaultContext()
    system.GetInputPort("request").FixValue(context, LatchedRequest.none(2).to_vector())
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.035)
    assert calls[0] == 0
    assert system.GetOutputPort("last_result").Eval(context) == LastResult(result=None, served=False)
    assert system.get_last_result(context) is None
    system.GetInputPort("request").FixValue(context, _request([0.5, 0.5], current_mode=0).to_vector())
    simulator.AdvanceTo(0.095)  # six updates see the request: one solves it
    assert calls[0] == 1
    assert system.GetOutputPort("answer").Eval(context).tolist() == [1.0, 1.0]
    last = system.GetOutputPort("last_result").Eval(context)
    assert isinstance(last, LastResult) and last.served
    result = last.result
    assert isinstance(result, DisambiguationResult) and system.get_last_result(context) is result
    served = disambiguate([0.5, 0.5], EE_POSE[:3], GOAL_POSES[:, :3], HEAD_ARRAY_ARM_MODES, current_mode=0)
    assert result.mode == served.mode == 1 and result.current_mode == 0
    np.testing.assert_array_equal(result.mode_scores, served.mode_scores)
    # A new request (a new id): solved once too, and the answer and result follow it.
    system.GetInputPort("request").FixValue(context, _request([0.5, 0.5], 1.0, request_id=2.0).to_vector())
    calls[0] = 0
    simulator.AdvanceTo(0.155)
    assert system.GetOutputPort("answer").Eval(context).tolist() == [2.0, -1.0]
    assert calls[0] == 1
    assert system.get_last_result(context).current_mode == 1


def _bad_goals(index: tuple[int, int], value: float) -> np.ndarray:
    goals = GOAL_POSES.copy()
    goals[index] = value
    return goals.ravel()


UNUSABLE = [
    ("belief", [np.nan, 0.5]),
    ("belief", [np.inf, 0.5]),
    ("belief", [0.5, -0.2]),
    ("belief", [0.0, 0.0]),
    ("current_mode", np.nan),
    ("ee_pose", [np.nan, 0.0, 0.1, *IDENTITY]),
    ("ee_pose", [0.0, 0.0, 0.1, 1e200, 0.0, 0.0, 0.0]),  # the quaternion's norm overflows
    ("goal_poses", _bad_goals((0, 3), 0.0)),  # zero quaternion (with the other entries 0)
    ("goal_poses", _bad_goals((1, 0), -np.inf)),
]


@pytest.mark.parametrize("field, value", UNUSABLE)
def test_unusable_requests_keep_the_mode_and_are_counted(field: str, value: object) -> None:
    system = DisambiguationSystem(ControlLoop(2, control_period=0.01), HEAD_ARRAY_ARM_MODES)
    changes = {"current_mode": value} if field == "current_mode" else {field: value}
    belief = changes.pop("belief", [0.5, 0.5])
    first = _request(belief, **changes)
    context = system.CreateDefaultContext()
    system.GetInputPort("request").FixValue(context, LatchedRequest.none(2).to_vector())
    count = system.GetOutputPort("sanitized_input_count")
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.015)
    assert count.Eval(context)[0] == 0  # nothing is counted while no request comes
    system.GetInputPort("request").FixValue(context, first.to_vector())
    with pytest.warns(RuntimeWarning, match="request ignored, the mode is kept"):
        simulator.AdvanceTo(0.025)
    assert count.Eval(context)[0] == 1
    assert system.GetOutputPort("answer").Eval(context).tolist() == [1.0, -1.0]
    assert system.GetOutputPort("last_result").Eval(context) == LastResult(result=None, served=True)
    second = LatchedRequest(2.0, first.belief, first.ee_pose, first.goal_poses, first.current_mode)
    system.GetInputPort("request").FixValue(context, second.to_vector())
    simulator.AdvanceTo(0.035)  # a second one, within a second: counted, not warned again
    assert count.Eval(context)[0] == 2 and system.get_sanitized_input_count(context) == 2
    assert count.Eval(system.CreateDefaultContext())[0] == 0  # a new context starts from zero


def test_a_drifted_belief_is_renormalised() -> None:
    system = DisambiguationSystem(ControlLoop(2), HEAD_ARRAY_ARM_MODES)
    for belief in ([0.7, 0.7], [1e308, 1e308], [1e-300, 1e-300]):  # the sum of the second overflows
        assert _answer(system, _request(belief))[0] == [1.0, 1.0]


@pytest.mark.parametrize("error", [ValueError("goal_positions: expected shape (n, 3)"), RuntimeError("bug")])
def test_other_errors_propagate(monkeypatch: pytest.MonkeyPatch, error: Exception) -> None:

    def broken(*args: object, **kwargs: object) -> None:
        raise error

    system = DisambiguationSystem(ControlLoop(2, control_period=0.01), HEAD_ARRAY_ARM_MODES)
    context = system.CreateDefaultContext()
    system.GetInputPort("request").FixValue(context, LatchedRequest.none(2).to_vector())
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.015)
    monkeypatch.setattr(system.method, "select", broken)
    system.GetInputPort("request").FixValue(context, _request([0.5, 0.5]).to_vector())
    with pytest.raises(type(error), match=re.escape(str(error))):
        simulator.AdvanceTo(0.025)
    assert system.GetOutputPort("sanitized_input_count").Eval(context)[0] == 0


def test_constructor_validation() -> None:
    with pytest.raises(ValueError, match=r"modes\[0\]"):
        DisambiguationSystem(ControlLoop(2), [[9]])
    with pytest.raises(AssertionError):  # the loop and the config are the resolved scenario's
        DisambiguationSystem(ControlLoop(2), HEAD_ARRAY_ARM_MODES, {"step": 0.1})  # type: ignore[arg-type]
    assert DisambiguationSystem(
        ControlLoop(2, control_period=0.02), HEAD_ARRAY_ARM_MODES
    ).GetUniquePeriodicDiscreteUpdateAttribute().period_sec() == pytest.approx(0.02)
    # The constructor runs one request (it loads the compiled kernels before any simulation), so
    # a configuration that does not fit the goal count fails when the diagram is built.
    with pytest.raises(ValueError, match="transition: expected a 3x3 matrix"):
        DisambiguationSystem(ControlLoop(3), HEAD_ARRAY_ARM_MODES, preset("mico", transition=np.eye(2)))


def test_interface_switches_mode_the_tick_after_the_request() -> None:
    """Wired to the interface: the request latched at the press's tick is answered in that tick
    and the answer applied in the next (no latency), solved from what the press saw."""
    from drake_disamb.interfaces.system import make_interface

    builder = DiagramBuilder()
    interface = builder.AddSystem(make_interface("head_array", n_goals=2, initial_mode=0))
    disamb = builder.AddSystem(DisambiguationSystem(ControlLoop(2, control_period=0.01), interface.arm_modes))
    for name, value in (("belief", [0.5, 0.5]), ("ee_pose", EE_POSE), ("goal_poses", GOAL_POSES.ravel())):
        source = builder.AddSystem(ConstantVectorSource(np.asarray(value, dtype=float)))
        builder.Connect(source.get_output_port(), interface.GetInputPort(name))
    builder.Connect(interface.GetOutputPort("request"), disamb.GetInputPort("request"))
    builder.Connect(disamb.GetOutputPort("answer"), interface.GetInputPort("answer"))
    builder.ExportInput(interface.GetInputPort("raw"), "raw")
    diagram = builder.Build()  # no algebraic loop
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    raw = diagram.get_input_port(0)
    raw.FixValue(context, np.zeros(4))
    simulator.AdvanceTo(0.045)
    icontext = interface.GetMyContextFromRoot(context)
    dcontext = disamb.GetMyContextFromRoot(context)
    assert interface.GetOutputPort("mode").Eval(icontext)[0] == 0.0
    raw.FixValue(context, [0.0, 0.0, 0.0, 1.0])  # press the request button
    simulator.AdvanceTo(0.0501)  # just after the tick at t = 0.05
    assert interface.GetOutputPort("mode").Eval(icontext)[0] == 0.0  # not yet: the answer comes
    assert interface.GetOutputPort("paused").Eval(icontext)[0] == 1.0
    assert interface.GetOutputPort("request_count").Eval(icontext)[0] == 1.0
    latched = LatchedRequest.from_vector(interface.GetOutputPort("request").Eval(icontext), 2)
    assert latched.id == 1.0 and latched.current_mode == 0.0 and latched.belief.tolist() == [0.5, 0.5]
    np.testing.assert_array_equal(latched.ee_pose, EE_POSE)
    np.testing.assert_array_equal(latched.goal_poses, GOAL_POSES.ravel())
    assert disamb.GetOutputPort("answer").Eval(dcontext).tolist() == [1.0, 1.0]  # answered in that tick
    result = disamb.get_last_result(dcontext)
    assert result.mode == 1 and result.current_mode == 0
    simulator.AdvanceTo(0.0601)  # the next tick applies it
    assert interface.GetOutputPort("mode").Eval(icontext)[0] == 1.0
    assert interface.GetOutputPort("paused").Eval(icontext)[0] == 0.0
    events = [(e.kind, round(e.time, 6)) for e in interface.get_event_log(icontext)]
    assert events == [("disambiguation_request", 0.05), ("disambiguation_switch", 0.06)]


def test_the_core_request_is_the_one_the_method_solved() -> None:
    """``core_request`` rebuilds, from a latched request, the request the method was given: its
    result is the answer's and ``last_result``'s; an unusable latched request gives None."""
    system = DisambiguationSystem(ControlLoop(2), HEAD_ARRAY_ARM_MODES)
    latched = _request([0.6, 0.4], current_mode=2.0)
    answer, context = _answer(system, latched)
    request = system.core_request(latched)
    assert (
        request is not None
        and request.current_mode == 2
        and request.modes == tuple(map(tuple, HEAD_ARRAY_ARM_MODES))
    )
    np.testing.assert_allclose(request.belief, [0.6, 0.4])
    again = system.method.select(request)
    assert answer == [1.0, float(again.mode)]
    np.testing.assert_array_equal(again.mode_scores, system.get_last_result(context).mode_scores)
    assert system.core_request(_request([np.nan, 1.0])) is None
