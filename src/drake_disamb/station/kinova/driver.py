"""The driver on a real arm: Kinova's Gen2 SDK behind Drake's Kinova messages, with the driver's
own safety (``drake-disamb mico-driver --kinova-sdk LIB``).

Each period (:meth:`SdkDriver.step`) it reads only what a status needs (``GetAngularPosition``,
``GetAngularVelocity``), publishes one ``lcmt_jaco_status`` and then, until the period ends,
receives commands and sends the latest fresh one as one ``ANGULAR_VELOCITY`` point. On the wire,
Drake's Jaco conventions as the station reads them: actuator angles and velocities in rad and
rad/s (the SDK's are degrees and degrees per second), fingers in SDK units x pi/180,
``num_joints = 6``, ``num_fingers = 2``. The joint velocities the SDK reports are multiplied by
``velocity_factor`` (:data:`GEN2_VELOCITY_FACTOR`, 2: Gen2 firmware reports them at half their
value; docs/real_arm.md says whose word this is, and how to check it on an arm).

Safety in the driver, not only in the controller:

- the control API and angular control are started before the loop, so before any point
  (:meth:`~drake_disamb.station.kinova.sdk.KinovaArm.start_control`);
- every point is the command's joint velocities scaled, all joints alike (the direction kept),
  to the model's joint speed limits, its finger speeds clipped to the model's finger speed, the
  seventh actuator's zero; at most one point a period (the arm's controller runs each point for
  one of its 10 ms cycles: a second would queue behind the first);
- no fresh command for :data:`HOLD_PERIODS` periods (the controller stopped, or its link), or a
  malformed one (undecodable, wrong sizes, not finite): a zero point at once, then
  ``EraseAllTrajectories`` (:meth:`~drake_disamb.station.kinova.sdk.KinovaArm.halt`); a fresh
  valid command afterwards moves the arm again;
- SIGINT, SIGTERM (the stop request ``stop``), an exception, an SDK call that fails: the session
  is closed, a zero point, ``EraseAllTrajectories``, ``StopControlAPI``, ``CloseAPI``, with SIGINT
  and SIGTERM held until it is done (:func:`serve`).

The period: an SDK call over USB can take milliseconds. Before the loop the driver times its
reads (:meth:`SdkDriver.calibrate`) and holds the period :func:`held_period` of a period's work,
two reads and one point (three calls, each as long as a read's), plus the controller's answer;
every :data:`PERIOD_CHECK` periods it looks at the reads of the last ones and lengthens the period
when the link slowed down. It
announces its period by the spacing of its statuses: a status's ``utime`` is the time of its
reading (us, the system's monotonic clock), so statuses are one period apart, and the
controller's watchdog follows that spacing
(:class:`~drake_disamb.station.lcm.systems.JacoStatusReceiver`): a slow link slows the loop
instead of tripping the watchdog.
"""

from __future__ import annotations

import contextlib
import math
import signal
import time
from collections import deque
from collections.abc import Callable, Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydrake.lcm import DrakeLcm

from drake_disamb.station.build import make_control_plant
from drake_disamb.station.config import FINGER_JOINTS, StationConfig, arm_velocity_limits
from drake_disamb.station.kinova.sdk import EthernetSettings, KinovaArm
from drake_disamb.station.lcm import mapping
from drake_disamb.station.lcm.bus import DriverEnds
from drake_disamb.station.lcm.driver import DEFAULT_COMMAND_CHANNEL, DEFAULT_STATUS_CHANNEL
from drake_disamb.station.lcm.loop import prepare_loop
from drake_disamb.station.lcm.messages import wire_status
from drake_disamb.station.lcm.systems import within_speed_limits

NOMINAL_PERIOD = 0.01
"""The period (s) Kinova asks for joint velocity points: its arm's controller runs at 100 Hz."""
HOLD_PERIODS = 3
"""Periods without a fresh command after which the driver stops the arm."""
GEN2_VELOCITY_FACTOR = 2.0
"""The factor of the joint velocities Gen2 firmware reports (at half their value)."""
PERIOD_MARGIN = 1.25
"""The period held is this much longer than its work (:func:`held_period`)."""
ANSWER_TIME = 0.003
"""Time (s) a period leaves for the controller's answer to its status (its latency's 99th
percentile on a 2-core machine: ``benchmarks/bench_hardware_loop.py``)."""
CALIBRATION_READS = 10
"""Reads :meth:`SdkDriver.calibrate` times before the loop."""
PERIOD_CHECK = 100
"""Periods between two looks at the work the periods took."""
LATE = 0.001
"""A period that ends this much (s) after its deadline is late."""


