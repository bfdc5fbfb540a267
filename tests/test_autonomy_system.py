"""PotentialFieldAutonomy system in isolation."""

from __future__ import annotations

import re

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from drake_disamb.core.autonomy import PotentialFieldConfig, potential_field_commands
from drake_disamb.core.geometry import quat_from_rotvec
from drake_disamb.systems.autonomy import PotentialFieldAutonomy
from drake_disamb.systems.loop import ControlLoop

IDENTITY = [1.0, 0.0, 0.0, 0.0]


def _context(system, ee_pose, goal_poses):
    ctx = system.CreateDefaultContext()
    system.GetInputPort("ee_pose").FixValue(ctx, np.asarray(ee_pose, dtype=float))
    system.GetInputPort("goal_poses").FixValue(ctx, np.asarray(goal_poses, dtype=float).reshape(-1))
    return ctx


def test_shape_and_direction_toward_each_goal() -> None:
    goals = np.array(
        [
            [0.5, 0.0, 0.3, *IDENTITY],
            [0.0, -0.5, 0.3, *IDENTITY],
            [0.0, 0.0, 0.0, *quat_from_rotvec([0.0, 0.0, 0.3])],
        ]
    )
    system = PotentialFieldAutonomy(ControlLoop(3))
    ctx = _context(system, [0.0, 0.0, 0.3, *IDENTITY], goals)
    u_a = system.get_output_port(0).Eval(ctx)
    assert u_a.shape == (18,)
    per_goal = u_a.reshape(3, 6)
    for i in range(3):
        v = per_goal[i, :3]
        to_goal = goals[i, :3] - [0.0, 0.0, 0.3]
        assert np.dot(v, to_goal) / (np.linalg.norm(v) * np.linalg.norm(to_goal)) > 0.99
    # Goal 2 is rotated +0.3 rad about z: the command turns about +z, the others do not turn.
    assert per_goal[2, 5] > 0 and np.allclose(per_goal[2, 3:5], 0.0)
    np.testing.assert_allclose(per_goal[:2, 3:], 0.0, atol=1e-12)
    # It is exactly the core function (thin wrapper).
    core = potential_field_commands([0.0, 0.0, 0.3], IDENTITY, goals[:, :3], goals[:, 3:])
    np.testing.assert_allclose(per_goal, core)


def test_config_is_used() -> None:
    cfg = PotentialFieldConfig(max_linear_speed=0.05)
    system = PotentialFieldAutonomy(ControlLoop(1), cfg)
    ctx = _context(system, [0.0, 0.0, 0.0, *IDENTITY], [1.0, 0.0, 0.0, *IDENTITY])
    np.testing.assert_allclose(system.get_output_port(0).Eval(ctx), [0.05, 0, 0, 0, 0, 0])
    assert system.HasDirectFeedthrough(0, 0) and system.HasDirectFeedthrough(1, 0)


GOALS_2 = [[0.3, 0, 0, *IDENTITY], [0, 0.3, 0, *IDENTITY]]


