"""Every task goal is a pose the MICO can hold from its start, clear of the IK's singular barrier.

A goal whose exact pose lies outside the arm's workspace can still be "reached" within the success
tolerances (2 cm, 0.15 rad), but only at the edge of the workspace, where the station's IK slows
every command that needs the arm stretched further and refuses one that would take the smallest
singular value of the Jacobian below ``IkParams.singular_barrier``. The reaching task's red box was
such a goal with a 30-degree lean (no exact IK solution from any seed): the simulated users' reaches
to it were their longest, where the study's people reached it fastest. Leaned 45 degrees straight
toward it, it has exact solutions, but not on the arm's branch from its start: the wrist (joint 5)
would have to pass its singularity at pi, so the arm stops at the barrier above the box.

So each goal pose must have an exact inverse-kinematics solution within the joint limits on the
start's branch (the solution nearest the task's start posture, which a continuous path from the
start keeps to), and its Jacobian's smallest singular value must be at least :data:`MARGIN` (four
times the barrier, well above ``IkParams.singular_threshold``).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from pydrake.common.eigen_geometry import Quaternion
from pydrake.math import RotationMatrix
from pydrake.multibody.inverse_kinematics import InverseKinematics
from pydrake.multibody.tree import JacobianWrtVariable
from pydrake.solvers import Solve

from drake_disamb.config import load_scenario
from drake_disamb.ik import IkParams
from drake_disamb.station import EE_FRAME, MICO_HOME_Q, StationConfig, build_station

MARGIN = 4.0 * IkParams().singular_barrier
"""Smallest singular value a goal pose must allow (m/rad for translation rows, 1 for rotation)."""

SEEDS = 12
"""Start guesses per goal for :func:`_best_sigma`: the home posture, then random ones around it."""


@functools.cache
def _arm():
    station = build_station(StationConfig(), [])
    plant = station.control_plant
    return plant, plant.GetFrameByName(EE_FRAME)


def _sigma_at_solution(
    position: list[float], orientation: list[float], guess: np.ndarray, nearest: bool
) -> float | None:
    """The Jacobian's smallest singular value at an exact IK solution of the pose from ``guess``
    (with ``nearest``, the solution nearest ``guess``), or None when the solver finds none."""
    plant, frame = _arm()
    q = np.asarray(orientation, dtype=float)
    p = np.asarray(position, dtype=float)
    ik = InverseKinematics(plant, plant.CreateDefaultContext())
    ik.AddPositionConstraint(frame, [0.0, 0.0, 0.0], plant.world_frame(), p - 1e-5, p + 1e-5)
    ik.AddOrientationConstraint(
        plant.world_frame(), RotationMatrix(Quaternion(q / np.linalg.norm(q))), frame, RotationMatrix(), 1e-4
    )
    if nearest:
        ik.prog().AddQuadraticErrorCost(np.eye(guess.size), guess, ik.q())
    ik.prog().SetInitialGuess(ik.q(), guess)
    result = Solve(ik.prog())
    if not result.is_success():
        return None
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, result.GetSolution(ik.q()))
    J = plant.CalcJacobianSpatialVelocity(
        context, JacobianWrtVariable.kV, frame, [0.0, 0.0, 0.0], plant.world_frame(), plant.world_frame()
    )
    return float(np.linalg.svd(J[:, :6], compute_uv=False).min())


def _best_sigma(position: list[float], orientation: list[float]) -> float | None:
    """The largest smallest singular value over exact IK solutions of the pose (None: none found)."""
    plant, _ = _arm()
    home = plant.GetPositions(plant.CreateDefaultContext())
    sigmas = [
        _sigma_at_solution(
            position,
            orientation,
            home + (np.random.default_rng(k).normal(0.0, 1.2, home.size) if k else 0.0),
            False,
        )
        for k in range(SEEDS)
    ]
    found = [v for v in sigmas if v is not None]
    return max(found) if found else None


def _start_branch_sigma(position: list[float], orientation: list[float], start: list[float]) -> float | None:
    """The smallest singular value at the exact IK solution nearest ``start`` (None: none)."""
    plant, _ = _arm()
    q0 = plant.GetPositions(plant.CreateDefaultContext())
    q0[: len(start)] = start
    return _sigma_at_solution(position, orientation, q0, True)


GOALS = [
    (task, goal.name, goal.position, goal.orientation, start)
    for task in ("reaching", "pouring")
    for scenario in [load_scenario(task)]
    for start in [list(scenario.start_joint_positions or MICO_HOME_Q)]
    for goal in scenario.goals
]


@pytest.mark.parametrize(
    ("task", "name", "position", "orientation", "start"), GOALS, ids=[f"{g[0]}-{g[1]}" for g in GOALS]
)
def test_every_goal_pose_is_held_from_the_start_clear_of_the_singular_barrier(
    task: str, name: str, position: list[float], orientation: list[float], start: list[float]
) -> None:
    sigma = _start_branch_sigma(position, orientation, start)
    assert sigma is not None, f"{task} goal {name}: no joint posture near the start holds the pose exactly"
    assert sigma >= MARGIN, f"{task} goal {name}: smallest singular value {sigma:.4f} < {MARGIN}"


def test_the_red_box_leaned_30_degrees_is_out_of_reach() -> None:
    """The red box's target until 2026-12-05 (lean 30, finger yaw -45): no exact posture at all."""
    assert _best_sigma([0.328, -0.516, 0.100], [0.1503, 0.8924, -0.3696, 0.2107]) is None


def test_the_red_box_leaned_45_degrees_toward_it_is_off_the_start_branch() -> None:
    """Leaned 45 degrees straight toward the box (azimuth -58): held by some posture, not by the
    home posture's branch."""
    pose = ([0.328, -0.516, 0.100], [0.2222, 0.8536, -0.3536, 0.3115])
    assert _best_sigma(*pose) is not None
    assert _start_branch_sigma(*pose, list(MICO_HOME_Q)) is None
