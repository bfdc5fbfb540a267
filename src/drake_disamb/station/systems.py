"""The station's three LeafSystems, each usable on its own with a fixed context:

- :class:`DifferentialIKIntegrator`: end-effector velocity command -> arm joint set points (100 Hz);
- :class:`GripperOpeningIntegrator`: finger opening-speed command -> finger set points;
- :class:`EndEffectorState`: the plant's body poses and velocities -> ``ee_pose`` / ``ee_velocity``
  in the project's conventions (quaternion ``[qw, qx, qy, qz]``, velocities in the paper's order
  ``[vx, vy, vz, wx, wy, wz]``, not Drake's ``[w; v]``).

Their discrete states have named layouts (:data:`IkIntegratorState`, :data:`GripperIntegratorState`,
``pydrake.common.containers.namedview`` classes) for reading a state vector by field.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from pydrake.common.containers import namedview
from pydrake.common.value import Value
from pydrake.math import RigidTransform
from pydrake.multibody.math import SpatialVelocity
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable, ModelInstanceIndex
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiscreteValues,
    EventStatus,
    InputPort,
    LeafSystem,
)

from drake_disamb.clearance import Solid
from drake_disamb.core.validation import all_finite
from drake_disamb.ik import IkParams, IkStatus, VelocityIkSolver
from drake_disamb.joint_limits import JointLimits
from drake_disamb.station.config import ARM_JOINTS, ARM_MODEL_NAME, EE_FRAME, SceneObject, StationConfig
from drake_disamb.station.geometry import StationGeometry
from drake_disamb.system_helpers.sanitized import SanitizedInputCounter
from drake_disamb.system_helpers.status import DID_NOTHING

IkIntegratorState = namedview(
    "IkIntegratorState", [f"{j}_q_d" for j in ARM_JOINTS] + [f"{j}_v_d" for j in ARM_JOINTS]
)
"""Layout of :class:`DifferentialIKIntegrator`'s set-point state group (12), its ``desired_state``
output: the set point ``q_d`` (rad, fields ``mico_joint_1_q_d`` ...) and its velocity ``v_d``
(rad/s, ``mico_joint_1_v_d`` ...); the slices :data:`IK_Q_D` and :data:`IK_V_D` take the vectors.
The :class:`~drake_disamb.ik.IkStatus` code of the last step is a second group of its own."""
IK_Q_D = slice(0, 6)
IK_V_D = slice(6, 12)

GripperIntegratorState = namedview("GripperIntegratorState", ["opening", "speed"])
"""Layout of :class:`GripperOpeningIntegrator`'s discrete state: desired opening (m) and its rate (m/s)."""


def _read_command(port: InputPort, context: Context, size: int) -> tuple[NDArray[np.float64], bool]:
    """The command on ``port`` and whether it is valid (finite, right size); invalid -> zeros."""
    value = np.asarray(port.Eval(context), dtype=float).reshape(-1)
    if value.size != size or not all_finite(value):
        return np.zeros(size), False
    return value, True