@pytest.mark.parametrize(
    "ee_pose, goal_poses",
    [
        ([np.nan, 0, 0, *IDENTITY], GOALS_2),
        ([0, 0, 0, np.inf, 0, 0, 0], GOALS_2),
        ([0, 0, 0, 1e200, 0, 0, 0], GOALS_2),  # the norm overflows: out of range
        ([0, 0, 0, *IDENTITY], [[0.3, 0, 0, 0, 0, 0, 0], [0, 0.3, 0, *IDENTITY]]),  # zero quaternion
    ],
)
def test_unusable_pose_gives_zero_and_is_counted(ee_pose, goal_poses) -> None:  # noqa: ANN001
    system = PotentialFieldAutonomy(ControlLoop(2, control_period=0.01))
    assert system.GetOutputPort("sanitized_input_count").size() == 1
    simulator = Simulator(system)
    ctx = simulator.get_mutable_context()
    system.GetInputPort("ee_pose").FixValue(ctx, np.asarray(ee_pose, dtype=float))
    system.GetInputPort("goal_poses").FixValue(ctx, np.asarray(goal_poses, dtype=float).ravel())
    np.testing.assert_array_equal(system.GetOutputPort("u_a").Eval(ctx), np.zeros(12))
    with pytest.warns(RuntimeWarning, match="u_a set to zero") as record:
        simulator.AdvanceTo(0.025)  # ticks at 0, 0.01 and 0.02
    assert len(record) == 1  # rate-limited: one warning per second of simulated time
    assert system.GetOutputPort("sanitized_input_count").Eval(ctx)[0] == 3
    np.testing.assert_array_equal(system.GetOutputPort("u_a").Eval(ctx), np.zeros(12))
    # The count lives in the context: a new one starts at zero and warns again.
    fresh = _context(system, ee_pose, goal_poses)
    assert system.GetOutputPort("sanitized_input_count").Eval(fresh)[0] == 0
    with pytest.warns(RuntimeWarning, match="u_a set to zero"):
        Simulator(system, fresh).AdvanceTo(0.005)
    assert system.GetOutputPort("sanitized_input_count").Eval(fresh)[0] == 1


def test_usable_poses_are_not_counted() -> None:
    system = PotentialFieldAutonomy(ControlLoop(2))
    simulator = Simulator(system, _context(system, [0, 0, 0.2, *IDENTITY], GOALS_2))
    simulator.AdvanceTo(0.05)
    assert system.GetOutputPort("sanitized_input_count").Eval(simulator.get_context())[0] == 0
    assert not system.HasDirectFeedthrough(0, system.GetOutputPort("sanitized_input_count").get_index())


@pytest.mark.parametrize("error", [ValueError("goal_quats: expected shape (n, 4)"), RuntimeError("kernel")])
def test_other_errors_propagate(monkeypatch: pytest.MonkeyPatch, error: Exception) -> None:
    from drake_disamb.systems import autonomy as module

    def broken(*args: object) -> None:
        raise error

    system = PotentialFieldAutonomy(ControlLoop(2))
    ctx = _context(system, [0, 0, 0.2, *IDENTITY], GOALS_2)
    monkeypatch.setattr(module, "potential_field_commands_from_poses", broken)
    with pytest.raises(type(error), match=re.escape(str(error))):
        system.GetOutputPort("u_a").Eval(ctx)
    assert system.GetOutputPort("sanitized_input_count").Eval(ctx)[0] == 0


def test_it_ticks_at_the_loops_period_and_asserts_its_config() -> None:
    # The bounds are the resolved scenario's (tests/test_bounds.py); the system asserts the types.
    system = PotentialFieldAutonomy(ControlLoop(2, control_period=0.02))
    assert system.GetUniquePeriodicDiscreteUpdateAttribute().period_sec() == 0.02
    assert system.GetInputPort("goal_poses").size() == 14 and system.GetOutputPort("u_a").size() == 12
    with pytest.raises(AssertionError):
        PotentialFieldAutonomy(ControlLoop(2), config={"max_linear_speed": 0.1})  # type: ignore[arg-type]


def test_usable_poses() -> None:
    from drake_disamb.system_helpers.sanitized import usable_poses

    good = np.array([0.1, -0.2, 0.3, *IDENTITY])
    assert usable_poses(good, np.tile(good, 3))
    assert usable_poses(np.array([0, 0, 0, 1e-12, 0, 0, 0]))  # normalised by the core
    for bad in (
        [np.nan, 0, 0, *IDENTITY],
        [0, 0, 0, 1, -np.inf, 0, 0],
        [0, 0, 0, 0, 0, 0, 0],  # zero quaternion
        [0, 0, 0, 1e-13, 0, 0, 0],
        [0, 0, 0, 1e200, 0, 0, 0],  # its norm overflows: normalised, it would be zeros
        [1e200, 0, 0, *IDENTITY],
    ):
        assert not usable_poses(np.asarray(bad, dtype=float)), bad
        assert not usable_poses(good, np.concatenate((good, bad)).astype(float)), bad
