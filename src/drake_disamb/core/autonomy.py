"""Potential-field autonomy: one 6-D end-effector command per goal (numpy, compiled row kernel).

Paper, Section "Shared Control": every goal ``g`` has a potential field that treats ``g`` as an
attractor and every *other* goal as a repeller; the autonomy command is the sum of the attractor
and repeller velocities, in the full 6-D Cartesian space. For goal ``i``::

    v_i = k_t (x_gi - x_r) + sum_{j != i, |x_r - x_gj| < rho} (x_r - x_gj) / (mu |x_r - x_gj|^2)
    w_i = k_r * orientation_error(q_r, q_gi)

with ``1/mu`` the repeller gain (m^2/s: a repeller at distance ``d`` pushes at ``gain / d`` m/s)
and ``rho`` its influence radius (m). ``v_i`` and ``w_i`` are then each saturated to their maximum
norms (the authors' simulation clipped the command norm to 0.2). Commands are ordered like the
paper, ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s), in the world frame W.

Degenerate scenes never give NaN: a goal exactly at the robot has a zero attractor; a repeller
whose goal sits exactly at the robot has no direction and contributes zero; a repeller's magnitude
is capped at :data:`REPELLER_SPEED_CAP_FACTOR` times the maximum linear speed before summation
(it is saturated afterwards anyway); a single goal has no repellers.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core._kernels import _field_one_pose, _field_rows
from drake_disamb.core.geometry import (
    check_vectors,
    normalized_quaternions,
)
from drake_disamb.core.rows import as_rows, batch_shape, shared_rows
from drake_disamb.core.validation import all_finite, check_real_fields

REPELLER_SPEED_CAP_FACTOR = 1e3
"""A single repeller's speed is capped at this multiple of ``max_linear_speed`` (keeps it finite)."""


@dataclass(frozen=True)
class PotentialFieldConfig:
    """Gains and limits of the per-goal potential field.

    Attributes:
        attractor_gain_translation: ``k_t`` (1/s): linear velocity per metre of position error.
        attractor_gain_rotation: ``k_r`` (1/s): angular velocity per radian of orientation error.
        repeller_gain: ``1/mu`` (m^2/s): a repeller at distance ``d`` pushes at ``gain / d`` m/s.
            0 disables repellers.
        repeller_radius: Influence radius ``rho`` (m) beyond which a goal does not repel.
        max_linear_speed: Saturation of the translational part (m/s).
        max_angular_speed: Saturation of the rotational part (rad/s).

    The defaults suit the MICO tasks (goals 0.2-0.4 m apart, docs/facts.md section 9): 1/s attractors reach
    the 0.2 m/s cap farther than 0.2 m from the goal and slow down smoothly inside it; a repeller
    felt within 0.1 m pushes at 0.02 m/s at its edge and at the full 0.2 m/s 1 cm from a goal.
    """

    attractor_gain_translation: float = 1.0
    attractor_gain_rotation: float = 1.0
    repeller_gain: float = 0.002
    repeller_radius: float = 0.1
    max_linear_speed: float = 0.2
    max_angular_speed: float = 0.4

    def __post_init__(self) -> None:
        check_real_fields(
            self,
            (
                "attractor_gain_translation",
                "attractor_gain_rotation",
                "repeller_gain",
                "repeller_radius",
            ),
            allow_zero=True,
        )
        check_real_fields(self, ("max_linear_speed", "max_angular_speed"))


def _field(
    position: NDArray[np.float64] | None,
    quat: NDArray[np.float64],
    goal_positions: NDArray[np.float64] | None,
    goal_quats: NDArray[np.float64],
    config: PotentialFieldConfig,
) -> NDArray[np.float64]:
    """Run :func:`_field_rows` on broadcast operands; without positions, the rotational part only."""
    n = goal_quats.shape[-2]
    translation = position is not None
    shapes = [quat.shape[:-1], goal_quats.shape[:-2]]
    if translation:
        shapes += [position.shape[:-1], goal_positions.shape[:-2]]
    batch = batch_shape(*shapes)
    out = np.empty((math.prod(batch), n, 6 if translation else 3))
    _field_rows(
        as_rows(position, batch, (3,)) if translation else np.empty((0, 3)),
        as_rows(quat, batch, (4,)),
        shared_rows(goal_positions, batch, (n, 3)) if translation else np.empty((0, n, 3)),
        shared_rows(goal_quats, batch, (n, 4)),
        *_gains(config),
        translation,
        out,
    )
    return out.reshape(*batch, n, out.shape[-1])


def _gains(config: PotentialFieldConfig) -> tuple[float, ...]:
    """The gains and limits :func:`_field_rows` takes, in its order."""
    return (
        float(config.attractor_gain_translation),
        float(config.attractor_gain_rotation),
        float(config.repeller_gain),
        float(config.repeller_radius),
        REPELLER_SPEED_CAP_FACTOR * config.max_linear_speed,
        float(config.max_linear_speed),
        float(config.max_angular_speed),
    )


