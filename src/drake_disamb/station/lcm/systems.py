"""The LeafSystems on either end of the wire, each usable on its own with a fixed context.

The station on LCM (the controller's side):

- :class:`JacoStatusReceiver`: waits for each status (the controller's clock), checks it, keeps
  the measurement in its state, and latches a fault (the watchdog, a joint outside the limits);
- :class:`ModelEndEffectorState`: measured arm angles -> ``ee_pose`` / ``ee_velocity`` from our
  model (paper order ``[vx, vy, vz, wx, wy, wz]`` in W);
- :class:`JacoCommandSender`: the station's joint and finger velocity commands -> one
  ``lcmt_jaco_command`` per control tick, zero once a fault is latched, clamped to the speed limits.

The simulated driver (the arm's side):

- :class:`JacoCommandReceiver`: the latest valid command -> the simulated station's joint and finger
  velocity commands, zero once commands stopped coming;
- :class:`JacoStatusSender`: the simulated station's measured joints and fingers -> one
  ``lcmt_jaco_status`` each time it is asked (a forced publish).
"""

from __future__ import annotations

import time
import warnings

import numpy as np
from numpy.typing import NDArray
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import JacobianWrtVariable, ModelInstanceIndex
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, EventStatus, LeafSystem

from drake_disamb.station.config import ARM_JOINTS, EE_FRAME
from drake_disamb.station.lcm.bus import CommandInbox, CommandLink, StatusInbox, StatusLink
from drake_disamb.station.lcm.faults import Fault
from drake_disamb.station.lcm.loop import prepare_loop
from drake_disamb.station.lcm.messages import (
    StatusReading,
    make_command,
    make_status,
    out_of_order,
    read_status,
)
from drake_disamb.system_helpers.sanitized import SanitizedInputCounter

LIMIT_TOLERANCE = 1e-6
"""Rounding allowed (rad) beyond a joint limit before a measured angle counts as outside it."""
MAX_JOINT_SPEED = 2.0
"""A joint speed (rad/s) no arm on the wire reaches: more than twice the MICO's fastest joint (48
deg/s = 0.84 rad/s)."""
JUMP_TOLERANCE = 0.05
"""A status whose joint moved further than ``JUMP_TOLERANCE + MAX_JOINT_SPEED * dt`` (rad) from the
last status used, ``dt`` the ``utime`` between them, jumped: it is not that arm's."""
STRAYS_TO_FAULT = 3
"""Statuses out of sequence (``utime`` gone back or repeated, a posture that jumped) that latch
:attr:`Fault.TWO_SOURCES` when they fall within :data:`STRAY_WINDOW`."""
STRAY_WINDOW = 1.0
"""The window (s of the controller's time) of :data:`STRAYS_TO_FAULT`."""
SPACING_WINDOW = 8
"""Statuses over which the receiver takes the driver's announced period: the smallest ``utime``
step between consecutive statuses used among the last ``SPACING_WINDOW`` (a missed status only
lengthens a step)."""


def within_speed_limits(v: NDArray[np.float64], limits: NDArray[np.float64]) -> NDArray[np.float64]:
    """The joint velocities ``v`` scaled down, all joints alike (the direction is kept), until every
    one is within its speed limit ``limits`` (same units); unchanged when they all are already."""
    v = np.asarray(v, dtype=float)
    scale = float(np.min(np.asarray(limits, dtype=float) / np.maximum(np.abs(v), 1e-300)))
    return v * scale if scale < 1.0 else v


def posture_jump(q: NDArray[np.float64], utime: int, last_q: NDArray[np.float64], last_utime: int) -> str:
    """Why the DH angles ``q`` (6, rad) at ``utime`` (us) cannot follow ``last_q`` at
    ``last_utime`` on one arm (a joint moved further than :data:`JUMP_TOLERANCE` plus
    :data:`MAX_JOINT_SPEED` over the time between them), or ``""``."""
    dt = max(utime - last_utime, 0) * 1e-6
    moved = np.abs(np.asarray(q, float) - np.asarray(last_q, float))
    k = int(np.argmax(moved))
    if moved[k] <= JUMP_TOLERANCE + MAX_JOINT_SPEED * dt:
        return ""
    return f"posture jumped: joint {k + 1} moved {moved[k]:.4f} rad in {dt:.3f} s"


