"""PotentialFieldAutonomy system in isolation."""

from __future__ import annotations

import numpy as np
import pytest

from drake_disamb.core.autonomy import PotentialFieldConfig, potential_field_commands
from drake_disamb.core.geometry import quat_from_rotvec
from drake_disamb.systems.autonomy import PotentialFieldAutonomy

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
    system = PotentialFieldAutonomy(3)
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
    system = PotentialFieldAutonomy(1, cfg)
    ctx = _context(system, [0.0, 0.0, 0.0, *IDENTITY], [1.0, 0.0, 0.0, *IDENTITY])
    np.testing.assert_allclose(system.get_output_port(0).Eval(ctx), [0.05, 0, 0, 0, 0, 0])
    assert system.HasDirectFeedthrough(0, 0) and system.HasDirectFeedthrough(1, 0)


def test_bad_pose_gives_zero_with_warning() -> None:
    system = PotentialFieldAutonomy(2)
    goals = [[0.3, 0, 0, *IDENTITY], [0, 0.3, 0, *IDENTITY]]
    ctx = _context(system, [np.nan, 0, 0, *IDENTITY], goals)
    with pytest.warns(RuntimeWarning, match="u_a set to zero"):
        u_a = system.get_output_port(0).Eval(ctx)
    np.testing.assert_array_equal(u_a, np.zeros(12))


def test_constructor_validation() -> None:
    with pytest.raises(ValueError, match="n_goals"):
        PotentialFieldAutonomy(0)
    with pytest.raises(ValueError, match="config"):
        PotentialFieldAutonomy(2, config={"max_linear_speed": 0.1})  # type: ignore[arg-type]
