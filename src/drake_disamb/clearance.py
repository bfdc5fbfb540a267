"""Clearance of the MICO above its table, from the station's own model (forward kinematics in Drake).

The scenario validation (:func:`drake_disamb.config.validation.check_scenario`) asks two questions that
need the arm's geometry: does a start posture keep every link and finger above the table top, and
does the gripper, placed at a goal pose, stay above it? Both are answered here with the model the
station simulates (``models/mico/mico_on_table.dmd.yaml``: our MICO URDF and the table), parsed
once into a MultibodyPlant with its SceneGraph:

- :func:`table_top_z` is the top of the table's collision box (z = 0 in W: the arm's base sits on it).
- :func:`arm_lowest_point` is the lowest point of the arm's collision geometry at joint angles ``q``.
- :func:`gripper_lowest_point` is the lowest point of the gripper (link 6 and fingers) with the end
  effector at a given pose, whatever joint angles reach it.

The fingers slide; both answers take the lower of the closed and the fully open gripper (every
point moves linearly with the opening, so the extremes bound it). Objects held in the gripper
(:class:`Solid` in the end-effector frame) count as part of it. The table top is treated as an
unbounded plane: nothing of the arm may go below it, even beyond the table's edges.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

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
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RigidTransform

    p = np.asarray(pose, dtype=float)
    return RigidTransform(Quaternion(p[3:] / np.linalg.norm(p[3:])), p[:3]).GetAsMatrix4()


@dataclass(frozen=True)
class _Model:
    builder: object
    plant: object
    arm_positions: tuple[int, ...]  # indices of the six arm joints in the plant's q
    finger_positions: tuple[int, ...]
    finger_travel: tuple[float, float]  # each finger's joint range (m)
    lower: NDArray[np.float64]  # arm joint limits (rad)
    upper: NDArray[np.float64]
    geometry: tuple[tuple[object, Solid], ...]  # (body, solid in the body frame)
    table_top: float


def _solid(name: str, shape: object, X: NDArray[np.float64]) -> Solid:
    kind = type(shape).__name__
    if kind == "Box":
        return Solid(name, "box", (shape.width(), shape.depth(), shape.height()), X)  # type: ignore[attr-defined]
    if kind == "Cylinder":
        return Solid(name, "cylinder", (shape.radius(), shape.length()), X)  # type: ignore[attr-defined]
    if kind == "Sphere":
        return Solid(name, "sphere", (shape.radius(),), X)  # type: ignore[attr-defined]
    raise RuntimeError(f"clearance: unsupported collision shape {kind} on {name}")  # pragma: no cover


@functools.cache
def _model() -> _Model:
    from pydrake.multibody.parsing import LoadModelDirectives, Parser, ProcessModelDirectives
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
    from pydrake.systems.framework import DiagramBuilder

    from drake_disamb.paths import MODELS_PACKAGE, mico_directives, models_dir
    from drake_disamb.station import ARM_JOINTS, ARM_MODEL_NAME, FINGER_JOINTS

    builder = DiagramBuilder()  # owns the plant: kept in the model
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    parser = Parser(plant)
    parser.package_map().Add(MODELS_PACKAGE, str(models_dir()))
    ProcessModelDirectives(LoadModelDirectives(str(mico_directives())), plant, parser)
    plant.Finalize()
    inspector = scene_graph.model_inspector()

    def solids(instance: object) -> list[tuple[object, Solid]]:
        out = []
        for index in plant.GetBodyIndices(instance):
            body = plant.get_body(index)
            for g in plant.GetCollisionGeometriesForBody(body):
                X = inspector.GetPoseInFrame(g).GetAsMatrix4()
                out.append((body, _solid(body.name(), inspector.GetShape(g), X)))
        return out

    ctx = plant.CreateDefaultContext()
    table_top = max(
        highest_z(s, plant.EvalBodyPoseInWorld(ctx, b).GetAsMatrix4())
        for b, s in solids(plant.GetModelInstanceByName("table"))
    )
    arm = plant.GetModelInstanceByName(ARM_MODEL_NAME)
    arm_q = tuple(plant.GetJointByName(j, arm).position_start() for j in ARM_JOINTS)
    fingers = [plant.GetJointByName(j, arm) for j in FINGER_JOINTS]
    travel = (float(fingers[0].position_lower_limits()[0]), float(fingers[0].position_upper_limits()[0]))
    lower = plant.GetPositionLowerLimits()[list(arm_q)]
    upper = plant.GetPositionUpperLimits()[list(arm_q)]
    return _Model(
        builder=builder,
        plant=plant,
        arm_positions=arm_q,
        finger_positions=tuple(f.position_start() for f in fingers),
        finger_travel=travel,
        lower=lower,
        upper=upper,
        geometry=tuple(solids(arm)),
        table_top=float(table_top),
    )


def table_top_z() -> float:
    """Height (m, in W) of the table top: the highest point of the table's collision geometry."""
    return _model().table_top


