"""TaskManager: goal-set publication, hold-to-succeed, stage switching, NaN poses."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from drake_disamb.config import load_scenario, resolve_scenario
from drake_disamb.core.geometry import quat_from_rotvec, quat_multiply
from drake_disamb.systems.task import FixedGoalSet, TaskConfig, TaskManager, pose_errors

STAGE_A = np.array([[0.3, -0.5, 0.1, 1, 0, 0, 0], [-0.3, -0.5, 0.1, 1, 0, 0, 0]], dtype=float)
STAGE_B = np.array([[0.2, -0.2, 0.1, 0, 1, 0, 0], [-0.2, -0.2, 0.1, 0, 1, 0, 0]], dtype=float)


def _fixed(system: TaskManager, ee_pose) -> tuple:
    context = system.CreateDefaultContext()
    system.get_input_port(0).FixValue(context, np.asarray(ee_pose, dtype=float))
    return context


def _advance(system: TaskManager, context, t_end: float) -> None:
    simulator = Simulator(system, context)
    simulator.AdvanceTo(t_end)


def test_ports_and_initial_outputs() -> None:
    tm = TaskManager(TaskConfig([STAGE_A, STAGE_B], hold_times=[0.5, 0.2], control_period=0.01))
    names = [tm.get_output_port(i).get_name() for i in range(tm.num_output_ports())]
    assert names == ["goal_poses", "stage", "done", "reached_goals", "stage_end_times"]
    assert tm.get_input_port(0).get_name() == "ee_pose" and tm.get_input_port(0).size() == 7
    context = _fixed(tm, [0, 0, 0.5, 1, 0, 0, 0])
    np.testing.assert_allclose(tm.GetOutputPort("goal_poses").Eval(context), STAGE_A.ravel())
    assert tm.GetOutputPort("stage").Eval(context)[0] == 0
    assert tm.GetOutputPort("done").Eval(context)[0] == 0
    np.testing.assert_array_equal(tm.GetOutputPort("reached_goals").Eval(context), [-1, -1])
    assert np.all(np.isnan(tm.GetOutputPort("stage_end_times").Eval(context)))


def test_far_pose_never_succeeds() -> None:
    tm = TaskManager(TaskConfig([STAGE_A], hold_times=0.1))
    context = _fixed(tm, [0, 0, 0.5, 1, 0, 0, 0])
    _advance(tm, context, 1.0)
    assert not tm.is_done(context)


def test_hold_then_switch_stage_then_done() -> None:
    tm = TaskManager(
        TaskConfig(
            [STAGE_A, STAGE_B], position_tolerance=0.02, orientation_tolerance=0.15, hold_times=[0.5, 0.2]
        )
    )
    # 1.5 cm off and 0.1 rad rotated: inside both tolerances of goal 1 of stage A.
    q = quat_multiply(quat_from_rotvec([0.0, 0.1, 0.0]), STAGE_A[1, 3:])
    context = _fixed(tm, [*(STAGE_A[1, :3] + [0.015, 0, 0]), *q])
    _advance(tm, context, 0.45)
    assert tm.stage(context) == 0  # not held long enough yet
    _advance(tm, context, 0.55)
    assert tm.stage(context) == 1
    assert tm.reached_goals(context)[0] == 1
    assert tm.stage_end_times(context)[0] == pytest.approx(0.5, abs=0.011)
    np.testing.assert_allclose(tm.GetOutputPort("goal_poses").Eval(context), STAGE_B.ravel())
    # Now hold at goal 0 of stage B.
    tm.get_input_port(0).FixValue(context, STAGE_B[0])
    _advance(tm, context, 1.0)
    assert tm.is_done(context)
    assert tm.GetOutputPort("done").Eval(context)[0] == 1.0
    assert tm.reached_goals(context) == [1, 0]
    _, t1 = tm.stage_end_times(context)
    assert t1 == pytest.approx(0.55 + 0.2, abs=0.011)  # the new pose arrived at t = 0.55
    # The last stage's goals stay published after completion.
    np.testing.assert_allclose(tm.GetOutputPort("goal_poses").Eval(context), STAGE_B.ravel())


def test_orientation_outside_tolerance_blocks_success() -> None:
    tm = TaskManager(TaskConfig([STAGE_A], orientation_tolerance=0.15, hold_times=0.0))
    q = quat_multiply(quat_from_rotvec([0.0, 0.0, 0.2]), STAGE_A[0, 3:])
    context = _fixed(tm, [*STAGE_A[0, :3], *q])
    _advance(tm, context, 0.5)
    assert not tm.is_done(context)


def test_leaving_resets_the_hold_timer() -> None:
    tm = TaskManager(TaskConfig([STAGE_A], hold_times=0.3))
    context = _fixed(tm, STAGE_A[0])
    _advance(tm, context, 0.2)
    tm.get_input_port(0).FixValue(context, [0, 0, 0.5, 1, 0, 0, 0])
    _advance(tm, context, 0.25)
    tm.get_input_port(0).FixValue(context, STAGE_A[0])
    _advance(tm, context, 0.5)
    assert not tm.is_done(context)  # only 0.25 s since it came back
    _advance(tm, context, 0.6)
    assert tm.is_done(context)


def test_nan_pose_never_counts() -> None:
    tm = TaskManager(TaskConfig([STAGE_A], hold_times=0.0))
    context = _fixed(tm, [np.nan] * 7)
    _advance(tm, context, 0.2)
    assert not tm.is_done(context)
    d, a = pose_errors([np.nan] * 7, STAGE_A)
    assert np.all(np.isinf(d)) and np.all(np.isinf(a))


def test_a_resolved_scenario_is_the_task_managers_config() -> None:
    """Resolution gives the task manager its config (its bounds checked there, naming the
    scenario's fields: tests/test_bounds.py); the manager asserts the shapes it relies on."""
    s = load_scenario("pouring")
    task = resolve_scenario(s).task
    assert len(task.stage_goal_poses) == 2
    for k in range(2):
        np.testing.assert_array_equal(task.stage_goal_poses[k], s.stage_goal_poses(k))
    assert task.hold_times == (s.hold_time(0), s.hold_time(1)) and task.control_period == s.control_period
    assert (task.position_tolerance, task.orientation_tolerance) == (0.02, 0.15)
    assert task.release_openings == (None, s.stages[1].release_opening) and task.targets == (None, None)
    tm = TaskManager(task)
    assert tm.n_stages == 2 and tm.n_goals == 2
    with pytest.raises(AssertionError):
        TaskManager(TaskConfig([STAGE_A, STAGE_A[:1]]))  # stages of different sizes
    with pytest.raises(AssertionError):
        TaskManager(TaskConfig([STAGE_A, STAGE_B], hold_times=[0.1]))  # not one per stage


def test_in_a_diagram_with_scenario_goals() -> None:
    s = load_scenario("pouring")
    builder = DiagramBuilder()
    tm = builder.AddSystem(TaskManager(resolve_scenario(s).task))
    src = builder.AddSystem(ConstantVectorSource(s.stage_goal_poses(0)[1]))
    builder.Connect(src.get_output_port(), tm.GetInputPort("ee_pose"))
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(1.2)
    ctx = tm.GetMyContextFromRoot(simulator.get_context())
    assert tm.stage(ctx) == 1 and tm.reached_goals(ctx) == [1, -1]


def test_a_release_stage_completes_once_the_gripper_is_open_at_the_goal() -> None:
    tm = TaskManager(TaskConfig([STAGE_A], hold_times=0.2, release_openings=[0.1]))
    names = [tm.get_input_port(i).get_name() for i in range(tm.num_input_ports())]
    assert names == ["ee_pose", "gripper_opening"]
    context = _fixed(tm, STAGE_A[0])
    tm.GetInputPort("gripper_opening").FixValue(context, [0.08])  # holding the object
    _advance(tm, context, 1.0)
    assert tm.stage(context) == 0  # held at the goal, not let go
    tm.GetInputPort("gripper_opening").FixValue(context, [np.nan])
    _advance(tm, context, 1.5)
    assert tm.stage(context) == 0  # a NaN opening never releases
    tm.GetInputPort("gripper_opening").FixValue(context, [0.1])
    _advance(tm, context, 1.6)
    assert tm.is_done(context) and tm.reached_goals(context) == [0]
    assert tm.stage_end_times(context)[0] == pytest.approx(1.5)  # the first tick that sees it open
    # open, but away from every goal: not done
    tm2 = TaskManager(TaskConfig([STAGE_A], hold_times=0.2, release_openings=[0.1]))
    context = _fixed(tm2, [0, 0, 0.5, 1, 0, 0, 0])
    tm2.GetInputPort("gripper_opening").FixValue(context, [0.12])
    _advance(tm2, context, 1.0)
    assert not tm2.is_done(context)


def test_a_stage_without_release_never_reads_the_opening() -> None:
    tm = TaskManager(TaskConfig([STAGE_A, STAGE_B], hold_times=0.1, release_openings=[None, 0.1]))
    context = _fixed(tm, STAGE_A[1])  # gripper_opening unconnected
    _advance(tm, context, 0.3)
    assert tm.stage(context) == 1


def test_a_named_target_ends_its_stage_only_there() -> None:
    # Stage A names goal 1 (the experimenter's target); stage B ends at any goal.
    tm = TaskManager(TaskConfig([STAGE_A, STAGE_B], hold_times=0.1, targets=[1, None]))
    context = _fixed(tm, STAGE_A[0])  # resting at the other goal of stage A
    _advance(tm, context, 1.0)
    assert tm.stage(context) == 0 and tm.reached_goals(context) == [-1, -1]
    tm.get_input_port(0).FixValue(context, STAGE_A[1])
    _advance(tm, context, 1.2)
    assert tm.stage(context) == 1 and tm.reached_goals(context)[0] == 1
    assert tm.stage_end_times(context)[0] == pytest.approx(1.1, abs=0.011)
    tm.get_input_port(0).FixValue(context, STAGE_B[1])  # not named: any goal of stage B
    _advance(tm, context, 1.5)
    assert tm.is_done(context) and tm.reached_goals(context) == [1, 1]


def test_fixed_goal_set_publishes_its_goals_and_depends_on_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    goals = np.array([[0.3, -0.4, 0.1, 1.0, 0.0, 0.0, 0.0], [-0.2, -0.5, 0.2, 0.0, 1.0, 0.0, 0.0]])
    calls = [0]
    calc = FixedGoalSet._calc

    def counted(*args):  # type: ignore[no-untyped-def]
        calls[0] += 1
        return calc(*args)

    monkeypatch.setattr(FixedGoalSet, "_calc", counted)
    source = FixedGoalSet(goals)
    ctx = source.CreateDefaultContext()
    port = source.GetOutputPort("goal_poses")
    np.testing.assert_array_equal(port.Eval(ctx), goals.ravel())
    ctx.SetTime(3.0)  # time is no prerequisite (Drake's ConstantVectorSource's output has it)
    port.Eval(ctx)
    assert calls[0] == 1
    goals[0, 0] = 9.0  # the system holds a copy
    assert port.Eval(ctx)[0] == pytest.approx(0.3)


@pytest.mark.parametrize(
    ("poses", "message"),
    [(np.zeros((0, 7)), r"shape \(n >= 1, 7\)"), (np.zeros(7), "shape"), ([[np.nan] * 7], "finite")],
)
def test_fixed_goal_set_rejects_bad_poses(poses: object, message: str) -> None:
    with pytest.raises(ValueError, match=f"goal_poses: .*{message}"):
        FixedGoalSet(poses)  # type: ignore[arg-type]
