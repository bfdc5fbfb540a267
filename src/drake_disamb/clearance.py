"""Clearance of rigid solids above the table: boxes, cylinders and spheres posed by 4 x 4 transforms
(numpy only).

The station's own model supplies the solids (:class:`drake_disamb.station.geometry.StationGeometry`
reads the arm's, the gripper's and the table's collision geometry from the station's plant); this
module only measures them:

- :func:`lowest_z` / :func:`highest_z`: the lowest / highest point of a solid in W;
- :func:`hull_points`: points whose convex hull holds a set of solids (the IK's floor constraint
  acts on them);
- :func:`pose_matrix`: the 4 x 4 transform of a pose ``[x, y, z, qw, qx, qy, qz]``.

The table top is treated as an unbounded plane: nothing of the arm may go below it, even beyond the
table's edges.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from drake_disamb.core.geometry import quat_to_matrix

GRIPPER_BODIES: tuple[str, ...] = ("mico_link_6", "mico_link_finger_left", "mico_link_finger_right")
"""Bodies that move rigidly with the end effector (up to the fingers' slide)."""


@dataclass(frozen=True)
class Solid:
    """A box, cylinder or sphere at a fixed pose in some frame.

    Attributes:
        name: What it is (shown in messages).
        shape: ``"box"`` (size = x, y, z lengths), ``"cylinder"`` (radius, length along its z) or
            ``"sphere"`` (radius); metres.
        size: As described for ``shape``.
        X: 4 x 4 homogeneous transform of the solid's frame (its centre) in the parent frame.
    """

    name: str
    shape: str
    size: tuple[float, ...]
    X: NDArray[np.float64]


def _half_height(solid: Solid, R: NDArray[np.float64]) -> float:
    """Half the vertical extent of ``solid`` when its frame has rotation ``R`` in W."""
    if solid.shape == "box":
        return float(0.5 * np.abs(R[2]) @ np.asarray(solid.size))
    if solid.shape == "cylinder":
        radius, length = solid.size
        c = min(abs(float(R[2, 2])), 1.0)  # cosine of the axis' angle to vertical
        return c * length / 2 + radius * math.sqrt(1.0 - c * c)
    return float(solid.size[0])


def lowest_z(solid: Solid, X_W: NDArray[np.float64] | None = None) -> float:
    """Lowest z (m, in W) of ``solid``, its parent frame at ``X_W`` in W (identity when ``None``)."""
    X = solid.X if X_W is None else X_W @ solid.X
    return float(X[2, 3]) - _half_height(solid, X[:3, :3])


def highest_z(solid: Solid, X_W: NDArray[np.float64] | None = None) -> float:
    """Highest z (m, in W) of ``solid``, its parent frame at ``X_W`` in W (identity when ``None``)."""
    X = solid.X if X_W is None else X_W @ solid.X
    return float(X[2, 3]) + _half_height(solid, X[:3, :3])


def pose_matrix(pose: Sequence[float]) -> NDArray[np.float64]:
    """4 x 4 transform of ``[x, y, z, qw, qx, qy, qz]`` (the quaternion is normalised)."""
    p = np.asarray(pose, dtype=float)
    X = np.eye(4)
    X[:3, :3] = quat_to_matrix(p[3:])
    X[:3, 3] = p[:3]
    return X


def hull_points(solids: Sequence[Solid]) -> NDArray[np.float64]:
    """Points (k, 3), in the solids' common parent frame, whose convex hull holds ``solids``: every
    box's corners, every cylinder's two rims (8 points each, on a circumscribed octagon), every
    sphere's circumscribed cube. The lowest of them is at most the solids' true lowest point: a
    floor on them keeps the solids themselves above it."""
    out = []
    for s in solids:
        if s.shape == "box":
            half = np.asarray(s.size, dtype=float) / 2
            local = (
                np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=float) * half
            )
        elif s.shape == "cylinder":
            r = s.size[0] / math.cos(math.pi / 8)
            ang = np.arange(8) * math.pi / 4
            ring = np.stack([r * np.cos(ang), r * np.sin(ang)], axis=1)
            local = np.concatenate(
                [np.hstack([ring, np.full((8, 1), z)]) for z in (-s.size[1] / 2, s.size[1] / 2)]
            )
        else:  # sphere
            r = s.size[0]
            local = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=float) * r
        out.append(local @ s.X[:3, :3].T + s.X[:3, 3])
    return np.concatenate(out)


__all__ = [
    "GRIPPER_BODIES",
    "Solid",
    "highest_z",
    "hull_points",
    "lowest_z",
    "pose_matrix",
]
