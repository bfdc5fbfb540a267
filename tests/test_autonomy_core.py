"""Potential-field autonomy core (drake_disamb.core.autonomy)."""

from __future__ import annotations

import numpy as np
import pytest

from drake_disamb.core.autonomy import PotentialFieldConfig, potential_field_commands
from drake_disamb.core.geometry import orientation_error, quat_from_rotvec

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def _reference(position, quat, goal_positions, goal_quats, cfg: PotentialFieldConfig) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Goal-by-goal loop straight from the paper's formula (Section "Study Methods", Shared Control)."""
    n = len(goal_positions)
    out = np.zeros((n, 6))
    for i in range(n):
        v = cfg.attractor_gain_translation * (goal_positions[i] - position)
        for j in range(n):
            if j == i:
                continue
            d = position - goal_positions[j]
            dist = np.linalg.norm(d)
            if 0.0 < dist < cfg.repeller_radius:
                mu = 1.0 / cfg.repeller_gain
                v = v + d / (mu * dist**2)
        w = cfg.attractor_gain_rotation * orientation_error(quat, goal_quats[i])
        if np.linalg.norm(v) > cfg.max_linear_speed:
            v = v / np.linalg.norm(v) * cfg.max_linear_speed
        if np.linalg.norm(w) > cfg.max_angular_speed:
            w = w / np.linalg.norm(w) * cfg.max_angular_speed
        out[i] = np.concatenate([v, w])
    return out


def _random_scene(rng: np.random.Generator, n: int):  # type: ignore[no-untyped-def]
    position = rng.uniform(-0.3, 0.3, 3)
    quat = quat_from_rotvec(rng.normal(scale=1.0, size=3))
    goals = position + rng.uniform(-0.15, 0.15, (n, 3))  # many inside the repeller radius
    goal_quats = quat_from_rotvec(rng.normal(scale=1.0, size=(n, 3)))
    return position, quat, goals, goal_quats


def test_matches_loop_reference_on_random_scenes() -> None:
    rng = np.random.default_rng(0)
    cfg = PotentialFieldConfig(repeller_gain=0.01, repeller_radius=0.15)
    for n in (1, 2, 3, 5, 8):
        for _ in range(10):
            scene = _random_scene(rng, n)
            np.testing.assert_allclose(
                potential_field_commands(*scene, cfg), _reference(*scene, cfg), atol=1e-12
            )


def test_batched_equals_single() -> None:
    rng = np.random.default_rng(1)
    scenes = [_random_scene(rng, 4) for _ in range(6)]
    stacked = [np.stack(parts) for parts in zip(*scenes, strict=True)]
    batched = potential_field_commands(*stacked)
    assert batched.shape == (6, 4, 6)
    for b, scene in enumerate(scenes):
        np.testing.assert_allclose(batched[b], potential_field_commands(*scene), atol=1e-15)


def test_attractor_direction_and_saturation() -> None:
    cfg = PotentialFieldConfig()
    far = potential_field_commands([0, 0, 0], IDENTITY, [[1.0, 0, 0]], [IDENTITY], cfg)[0]
    np.testing.assert_allclose(far[:3], [cfg.max_linear_speed, 0, 0], atol=1e-15)
    near = potential_field_commands([0, 0, 0], IDENTITY, [[0.05, 0, 0]], [IDENTITY], cfg)[0]
    np.testing.assert_allclose(near[:3], [0.05 * cfg.attractor_gain_translation, 0, 0], atol=1e-15)
    # Rotation: goal rotated 1 rad about z -> command about +z, saturated to 0.4 rad/s.
    rot = potential_field_commands([0, 0, 0], IDENTITY, [[0, 0, 0]], [quat_from_rotvec([0, 0, 1.0])], cfg)[0]
    np.testing.assert_allclose(rot, [0, 0, 0, 0, 0, cfg.max_angular_speed], atol=1e-15)


