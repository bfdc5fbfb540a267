"""The station's clearance geometry, read from a station's own plant: the table top, the arm's joint
limits and the collision solids of the arm and the gripper (:class:`StationGeometry`).

Two questions need the arm's geometry: does a posture keep every link and finger above the table
top (:meth:`StationGeometry.arm_lowest_point`), and does the gripper, placed at a pose, stay above
it (:meth:`StationGeometry.gripper_lowest_point`)? The station's IK keeps the points of
:meth:`StationGeometry.gripper_points_in_ee` above its floor. The fingers slide; every answer takes
the closed and the fully open gripper (every point moves linearly with the opening, so the extremes
bound it). Objects held in the gripper (:class:`~drake_disamb.clearance.Solid` in the end-effector
frame) count as part of it.

A built station carries the geometry of its own plant (``Station.geometry``). The scenario checks
run before any station exists; they use :func:`model_geometry`, the same measurement on a plant of
the model directives alone (the table, the arm and the gripper are the directives'; scene objects
do not change the answers).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from pydrake.geometry import SceneGraph
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import ModelInstanceIndex

from drake_disamb.clearance import GRIPPER_BODIES, Solid, highest_z, hull_points, lowest_z, pose_matrix
from drake_disamb.station.config import ARM_JOINTS, EE_FRAME, FINGER_JOINTS

TABLE_MODEL_NAME = "table"
"""Model instance name of the table in the model directives."""


def _solid(name: str, shape: object, X: NDArray[np.float64]) -> Solid:
    kind = type(shape).__name__
    if kind == "Box":
        return Solid(name, "box", (shape.width(), shape.depth(), shape.height()), X)  # type: ignore[attr-defined]
    if kind == "Cylinder":
        return Solid(name, "cylinder", (shape.radius(), shape.length()), X)  # type: ignore[attr-defined]
    if kind == "Sphere":
        return Solid(name, "sphere", (shape.radius(),), X)  # type: ignore[attr-defined]
    raise RuntimeError(f"station geometry: unsupported collision shape {kind} on {name}")  # pragma: no cover


@dataclass(frozen=True)
class StationGeometry:
    """The clearance geometry of one station's plant (see the module docstring).

    Attributes:
        table_top: Height (m, in W) of the table top: the highest point of the table's collision
            geometry.
        plant: The plant measured (its kinematics pose the arm per query).
        arm_positions, finger_positions: Indices of the arm's and the fingers' joints in its q.
        finger_travel: Each finger's joint range (m).
        lower, upper: Position limits (rad) of the six arm joints, base to wrist.
        arm_bodies: ``(body name, solid in the body frame)`` of every collision solid of the MICO.
        gripper_in_ee: The gripper's collision solids in the end-effector frame, closed then
            fully open.
    """

    plant: MultibodyPlant
    arm_positions: tuple[int, ...]
    finger_positions: tuple[int, ...]
    finger_travel: tuple[float, float]
    lower: NDArray[np.float64]
    upper: NDArray[np.float64]
    arm_bodies: tuple[tuple[str, Solid], ...]
    table_top: float
    gripper_in_ee: tuple[Solid, ...]

    @classmethod
    def from_plant(
        cls, plant: MultibodyPlant, scene_graph: SceneGraph, arm: ModelInstanceIndex
    ) -> StationGeometry:
        """Read the geometry of a finalized ``plant`` (registered with ``scene_graph``) whose model
        instance ``arm`` is the MICO and which holds the model directives' table."""
        inspector = scene_graph.model_inspector()

        def solids(instance: ModelInstanceIndex) -> list[tuple[object, Solid]]:
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
            for b, s in solids(plant.GetModelInstanceByName(TABLE_MODEL_NAME))
        )
        arm_q = tuple(plant.GetJointByName(j, arm).position_start() for j in ARM_JOINTS)
        fingers = [plant.GetJointByName(j, arm) for j in FINGER_JOINTS]
        travel = (float(fingers[0].position_lower_limits()[0]), float(fingers[0].position_upper_limits()[0]))
        geometry = cls(
            plant=plant,
            arm_positions=arm_q,
            finger_positions=tuple(f.position_start() for f in fingers),
            finger_travel=travel,
            lower=plant.GetPositionLowerLimits()[list(arm_q)],
            upper=plant.GetPositionUpperLimits()[list(arm_q)],
            arm_bodies=tuple((b.name(), s) for b, s in solids(arm)),
            table_top=float(table_top),
            gripper_in_ee=(),
        )
        gripper = []
        for X_WE, bodies in geometry._poses(np.zeros(6)):
            X_EW = np.linalg.inv(X_WE)
            for body, solid in geometry.arm_bodies:
                if body in GRIPPER_BODIES:
                    gripper.append(Solid(solid.name, solid.shape, solid.size, X_EW @ bodies[body] @ solid.X))
        object.__setattr__(geometry, "gripper_in_ee", tuple(gripper))
        return geometry

    def joint_limits(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Lower and upper position limits (rad) of the six arm joints, base to wrist (copies)."""
        return self.lower.copy(), self.upper.copy()

    def velocity_limits(self) -> NDArray[np.float64]:
        """The model's speed limits (rad/s) of the six arm joints, base to wrist."""
        v = self.plant.GetVelocityUpperLimits()
        return np.array([v[self.plant.GetJointByName(j).velocity_start()] for j in ARM_JOINTS])

    def _poses(self, q: Sequence[float]) -> list[tuple[NDArray[np.float64], dict[str, NDArray[np.float64]]]]:
        """For the closed and the fully open gripper: (X_WE, {body name: X_WB})."""
        plant = self.plant
        ctx = plant.CreateDefaultContext()
        names = {name for name, _ in self.arm_bodies}
        out = []
        for opening in self.finger_travel:
            x = plant.GetPositions(ctx)
            x[list(self.arm_positions)] = np.asarray(q, dtype=float)
            x[list(self.finger_positions)] = opening
            plant.SetPositions(ctx, x)
            bodies = {n: plant.EvalBodyPoseInWorld(ctx, plant.GetBodyByName(n)).GetAsMatrix4() for n in names}
            X_WE = plant.GetFrameByName(EE_FRAME).CalcPoseInWorld(ctx).GetAsMatrix4()
            out.append((X_WE, bodies))
        return out

    def arm_lowest_point(self, q: Sequence[float], attached: Sequence[Solid] = ()) -> tuple[float, str]:
        """Lowest z (m, in W) of the arm's collision geometry at arm joint angles ``q`` (6, rad, DH),
        with ``attached`` solids held in the gripper (posed in the end-effector frame); returns the
        height and the name of the body (or held solid) that reaches lowest."""
        best = (math.inf, "")
        for X_WE, bodies in self._poses(q):
            for body, solid in self.arm_bodies:
                best = min(best, (lowest_z(solid, bodies[body]), solid.name))
            for solid in attached:
                best = min(best, (lowest_z(solid, X_WE), solid.name))
        return best

    def gripper_points_in_ee(self, attached: Sequence[Solid] = ()) -> NDArray[np.float64]:
        """Points (k, 3) in the end-effector frame whose convex hull holds the gripper (closed and
        fully open) and the ``attached`` solids (:func:`~drake_disamb.clearance.hull_points`)."""
        return hull_points((*self.gripper_in_ee, *attached))

    def gripper_lowest_point(
        self, pose: Sequence[float], attached: Sequence[Solid] = ()
    ) -> tuple[float, str]:
        """Lowest z (m, in W) of the gripper with the end effector at ``pose`` ``[x, y, z, qw, qx,
        qy, qz]`` (the quaternion is normalised) and ``attached`` solids held; returns the height and
        the name of the body (or held solid) that reaches lowest."""
        X_WE = pose_matrix(pose)
        return min((lowest_z(s, X_WE), s.name) for s in (*self.gripper_in_ee, *attached))


@functools.cache
def model_geometry() -> StationGeometry:
    """The :class:`StationGeometry` of the model directives on their own (for the scenario checks,
    which run before a station is built)."""
    from pydrake.multibody.parsing import LoadModelDirectives, ProcessModelDirectives
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph
    from pydrake.systems.framework import DiagramBuilder

    from drake_disamb.paths import mico_directives
    from drake_disamb.station.config import ARM_MODEL_NAME, model_parser

    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlantSceneGraph(builder, 0.0)
    ProcessModelDirectives(LoadModelDirectives(str(mico_directives())), plant, model_parser(plant))
    plant.Finalize()
    geometry = StationGeometry.from_plant(plant, scene_graph, plant.GetModelInstanceByName(ARM_MODEL_NAME))
    object.__setattr__(geometry, "_builder", builder)  # the builder owns the plant: keep it alive
    return geometry