def _commands_from_one_pose(
    ee_pose: NDArray[np.float64], goal_poses: NDArray[np.float64], config: PotentialFieldConfig
) -> NDArray[np.float64]:
    """:func:`_field` for one pose ``(7,)`` and ``(n, 7)`` goal poses (finite, quaternions of norm at
    least 1e-12) in one compiled call (:func:`~drake_disamb.core._kernels._field_one_pose`): the
    same kernels, in the same order, on the same numbers as normalising the quaternions
    (:func:`~drake_disamb.core._kernels._normalize_quaternion_rows`) and laying out the rows
    first, without that work in numpy (a control loop computes one row per tick)."""
    out = np.empty((1, goal_poses.shape[0], 6))
    _field_one_pose(np.ascontiguousarray(ee_pose), np.ascontiguousarray(goal_poses), *_gains(config), out)
    return out[0]


def potential_field_rotation(
    quat: NDArray[np.float64], goal_quats: NDArray[np.float64], config: PotentialFieldConfig
) -> NDArray[np.float64]:
    """Rotational part ``w_i`` of the per-goal commands, ``(..., n, 3)`` (rad/s, saturated).

    Unchecked (unit quaternions assumed). It depends on the orientations only: repellers act on
    the translational part alone, so callers that need just ``u_a[..., 3:6]`` (the agreement
    term) need neither the positions nor the repellers.
    """
    return _field(None, quat, None, goal_quats, config)


def _potential_field_commands(
    position: NDArray[np.float64],
    quat: NDArray[np.float64],
    goal_positions: NDArray[np.float64],
    goal_quats: NDArray[np.float64],
    config: PotentialFieldConfig,
) -> NDArray[np.float64]:
    """Unchecked kernel of :func:`potential_field_commands` (unit quaternions assumed)."""
    return _field(position, quat, goal_positions, goal_quats, config)


def potential_field_commands(
    position: ArrayLike,
    quat: ArrayLike,
    goal_positions: ArrayLike,
    goal_quats: ArrayLike,
    config: PotentialFieldConfig | None = None,
) -> NDArray[np.float64]:
    """Per-goal autonomy commands ``u_a`` (``(..., n, 6)``, ``[vx, vy, vz, wx, wy, wz]`` in W).

    Args:
        position: End-effector position(s) ``(..., 3)`` (m).
        quat: End-effector orientation(s) ``(..., 4)`` ``[qw, qx, qy, qz]``.
        goal_positions: ``(..., n, 3)`` goal positions (m).
        goal_quats: ``(..., n, 4)`` goal orientations.
        config: Gains and limits; ``None`` means the defaults.

    Leading dimensions broadcast together. Row ``i`` drives the robot towards goal ``i`` and away
    from every other goal within the repeller radius; translational and rotational parts are each
    saturated. Never NaN (see the module docstring for the degenerate cases).
    """
    cfg = PotentialFieldConfig() if config is None else config
    p = check_vectors(position, 3, "position")
    q = normalized_quaternions(quat, "quat")
    gp = check_vectors(goal_positions, 3, "goal_positions")
    gq = normalized_quaternions(goal_quats, "goal_quats")
    if gp.ndim < 2 or gq.ndim < 2:
        raise ValueError(
            "goal_positions/goal_quats: expected shapes (..., n, 3) and (..., n, 4), "
            f"got {gp.shape} and {gq.shape}"
        )
    if gp.shape[-2] != gq.shape[-2]:
        raise ValueError(
            f"goal_quats: expected {gp.shape[-2]} goals like goal_positions, got shape {gq.shape}"
        )
    if gp.shape[-2] < 1:
        raise ValueError("goal_positions: expected at least one goal, got 0")
    return _potential_field_commands(p, q, gp, gq, cfg)


def potential_field_commands_from_poses(
    ee_pose: NDArray[np.float64],
    goal_poses: NDArray[np.float64],
    config: PotentialFieldConfig,
    checked: bool = True,
) -> NDArray[np.float64]:
    """:func:`potential_field_commands` for one pose ``[x, y, z, qw, qx, qy, qz]`` and ``(n, 7)`` goal
    poses, with the lean validation of a control loop's hot path; returns ``(n, 6)``.

    The same numbers as :func:`potential_field_commands` (the same normalisation and kernel);
    shapes are the caller's business (a Drake port fixes them). A non-finite entry or a (near) zero
    quaternion is a ``ValueError`` naming the argument, as there. ``checked=False`` skips those
    checks: the caller has already checked the poses (every entry finite, each quaternion's norm
    at least 1e-12 and finite, e.g. :func:`drake_disamb.system_helpers.sanitized.usable_poses`), and they
    are not checked twice per control tick.
    """
    if not checked:
        return _commands_from_one_pose(ee_pose, goal_poses, config)
    if not all_finite(ee_pose, goal_poses):
        name = "quat" if not all_finite(ee_pose) else "goal_quats"
        bad = ee_pose if name == "quat" else goal_poses
        raise ValueError(f"{name}: expected finite poses, got {bad.tolist()!r}")
    q = normalized_quaternions(ee_pose[3:], "quat")
    gq = normalized_quaternions(goal_poses[:, 3:], "goal_quats")
    return _potential_field_commands(ee_pose[:3], q, goal_poses[:, :3], gq, config)
