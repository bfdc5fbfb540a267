"""Cost of one differential-IK step (drake_disamb.ik) on the MICO's Jacobian.

Usage: ``python benchmarks/bench_ik.py [--calls 3000]``. Prints the median and 95th percentile
wall time (microseconds) of ``VelocityIkSolver.solve`` for: the fast path (home pose, a command
J^-1 V meets every limit), the robust path at a near-singular wrist (theta_5 = 0.01), the robust
path with joint 3 on its limit, and for comparison Drake's Jacobian evaluation and Drake's own
``DoDifferentialInverseKinematics`` (the same direction-preserving problem posed as a
MathematicalProgram and handed to a QP solver) on the home case.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from pydrake.multibody.inverse_kinematics import (
    DifferentialInverseKinematicsParameters,
    DoDifferentialInverseKinematics,
)
from pydrake.multibody.tree import JacobianWrtVariable

from drake_disamb.ik import IkStatus, VelocityIkSolver
from drake_disamb.joint_limits import JointLimits
from drake_disamb.station import EE_FRAME, MICO_HOME_Q, StationConfig, build_station


def _timed(fn, calls: int) -> tuple[float, float]:
    times = np.empty(calls)
    for k in range(calls):
        t0 = time.perf_counter()
        fn()
        times[k] = time.perf_counter() - t0
    return float(np.median(times) * 1e6), float(np.percentile(times, 95) * 1e6)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=3000)
    args = parser.parse_args()

    station = build_station(StationConfig())
    plant = station.control_plant
    ctx = plant.CreateDefaultContext()
    frame = plant.GetFrameByName(EE_FRAME)
    lower, upper = station.geometry.joint_limits()
    vmax = np.array([plant.GetJointByName(f"mico_joint_{i}").velocity_upper_limits()[0] for i in range(1, 7)])
    solver = VelocityIkSolver(JointLimits(lower, upper, vmax, [20.0] * 6), 0.01, q_nominal=MICO_HOME_Q)

    def jacobian(q: np.ndarray) -> np.ndarray:
        x = plant.GetPositions(ctx)
        x[:6] = q
        plant.SetPositions(ctx, x)
        Jd = plant.CalcJacobianSpatialVelocity(
            ctx, JacobianWrtVariable.kV, frame, np.zeros(3), plant.world_frame(), plant.world_frame()
        )[:, :6]
        return Jd[[3, 4, 5, 0, 1, 2]]

    home = np.array(MICO_HOME_Q)
    singular = home.copy()
    singular[4] = 0.01
    at_limit = home.copy()
    at_limit[2] = lower[2]
    cases = []
    J = jacobian(home)
    V = np.array([0.05, 0.0, 0.0, 0.0, 0.0, 0.0])
    cases.append(("fast path (home, 5 cm/s along x)", J, V, home, np.linalg.solve(J, V)))
    J = jacobian(singular)
    V = np.array([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
    cases.append(("near-singular wrist (theta_5 = 0.01)", J, V, singular, np.zeros(6)))
    J = jacobian(at_limit)
    V = J @ np.array([0.0, 0.0, -0.3, 0.0, 0.0, 0.0])
    cases.append(("joint 3 on its lower limit", J, V, at_limit, np.zeros(6)))
    print(f"{'case':40s} {'status':>9s} {'median us':>10s} {'p95 us':>8s}")
    for name, J, V, q, v_prev in cases:
        status = IkStatus(solver.solve(J, V, q, v_prev).status).name
        med, p95 = _timed(lambda J=J, V=V, q=q, v=v_prev: solver.solve(J, V, q, v), args.calls)
        print(f"{name:40s} {status:>9s} {med:10.1f} {p95:8.1f}")
    med, p95 = _timed(lambda: jacobian(home), args.calls)
    print(f"{'(Drake Jacobian, for comparison)':40s} {'':>9s} {med:10.1f} {p95:8.1f}")
    params = DifferentialInverseKinematicsParameters(6, 6)
    params.set_time_step(0.01)
    params.set_joint_position_limits((lower, upper))
    params.set_joint_velocity_limits((-vmax, vmax))
    params.set_joint_acceleration_limits((np.full(6, -20.0), np.full(6, 20.0)))
    params.set_nominal_joint_position(home)
    J = jacobian(home)
    V = np.array([0.05, 0.0, 0.0, 0.0, 0.0, 0.0])
    J_drake, V_drake = J[[3, 4, 5, 0, 1, 2]], V[[3, 4, 5, 0, 1, 2]]
    v0 = np.linalg.solve(J, V)
    result = DoDifferentialInverseKinematics(home, v0, V_drake, J_drake, params)
    med, p95 = _timed(lambda: DoDifferentialInverseKinematics(home, v0, V_drake, J_drake, params), args.calls)
    label = "(Drake DoDifferentialInverseKinematics)"
    print(f"{label:40s} {result.status.name[1:]:>9s} {med:10.1f} {p95:8.1f}")


if __name__ == "__main__":
    main()
