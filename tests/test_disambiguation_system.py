"""DisambiguationSystem: in isolation with fixed inputs, and wired to the head-array interface."""

from __future__ import annotations

import re

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from drake_disamb.core.disambiguation import DisambiguationResult, disambiguate, preset
from drake_disamb.systems.disambiguation import DisambiguationSystem, LastResult

HEAD_ARRAY_ARM_MODES = [[0], [1], [2], [3], [4], [5]]
IDENTITY = [1.0, 0.0, 0.0, 0.0]
# Two goals that differ only along y: the answer is the vy mode (index 1).
GOAL_POSES = np.array([[0.2, -0.25, 0.1, *IDENTITY], [0.2, 0.25, 0.1, *IDENTITY]])
EE_POSE = np.array([0.0, 0.0, 0.1, *IDENTITY])


def _fixed_context(system: DisambiguationSystem, belief, current_mode: float = 0.0, count: float = 0.0):  # type: ignore[no-untyped-def]
    context = system.CreateDefaultContext()
    system.GetInputPort("belief").FixValue(context, np.asarray(belief, dtype=float))
    system.GetInputPort("ee_pose").FixValue(context, EE_POSE)
    system.GetInputPort("goal_poses").FixValue(context, GOAL_POSES.ravel())
    system.GetInputPort("current_mode").FixValue(context, [current_mode])
    system.GetInputPort("request_count").FixValue(context, [count])
    return context


def test_ports_and_feedthrough() -> None:
    system = DisambiguationSystem(2, HEAD_ARRAY_ARM_MODES)
    sizes = {system.get_input_port(i).get_name(): system.get_input_port(i).size() for i in range(5)}
    assert sizes == {"belief": 2, "ee_pose": 7, "goal_poses": 14, "current_mode": 1, "request_count": 1}
    mode_port = system.GetOutputPort("disambiguation_mode")
    assert mode_port.size() == 1
    system.GetOutputPort("last_result")  # exists (abstract)
    out = mode_port.get_index()
    for name, expected in [("belief", True), ("ee_pose", True), ("goal_poses", True), ("current_mode", True),
                           ("request_count", False)]:  # fmt: skip
        assert system.HasDirectFeedthrough(system.GetInputPort(name).get_index(), out) is expected, name
    assert not system.HasDirectFeedthrough(
        system.GetInputPort("belief").get_index(), system.GetOutputPort("last_result").get_index()
    )


def test_mode_output_matches_core() -> None:
    system = DisambiguationSystem(2, HEAD_ARRAY_ARM_MODES, preset("mico"))
    context = _fixed_context(system, [0.5, 0.5], current_mode=0)
    assert system.GetOutputPort("disambiguation_mode").Eval(context)[0] == 1.0
    # Already in the vy mode: kept (-1).
    context = _fixed_context(system, [0.5, 0.5], current_mode=1)
    assert system.GetOutputPort("disambiguation_mode").Eval(context)[0] == -1.0
    # Same as the core on a random scene, with a non-identity end-effector orientation.
    rng = np.random.default_rng(0)
    goals = np.hstack([rng.uniform(-0.4, 0.4, (3, 3)), rng.normal(size=(3, 4))])
    goals[:, 3:] /= np.linalg.norm(goals[:, 3:], axis=1, keepdims=True)
    pose = np.array([0.0, -0.3, 0.3, 0.9, 0.1, -0.2, 0.1])
    pose[3:] /= np.linalg.norm(pose[3:])
    system3 = DisambiguationSystem(3, HEAD_ARRAY_ARM_MODES)
    context = system3.CreateDefaultContext()
    system3.GetInputPort("belief").FixValue(context, [0.2, 0.5, 0.3])
    system3.GetInputPort("ee_pose").FixValue(context, pose)
    system3.GetInputPort("goal_poses").FixValue(context, goals.ravel())
    system3.GetInputPort("current_mode").FixValue(context, [6.0])  # the gripper mode
    system3.GetInputPort("request_count").FixValue(context, [0.0])
    core = disambiguate([0.2, 0.5, 0.3], pose[:3], goals[:, :3], HEAD_ARRAY_ARM_MODES, orientation=pose[3:],
                        goal_orientations=goals[:, 3:], current_mode=6)  # fmt: skip
    expected = -1.0 if core.mode is None else float(core.mode)
    assert system3.GetOutputPort("disambiguation_mode").Eval(context)[0] == expected


