"""Vector layouts every layer shares: the command's dimensions, the pose, an object's size.

A command has the paper's six end-effector dimensions ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s,
world frame W) and the gripper as a seventh; a control mode is a tuple of these indices. A pose on
a vector port is ``[x, y, z, qw, qx, qy, qz]`` (m; unit quaternion, Drake's w-first order).
"""

from __future__ import annotations

GRIPPER_DIM: int = 6
"""Dimension index of the gripper in a control mode (0..5 are vx, vy, vz, wx, wy, wz)."""

DIM_NAMES: tuple[str, ...] = ("vx", "vy", "vz", "wx", "wy", "wz", "gripper")
"""Human-readable names of the dimension indices 0..6."""


def is_translation_mode(dims: tuple[int, ...]) -> bool:
    """Whether a control mode's dimensions are all translations (vx, vy, vz: 0 to 2)."""
    return bool(dims) and all(0 <= d <= 2 for d in dims)


def is_rotation_mode(dims: tuple[int, ...]) -> bool:
    """Whether a control mode's dimensions are all rotations (wx, wy, wz: 3 to 5)."""
    return bool(dims) and all(3 <= d <= 5 for d in dims)


POSE_SIZE: int = 7
"""Length of a pose on a vector port: ``[x, y, z, qw, qx, qy, qz]``."""

SHAPE_SIZES: dict[str, int] = {"box": 3, "cylinder": 2, "sphere": 1}
"""Entries of an object's ``size`` vector per shape: a box's x, y, z lengths, a cylinder's radius and length,
a sphere's radius (m)."""