class JacoStatusReceiver(LeafSystem):
    """The controller's clock and the arm's measurement: at every tick, waits for a fresh status.

    Every ``period`` it polls the bus until a status arrives that decodes, has 6 joints and 2
    fingers, is finite and follows the last one used: a ``utime`` after its own, and no joint
    moved further than an arm moves in that time (:func:`posture_jump`). Others are dropped and
    counted on ``sanitized_input_count``; of several (a burst) the latest is used, and the ones
    skipped are counted as missed (LCM over UDP keeps only the latest message of a channel, so
    there they show only as a gap in ``utime``). The loop's first tick discards what waits on the
    bus (it was published before the loop started, while the station was being built) and waits
    for a fresh status; the watchdog and the missed count start there. Faults it latches:

    - :attr:`Fault.JOINT_LIMIT`: a status puts a joint outside the model's limits;
    - :attr:`Fault.STATUS_TIMEOUT`: no usable status within the status timeout (wall clock) of
      the last one;
    - :attr:`Fault.TWO_SOURCES`: :data:`STRAYS_TO_FAULT` statuses out of sequence (``utime`` gone
      back or repeated, or a posture that jumped) within :data:`STRAY_WINDOW`, or the watchdog's
      timeout with only such statuses since the last one used: one is a stray (a garbled or
      replayed message, dropped), a stream of them is a second driver on the channel (over UDP
      its statuses can also hide the first driver's: one message per channel is kept);
    - :attr:`Fault.CONTROLLER_STALLED` (with ``real_time``): the bus went unwatched for longer
      than the status timeout (the process was paused or starved: what it then receives is stale,
      and the watchdog could not have tripped meanwhile); a warning names the gap.

    Once a fault is latched it no longer waits and its measurement holds still (velocities zero).

    The status timeout follows the period the driver announces by the spacing of its statuses'
    ``utime`` (a driver on a slow link, e.g. Kinova's SDK over USB, holds a longer period than
    ``period``): ``status_timeout`` is for statuses every ``period``, and it is scaled by
    ``spacing / period`` when the driver's spacing is longer, ``spacing`` the smallest ``utime``
    step of the last :data:`SPACING_WINDOW` statuses used (``spacing`` at the start: the start
    check's measurement), held to at most ``max_spacing``: statuses further apart than that trip
    the watchdog. The missed count takes the same spacing.

    @system
    name: JacoStatusReceiver
    output_ports:
    - arm_joint_state (12): measured DH angles (rad) then velocities (rad/s)
    - finger_state (4): finger slides (m) then speeds (m/s)
    - fault (1): the latched Fault code (0 while none)
    - status_count (3): statuses used, dropped, and missed (skipped between two used ones, by
      their utime: a burst, or a tick that came late; counted from the loop's first tick)
    - sanitized_input_count (1): ticks at which a status was dropped
    @endsystem

    At initialisation, with ``real_time``, it readies the process for the loop
    (:meth:`_before_the_loop`). Discrete state: the four output groups, plus ``[utime of the
    status used (us)]``, the controller's times (s) of the last :data:`STRAYS_TO_FAULT` statuses
    out of sequence (``-inf`` before any) and the last :data:`SPACING_WINDOW` ``utime`` steps (s);
    all start from the ``first`` status (the station's start check).
    """

    def __init__(
        self,
        inbox: StatusInbox,
        first: StatusReading,
        lower: NDArray[np.float64],
        upper: NDArray[np.float64],
        period: float,
        status_timeout: float,
        warn_interval: float = 1.0,
        real_time: bool = True,
        spacing: float | None = None,
        max_spacing: float | None = None,
    ) -> None:
        super().__init__()
        self._inbox = inbox
        self._lower, self._upper = np.asarray(lower, float), np.asarray(upper, float)
        self._timeout = float(status_timeout)
        self._real_time = bool(real_time)
        self._period = float(period)
        self._max_spacing = float(max_spacing) if max_spacing is not None else float("inf")
        self._arm = self.DeclareDiscreteState(np.concatenate([first.q, first.v]))
        self._finger = self.DeclareDiscreteState(np.concatenate([first.finger_q, first.finger_v]))
        self._fault = self.DeclareDiscreteState([float(Fault.NONE)])
        self._counts = self.DeclareDiscreteState(np.zeros(3))
        self._utime = self.DeclareDiscreteState([float(first.utime)])
        self._strays = self.DeclareDiscreteState(np.full(STRAYS_TO_FAULT, -np.inf))
        start_spacing = period if spacing is None else spacing
        self._steps = self.DeclareDiscreteState(np.full(SPACING_WINDOW, float(start_spacing)))
        self._sanitized = SanitizedInputCounter(self, warn_interval)
        self.DeclareStateOutputPort("arm_joint_state", self._arm)
        self.DeclareStateOutputPort("finger_state", self._finger)
        self.DeclareStateOutputPort("fault", self._fault)
        self.DeclareStateOutputPort("status_count", self._counts)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        if real_time:  # (not for a driver stepped in-process: nothing there is timed)
            self.DeclareInitializationPublishEvent(self._before_the_loop)

    def _before_the_loop(self, context: Context) -> EventStatus:
        """At the simulator's initialisation, once the whole diagram is built:
        :func:`~drake_disamb.station.lcm.loop.prepare_loop` (nothing in the loop's first ticks
        loads a kernel or collects the built diagram; BLAS on one thread)."""
        prepare_loop()
        return EventStatus.Succeeded()

    def last_utime(self, context: Context) -> int:
        """The ``utime`` (us) of the status used last in ``context``."""
        return int(context.get_discrete_state(self._utime).get_value()[0])

    def fault(self, context: Context) -> Fault:
        """The fault latched in ``context``."""
        return Fault(int(context.get_discrete_state(self._fault).get_value()[0]))

    def spacing(self, context: Context) -> float:
        """The driver's announced period (s) in ``context``: the smallest ``utime`` step of the last
        statuses used, at most ``max_spacing``."""
        return min(float(np.min(context.get_discrete_state(self._steps).get_value())), self._max_spacing)

    def status_timeout(self, context: Context) -> float:
        """The watchdog's timeout (s, wall clock) in ``context``: ``status_timeout``, scaled by the
        announced period when it is longer than ``period`` (class docstring)."""
        return self._timeout * max(1.0, self.spacing(context) / self._period)

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        if self.fault(context) != Fault.NONE:
            return EventStatus.DidNothing()
        arm = context.get_discrete_state(self._arm).get_value()
        last_utime = int(context.get_discrete_state(self._utime).get_value()[0])
        used, dropped, missed = context.get_discrete_state(self._counts).get_value()
        previous_utime = last_utime
        timeout = self.status_timeout(context)
        spacing_us = self.spacing(context) * 1e6
        running = used > 0  # a tick has used a status (the first either does or latches a fault)
        if not running:  # the loop's first tick: what waits on the bus predates it
            self._inbox.poll(0.0)
            self._inbox.take()
            self._inbox.last_good = time.monotonic()  # the watchdog counts from the loop's start
        good: StatusReading | None = None
        good_at = 0.0
        fault = Fault.NONE
        reason = ""
        strays = 0  # statuses out of sequence since the last one used
        stray_times = context.get_discrete_state(self._strays).get_value().copy()
        while True:
            now = time.monotonic()
            unwatched = self._inbox.poll(min(max(self._inbox.last_good + timeout - now, 0.0), 0.002))
            if self._real_time and unwatched > timeout:  # what it took is stale: not used
                fault = Fault.CONTROLLER_STALLED
                warnings.warn(
                    f"{self.get_name() or type(self).__name__} at t = {context.get_time():.3f} s: the "
                    f"controller missed its periods: the bus went unwatched for {unwatched:.3f} s (paused "
                    f"or starved), longer than the status timeout ({timeout:g} s)",
                    RuntimeWarning,
                    stacklevel=2,
                )
                break
            for data, received in self._inbox.take():
                last_q = arm[:6] if good is None else good.q
                reading, why = read_status(data, None, last_q)
                if reading is not None:
                    why = out_of_order(reading.utime, last_utime)
                    if not why and (
                        np.any(reading.q < self._lower - LIMIT_TOLERANCE)
                        or np.any(reading.q > self._upper + LIMIT_TOLERANCE)
                    ):
                        fault = Fault.JOINT_LIMIT
                        reason = (
                            f"joint angles {np.round(reading.q, 4).tolist()} rad outside the model's limits"
                        )
                        break
                    why = why or posture_jump(reading.q, reading.utime, last_q, last_utime)
                    if why:  # a valid status out of sequence: a stray, or another source's
                        strays += 1
                        stray_times = np.append(stray_times[1:], context.get_time())
                if reading is None or why:
                    dropped += 1
                    reason = reason or why
                    continue
                good, good_at, last_utime = reading, received, reading.utime
            if fault == Fault.NONE and stray_times[0] > context.get_time() - STRAY_WINDOW:
                fault = Fault.TWO_SOURCES
            if fault != Fault.NONE or good is not None:
                break
            if time.monotonic() >= self._inbox.last_good + timeout:
                # Statuses that kept coming, none of them this arm's: another source's.
                fault = Fault.TWO_SOURCES if strays else Fault.STATUS_TIMEOUT
                break
        discrete_state.get_mutable_vector(self._strays).SetFromVector(stray_times)
        if reason:
            self._sanitized.record(context, discrete_state, f"status dropped or refused: {reason}")
        if fault != Fault.NONE:
            discrete_state.get_mutable_vector(self._fault).SetAtIndex(0, float(fault))
            held = np.concatenate([arm[:6], np.zeros(6)])
            discrete_state.get_mutable_vector(self._arm).SetFromVector(held)
            finger = context.get_discrete_state(self._finger).get_value()
            discrete_state.get_mutable_vector(self._finger).SetFromVector(
                np.concatenate([finger[:2], np.zeros(2)])
            )
        else:
            assert good is not None
            self._inbox.last_good = good_at
            discrete_state.get_mutable_vector(self._arm).SetFromVector(np.concatenate([good.q, good.v]))
            discrete_state.get_mutable_vector(self._finger).SetFromVector(
                np.concatenate([good.finger_q, good.finger_v])
            )
            discrete_state.get_mutable_vector(self._utime).SetAtIndex(0, float(good.utime))
            used += 1
            if running:  # (the statuses before the loop's first tick were not missed by it)
                missed += max(0, round((good.utime - previous_utime) / spacing_us) - 1)
                steps = context.get_discrete_state(self._steps).get_value()
                discrete_state.get_mutable_vector(self._steps).SetFromVector(
                    np.append(steps[1:], (good.utime - previous_utime) * 1e-6)
                )
        discrete_state.get_mutable_vector(self._counts).SetFromVector([used, dropped, missed])
        return EventStatus.Succeeded()