def arm_joint_limits() -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lower and upper position limits (rad) of the six arm joints, base to wrist."""
    m = _model()
    return m.lower.copy(), m.upper.copy()


def _poses(q: Sequence[float]) -> list[tuple[NDArray[np.float64], dict[str, NDArray[np.float64]]]]:
    """For the closed and the fully open gripper: (X_WE, {body name: X_WB})."""
    from drake_disamb.station import EE_FRAME

    m = _model()
    plant = m.plant
    ctx = plant.CreateDefaultContext()  # type: ignore[attr-defined]
    out = []
    for opening in m.finger_travel:
        x = plant.GetPositions(ctx)  # type: ignore[attr-defined]
        x[list(m.arm_positions)] = np.asarray(q, dtype=float)
        x[list(m.finger_positions)] = opening
        plant.SetPositions(ctx, x)  # type: ignore[attr-defined]
        bodies = {b.name(): plant.EvalBodyPoseInWorld(ctx, b).GetAsMatrix4() for b, _ in m.geometry}  # type: ignore[attr-defined]
        X_WE = plant.GetFrameByName(EE_FRAME).CalcPoseInWorld(ctx).GetAsMatrix4()  # type: ignore[attr-defined]
        out.append((X_WE, bodies))
    return out


def arm_lowest_point(q: Sequence[float], attached: Sequence[Solid] = ()) -> tuple[float, str]:
    """Lowest z (m, in W) of the arm's collision geometry at arm joint angles ``q`` (6, rad).

    Args:
        q: The six arm joint angles (rad, DH).
        attached: Solids held in the gripper, posed in the end-effector frame.

    Returns:
        The height and the name of the body (or held solid) that reaches lowest.
    """
    m = _model()
    best = (math.inf, "")
    for X_WE, bodies in _poses(q):
        for body, solid in m.geometry:
            best = min(best, (lowest_z(solid, bodies[body.name()]), solid.name))  # type: ignore[attr-defined]
        for solid in attached:
            best = min(best, (lowest_z(solid, X_WE), solid.name))
    return best


@functools.cache
def _gripper_in_ee() -> tuple[Solid, ...]:
    """The gripper's collision solids in the end-effector frame, closed then fully open."""
    m = _model()
    out = []
    for X_WE, bodies in _poses(np.zeros(6)):
        X_EW = np.linalg.inv(X_WE)
        for body, solid in m.geometry:
            if body.name() in GRIPPER_BODIES:  # type: ignore[attr-defined]
                out.append(Solid(solid.name, solid.shape, solid.size, X_EW @ bodies[body.name()] @ solid.X))  # type: ignore[attr-defined]
    return tuple(out)


def gripper_points_in_ee(attached: Sequence[Solid] = ()) -> NDArray[np.float64]:
    """Points (k, 3) in the end-effector frame whose convex hull holds the gripper (closed and fully
    open) and the ``attached`` solids: every box's corners, every cylinder's two rims (8 points
    each, on a circumscribed octagon), every sphere's circumscribed cube. The lowest of them is at
    most the gripper's true lowest point: a floor on them keeps the gripper itself above it."""
    out = []
    for s in (*_gripper_in_ee(), *attached):
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


def gripper_lowest_point(pose: Sequence[float], attached: Sequence[Solid] = ()) -> tuple[float, str]:
    """Lowest z (m, in W) of the gripper with the end effector at ``pose`` ``[x, y, z, qw, qx, qy, qz]``.

    Args:
        pose: End-effector pose in W (the quaternion is normalised).
        attached: Solids held in the gripper, posed in the end-effector frame.

    Returns:
        The height and the name of the body (or held solid) that reaches lowest.
    """
    X_WE = pose_matrix(pose)
    return min((lowest_z(s, X_WE), s.name) for s in (*_gripper_in_ee(), *attached))


__all__ = [
    "GRIPPER_BODIES",
    "Solid",
    "arm_joint_limits",
    "arm_lowest_point",
    "gripper_lowest_point",
    "gripper_points_in_ee",
    "highest_z",
    "lowest_z",
    "pose_matrix",
    "table_top_z",
]
