"""The controllers between the shared-control commands and the station's joint-level inputs, each
usable on its own with a fixed context:

- :class:`DifferentialIKIntegrator`: the commanded end-effector velocity -> the arm's joint
  velocities (the direction-preserving IK of :mod:`drake_disamb.ik`, with its integrated set point,
  its floor above the table and its ``ik_status``);
- :class:`GripperController`: the gripper's opening speed -> the two finger slides' velocities.

Both tick every control period and hold their output between ticks, as the station's joint
velocity commands of a Kinova Gen2 arm (``lcmt_jaco_command``) are sent once per period.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable, ModelInstanceIndex
from pydrake.systems.framework import (
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
from drake_disamb.station.config import (
    ARM_JOINTS,
    ARM_MODEL_NAME,
    EE_FRAME,
    SceneObject,
    StationConfig,
    arm_velocity_limits,
)
from drake_disamb.station.geometry import StationGeometry
from drake_disamb.system_helpers.sanitized import SanitizedInputCounter
from drake_disamb.system_helpers.status import DID_NOTHING


def _read_command(port: InputPort, context: Context, size: int) -> tuple[NDArray[np.float64], bool]:
    """The command on ``port`` and whether it is valid (finite, right size); invalid -> zeros."""
    value = np.asarray(port.Eval(context), dtype=float).reshape(-1)
    if value.size != size or not all_finite(value):
        return np.zeros(size), False
    return value, True


class DifferentialIKIntegrator(LeafSystem):
    """Turns a commanded end-effector spatial velocity into the arm's joint velocities, at a fixed
    rate: the controller between the blender and the station's ``arm_velocity_command``.

    Every ``control_period`` it (1) reads ``ee_velocity_command`` (paper order), (2) computes the
    Jacobian of ``mico_end_effector`` at its integrated set point q_d (rows in the paper's order)
    and solves :meth:`drake_disamb.ik.VelocityIkSolver.solve` there, with the joint position,
    velocity and acceleration limits and the floor ``StationConfig.table_clearance`` under every
    point of the gripper, (3) outputs the solution ``v`` as ``arm_velocity_command`` and integrates
    ``q_d += v * period`` (inside the joint limits by construction; clamped against rounding). The
    simulated arm's velocity mode integrates the same joint velocities the same way
    (:class:`~drake_disamb.station.systems.JointVelocityIntegrator`), so that its set point and q_d
    agree; on a wire q_d is where the IK expects the arm to be.

    **Motion only where commanded.** The set point's end effector moves along the commanded twist
    and nowhere else: where the command cannot be met in full (a joint limit, a singularity, the
    floor) it is slowed along its own direction or stopped, never bent, and ``ik_status`` says
    why (``LIMITED``, ``SINGULAR``, ``WORKSPACE``, ``STOPPED``); :mod:`drake_disamb.ik` states the
    bound (rounding plus a null-space pull under 0.2 mm/s). On the simulated arm, which tracks
    the set points through its PD, every single-axis command held 10 s from the tested postures
    (home, near the wrist singularity, a joint on its limit, ...) moves the end effector off the
    command by at most 2 cm in total and 1 cm/s (``tests/test_station_safety.py``). The set point
    is initialised from ``arm_joint_state`` when the simulator initialises and re-seeded from it
    (with a zero velocity for that tick) when it drifts more than ``reseed_tolerance`` away.

    @system
    name: DifferentialIKIntegrator
    input_ports:
    - ee_velocity_command (6): desired V_WE, [vx, vy, vz, wx, wy, wz] (m/s, rad/s; paper order,
      NOT Drake's [w; v]), expressed in W at the origin of mico_end_effector
    - arm_joint_state (12): measured arm q (rad) then v (rad/s)
    output_ports:
    - arm_velocity_command (6): joint velocities v (rad/s, DH joint order), held between control steps
    - set_point (6): the integrated set point q_d (rad) after the last control step
    - ik_status (1): IkStatus code of the last control step
    - sanitized_input_count (1): control steps whose command had a NaN/inf entry (read as zero)
    @endsystem

    Discrete state: the set point ``[q_d (6)]``, the velocity ``[v (6)]``, ``[status (1)]`` and the
    sanitised-input count with its warning time
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
        vmax = arm_velocity_limits(config, control_plant, instance)
        amax = np.array(config.joint_acceleration_limits)
        self._lower, self._upper = lower, upper
        self._vmax, self._amax = vmax, amax
        home = np.array(config.home_q)
        # The station's own config: building the station refused a home posture outside the limits.
        assert np.all(home >= lower) and np.all(home <= upper), home
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

        self._set_point = self.DeclareDiscreteState(home)
        self._velocity = self.DeclareDiscreteState(np.zeros(6))
        self._status = self.DeclareDiscreteState([float(IkStatus.OK)])
        self._sanitized = SanitizedInputCounter(self, config.warn_interval)
        self._command_port = self.DeclareVectorInputPort("ee_velocity_command", 6)
        self._measured_port = self.DeclareVectorInputPort("arm_joint_state", 12)
        self.DeclareStateOutputPort("arm_velocity_command", self._velocity)
        self.DeclareStateOutputPort("set_point", self._set_point)
        self.DeclareStateOutputPort("ik_status", self._status)
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._update)
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)

    def control_plant(self) -> MultibodyPlant:
        """The arm-only plant the IK computes its Jacobian on (owned by the caller)."""
        return self._plant

    @property
    def velocity_limits(self) -> NDArray[np.float64]:
        """Joint speed limits (rad/s) the IK respects."""
        return self._vmax.copy()

    @property
    def joint_position_limits(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Lower and upper joint limits (rad) the IK respects."""
        return self._lower.copy(), self._upper.copy()

    def _initialize(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        meas = np.asarray(self._measured_port.Eval(context), dtype=float)
        if meas.size == 12 and np.all(np.isfinite(meas[:6])):
            q = np.clip(meas[:6], self._lower, self._upper)
            discrete_state.get_mutable_vector(self._set_point).SetFromVector(q)
            discrete_state.get_mutable_vector(self._velocity).SetFromVector(np.zeros(6))
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
        q = context.get_discrete_state(self._set_point).CopyToVector()
        v_prev = context.get_discrete_state(self._velocity).CopyToVector()
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
        discrete_state.get_mutable_vector(self._set_point).SetFromVector(q_next)
        discrete_state.get_mutable_vector(self._velocity).SetFromVector(v)
        discrete_state.get_mutable_vector(self._status).SetAtIndex(0, float(status))
        return EventStatus.Succeeded()


class GripperController(LeafSystem):
    """The gripper's opening speed -> the finger slides' velocities: each finger moves at half the
    opening speed (the fingers close symmetrically), sampled every ``config.control_period`` (the
    station's :class:`~drake_disamb.station.config.StationConfig`, which also gives the warnings'
    ``warn_interval``) and held.

    @system
    name: GripperController
    input_ports:
    - gripper_command (1): opening speed, m/s (positive opens); NaN/inf is treated as 0 with a warning
    output_ports:
    - finger_velocity_command (2): velocities of the left and right finger slides, m/s
    - sanitized_input_count (1): control steps whose command was NaN/inf (read as zero)
    @endsystem

    Discrete state ``[left, right]`` (m/s), the output; plus the sanitised-input count
    (:class:`~drake_disamb.system_helpers.sanitized.SanitizedInputCounter`). The opening's limits
    are the fingers' travel, which the station keeps.
    """

    def __init__(self, config: StationConfig) -> None:
        super().__init__()
        assert isinstance(config, StationConfig), config  # a StationConfig checks itself when made
        self._state = self.DeclareDiscreteState(np.zeros(2))
        self._sanitized = SanitizedInputCounter(self, config.warn_interval)
        self._command_port = self.DeclareVectorInputPort("gripper_command", 1)
        self.DeclareStateOutputPort("finger_velocity_command", self._state)
        self.DeclarePeriodicDiscreteUpdateEvent(config.control_period, 0.0, self._update)

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        cmd = self._command_port.Eval(context)[0].item()
        if not math.isfinite(cmd):
            cmd = 0.0
            self._sanitized.record(context, discrete_state, "non-finite gripper_command treated as zero")
        elif context.get_discrete_state(self._state).GetAtIndex(0) == cmd * 0.5:
            return DID_NOTHING  # the same command as at the last tick (most ticks): nothing changes
        discrete_state.get_mutable_vector(self._state).SetFromVector([cmd * 0.5, cmd * 0.5])
        return EventStatus.Succeeded()