def test_last_result_updates_when_request_count_grows() -> None:
    system = DisambiguationSystem(2, HEAD_ARRAY_ARM_MODES, control_period=0.01)
    context = _fixed_context(system, [0.5, 0.5], current_mode=0, count=0)
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.035)
    assert system.GetOutputPort("last_result").Eval(context) == LastResult(result=None, served=False)
    assert system.get_last_result(context) is None
    # The interface serves a request at the tick t = 0.04 (with belief [0.5, 0.5] and mode 0): its
    # update, which Drake runs before this system's discrete one, counts it and switches the mode.
    # The logged result must be the one served: from mode 0, not from the mode switched to.
    system.GetInputPort("request_count").FixValue(context, [1.0])
    system.GetInputPort("current_mode").FixValue(context, [1.0])
    simulator.AdvanceTo(0.041)
    last = system.GetOutputPort("last_result").Eval(context)
    assert isinstance(last, LastResult) and last.served
    result = last.result
    assert isinstance(result, DisambiguationResult) and system.get_last_result(context) is result
    served = disambiguate([0.5, 0.5], EE_POSE[:3], GOAL_POSES[:, :3], HEAD_ARRAY_ARM_MODES, current_mode=0)
    assert result.mode == served.mode == 1 and result.current_mode == 0
    np.testing.assert_array_equal(result.mode_scores, served.mode_scores)
    # No new request: the result stays, even though the inputs change.
    system.GetInputPort("belief").FixValue(context, [0.3, 0.7])
    system.GetInputPort("current_mode").FixValue(context, [3.0])
    simulator.AdvanceTo(0.085)
    later = system.get_last_result(context)
    assert later.mode == 1
    np.testing.assert_array_equal(later.mode_scores, served.mode_scores)


def _bad_goals(index: tuple[int, int], value: float) -> np.ndarray:
    goals = GOAL_POSES.copy()
    goals[index] = value
    return goals.ravel()


UNUSABLE = [
    ("belief", [np.nan, 0.5]),
    ("belief", [np.inf, 0.5]),
    ("belief", [0.5, -0.2]),
    ("belief", [0.0, 0.0]),
    ("current_mode", [np.nan]),
    ("ee_pose", [np.nan, 0.0, 0.1, *IDENTITY]),
    ("ee_pose", [0.0, 0.0, 0.1, 1e200, 0.0, 0.0, 0.0]),  # the quaternion's norm overflows
    ("goal_poses", _bad_goals((0, 3), 0.0)),  # zero quaternion (with the other entries 0)
    ("goal_poses", _bad_goals((1, 0), -np.inf)),
]


@pytest.mark.parametrize("port, value", UNUSABLE)
def test_unusable_inputs_keep_the_mode_and_are_counted(port: str, value: list[float]) -> None:
    system = DisambiguationSystem(2, HEAD_ARRAY_ARM_MODES, control_period=0.01)
    context = _fixed_context(system, [0.5, 0.5])
    system.GetInputPort(port).FixValue(context, np.asarray(value, dtype=float))
    assert system.GetOutputPort("disambiguation_mode").Eval(context)[0] == -1.0  # no error, no warning
    count = system.GetOutputPort("sanitized_input_count")
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.015)
    assert count.Eval(context)[0] == 0  # nothing is counted while no request is served
    system.GetInputPort("request_count").FixValue(context, [1.0])  # the interface served one at 0.01
    with pytest.warns(RuntimeWarning, match="request ignored, the mode is kept"):
        simulator.AdvanceTo(0.025)
    assert count.Eval(context)[0] == 1
    assert system.GetOutputPort("last_result").Eval(context) == LastResult(result=None, served=True)
    system.GetInputPort("request_count").FixValue(context, [2.0])
    simulator.AdvanceTo(0.035)  # a second one, within a second: counted, not warned again
    assert count.Eval(context)[0] == 2 and system.get_sanitized_input_count(context) == 2
    assert count.Eval(_fixed_context(system, [0.5, 0.5]))[0] == 0  # a new context starts from zero