class ModelEndEffectorState(LeafSystem):
    """Pose and spatial velocity of ``mico_end_effector`` from measured arm angles, on our model.

    @system
    name: ModelEndEffectorState
    input_ports:
    - arm_joint_state (12): DH angles (rad) then velocities (rad/s)
    output_ports:
    - ee_pose (7): [x, y, z, qw, qx, qy, qz] of the end effector in W (m)
    - ee_velocity (6): [vx, vy, vz, wx, wy, wz] of its origin in W (m/s, rad/s; paper order)
    @endsystem

    The forward kinematics run on a scratch context of ``plant`` (arm-only, owned by the caller),
    like the differential IK's Jacobian.
    """

    def __init__(self, plant: MultibodyPlant, arm: ModelInstanceIndex) -> None:
        super().__init__()
        self._plant = plant
        self._ctx = plant.CreateDefaultContext()
        joints = [plant.GetJointByName(n, arm) for n in ARM_JOINTS]
        self._q_idx = [j.position_start() for j in joints]
        self._v_idx = [j.velocity_start() for j in joints]
        self._frame = plant.GetFrameByName(EE_FRAME, arm)
        self._input = self.DeclareVectorInputPort("arm_joint_state", 12)
        ticket = {self._input.ticket()}
        self.DeclareVectorOutputPort("ee_pose", 7, self._calc_pose, prerequisites_of_calc=ticket)
        self.DeclareVectorOutputPort("ee_velocity", 6, self._calc_velocity, prerequisites_of_calc=ticket)

    def _pose_at(self, q: NDArray[np.float64]) -> None:
        x = self._plant.GetPositions(self._ctx)
        x[self._q_idx] = q
        self._plant.SetPositions(self._ctx, x)

    def _calc_pose(self, context: Context, output: BasicVector) -> None:
        self._pose_at(np.asarray(self._input.Eval(context))[:6])
        X = self._frame.CalcPoseInWorld(self._ctx)
        output.SetFromVector(np.concatenate([X.translation(), X.rotation().ToQuaternion().wxyz()]))

    def _calc_velocity(self, context: Context, output: BasicVector) -> None:
        state = np.asarray(self._input.Eval(context))
        self._pose_at(state[:6])
        world = self._plant.world_frame()
        J = self._plant.CalcJacobianSpatialVelocity(
            self._ctx, JacobianWrtVariable.kV, self._frame, np.zeros(3), world, world
        )[:, self._v_idx]
        V = J @ state[6:]  # Drake's [w; v]
        output.SetFromVector(np.concatenate([V[3:], V[:3]]))