def test_repeller_pushes_away_only_within_radius_and_not_from_own_goal() -> None:
    cfg = PotentialFieldConfig(attractor_gain_translation=0.0, repeller_gain=0.002, repeller_radius=0.1)
    goals = np.array([[0.05, 0.0, 0.0], [0.0, 0.5, 0.0]])
    u = potential_field_commands([0, 0, 0], IDENTITY, goals, [IDENTITY, IDENTITY], cfg)
    # Goal 0 (5 cm away, inside the radius) repels the command for goal 1 at gain / d = 0.04 m/s, along -x.
    np.testing.assert_allclose(u[1, :3], [-0.04, 0.0, 0.0], atol=1e-15)
    # Goal 1 is outside the radius: no repeller on the command for goal 0; its own goal never repels.
    np.testing.assert_allclose(u[0, :3], 0.0, atol=1e-15)


def test_robot_on_a_goal_and_single_goal_never_nan() -> None:
    cfg = PotentialFieldConfig()
    goals = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1e-300, 0.0, 0.0], [0.2, 0.1, 0.0]])
    quats = np.tile(IDENTITY, (4, 1))
    u = potential_field_commands([0, 0, 0], IDENTITY, goals, quats, cfg)
    assert np.all(np.isfinite(u))
    assert np.all(np.linalg.norm(u[:, :3], axis=-1) <= cfg.max_linear_speed + 1e-15)
    np.testing.assert_allclose(u[0, 3:], 0.0)
    single = potential_field_commands([0, 0, 0], IDENTITY, goals[:1], quats[:1], cfg)
    np.testing.assert_array_equal(single, np.zeros((1, 6)))


def test_permuting_goals_permutes_commands() -> None:
    rng = np.random.default_rng(2)
    position, quat, goals, goal_quats = _random_scene(rng, 5)
    perm = rng.permutation(5)
    u = potential_field_commands(position, quat, goals, goal_quats)
    np.testing.assert_allclose(
        potential_field_commands(position, quat, goals[perm], goal_quats[perm]), u[perm], atol=1e-15
    )


def test_config_validation() -> None:
    with pytest.raises(ValueError, match="max_linear_speed"):
        PotentialFieldConfig(max_linear_speed=0.0)
    with pytest.raises(ValueError, match="repeller_radius"):
        PotentialFieldConfig(repeller_radius=float("nan"))
    with pytest.raises(ValueError, match="attractor_gain_rotation"):
        PotentialFieldConfig(attractor_gain_rotation=-1.0)


def test_shape_validation() -> None:
    with pytest.raises(ValueError, match="goal_quats"):
        potential_field_commands([0, 0, 0], IDENTITY, [[1, 0, 0], [0, 1, 0]], [IDENTITY], None)
    with pytest.raises(ValueError, match="goal_positions"):
        potential_field_commands([0, 0, 0], IDENTITY, [[1, 0]], [IDENTITY], None)
    with pytest.raises(ValueError, match="quat"):
        potential_field_commands([0, 0, 0], [0, 0, 0, 0], [[1, 0, 0]], [IDENTITY], None)


def test_rotational_part_needs_neither_positions_nor_repellers() -> None:
    """The disambiguation's agreement term uses only u_a[..., 3:6], computed by the rotation kernel."""
    from drake_disamb.core.autonomy import potential_field_rotation

    rng = np.random.default_rng(3)
    cfg = PotentialFieldConfig(repeller_gain=0.01, repeller_radius=0.5, max_angular_speed=0.3)
    _, _, goals, goal_quats = _random_scene(rng, 4)
    quats = quat_from_rotvec(rng.normal(scale=1.5, size=(7, 3)))
    w = potential_field_rotation(quats, goal_quats, cfg)
    assert w.shape == (7, 4, 3)
    for b in range(7):
        for position in (goals[0], rng.uniform(-1, 1, 3)):  # on a goal (repellers) or anywhere
            full = potential_field_commands(position, quats[b], goals, goal_quats, cfg)
            np.testing.assert_allclose(w[b], full[:, 3:], rtol=0, atol=1e-15)  # up to re-normalising
    assert np.all(np.linalg.norm(w, axis=-1) <= cfg.max_angular_speed + 1e-15)


