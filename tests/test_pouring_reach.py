"""The pouring task's geometry: side grasp, reachable goals, objects clear of the arm.

Every goal pose of ``tasks/pouring.yaml`` is checked reachable from the scenario's start
configuration in two ways: statically with Drake's ``InverseKinematics`` (seeded at the start), and
by driving the controller's :class:`~drake_disamb.controller.DifferentialIKIntegrator` (fixed-input
context, perfect joint tracking) with a proportional Cartesian controller from the start to each
pour pose and on to each placing pose. At every goal configuration reached (within the simulated
user's success tolerance), the arm and the cup are at least 1 mm clear of every scene object (a
placed cup's bottom is 1 cm above its platform at the exact goal).
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RotationMatrix
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.solvers import Solve

from drake_disamb.builder import start_ee_pose
from drake_disamb.config import Scenario, load_scenario, scene_objects
from drake_disamb.controller import DifferentialIKIntegrator
from drake_disamb.core.geometry import orientation_error, quat_to_matrix
from drake_disamb.station import (
    ARM_JOINTS,
    EE_FRAME,
    Station,
    StationConfig,
    build_station,
)

# The controller: speeds of the head array (docs/facts.md section 6), gain 2/s; success as the task's.
LINEAR_SPEED, ANGULAR_SPEED, GAIN = 0.1, 0.2, 2.0
MAX_TIME = 20.0  # s of simulated driving per leg


@functools.cache
def _setup() -> tuple[Scenario, Station]:
    scenario = load_scenario("pouring")
    station = build_station(
        StationConfig(home_q=tuple(scenario.start_joint_positions)), scene_objects(scenario)
    )
    return scenario, station


class _Driver:
    """The DifferentialIKIntegrator alone, driven by a proportional Cartesian controller."""

    def __init__(self, station: Station, config: StationConfig) -> None:
        self.plant = station.control_plant
        self.ctx = self.plant.CreateDefaultContext()
        self.frame = self.plant.GetFrameByName(EE_FRAME)
        self.q_idx = [self.plant.GetJointByName(n).position_start() for n in ARM_JOINTS]
        self.ik = DifferentialIKIntegrator(self.plant, config, geometry=station.geometry)
        self.ik_ctx = self.ik.CreateDefaultContext()
        self.period = config.control_period

    def pose(self, q: np.ndarray) -> np.ndarray:
        full = self.plant.GetPositions(self.ctx)
        full[self.q_idx] = q
        self.plant.SetPositions(self.ctx, full)
        X = self.frame.CalcPoseInWorld(self.ctx)
        return np.concatenate((X.translation(), X.rotation().ToQuaternion().wxyz()))

    def drive(
        self, q0: np.ndarray, goal: np.ndarray, pos_tol: float, ori_tol: float
    ) -> tuple[bool, np.ndarray]:
        """Drive from joint angles ``q0`` toward ``goal``; True once within both tolerances."""
        q, v = q0.copy(), np.zeros(6)  # the IK's set point q_d and joint velocity
        for _ in range(int(MAX_TIME / self.period)):
            pose = self.pose(q)
            err = np.concatenate((goal[:3] - pose[:3], orientation_error(pose[3:], goal[3:])))
            if np.linalg.norm(err[:3]) <= pos_tol and np.linalg.norm(err[3:]) <= ori_tol:
                return True, q
            V = GAIN * err
            V[:3] *= min(1.0, LINEAR_SPEED / max(np.linalg.norm(V[:3]), 1e-12))
            V[3:] *= min(1.0, ANGULAR_SPEED / max(np.linalg.norm(V[3:]), 1e-12))
            self.ik_ctx.SetDiscreteState(0, q)
            self.ik_ctx.SetDiscreteState(1, v)
            self.ik.GetInputPort("arm_joint_state").FixValue(self.ik_ctx, np.concatenate((q, v)))
            self.ik.GetInputPort("ee_velocity_command").FixValue(self.ik_ctx, V)
            update = self.ik.EvalUniquePeriodicDiscreteUpdate(self.ik_ctx)
            q, v = update.get_vector(0).CopyToVector(), update.get_vector(1).CopyToVector()
        return False, q


@functools.cache
def _drives() -> dict[tuple[int, int | None], np.ndarray]:
    """Joint angles reached: ``(pour goal, None)`` from the start, ``(pour, place)`` from that pour."""
    scenario, station = _setup()
    driver = _Driver(station, station.config)
    q_start = np.asarray(scenario.start_joint_positions)
    tol = scenario.user.config
    pos_tol, ori_tol = tol.success_position_tolerance, tol.success_orientation_tolerance
    reached: dict[tuple[int, int | None], np.ndarray] = {}
    for i, pour in enumerate(scenario.stage_goal_poses(0)):
        ok, q_pour = driver.drive(q_start, pour, pos_tol, ori_tol)
        assert ok, f"pour goal {scenario.stage_goals(0)[i].name} not reached from the start"
        reached[(i, None)] = q_pour
        for j, place in enumerate(scenario.stage_goal_poses(1)):
            ok, q_place = driver.drive(q_pour, place, pos_tol, ori_tol)
            assert ok, (
                f"place goal {scenario.stage_goals(1)[j].name} not reached from "
                f"{scenario.stage_goals(0)[i].name}"
            )
            reached[(i, j)] = q_place
    return reached


def test_side_grasp_geometry() -> None:
    scenario, station = _setup()
    start = start_ee_pose(station)
    np.testing.assert_allclose(start[:3], [0.0, -0.45, 0.30], atol=2e-3)
    cup = scenario.carried_object
    assert cup is not None and cup.shape == "cylinder"
    cup_axis_in_ee = quat_to_matrix(cup.orientation)[:, 2]
    # The start: gripper horizontal (approach axis z_E), fingers closing horizontally (y_E),
    # the cup's axis vertical.
    R = quat_to_matrix(start[3:])
    assert abs(R[2, 2]) < 0.02 and abs(R[2, 1]) < 0.02
    assert (R @ cup_axis_in_ee)[2] == pytest.approx(1.0, abs=1e-3)
    for pose in scenario.stage_goal_poses(1):  # placing: upright, gripper horizontal
        R = quat_to_matrix(pose[3:])
        assert (R @ cup_axis_in_ee)[2] == pytest.approx(1.0, abs=1e-3)
        assert abs(R[2, 2]) < 1e-3
    rolls = []
    for pose in scenario.stage_goal_poses(0):  # pouring: rolled about the horizontal approach axis
        R = quat_to_matrix(pose[3:])
        assert abs(R[2, 2]) < 1e-3
        tilt = math.degrees(math.acos((R @ cup_axis_in_ee)[2]))
        assert 55.0 <= tilt <= 95.0
        rolls.append(float(np.dot(R @ cup_axis_in_ee, np.cross(R[:, 2], [0.0, 0.0, 1.0]))))
    assert rolls[0] * rolls[1] < 0  # one container one way, the other the other way


def test_goals_static_inverse_kinematics_from_the_start() -> None:
    scenario, station = _setup()
    plant = station.control_plant
    frame = plant.GetFrameByName(EE_FRAME)
    q_idx = [plant.GetJointByName(n).position_start() for n in ARM_JOINTS]
    seed = np.zeros(plant.num_positions())
    seed[q_idx] = scenario.start_joint_positions
    for g in scenario.goals:
        ik = InverseKinematics(plant)
        p = np.asarray(g.position)
        ik.AddPositionConstraint(frame, np.zeros(3), plant.world_frame(), p - 1e-4, p + 1e-4)
        q_goal = np.asarray(g.orientation) / np.linalg.norm(g.orientation)
        ik.AddOrientationConstraint(
            frame, RotationMatrix(), plant.world_frame(), RotationMatrix(Quaternion(q_goal)), 1e-3
        )
        ik.get_mutable_prog().SetInitialGuess(ik.q(), seed)
        assert Solve(ik.prog()).is_success(), f"goal {g.name}: no IK solution seeded at the start"


def test_every_goal_reached_by_differential_ik_from_the_start() -> None:
    scenario, _ = _setup()
    reached = _drives()
    assert len(reached) == scenario.n_goals + scenario.n_goals**2


def test_arm_and_cup_clear_of_the_objects_at_every_goal() -> None:
    scenario, station = _setup()
    plant, scene_graph = station.plant, station.scene_graph
    context = station.diagram.CreateDefaultContext()
    plant_ctx = plant.GetMyMutableContextFromRoot(context)
    q_idx = [plant.GetJointByName(n).position_start() for n in ARM_JOINTS]
    objects = {g.name for g in scenario.goals}
    for key, q in _drives().items():
        full = plant.GetPositions(plant_ctx)
        full[q_idx] = q
        plant.SetPositions(plant_ctx, full)
        query = scene_graph.get_query_output_port().Eval(scene_graph.GetMyContextFromRoot(context))
        inspector = query.inspector()
        for pair in query.ComputeSignedDistancePairwiseClosestPoints(0.001):
            names = {
                plant.GetBodyFromFrameId(inspector.GetFrameId(pair.id_A)).name(),
                plant.GetBodyFromFrameId(inspector.GetFrameId(pair.id_B)).name(),
            }
            if names & objects and not names <= objects:
                pytest.fail(f"{key}: {sorted(names)} only {pair.distance * 1000:.1f} mm apart")