def _set_point(q: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """The :data:`IkIntegratorState` vector of set point ``q`` and velocity ``v``."""
    x = np.empty(len(IkIntegratorState.get_fields()))
    view = IkIntegratorState(x)
    view[IK_Q_D] = q
    view[IK_V_D] = v
    return x


class DifferentialIKIntegrator(LeafSystem):
    """Turns a commanded end-effector spatial velocity into arm joint set points, at a fixed rate.

    Every ``control_period`` it (1) reads ``ee_velocity_command`` (paper order), (2) computes the
    Jacobian of ``mico_end_effector`` at the integrated set point q_d (rows in the paper's order)
    and solves :meth:`drake_disamb.ik.VelocityIkSolver.solve` there, with the joint position,
    velocity and acceleration limits and the floor ``StationConfig.table_clearance`` under every
    point of the gripper, (3) sets
    ``v_d`` to the solution and integrates ``q_d += v_d * period`` (inside the joint limits by
    construction; clamped against rounding).

    **Motion only where commanded.** The set point's end effector moves along the commanded twist
    and nowhere else: where the command cannot be met in full (a joint limit, a singularity, the
    floor) it is slowed along its own direction or stopped, never bent, and ``ik_status`` says
    why (``LIMITED``, ``SINGULAR``, ``WORKSPACE``, ``STOPPED``); :mod:`drake_disamb.ik` states the
    bound (rounding plus a null-space pull under 0.2 mm/s). On the simulated arm, which tracks
    the set points through its PD, every single-axis command held 10 s from the tested postures
    (home, near the wrist singularity, a joint on its limit, ...) moves the end effector off the
    command by at most 2 cm in total and 1 cm/s (``tests/test_station_safety.py``). The integrator
    is initialised from ``arm_joint_state`` when the simulator initialises and re-seeded from it
    when the set point drifts more than ``reseed_tolerance`` away.

    @system
    name: DifferentialIKIntegrator
    input_ports:
    - ee_velocity_command (6): desired V_WE, [vx, vy, vz, wx, wy, wz] (m/s, rad/s; paper order,
      NOT Drake's [w; v]), expressed in W at the origin of mico_end_effector
    - arm_joint_state (12): measured arm q (rad) then v (rad/s)
    output_ports:
    - desired_state (12): set point q_d (rad) then v_d (rad/s), held between control steps
    - ik_status (1): IkStatus code of the last control step
    - sanitized_input_count (1): control steps whose command had a NaN/inf entry (read as zero)
    @endsystem

    Discrete state: the set point ``[q_d (6), v_d (6)]`` (:data:`IkIntegratorState`), ``[status
    (1)]`` and the sanitised-input count with its warning time
    (:class:`~drake_disamb.system_helpers.sanitized.SanitizedInputCounter`); the outputs are state
    output ports (no Python callback to read them). The floor's table top and the gripper's points
    come from ``geometry``, the station's own :class:`~drake_disamb.station.geometry.StationGeometry`.
    """

    def __init__(
        self,
        control_plant: MultibodyPlant,
        config: StationConfig,
        arm_instance: ModelInstanceIndex | None = None,
        held_objects: Sequence[SceneObject] = (),
        *,
        geometry: StationGeometry,
    ) -> None:
        super().__init__()
        self._plant = control_plant
        self._context = control_plant.CreateDefaultContext()
        instance = (
            arm_instance if arm_instance is not None else control_plant.GetModelInstanceByName(ARM_MODEL_NAME)
        )
        joints = [control_plant.GetJointByName(n, instance) for n in ARM_JOINTS]
        self._q_idx = [j.position_start() for j in joints]
        self._v_idx = [j.velocity_start() for j in joints]
        self._frame_E = control_plant.GetFrameByName(EE_FRAME, instance)
        self._world = control_plant.world_frame()
        self._period = float(config.control_period)
        self._reseed_tol = float(config.reseed_tolerance)
        self._limited_alpha = float(config.limited_alpha)

        lower = np.array([j.position_lower_limits()[0] for j in joints])
        upper = np.array([j.position_upper_limits()[0] for j in joints])
        vmax = (
            np.array(config.joint_velocity_limits)
            if config.joint_velocity_limits is not None
            else np.array([j.velocity_upper_limits()[0] for j in joints])
        )
        amax = np.array(config.joint_acceleration_limits)
        self._lower, self._upper = lower, upper
        self._vmax, self._amax = vmax, amax
        home = np.array(config.home_q)
        if np.any(home < lower) or np.any(home > upper):
            raise ValueError(
                f"StationConfig.home_q: outside the joint limits [{lower}, {upper}], got {home.tolist()}"
            )
        nominal = np.array(config.nominal_posture) if config.nominal_posture is not None else home

        self._floor = None if config.table_clearance is None else geometry.table_top + config.table_clearance
        self._floor_time_constant = max(0.1, self._period)
        held = [
            Solid(o.name, o.shape, tuple(o.size), o.transform().GetAsMatrix4())
            for o in held_objects
            if o.attached_to_gripper
        ]
        self._gripper_points = geometry.gripper_points_in_ee(held)
        self._ik = VelocityIkSolver(
            JointLimits(lower, upper, vmax, amax),
            self._period,
            IkParams(nominal_gain=config.nominal_posture_gain, limited_alpha=self._limited_alpha),
            nominal,
        )

        self._state = self.DeclareDiscreteState(_set_point(home, np.zeros(6)))
        self._status = self.DeclareDiscreteState([float(IkStatus.OK)])
        self._sanitized = SanitizedInputCounter(self, config.warn_interval)
        self._command_port = self.DeclareVectorInputPort("ee_velocity_command", 6)
        self._measured_port = self.DeclareVectorInputPort("arm_joint_state", 12)
        self.DeclareStateOutputPort("desired_state", self._state)
        self.DeclareStateOutputPort("ik_status", self._status)
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._update)
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)

    def control_plant(self) -> MultibodyPlant:
        """The arm-only plant the integrator computes its Jacobian on (owned by the caller)."""
        return self._plant

    @property
    def velocity_limits(self) -> NDArray[np.float64]:
        """Joint speed limits (rad/s) the integrator respects."""
        return self._vmax.copy()

    @property
    def joint_position_limits(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Lower and upper joint limits (rad) the integrator respects."""
        return self._lower.copy(), self._upper.copy()

    def _initialize(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        meas = np.asarray(self._measured_port.Eval(context), dtype=float)
        x = discrete_state.get_mutable_vector(self._state)
        if meas.size == 12 and np.all(np.isfinite(meas[:6])):
            q = np.clip(meas[:6], self._lower, self._upper)
            x.SetFromVector(_set_point(q, np.zeros(6)))
            discrete_state.get_mutable_vector(self._status).SetAtIndex(0, float(IkStatus.OK))
        return EventStatus.Succeeded()

    def _jacobian_at(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """The arm's end-effector Jacobian (Drake's order ``[w; v]``) at ``q``; leaves the control
        plant's context at ``q``."""
        plant, ctx = self._plant, self._context
        q_full = plant.GetPositions(ctx)
        q_full[self._q_idx] = q
        plant.SetPositions(ctx, q_full)
        return plant.CalcJacobianSpatialVelocity(
            ctx, JacobianWrtVariable.kV, self._frame_E, np.zeros(3), self._world, self._world
        )[:, self._v_idx]

    def _sigma_min_at(self, q: NDArray[np.float64]) -> float:
        """The Jacobian's smallest singular value at ``q`` (the IK's singular barrier asks for it at
        a step's end; the row order does not change it)."""
        return float(np.linalg.svd(self._jacobian_at(q), compute_uv=False)[-1])

    def _solve(self, q: NDArray[np.float64], v_prev: NDArray[np.float64], V: NDArray[np.float64]):
        """Joint velocities for the paper-order command V at q, and the status code."""
        J = self._jacobian_at(q)
        ctx = self._context
        rows = lower = None
        if self._floor is not None:
            X_WE = self._frame_E.CalcPoseInWorld(ctx)
            r_W = self._gripper_points @ X_WE.rotation().matrix().T  # from the EE origin, in W
            height = X_WE.translation()[2] + r_W[:, 2] - self._floor
            near = height < 0.2  # the points that could reach the floor within this step
            if near.any():
                # Vertical speed of point i: vz + wx r_y - wy r_x (paper order [v; w]); it may not
                # be below -height / tau: the floor is approached exponentially and never crossed.
                r = r_W[near]
                rows = np.zeros((r.shape[0], 6))
                rows[:, 2] = 1.0
                rows[:, 3] = r[:, 1]
                rows[:, 4] = -r[:, 0]
                lower = -np.maximum(height[near], 0.0) / self._floor_time_constant
        J_paper = J[[3, 4, 5, 0, 1, 2]]  # paper order [v; w]
        solution = self._ik.solve(J_paper, V, q, v_prev, rows, lower, self._sigma_min_at)
        return solution.v, solution.status

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        x = IkIntegratorState(context.get_discrete_state(self._state).get_value())
        q, v_prev = x[IK_Q_D].copy(), x[IK_V_D].copy()
        V, valid = _read_command(self._command_port, context, 6)
        status = IkStatus.OK
        if not valid:
            status = IkStatus.INVALID_COMMAND
            self._sanitized.record(
                context,
                discrete_state,
                "non-finite ee_velocity_command treated as zero (ik_status = INVALID_COMMAND)",
            )
        meas = np.asarray(self._measured_port.Eval(context), dtype=float)[:6]
        # The largest drift; NaN or inf when the measurement is not finite (then no reseed).
        drift = float(np.max(np.abs(q - meas)))
        if self._reseed_tol < drift < math.inf:
            q = np.clip(meas, self._lower, self._upper)
            v = np.zeros(6)
            if status == IkStatus.OK:
                status = IkStatus.RESEEDED
        elif not V.any():
            v = np.zeros(6)
            if (
                valid  # (an invalid command's count is written to the state: not this path)
                and not v_prev.any()
                and context.get_discrete_state(self._status).GetAtIndex(0) == float(status)
            ):
                # At rest with no command (most ticks of a trial): the set point stays where it is
                # (it is within the limits); the update returns before building and writing it.
                return DID_NOTHING
        else:
            v, status = self._solve(q, v_prev, V)
        # np.clip without its Python-level dispatch (the same values, NaN propagating alike).
        q_next = np.minimum(np.maximum(q + v * self._period, self._lower), self._upper)
        discrete_state.get_mutable_vector(self._state).SetFromVector(_set_point(q_next, v))
        discrete_state.get_mutable_vector(self._status).SetAtIndex(0, float(status))
        return EventStatus.Succeeded()