class JacoCommandSender(LeafSystem):
    """Publishes one ``lcmt_jaco_command`` per control tick: the commanded joint velocities and
    finger speeds, zero once a fault is latched or when a value is not finite, and scaled (all
    joints alike, so the direction is kept) to the joint speed limits. The message's positions are
    the measured ones (a driver in velocity mode uses the velocities only).

    @system
    name: JacoCommandSender
    input_ports:
    - arm_velocity_command (6): joint velocities, rad/s (DH)
    - finger_velocity_command (2): finger slide speeds, m/s
    - arm_joint_state (12): the measured DH angles (rad) then velocities (rad/s)
    - finger_state (4): the measured finger slides (m) then speeds (m/s)
    - fault (1): the receiver's latched Fault code
    output_ports:
    - command (8): the last command's DH joint velocities (rad/s) and finger speeds (m/s)
    @endsystem
    """

    def __init__(
        self,
        link: CommandLink,
        inbox: StatusInbox,
        velocity_limits: NDArray[np.float64],
        finger_speed_limit: float,
        period: float,
    ) -> None:
        super().__init__()
        self._link = link
        self._inbox = inbox
        self._vmax = np.asarray(velocity_limits, dtype=float)
        self._fmax = float(finger_speed_limit)
        self._velocity = self.DeclareVectorInputPort("arm_velocity_command", 6)
        self._finger_velocity = self.DeclareVectorInputPort("finger_velocity_command", 2)
        self._arm = self.DeclareVectorInputPort("arm_joint_state", 12)
        self._finger = self.DeclareVectorInputPort("finger_state", 4)
        self._fault = self.DeclareVectorInputPort("fault", 1)
        self.DeclareVectorOutputPort("command", 8, self._calc_command)
        self.DeclarePeriodicPublishEvent(period, 0.0, self._publish)

    def command(self, context: Context) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The clamped joint (6, rad/s) and finger (2, m/s) velocities of ``context``."""
        v = np.asarray(self._velocity.Eval(context), dtype=float)
        fv = np.asarray(self._finger_velocity.Eval(context), dtype=float)
        if self._fault.Eval(context)[0] != Fault.NONE or not (
            np.all(np.isfinite(v)) and np.all(np.isfinite(fv))
        ):
            return np.zeros(6), np.zeros(2)
        return within_speed_limits(v, self._vmax), np.clip(fv, -self._fmax, self._fmax)

    def _calc_command(self, context: Context, output: BasicVector) -> None:
        v, fv = self.command(context)
        output.SetFromVector(np.concatenate([v, fv]))

    def _publish(self, context: Context) -> EventStatus:
        v, fv = self.command(context)
        q = np.asarray(self._arm.Eval(context), dtype=float)[:6]
        finger_q = np.asarray(self._finger.Eval(context), dtype=float)[:2]
        utime = int(round(context.get_time() * 1e6))
        finger_q = np.where(np.isfinite(finger_q), finger_q, 0.0)
        q = np.where(np.isfinite(q), q, 0.0)
        self._link.publish(make_command(utime, q, v, finger_q, fv), answered_at=self._inbox.last_good)
        return EventStatus.Succeeded()


class JacoCommandReceiver(LeafSystem):
    """The simulated driver's side of the commands: at every tick, the latest valid command becomes
    the joint and finger velocities it applies, with a real Kinova driver's semantics (velocities
    only); when no valid command arrived for ``timeout_ticks`` ticks, zero (the arm stops).

    @system
    name: JacoCommandReceiver
    output_ports:
    - arm_velocity_command (6): the DH joint velocities applied (rad/s)
    - finger_velocity_command (2): the finger slide speeds applied (m/s)
    @endsystem

    Every ``period`` it takes what ``inbox`` (a :class:`~drake_disamb.station.lcm.bus.CommandInbox`)
    received since the last tick. Discrete state: the latest valid command ``[v (6), finger v
    (2)]``, the ticks since it arrived (one more than ``timeout_ticks`` before any), and the two
    outputs (state output ports: they change only at ticks).
    """

    def __init__(self, inbox: CommandInbox, period: float, timeout_ticks: int) -> None:
        super().__init__()
        self._inbox = inbox
        self._timeout = int(timeout_ticks)
        self._latest = self.DeclareDiscreteState(np.zeros(8))
        self._age = self.DeclareDiscreteState([float(self._timeout + 1)])
        self._arm = self.DeclareDiscreteState(np.zeros(6))
        self._finger = self.DeclareDiscreteState(np.zeros(2))
        self.DeclareStateOutputPort("arm_velocity_command", self._arm)
        self.DeclareStateOutputPort("finger_velocity_command", self._finger)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        received = self._inbox.take()
        if received:
            v, fv = received[-1]
            latest, age = np.concatenate([v, fv]), 0.0
            discrete_state.get_mutable_vector(self._latest).SetFromVector(latest)
        else:
            latest = context.get_discrete_state(self._latest).get_value()
            age = context.get_discrete_state(self._age).GetAtIndex(0) + 1.0
        discrete_state.get_mutable_vector(self._age).SetAtIndex(0, age)
        applied = latest if age < self._timeout else np.zeros(8)
        discrete_state.get_mutable_vector(self._arm).SetFromVector(applied[:6])
        discrete_state.get_mutable_vector(self._finger).SetFromVector(applied[6:])
        return EventStatus.Succeeded()


class JacoStatusSender(LeafSystem):
    """The simulated driver's side of the statuses: publishes the measured joints and fingers as one
    ``lcmt_jaco_status`` (``utime`` = the context's time, us) when its forced publish event is run
    (``ForcedPublish``: the driver's loop asks once per period, after the arm's step).

    @system
    name: JacoStatusSender
    input_ports:
    - arm_joint_state (12): DH angles (rad) then velocities (rad/s)
    - finger_state (4): finger slides (m) then speeds (m/s)
    @endsystem
    """

    def __init__(self, link: StatusLink) -> None:
        super().__init__()
        self._link = link
        self._arm = self.DeclareVectorInputPort("arm_joint_state", 12)
        self._finger = self.DeclareVectorInputPort("finger_state", 4)
        self.DeclareForcedPublishEvent(self._publish)

    def _publish(self, context: Context) -> EventStatus:
        arm = self._arm.Eval(context)
        finger = self._finger.Eval(context)
        utime = int(round(context.get_time() * 1e6))
        self._link.publish(make_status(utime, arm[:6], arm[6:], finger[:2], finger[2:]))
        return EventStatus.Succeeded()


__all__ = [
    "JUMP_TOLERANCE",
    "LIMIT_TOLERANCE",
    "MAX_JOINT_SPEED",
    "STRAYS_TO_FAULT",
    "STRAY_WINDOW",
    "JacoCommandReceiver",
    "JacoCommandSender",
    "JacoStatusReceiver",
    "JacoStatusSender",
    "ModelEndEffectorState",
    "posture_jump",
    "within_speed_limits",
]