def test_position_and_orientation_batches_broadcast() -> None:
    rng = np.random.default_rng(4)
    position, _, goals, goal_quats = _random_scene(rng, 3)
    quats = quat_from_rotvec(rng.normal(size=(5, 3)))
    u = potential_field_commands(position, quats, goals, goal_quats)  # (3,) with (5, 4)
    assert u.shape == (5, 3, 6) and u.flags.c_contiguous
    for b in range(5):
        np.testing.assert_array_equal(u[b], potential_field_commands(position, quats[b], goals, goal_quats))


@pytest.mark.parametrize("seed", range(8))
def test_from_poses_matches_potential_field_commands(seed: int) -> None:
    """potential_field_commands_from_poses (the Drake system's lean-validation wrapper) gives the
    numbers of potential_field_commands (same normalisation, same kernel), repellers acting or not,
    unnormalised quaternions included; bad poses raise ValueError."""
    from drake_disamb.core.autonomy import potential_field_commands_from_poses

    rng = np.random.default_rng(seed)
    config = PotentialFieldConfig()
    for n in (1, 2, 5, 7):
        for case in ("far", "near", "two near", "at"):
            ee = np.r_[rng.normal(scale=0.3, size=3), rng.normal(size=4) * rng.choice([0.1, 1.0, 5.0])]
            goals = np.c_[rng.normal(scale=0.3, size=(n, 3)), rng.normal(size=(n, 4))]
            if case == "near":  # a repeller acts
                goals[0, :3] = ee[:3] + rng.normal(scale=0.02, size=3)
            elif case == "two near" and n > 2:  # two repellers act on every other goal
                goals[:2, :3] = ee[:3] + rng.normal(scale=0.04, size=(2, 3))
            elif case == "at":
                goals[0, :3] = ee[:3]
            expected = potential_field_commands(ee[:3], ee[3:], goals[:, :3], goals[:, 3:], config)
            got = potential_field_commands_from_poses(ee, goals, config)
            np.testing.assert_array_equal(got, expected)
            assert not np.any(np.signbit(got) != np.signbit(expected))
    with pytest.raises(ValueError, match="quat"):
        potential_field_commands_from_poses(np.r_[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], goals, config)
    with pytest.raises(ValueError, match="finite"):
        potential_field_commands_from_poses(np.r_[np.nan, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0], goals, config)


@pytest.mark.parametrize("seed", range(4))
def test_from_poses_unchecked_is_the_composition_it_replaces(seed: int) -> None:
    """The control loop's path (checked=False: one compiled call, _field_one_pose) gives exactly the
    numbers of normalising with normalized_quaternions_unchecked and running the broadcasting
    kernel path, repellers acting or not, unnormalised quaternions included."""
    from support import normalized_quaternions_unchecked

    from drake_disamb.core.autonomy import _potential_field_commands, potential_field_commands_from_poses

    rng = np.random.default_rng(seed)
    config = PotentialFieldConfig(repeller_radius=0.2)
    for n in (1, 2, 5):
        for near in (False, True):
            ee = np.r_[rng.normal(scale=0.3, size=3), rng.normal(size=4) * rng.choice([1e-3, 1.0, 50.0])]
            goals = np.c_[rng.normal(scale=0.3, size=(n, 3)), rng.normal(size=(n, 4))]
            if near:
                goals[:, :3] = ee[:3] + rng.normal(scale=0.05, size=(n, 3))
            q = normalized_quaternions_unchecked(ee[3:])
            gq = normalized_quaternions_unchecked(goals[:, 3:])
            expected = _potential_field_commands(ee[:3], q, goals[:, :3], gq, config)
            got = potential_field_commands_from_poses(ee, goals, config, False)
            assert got.shape == (n, 6)
            np.testing.assert_array_equal(got, expected)
            assert not np.any(np.signbit(got) != np.signbit(expected))