def held_period(work: float) -> float:
    """The period (s) to hold when a period's work (its SDK calls) takes ``work`` seconds: at least
    :data:`NOMINAL_PERIOD`, and ``PERIOD_MARGIN * work + ANSWER_TIME`` rounded up to the ms."""
    return max(NOMINAL_PERIOD, math.ceil((PERIOD_MARGIN * work + ANSWER_TIME) * 1000 - 1e-9) / 1000)


def model_speed_limits() -> tuple[NDArray[np.float64], float]:
    """Our MICO model's joint speed limits (6, rad/s, base to wrist) and its finger slides' speed
    limit (m/s)."""
    plant, arm = make_control_plant(())
    joints = arm_velocity_limits(StationConfig(), plant, arm)
    finger = min(plant.GetJointByName(name, arm).velocity_upper_limits()[0] for name in FINGER_JOINTS)
    return joints, float(finger)


class SdkDriver(DriverEnds):
    """The loop on an arm whose angular control was started (module docstring).

    Attributes:
        arm: The SDK session.
        lcm: The bus.
        period: The period (s) it holds (:meth:`calibrate`, lengthened when the link slows).
        call_time: An SDK call's time (s) as :meth:`calibrate` measured it.
        halts: Times the arm was stopped, by reason (``"no fresh command"``, ``"a malformed
            command"``).
        late: Periods that ended after their deadline (:meth:`run`).
        elapsed: Wall-clock seconds :meth:`run` ran.
    """

    def __init__(
        self,
        arm: KinovaArm,
        lcm: DrakeLcm,
        joint_speed_limits: ArrayLike,
        finger_speed_limit: float,
        status_channel: str = DEFAULT_STATUS_CHANNEL,
        command_channel: str = DEFAULT_COMMAND_CHANNEL,
        velocity_factor: float = GEN2_VELOCITY_FACTOR,
    ) -> None:
        self.arm = arm
        self.lcm = lcm
        self._vmax = np.asarray(joint_speed_limits, dtype=float).reshape(6)
        self._fmax = float(finger_speed_limit)
        self._factor = float(velocity_factor)
        self.period = NOMINAL_PERIOD
        self.call_time = 0.0
        DriverEnds.__init__(self, lcm, status_channel, command_channel)
        self._reads: deque[float] = deque(maxlen=PERIOD_CHECK)  # (s) each period's two reads
        self._dropped = 0
        self._pending: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
        self._sent = False  # this period had its point
        self._idle = 0  # periods since the last fresh command
        self._halted = True  # no point moves the arm (before the first, after a halt)
        self.halts = {"no fresh command": 0, "a malformed command": 0}
        self.late = 0
        self.elapsed = 0.0

    def calibrate(self) -> float:
        """Time :data:`CALIBRATION_READS` reads of the arm (two calls each) and hold the period of
        three calls' work (:func:`held_period`); the period (s)."""
        reads = []
        for _ in range(CALIBRATION_READS):
            began = time.monotonic()
            self.arm.read()
            reads.append(time.monotonic() - began)
        self.call_time = float(np.percentile(reads, 90)) / 2
        self.period = held_period(3 * self.call_time)
        return self.period

    def step(self, deadline: float) -> None:
        """One period, until ``deadline`` (``time.monotonic()``): read the arm and publish the
        status, send a command held over from the last period, then receive commands until the
        deadline; with no fresh command for :data:`HOLD_PERIODS` periods, halt the arm."""
        began = time.monotonic()
        q, finger_q, v, finger_v = self.arm.read()
        read_at = time.monotonic()
        self._link.publish(
            wire_status(
                int(read_at * 1e6),
                np.radians(q),
                np.radians(v * self._factor),
                np.radians(finger_q),
                np.radians(finger_v),
            )
        )
        self._reads.append(read_at - began)
        self._sent = fresh = False
        if self._pending is not None:
            pending, self._pending = self._pending, None
            self._send(*pending)
            fresh = True
        while True:
            fresh = self._receive() or fresh
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                break
            if remaining >= 0.001:
                self.lcm.HandleSubscriptions(int(remaining * 1000))
            else:
                time.sleep(remaining)
        if fresh:
            self._idle = 0
        else:
            self._idle += 1
            if self._idle >= HOLD_PERIODS and not self._halted:
                self._halt("no fresh command")

    def _receive(self) -> bool:
        """Take what arrived: a malformed command halts the arm at once (and drops what came with
        it); the latest valid one is sent now, or at the next period's start when this period had
        its point. Whether a valid command came."""
        while self.lcm.HandleSubscriptions(0) > 0:
            pass
        received = self._inbox.take()
        if self._inbox.dropped > self._dropped:
            self._dropped = self._inbox.dropped
            self._pending = None
            self._halt("a malformed command")
            return False
        if not received:
            return False
        if self._sent:
            self._pending = received[-1]
        else:
            self._send(*received[-1])
        return True

    def _send(self, v: NDArray[np.float64], finger_v: NDArray[np.float64]) -> None:
        """Send a command (DH joint velocities, rad/s; finger slide speeds, m/s) as one point
        within the limits."""
        v = within_speed_limits(v, self._vmax)
        finger_v = np.clip(finger_v, -self._fmax, self._fmax)
        # Actuator rad/s -> deg/s; the message's finger units (SDK units x pi/180) -> SDK units.
        self.arm.send(np.degrees(mapping.dh_velocity(v)), np.degrees(mapping.finger_unit_rate(finger_v)))
        self._sent, self._halted = True, False

    def _halt(self, reason: str) -> None:
        self.halts[reason] += 1
        self._sent = self._halted = True
        self.arm.halt()

    def run(
        self,
        stop: Callable[[], bool],
        duration: float | None = None,
        on_start: Callable[[], None] | None = None,
        on_period: Callable[[float], None] | None = None,
    ) -> int:
        """Run periods until ``stop()`` or ``duration`` seconds; the late periods. What waits on the
        bus from before is dropped. ``on_start`` is called just before the first status,
        ``on_period`` with the new period when the link slowed and it was lengthened. A period
        that started late is not caught up with: the next status comes at least half a period
        after it."""
        prepare_loop(kernels=False)
        while self.lcm.HandleSubscriptions(0) > 0:
            pass
        self._inbox.take()
        self._dropped = self._inbox.dropped
        if on_start is not None:
            on_start()
        started = now = time.monotonic()
        deadline = started + self.period
        while not stop() and (duration is None or now - started < duration):
            self.step(deadline)
            now = time.monotonic()
            self.late += now > deadline + LATE
            if len(self._reads) == PERIOD_CHECK and self.statuses % PERIOD_CHECK == 0:
                needed = held_period(1.5 * float(np.percentile(self._reads, 90)))
                if needed > self.period:
                    self.period = needed
                    if on_period is not None:
                        on_period(needed)
            deadline = max(deadline + self.period, now + self.period / 2)
            self.elapsed = now - started
        return self.late


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """SIGINT and SIGTERM held (blocked, delivered on leaving) while inside: a second Ctrl-C does
    not cut the arm's stop short."""
    held = {signal.SIGINT, signal.SIGTERM}
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def serve(
    arm: KinovaArm,
    lcm: DrakeLcm,
    stop: Callable[[], bool],
    *,
    ethernet: EthernetSettings | None = None,
    status_channel: str = DEFAULT_STATUS_CHANNEL,
    command_channel: str = DEFAULT_COMMAND_CHANNEL,
    velocity_factor: float = GEN2_VELOCITY_FACTOR,
    duration: float | None = None,
    on_start: Callable[[SdkDriver, str], None] | None = None,
    on_period: Callable[[SdkDriver], None] | None = None,
) -> SdkDriver:
    """The driver's life on an arm: open the session (the arm checked), start angular control,
    measure the period, run (:meth:`SdkDriver.run`) until ``stop()`` or ``duration``; on every way
    out, close the session (a zero point, ``EraseAllTrajectories``, ``StopControlAPI``,
    ``CloseAPI``) with SIGINT and SIGTERM held. ``on_start`` is called with the driver and the arm
    in words before the first status, ``on_period`` when the period was lengthened.

    Raises:
        ArmRefused: no arm, or not a 6-joint MICO (nothing was sent to it).
        ValueError: the Ethernet layer without ``ethernet``, or a bad address.
        SdkCallError: a call failed (the session was closed first), or only the close did.
        BaseException: what the loop raised (after the close; a close that failed is noted on it).
    """
    joints, finger = model_speed_limits()
    try:
        described = arm.open(ethernet)
        arm.start_control()
        driver = SdkDriver(arm, lcm, joints, finger, status_channel, command_channel, velocity_factor)
        driver.calibrate()
        driver.run(
            stop,
            duration,
            on_start=None if on_start is None else lambda: on_start(driver, described),
            on_period=None if on_period is None else lambda _: on_period(driver),
        )
    except BaseException as raised:
        with signals_held():
            failed = arm.close()
        for exc in failed:
            raised.add_note(f"then, closing the session: {exc}")
        raise
    with signals_held():
        failed = arm.close()
    if failed:
        raise failed[0]
    return driver


__all__ = [
    "ANSWER_TIME",
    "GEN2_VELOCITY_FACTOR",
    "HOLD_PERIODS",
    "NOMINAL_PERIOD",
    "PERIOD_CHECK",
    "SdkDriver",
    "held_period",
    "model_speed_limits",
    "serve",
    "signals_held",
]