class GripperOpeningIntegrator(LeafSystem):
    """Integrates the finger opening-speed command into symmetric finger set points.

    @system
    name: GripperOpeningIntegrator
    input_ports:
    - gripper_command (1): opening speed, m/s (positive opens); NaN/inf is treated as 0 with a warning
    - finger_state (4): measured finger q_left, q_right (m) then v_left, v_right (m/s)
    output_ports:
    - finger_desired_state (4): q_left, q_right (m) then v_left, v_right (m/s); each finger is at
      half the desired opening
    - desired_opening (1): desired distance between the fingertips, m
    - sanitized_input_count (1): control steps whose command was NaN/inf (read as zero)
    @endsystem

    Discrete state ``[opening_d (m), speed_d (m/s)]`` (:data:`GripperIntegratorState`), plus the
    sanitised-input count (:class:`~drake_disamb.system_helpers.sanitized.SanitizedInputCounter`); the opening
    is clamped to ``[0, max_opening]``, initialised from ``finger_state`` when the simulator
    initialises.
    """

    def __init__(
        self, control_period: float, max_opening: float, initial_opening: float, warn_interval: float = 1.0
    ):
        super().__init__()
        if not (math.isfinite(control_period) and control_period > 0):
            raise ValueError(f"GripperOpeningIntegrator.control_period: expected > 0, got {control_period!r}")
        if not (math.isfinite(max_opening) and max_opening > 0):
            raise ValueError(f"GripperOpeningIntegrator.max_opening: expected > 0, got {max_opening!r}")
        if not (0 <= initial_opening <= max_opening):
            raise ValueError(
                f"GripperOpeningIntegrator.initial_opening: expected a number in [0, {max_opening}], "
                f"got {initial_opening!r}"
            )
        self._period = float(control_period)
        self._max = float(max_opening)
        self._state = self.DeclareDiscreteState(np.array([initial_opening, 0.0]))
        self._sanitized = SanitizedInputCounter(self, warn_interval)
        self._command_port = self.DeclareVectorInputPort("gripper_command", 1)
        self._finger_port = self.DeclareVectorInputPort("finger_state", 4)
        ticket = {self.discrete_state_ticket(self._state)}
        self.DeclareVectorOutputPort(
            "finger_desired_state", 4, self._calc_desired, prerequisites_of_calc=ticket
        )
        self.DeclareVectorOutputPort("desired_opening", 1, self._calc_opening, prerequisites_of_calc=ticket)
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._update)
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)

    def _calc_desired(self, context: Context, output: BasicVector) -> None:
        x = GripperIntegratorState(context.get_discrete_state(self._state).get_value())
        output.SetFromVector([x.opening / 2, x.opening / 2, x.speed / 2, x.speed / 2])

    def _calc_opening(self, context: Context, output: BasicVector) -> None:
        output.SetAtIndex(
            0, GripperIntegratorState(context.get_discrete_state(self._state).get_value()).opening
        )

    def _initialize(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        meas = np.asarray(self._finger_port.Eval(context), dtype=float)
        if np.all(np.isfinite(meas[:2])):
            opening = float(np.clip(meas[0] + meas[1], 0.0, self._max))
            discrete_state.get_mutable_vector(self._state).SetFromVector([opening, 0.0])
        return EventStatus.Succeeded()

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        state = GripperIntegratorState(context.get_discrete_state(self._state).get_value())
        cmd = self._command_port.Eval(context)[0].item()
        if cmd == 0.0 and state.speed == 0.0:
            return DID_NOTHING  # at rest and not commanded (most ticks): nothing changes
        opening = float(state.opening)
        if not math.isfinite(cmd):
            cmd = 0.0
            self._sanitized.record(context, discrete_state, "non-finite gripper_command treated as zero")
        new = min(max(opening + cmd * self._period, 0.0), self._max)  # np.clip of a finite number
        discrete_state.get_mutable_vector(self._state).SetFromVector([new, (new - opening) / self._period])
        return EventStatus.Succeeded()


class EndEffectorState(LeafSystem):
    """Pose and spatial velocity of one body, in the project's vector conventions.

    @system
    name: EndEffectorState
    input_ports:
    - body_poses (abstract): list of RigidTransform X_WB (MultibodyPlant body_poses output)
    - body_spatial_velocities (abstract): list of SpatialVelocity V_WB (MultibodyPlant output)
    output_ports:
    - ee_pose (7): [x, y, z, qw, qx, qy, qz] of the body frame in W (m)
    - ee_velocity (6): [vx, vy, vz, wx, wy, wz] of the body origin in W (m/s, rad/s; paper order)
    @endsystem
    """

    def __init__(self, body_index: int) -> None:
        super().__init__()
        self._index = int(body_index)
        self._poses = self.DeclareAbstractInputPort("body_poses", Value([RigidTransform()]))
        self._vels = self.DeclareAbstractInputPort("body_spatial_velocities", Value([SpatialVelocity()]))
        self.DeclareVectorOutputPort(
            "ee_pose", 7, self._calc_pose, prerequisites_of_calc={self._poses.ticket()}
        )
        self.DeclareVectorOutputPort(
            "ee_velocity", 6, self._calc_velocity, prerequisites_of_calc={self._vels.ticket()}
        )

    def _calc_pose(self, context: Context, output: BasicVector) -> None:
        X = self._poses.Eval(context)[self._index]
        output.SetFromVector(np.concatenate([X.translation(), X.rotation().ToQuaternion().wxyz()]))

    def _calc_velocity(self, context: Context, output: BasicVector) -> None:
        V = self._vels.Eval(context)[self._index]
        output.SetFromVector(np.concatenate([V.translational(), V.rotational()]))
