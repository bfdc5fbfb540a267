"""The simulated station's two LeafSystems, each usable on its own with a fixed context:

- :class:`JointVelocityIntegrator`: the arm in velocity mode, as a Kinova Gen2 arm's driver runs it:
  the commanded joint and finger velocities -> the set points the plant's joint PD tracks;
- :class:`EndEffectorState`: the plant's body poses and velocities -> ``ee_pose`` / ``ee_velocity``
  in the project's conventions (quaternion ``[qw, qx, qy, qz]``, velocities in the paper's order
  ``[vx, vy, vz, wx, wy, wz]``, not Drake's ``[w; v]``).

The controllers that turn the shared-control commands into these joint velocities are
:mod:`drake_disamb.controller`'s.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray
from pydrake.common.value import Value
from pydrake.math import RigidTransform
from pydrake.multibody.math import SpatialVelocity
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiscreteValues,
    EventStatus,
    LeafSystem,
)

from drake_disamb.core.validation import all_finite
from drake_disamb.system_helpers.sanitized import SanitizedInputCounter
from drake_disamb.system_helpers.status import DID_NOTHING


class JointVelocityIntegrator(LeafSystem):
    """The simulated arm's velocity mode: integrates the commanded joint and finger velocities into
    the set points its joint PD tracks, inside the joint limits and the fingers' travel.

    Every ``period`` the set point ``q`` advances by the command over that period: the
    ``desired_state`` the plant tracks is ``q_d = clip(q + v * period)`` with velocity ``v`` for the
    arm (the limits clamp only rounding there: the IK never commands past them) and, for the
    fingers, the rate at which their set point moves (zero against a stop: a gripper command may
    push past it), and at each tick ``q_d`` becomes the new ``q``. ``desired_state`` thus follows
    the command held on the inputs at once, which the controllers change only at their ticks: it is
    the set point for the end of the current period. Like a drive's following-error guard, an arm
    set point further than ``reseed_tolerance`` (any joint) from the measured angles is re-anchored
    at them (clamped to the limits), so that an arm held back (blocked by contact) does not wind up
    its set point; the differential IK re-seeds its own integrated set point, computed the same
    way from the same joint velocities, at the same tick.

    @system
    name: JointVelocityIntegrator
    input_ports:
    - arm_velocity_command (6): joint velocities, rad/s (DH joint order); NaN/inf -> 0 with a warning
    - finger_velocity_command (2): finger slide velocities, m/s (positive opens); NaN/inf -> 0
    - arm_joint_state (12): measured arm q (rad) then v (rad/s)
    - finger_state (4): measured finger slides (m) then velocities (m/s)
    output_ports:
    - desired_state (16): set points [arm q (6, rad), finger q (2, m), arm v (6, rad/s), finger v
      (2, m/s)], joints in ARM_JOINTS + FINGER_JOINTS order
    - sanitized_input_count (1): control ticks whose command had a NaN/inf entry (read as zero)
    @endsystem

    Discrete state: the set point ``[arm q (6), finger q (2)]`` at the last tick, initialised from
    the measured state when the simulator initialises (``home_q`` and ``home_fingers`` before), and
    the sanitised-input count (:class:`~drake_disamb.system_helpers.sanitized.SanitizedInputCounter`).
    """

    def __init__(
        self,
        period: float,
        lower: NDArray[np.float64],
        upper: NDArray[np.float64],
        finger_travel: float,
        home_q: Sequence[float],
        home_fingers: Sequence[float],
        reseed_tolerance: float = math.inf,
        warn_interval: float = 1.0,
    ) -> None:
        super().__init__()
        if not (math.isfinite(period) and period > 0):
            raise ValueError(f"JointVelocityIntegrator.period: expected > 0, got {period!r}")
        self._period = float(period)
        self._lower = np.asarray(lower, dtype=float).copy()
        self._upper = np.asarray(upper, dtype=float).copy()
        self._travel = float(finger_travel)
        self._low = np.concatenate((self._lower, [0.0, 0.0]))  # the arm's limits, the fingers' travel
        self._high = np.concatenate((self._upper, [self._travel] * 2))
        self._reseed_tol = float(reseed_tolerance)
        self._set_point = self.DeclareDiscreteState(np.concatenate([home_q, home_fingers]).astype(float))
        self._sanitized = SanitizedInputCounter(self, warn_interval)
        self._arm_port = self.DeclareVectorInputPort("arm_velocity_command", 6)
        self._finger_port = self.DeclareVectorInputPort("finger_velocity_command", 2)
        self._measured_port = self.DeclareVectorInputPort("arm_joint_state", 12)
        self._fingers_port = self.DeclareVectorInputPort("finger_state", 4)
        prerequisites = {
            self.discrete_state_ticket(self._set_point),
            self._arm_port.ticket(),
            self._finger_port.ticket(),
        }
        self._desired_port = self.DeclareVectorOutputPort(
            "desired_state", 16, self._calc_desired, prerequisites_of_calc=prerequisites
        )
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._update)
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)

    @property
    def joint_position_limits(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Lower and upper arm joint limits (rad) of the set points."""
        return self._lower.copy(), self._upper.copy()

    def _calc_desired(self, context: Context, output: BasicVector) -> None:
        q = context.get_discrete_state(self._set_point).get_value()
        v = self._arm_port.Eval(context)
        fv = self._finger_port.Eval(context)
        w = np.concatenate((v, fv))
        if not all_finite(w):
            w = np.zeros(8)
        # The set point one period on (np.clip without its Python-level dispatch: the same values).
        x = np.minimum(np.maximum(q + w * self._period, self._low), self._high)
        output.SetFromVector(np.concatenate((x, w[:6], (x[6:] - q[6:]) / self._period)))

    def _initialize(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        x = discrete_state.get_mutable_vector(self._set_point)
        q = x.CopyToVector()
        arm = np.asarray(self._measured_port.Eval(context), dtype=float)[:6]
        if all_finite(arm):
            q[:6] = np.minimum(np.maximum(arm, self._lower), self._upper)
        fingers = np.asarray(self._fingers_port.Eval(context), dtype=float)[:2]
        if all_finite(fingers):
            q[6:] = np.minimum(np.maximum(fingers, 0.0), self._travel)
        x.SetFromVector(q)
        return EventStatus.Succeeded()

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        # The set point the plant tracks this period (computed once: the plant has read it).
        desired = self._desired_port.Eval(context)
        write = desired[8:].any()  # commanded (a non-finite command was read as zero: checked here)
        if not write and not all_finite(self._arm_port.Eval(context), self._finger_port.Eval(context)):
            write = True  # (the count)
            self._sanitized.record(
                context, discrete_state, "non-finite arm or finger velocity command treated as zero"
            )
        meas = self._measured_port.Eval(context)[:6]
        # The largest drift; NaN or inf when the measurement is not finite (then no re-anchoring).
        drift = float(np.abs(desired[:6] - meas).max())
        if self._reseed_tol < drift < math.inf:
            arm = np.minimum(np.maximum(meas, self._lower), self._upper)
            discrete_state.get_mutable_vector(self._set_point).SetFromVector(
                np.concatenate((arm, desired[6:8]))
            )
        elif write:
            discrete_state.get_mutable_vector(self._set_point).SetFromVector(desired[:8])
        else:
            return DID_NOTHING  # at rest (most ticks of a trial): the set point stays where it is
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