def test_a_drifted_belief_is_renormalised() -> None:
    system = DisambiguationSystem(2, HEAD_ARRAY_ARM_MODES)
    for belief in ([0.7, 0.7], [1e308, 1e308], [1e-300, 1e-300]):  # the sum of the second overflows
        context = _fixed_context(system, belief)
        assert system.GetOutputPort("disambiguation_mode").Eval(context)[0] == 1.0


@pytest.mark.parametrize("error", [ValueError("goal_positions: expected shape (n, 3)"), RuntimeError("bug")])
def test_other_errors_propagate(monkeypatch: pytest.MonkeyPatch, error: Exception) -> None:

    def broken(*args: object, **kwargs: object) -> None:
        raise error

    system = DisambiguationSystem(2, HEAD_ARRAY_ARM_MODES, control_period=0.01)
    context = _fixed_context(system, [0.5, 0.5])
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.015)
    monkeypatch.setattr(system.method, "select", broken)
    with pytest.raises(type(error), match=re.escape(str(error))):
        system.GetOutputPort("disambiguation_mode").Eval(context)
    system.GetInputPort("request_count").FixValue(context, [1.0])
    simulator.AdvanceTo(0.025)  # the served request is stored; solving it fails on demand
    with pytest.raises(type(error), match=re.escape(str(error))):
        system.GetOutputPort("last_result").Eval(context)
    assert system.GetOutputPort("sanitized_input_count").Eval(context)[0] == 0


def test_constructor_validation() -> None:
    with pytest.raises(ValueError, match="n_goals"):
        DisambiguationSystem(0, HEAD_ARRAY_ARM_MODES)
    with pytest.raises(ValueError, match=r"modes\[0\]"):
        DisambiguationSystem(2, [[9]])
    with pytest.raises(ValueError, match="control_period"):
        DisambiguationSystem(2, HEAD_ARRAY_ARM_MODES, control_period=0.0)
    # The constructor runs one request (it loads the compiled kernels before any simulation), so
    # a configuration that does not fit the goal count fails when the diagram is built.
    with pytest.raises(ValueError, match="transition: expected a 3x3 matrix"):
        DisambiguationSystem(3, HEAD_ARRAY_ARM_MODES, preset("mico", transition=np.eye(2)))


def test_interface_switches_mode_in_the_request_period() -> None:
    from drake_disamb.systems.interfaces import make_interface

    builder = DiagramBuilder()
    interface = builder.AddSystem(make_interface("head_array", initial_mode=0))
    disamb = builder.AddSystem(DisambiguationSystem(2, interface.arm_modes, control_period=0.01))
    for name, value in (("belief", [0.5, 0.5]), ("ee_pose", EE_POSE), ("goal_poses", GOAL_POSES.ravel())):
        source = builder.AddSystem(ConstantVectorSource(np.asarray(value, dtype=float)))
        builder.Connect(source.get_output_port(), disamb.GetInputPort(name))
    builder.Connect(interface.GetOutputPort("mode"), disamb.GetInputPort("current_mode"))
    builder.Connect(interface.GetOutputPort("request_count"), disamb.GetInputPort("request_count"))
    builder.Connect(
        disamb.GetOutputPort("disambiguation_mode"), interface.GetInputPort("disambiguation_mode")
    )
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
    assert interface.GetOutputPort("mode").Eval(icontext)[0] == 1.0  # switched in that same period
    assert interface.GetOutputPort("request_count").Eval(icontext)[0] == 1.0
    result = disamb.get_last_result(dcontext)  # logged in that same period
    assert result.mode == 1 and result.current_mode == 0
