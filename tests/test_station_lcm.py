"""The station on LCM: the angle mapping, the messages, the in-process form on one memq:// bus
(the same arm motion and trial as the simulation), and safety on the wire."""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
import pytest
from drake import lcmt_jaco_command
from pydrake.lcm import DrakeLcm
from pydrake.systems.analysis import Simulator
from support import multicast_url

from drake_disamb.controller import build_controlled_station
from drake_disamb.station import MICO_HOME_Q, StationConfig, build_station
from drake_disamb.station.backends import BACKENDS, InProcessLcm, Lcm
from drake_disamb.station.lcm import mapping
from drake_disamb.station.lcm.driver import DEFAULT_COMMAND_CHANNEL, DEFAULT_STATUS_CHANNEL, SimulatedDriver
from drake_disamb.station.lcm.faults import Fault
from drake_disamb.station.lcm.messages import make_status, read_command, read_status
from drake_disamb.station.lcm.station import build_lcm_station

PERIOD = 0.01


# ----------------------------------------------------------------------------------------------
# The mapping and the messages.
# ----------------------------------------------------------------------------------------------
def test_actuator_angles_map_to_the_dh_angles_as_kinova_defines_them() -> None:
    q = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    theta = mapping.dh_from_actuator(q, reference=mapping.JOINT_SIGNS * q + mapping.JOINT_OFFSETS)
    expected = [-0.1, 0.2 - math.pi / 2, 0.3 + math.pi / 2, 0.4, 0.5 - math.pi, 0.6 + math.pi / 2]
    np.testing.assert_allclose(theta, expected, atol=1e-12)
    np.testing.assert_allclose(mapping.actuator_from_dh(theta), q, atol=1e-12)
    np.testing.assert_allclose(mapping.dh_velocity([1, 1, 1, 1, 1, 1]), [-1, 1, 1, 1, 1, 1])
    # An actuator angle is known modulo 2 pi: the DH angle nearest the reference is taken.
    theta_home = np.array(MICO_HOME_Q)
    wrapped = mapping.actuator_from_dh(theta_home) + 2 * math.pi * np.array([1, -1, 0, 1, 2, -1])
    np.testing.assert_allclose(mapping.dh_from_actuator(wrapped, theta_home), theta_home, atol=1e-9)


def test_at_the_start_each_joint_takes_its_equivalent_inside_the_limits() -> None:
    """The arm at home (where `mico-driver` starts) read with the pouring task's start posture as
    the reference: joint 5's nearest equivalent, -7.41 rad, is outside its limits; -1.13 is inside."""
    from drake_disamb.config import load_scenario

    lower, upper = build_station(StationConfig()).geometry.joint_limits()
    pouring = np.array(load_scenario("pouring").start_joint_positions)
    q = mapping.actuator_from_dh(MICO_HOME_Q)
    assert mapping.dh_from_actuator(q, pouring)[4] == pytest.approx(MICO_HOME_Q[4] - 2 * math.pi)
    np.testing.assert_allclose(mapping.dh_from_actuator(q, pouring, (lower, upper)), MICO_HOME_Q, atol=1e-12)
    # Joint 1 (limits +-2 pi) at 1 rad has two equivalents inside: the one nearest the reference.
    theta = np.array(MICO_HOME_Q)
    theta[0] = 1.0
    reference = theta.copy()
    reference[0] = -6.0
    assert mapping.dh_from_actuator(mapping.actuator_from_dh(theta), reference, (lower, upper))[0] == (
        pytest.approx(1.0 - 2 * math.pi)
    )
    # Joint 2 (limits [-0.75, 3.89] rad) at 4.5 rad has none inside: the nearest, for the refusal.
    theta[1] = 4.5
    got = mapping.dh_from_actuator(mapping.actuator_from_dh(theta), MICO_HOME_Q, (lower, upper))
    assert got[1] == pytest.approx(4.5 - 2 * math.pi)


def test_finger_units_map_to_the_slides() -> None:
    np.testing.assert_allclose(mapping.finger_slide([0.0, mapping.FINGER_CLOSED]), [0.06, 0.0])
    np.testing.assert_allclose(mapping.finger_units(mapping.finger_slide([12.5, 80.0])), [12.5, 80.0])
    assert mapping.FINGER_CLOSED == pytest.approx(118.68, abs=0.01)  # Drake's Jaco scale
    assert mapping.finger_slide_rate([mapping.FINGER_CLOSED])[0] == pytest.approx(-0.06)  # closing


def _status(utime: int = 10, q=None, joints: int = 6, fingers: int = 2) -> bytes:
    msg = make_status(
        utime, np.array(MICO_HOME_Q) if q is None else q, np.zeros(6), np.full(2, 0.04), np.zeros(2)
    )
    msg.num_joints, msg.num_fingers = joints, fingers
    msg.joint_position = list(msg.joint_position)[:joints] + [0.0] * max(0, joints - 6)
    msg.joint_velocity = list(msg.joint_velocity)[:joints] + [0.0] * max(0, joints - 6)
    msg.joint_torque = msg.joint_torque_external = msg.joint_current = [0.0] * joints
    msg.finger_position = (list(msg.finger_position) + [0.0])[:fingers]
    msg.finger_velocity = msg.finger_torque = msg.finger_torque_external = msg.finger_current = [
        0.0
    ] * fingers
    return msg.encode()


def test_a_status_reads_back_in_our_models_terms() -> None:
    reading, why = read_status(_status(), None, np.array(MICO_HOME_Q))
    assert why == ""
    np.testing.assert_allclose(reading.q, MICO_HOME_Q, atol=1e-12)
    np.testing.assert_allclose(reading.finger_q, [0.04, 0.04], atol=1e-12)


@pytest.mark.parametrize(
    ("data", "last", "reason"),
    [
        (_status(joints=7, fingers=3), None, "num_joints / num_fingers: expected 6 / 2, got 7 / 3"),
        (_status(q=np.array([np.nan, 0, 0, 0, 0, 0])), None, "joint_position: expected finite numbers"),
        (_status(utime=10), 10, "utime repeated"),
        (_status(utime=5), 10, "utime went back"),
        (b"not a status", None, "undecodable status"),
    ],
)
def test_bad_statuses_are_dropped(data: bytes, last: int | None, reason: str) -> None:
    reading, why = read_status(data, last, np.array(MICO_HOME_Q))
    assert reading is None and why.startswith(reason), why


def test_bad_commands_are_ignored_by_the_driver() -> None:
    msg = lcmt_jaco_command()
    msg.num_joints, msg.joint_position, msg.joint_velocity = 6, [0.0] * 6, [float("nan")] + [0.0] * 5
    msg.num_fingers, msg.finger_position, msg.finger_velocity = 2, [0.0] * 2, [0.0] * 2
    assert read_command(msg.encode())[0] is None
    msg.joint_velocity = [0.1] * 6
    v, fv = read_command(msg.encode())[0]
    np.testing.assert_allclose(v, [-0.1, 0.1, 0.1, 0.1, 0.1, 0.1])


def test_the_backends_are_chosen_by_a_yaml_tag() -> None:
    from drake_disamb.config import load_scenario

    backend = load_scenario("reaching", "station: !Lcm {lcm_url: 'memq://', status_timeout: 0.05}").station
    assert isinstance(backend, Lcm) and backend.status_timeout == 0.05
    assert set(BACKENDS) == {"sim", "lcm"}
    from drake_disamb.commands._station import STATION_CHOICES

    assert set(STATION_CHOICES) == set(BACKENDS)
    with pytest.raises(ValueError, match=r"scenario\.station: unknown tag '!Ros' \(one of !Sim, !Lcm\)"):
        load_scenario("reaching", "station: !Ros {}")
    with pytest.raises(
        ValueError, match=r"station\.status_timeout: expected a number in \(0.005, 1\], got 0"
    ):
        Lcm(status_timeout=0).check()


# ----------------------------------------------------------------------------------------------
# The in-process form: the station steps the driver on one memq:// bus.
# ----------------------------------------------------------------------------------------------
class Wire:
    """A station on LCM behind its controllers, with the simulated driver on one memq:// bus, and a
    tap on the commands."""

    def __init__(self, extra=None, settings: Lcm | None = None) -> None:  # noqa: ANN001
        self.settings = settings or Lcm(lcm_url="memq://")
        self.driver = SimulatedDriver(DrakeLcm("memq://"), StationConfig())
        self.lcm = self.driver.lcm
        self.commands: list[tuple[float, np.ndarray]] = []
        self.lcm.Subscribe(DEFAULT_COMMAND_CHANNEL, self._tap)
        self.extra = extra

        def pump() -> None:
            self.driver.step()
            if self.extra is not None:
                self.extra(self)

        self.station = build_lcm_station(self.settings, StationConfig(), lcm=self.lcm, pump=pump)
        self.diagram = d = build_controlled_station(self.station).diagram
        self.simulator = Simulator(d)
        self.ctx = self.simulator.get_mutable_context()
        d.GetInputPort("ee_velocity_command").FixValue(self.ctx, np.zeros(6))
        d.GetInputPort("gripper_command").FixValue(self.ctx, [0.0])

    def _tap(self, data: bytes) -> None:
        msg = lcmt_jaco_command.decode(data)
        self.commands.append(
            (time.monotonic(), np.array(list(msg.joint_velocity) + list(msg.finger_velocity)))
        )

    def command(self, V) -> None:  # noqa: ANN001
        self.diagram.GetInputPort("ee_velocity_command").FixValue(self.ctx, np.asarray(V, float))

    def out(self, name: str) -> np.ndarray:
        return np.asarray(self.diagram.GetOutputPort(name).Eval(self.ctx)).copy()

    def receiver(self):  # noqa: ANN201
        return self.station.diagram.GetSubsystemByName("status_receiver")

    def counts(self) -> np.ndarray:
        r = self.receiver()
        return np.asarray(r.GetOutputPort("status_count").Eval(r.GetMyContextFromRoot(self.ctx)))


def test_the_arm_on_the_wire_moves_as_the_simulated_station_does() -> None:
    wire = Wire()
    sim = build_controlled_station(build_station(StationConfig()))
    sim_sim = Simulator(sim.diagram)
    sim_ctx = sim_sim.get_mutable_context()
    sim.diagram.GetInputPort("gripper_command").FixValue(sim_ctx, [0.0])
    for V in ([0.05, 0, 0, 0, 0, 0], [0, 0, 0.04, 0, 0, 0.2]):
        wire.command(V)
        sim.diagram.GetInputPort("ee_velocity_command").FixValue(sim_ctx, V)
        t = wire.ctx.get_time() + 1.0
        wire.simulator.AdvanceTo(t)
        sim_sim.AdvanceTo(t)
        p_wire, p_sim = wire.out("ee_pose"), sim.diagram.GetOutputPort("ee_pose").Eval(sim_ctx)
        assert np.linalg.norm(p_wire[:3] - p_sim[:3]) < 1e-3  # one period of latency: < 1 mm here
    # One command per status, never more: the driver's statuses, the station's ticks, the commands.
    # Before the ticks, the driver published the start check's status and the one the loop's first
    # tick found waiting (and discarded: it predates the loop).
    used = wire.counts()[0]
    assert abs(len(wire.commands) - used) <= 1 and wire.driver.statuses - used == 2
    assert wire.out("fault")[0] == Fault.NONE


def test_watchdog_latches_a_fault_and_commands_zero_when_the_driver_dies() -> None:
    wire = Wire()
    wire.command([0.05, 0, 0, 0, 0, 0])
    wire.simulator.AdvanceTo(0.5)
    assert np.any(np.abs(wire.commands[-1][1]) > 1e-3)
    link = wire.station.link
    publish = link.publish
    after: list[tuple[float, np.ndarray]] = []  # (publication time, command) from the kill on

    def timed(msg, answered_at=None) -> None:  # noqa: ANN001
        after.append((time.monotonic(), np.array(list(msg.joint_velocity) + list(msg.finger_velocity))))
        publish(msg, answered_at)

    link.publish = timed
    wire.driver.kill()
    killed = time.monotonic()
    wire.simulator.AdvanceTo(0.6)
    assert wire.out("fault")[0] == Fault.STATUS_TIMEOUT
    zero_at = next(t for t, c in after if not np.any(c))
    assert zero_at - killed <= 3 * PERIOD + 0.005  # within 3 status periods
    assert all(not np.any(c) for t, c in after if t >= zero_at)  # latched: zero from then on
    assert not np.any(wire.out("arm_joint_state")[6:])


def test_zero_is_sent_several_times_when_the_controller_stops() -> None:
    wire = Wire()
    wire.command([0.05, 0, 0, 0, 0, 0])
    wire.simulator.AdvanceTo(0.3)
    wire.lcm.HandleSubscriptions(0)
    before = len(wire.commands)
    wire.station.link.stop_arm()
    wire.station.link.stop_arm()  # once only
    wire.lcm.HandleSubscriptions(0)
    zeros = wire.commands[before:]
    assert len(zeros) == wire.settings.zero_command_repeats and all(not np.any(c) for _, c in zeros)


def _inject(data_of):  # noqa: ANN001, ANN202
    """A pump extra that publishes ``data_of(wire)`` once, on the third tick."""
    calls = [0]

    def extra(wire: Wire) -> None:
        calls[0] += 1
        if calls[0] == 3:
            wire.lcm.Publish(DEFAULT_STATUS_CHANNEL, data_of(wire))

    return extra


@pytest.mark.parametrize(
    "bad",
    [
        lambda w: _status(utime=10**9, q=np.array([np.nan] * 6)),
        lambda w: _status(utime=10**9, joints=7, fingers=3),
        lambda w: _status(utime=1),  # gone back
        lambda w: _status(utime=w.driver.statuses * 10_000, q=np.array(MICO_HOME_Q) + 0.3),  # repeated
    ],
    ids=["nan", "sizes", "utime_back", "utime_repeated"],
)
def test_a_bad_status_is_dropped_never_commanded(bad) -> None:  # noqa: ANN001
    wire = Wire(extra=_inject(bad))
    wire.simulator.AdvanceTo(0.1)
    assert wire.counts()[1] == 1  # dropped
    assert wire.out("fault")[0] == Fault.NONE
    assert all(not np.any(c) for _, c in wire.commands)  # the zero command stays zero
    np.testing.assert_allclose(wire.out("arm_joint_state")[:6], MICO_HOME_Q, atol=1e-3)


def test_an_out_of_limit_status_stops_the_arm() -> None:
    def bad(w: Wire) -> bytes:
        q = np.array(MICO_HOME_Q)
        q[1] = 4.5  # joint 2 (range [-0.75, 3.89] rad) beyond its limits, whichever 2 pi turn
        return _status(utime=w.driver.statuses * 10_000 + 5_000, q=q)

    wire = Wire(extra=_inject(bad))
    wire.command([0.05, 0, 0, 0, 0, 0])
    wire.simulator.AdvanceTo(0.2)
    assert wire.out("fault")[0] == Fault.JOINT_LIMIT
    wire.lcm.HandleSubscriptions(0)
    n_moving = sum(1 for _, c in wire.commands if np.any(c))
    assert n_moving <= 3 and not np.any(wire.commands[-1][1])


def test_a_burst_is_read_as_its_latest_status() -> None:
    def extra(wire: Wire) -> None:
        if wire.driver.statuses == 5:
            wire.driver.step()
            wire.driver.step()

    wire = Wire(extra=extra)
    wire.simulator.AdvanceTo(0.1)
    used, dropped, missed = wire.counts()
    assert missed == 2 and dropped == 0
    assert len(wire.commands) <= used + 1


ELSEWHERE = tuple(np.array(MICO_HOME_Q) + [0.4, -0.3, 0.2, 0.0, 0.3, 0.0])
"""Another arm's posture, inside the limits."""


def _second_source(kind: str, start: int, published: list[int]):  # noqa: ANN202
    """A pump extra: from its ``start``-th call on, a second source publishes one status per tick
    (the ticks at which it did are appended to ``published``):

    - ``driver``: a second simulated driver, its arm elsewhere, its clock started later (its
      ``utime`` goes back against the first one's);
    - ``interleaved``: another arm's posture, each ``utime`` 5 ms after the first driver's;
    - ``ahead``: the first arm's own posture, on a clock 100 s ahead;
    - ``instead``: the second driver, and the first one's statuses no longer reach the station
      (over UDP, one message per channel is kept: the second driver's can hide the first one's).
    """
    calls = [0]
    other: list[SimulatedDriver] = []

    def extra(wire: Wire) -> None:
        calls[0] += 1
        if kind in ("driver", "instead") and not other:
            other.append(SimulatedDriver(wire.lcm, StationConfig(home_q=ELSEWHERE)))
        if calls[0] < start:
            return
        published.append(calls[0])
        utime = wire.driver.statuses * 10_000
        if kind in ("driver", "instead"):
            if kind == "instead":
                wire.driver.kill()
            other[0].step()
        elif kind == "interleaved":
            wire.lcm.Publish(DEFAULT_STATUS_CHANNEL, _status(utime=utime + 5_000, q=np.array(ELSEWHERE)))
        else:
            q = wire.driver.joint_positions()
            wire.lcm.Publish(DEFAULT_STATUS_CHANNEL, _status(utime=utime + 100_000_000, q=q))

    return extra


@pytest.mark.parametrize("kind", ["driver", "interleaved", "ahead", "instead"])
def test_a_second_source_on_the_status_channel_stops_the_arm_within_a_few_periods(kind: str) -> None:
    published: list[int] = []
    wire = Wire(extra=_second_source(kind, 30, published))
    wire.command([0.05, 0, 0, 0, 0, 0])
    ticks = 0
    while wire.out("fault")[0] == Fault.NONE and ticks < 100:
        ticks += 1
        wire.simulator.AdvanceTo(ticks * PERIOD)
    assert wire.out("fault")[0] == Fault.TWO_SOURCES
    assert "two sources on the status channel" in Fault.TWO_SOURCES.reason
    assert published and len(published) <= 4  # latched within 4 of the second source's statuses
    wire.lcm.HandleSubscriptions(0)
    moving_until = max(k for k, (_, c) in enumerate(wire.commands) if np.any(c))
    for _ in range(20):
        wire.simulator.AdvanceTo(wire.ctx.get_time() + PERIOD)
    wire.lcm.HandleSubscriptions(0)
    assert all(not np.any(c) for _, c in wire.commands[moving_until + 1 :])
    assert len(wire.commands) > moving_until + 20  # zero, every tick from the fault on


@pytest.mark.parametrize("where", ["between_ticks", "in_a_poll"])
def test_a_controller_that_missed_its_periods_past_the_status_timeout_latches_a_fault(where: str) -> None:
    """Paused (SIGSTOP) or starved for longer than the status timeout: what it then receives is
    stale and the watchdog could not trip meanwhile; it says so, and stops the arm."""
    from pydrake.systems.analysis import InitializeParams

    from drake_disamb.station.lcm.bus import StatusInbox
    from drake_disamb.station.lcm.systems import JacoStatusReceiver

    lcm = DrakeLcm("memq://")
    utime = [10_000]
    pause = [0.0]

    def driver() -> None:  # publishes the next status at every poll, as a driver keeping time would
        time.sleep(pause[0])
        pause[0] = 0.0
        utime[0] += 10_000
        lcm.Publish(DEFAULT_STATUS_CHANNEL, _status(utime=utime[0]))

    first, _ = read_status(_status(utime=utime[0]), None, np.array(MICO_HOME_Q))
    lower, upper = build_station(StationConfig()).geometry.joint_limits()
    inbox = StatusInbox(lcm, DEFAULT_STATUS_CHANNEL, driver)
    receiver = JacoStatusReceiver(inbox, first, lower, upper, PERIOD, 0.03, real_time=True)
    simulator = Simulator(receiver)
    simulator.Initialize(InitializeParams(suppress_initialization_events=True))  # (no prepare_loop)
    ctx = simulator.get_mutable_context()
    simulator.AdvanceTo(0.2)
    assert receiver.fault(ctx) == Fault.NONE
    if where == "between_ticks":
        time.sleep(0.1)
    else:
        pause[0] = 0.1
    with pytest.warns(
        RuntimeWarning,
        match=r"the controller missed its periods: the bus went unwatched for 0\.\d{3} s \(paused or "
        r"starved\), longer than the status timeout \(0\.03 s\)",
    ):
        simulator.AdvanceTo(0.3)
    assert receiver.fault(ctx) == Fault.CONTROLLER_STALLED
    assert not np.any(receiver.GetOutputPort("arm_joint_state").Eval(ctx)[6:])
    assert "missed its periods" in Fault.CONTROLLER_STALLED.reason


class PacedDriver:
    """A driver holding ``period`` (s) of wall-clock time, each status's ``utime`` one period after
    the last (a driver on a slow link announces its period so): called before every poll, it
    publishes the statuses that came due; ``period = None`` stops it."""

    def __init__(self, lcm: DrakeLcm, period: float | None) -> None:
        self.lcm, self.period = lcm, period
        self.utime = 10_000
        self.due = time.monotonic()

    def __call__(self) -> None:
        while self.period is not None and time.monotonic() >= self.due:
            self.due += self.period
            self.utime += int(round(self.period * 1e6))
            self.lcm.Publish(DEFAULT_STATUS_CHANNEL, _status(utime=self.utime))


def _paced_receiver(period: float | None, spacing: float | None, max_spacing: float | None = None):  # noqa: ANN202
    """A receiver (its simulator, context) on statuses from a :class:`PacedDriver`, and the driver."""
    from pydrake.systems.analysis import InitializeParams

    from drake_disamb.station.lcm.bus import StatusInbox
    from drake_disamb.station.lcm.systems import JacoStatusReceiver

    lcm = DrakeLcm("memq://")
    driver = PacedDriver(lcm, period)
    first, _ = read_status(_status(utime=driver.utime), None, np.array(MICO_HOME_Q))
    lower, upper = build_station(StationConfig()).geometry.joint_limits()
    inbox = StatusInbox(lcm, DEFAULT_STATUS_CHANNEL, driver)
    receiver = JacoStatusReceiver(
        inbox, first, lower, upper, PERIOD, 0.03, real_time=True, spacing=spacing, max_spacing=max_spacing
    )
    simulator = Simulator(receiver)
    simulator.Initialize(InitializeParams(suppress_initialization_events=True))  # (no prepare_loop)
    return receiver, simulator, simulator.get_mutable_context(), driver


def test_the_watchdog_follows_the_period_the_driver_announces() -> None:
    """A driver on a slow link (statuses every 40 ms, 4 control periods): the start measures its
    period, the watchdog's timeout is 3 of its periods, no fault and no status counted as missed;
    when it stops, the watchdog trips after those 3 periods."""
    from drake_disamb.station.lcm.bus import StatusInbox
    from drake_disamb.station.lcm.station import status_spacing

    lcm = DrakeLcm("memq://")
    driver = PacedDriver(lcm, 0.04)
    inbox = StatusInbox(lcm, DEFAULT_STATUS_CHANNEL, driver)
    first, _ = read_status(_status(utime=driver.utime), None, np.array(MICO_HOME_Q))
    assert status_spacing(inbox, first, 1.0, 0.05) == pytest.approx(0.04)

    receiver, simulator, ctx, driver = _paced_receiver(0.04, spacing=0.04, max_spacing=0.05)
    simulator.AdvanceTo(0.3)  # 30 ticks, one per status: 1.2 s of wall-clock time
    assert receiver.fault(ctx) == Fault.NONE
    assert receiver.status_timeout(ctx) == pytest.approx(0.12)
    used, dropped, missed = receiver.GetOutputPort("status_count").Eval(ctx)
    assert used >= 30 and (dropped, missed) == (0, 0)
    driver.period = None
    stopped = time.monotonic()
    simulator.AdvanceTo(0.4)
    assert receiver.fault(ctx) == Fault.STATUS_TIMEOUT
    assert 0.08 <= time.monotonic() - stopped <= 0.25

    # From the nominal period: the spacing is learnt from the statuses' utime steps.
    receiver, simulator, ctx, driver = _paced_receiver(0.02, spacing=None)
    simulator.AdvanceTo(0.15)
    assert receiver.fault(ctx) == Fault.NONE
    assert receiver.spacing(ctx) == pytest.approx(0.02) and receiver.status_timeout(ctx) == pytest.approx(
        0.06
    )


def test_a_driver_slower_than_the_max_status_period_is_refused_and_trips_the_watchdog() -> None:
    from drake_disamb.station.lcm.bus import StatusInbox
    from drake_disamb.station.lcm.station import status_spacing

    lcm = DrakeLcm("memq://")
    driver = PacedDriver(lcm, 0.08)
    inbox = StatusInbox(lcm, DEFAULT_STATUS_CHANNEL, driver)
    first, _ = read_status(_status(utime=driver.utime), None, np.array(MICO_HOME_Q))
    with pytest.raises(
        RuntimeError,
        match=r"the driver's statuses come every 0\.080 s \(12\.5 Hz\), slower than "
        r"station\.max_status_period \(0\.05 s\): the link to the arm is too slow",
    ):
        status_spacing(inbox, first, 1.0, 0.05)
    driver.period = None
    with pytest.raises(RuntimeError, match="stopped after the first one"):
        status_spacing(inbox, first, 0.1, 0.05)
    # At run time the timeout is held to 3 of the slowest periods followed: 0.15 s, not 0.6 s.
    receiver, simulator, ctx, _ = _paced_receiver(0.2, spacing=0.2, max_spacing=0.05)
    assert receiver.status_timeout(ctx) == pytest.approx(0.15)
    simulator.AdvanceTo(0.05)
    assert receiver.fault(ctx) == Fault.STATUS_TIMEOUT


def test_the_loops_first_tick_takes_a_fresh_status_and_counts_nothing_before_it_as_missed() -> None:
    wire = Wire()
    for _ in range(5):  # statuses published while the station is built, before the loop starts
        wire.driver.step()
    wire.simulator.AdvanceTo(0.0)
    used, dropped, missed = wire.counts()
    assert (used, dropped, missed) == (1, 0, 0)
    latest = int(round(wire.driver.statuses * PERIOD * 1e6))  # the driver's utime: steps * period
    assert wire.receiver().last_utime(wire.receiver().GetMyContextFromRoot(wire.ctx)) == latest
    wire.simulator.AdvanceTo(0.1)
    assert wire.counts()[2] == 0


def test_prepare_loop_loads_the_kernels_freezes_the_heap_and_holds_blas_to_one_thread() -> None:
    import ast
    import subprocess
    import sys

    script = (
        "import gc\n"
        "from threadpoolctl import threadpool_info\n"
        "from drake_disamb.station.lcm.loop import prepare_loop\n"
        "prepare_loop()\n"
        "from drake_disamb.core import warmup\n"
        "blas = [i['num_threads'] for i in threadpool_info() if i['user_api'] == 'blas']\n"
        "print(warmup._DONE, gc.get_freeze_count() > 0, blas)\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    ready, frozen, blas = done.stdout.strip().split(" ", 2)
    assert ready == "True" and frozen == "True" and set(ast.literal_eval(blas)) <= {1}, done.stdout


def test_start_checks_name_what_is_wrong() -> None:
    lcm = DrakeLcm("memq://")
    with pytest.raises(
        RuntimeError, match=r"no usable arm status on 'KINOVA_JACO_STATUS' at memq:// within 0.1 s"
    ):
        build_lcm_station(Lcm(lcm_url="memq://", start_timeout=0.1), StationConfig(), lcm=lcm)
    with pytest.raises(
        RuntimeError, match=r"the last one was dropped: num_joints / num_fingers: expected 6 / 2"
    ):
        build_lcm_station(
            Lcm(lcm_url="memq://", start_timeout=0.1),
            StationConfig(),
            lcm=lcm,
            pump=lambda: lcm.Publish(DEFAULT_STATUS_CHANNEL, _status(joints=7, fingers=3)),
        )
    q = np.array(MICO_HOME_Q)
    q[1] = 4.5
    with pytest.raises(
        RuntimeError, match=r"first status puts joint 2 at -1.7832 rad, outside the model's limits"
    ):
        build_lcm_station(
            Lcm(lcm_url="memq://", start_timeout=0.1),
            StationConfig(),
            lcm=lcm,
            pump=lambda: lcm.Publish(DEFAULT_STATUS_CHANNEL, _status(q=q)),
        )


def test_the_station_starts_where_the_arm_is() -> None:
    from drake_disamb.builder import start_ee_pose

    driver = SimulatedDriver(DrakeLcm("memq://"), StationConfig(home_q=tuple(np.array(MICO_HOME_Q) + 0.05)))
    station = InProcessLcm(lcm_url="memq://", driver=driver).build(StationConfig())
    plant = station.plant  # the model the statuses pose: its default posture is the measured one
    X = plant.GetFrameByName("mico_end_effector").CalcPoseInWorld(plant.CreateDefaultContext())
    np.testing.assert_allclose(start_ee_pose(station)[:3], X.translation(), atol=1e-9)
    reference = build_station(StationConfig()).diagram
    home = reference.GetOutputPort("ee_pose").Eval(reference.CreateDefaultContext())
    assert np.linalg.norm(start_ee_pose(station)[:3] - home[:3]) > 0.01  # not the model's home


def test_the_pouring_task_starts_on_the_wire_with_the_arm_at_home() -> None:
    """Every task runs against a driver whose arm is anywhere inside its limits (`mico-driver`
    starts at home, far from the pouring task's start posture)."""
    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.trial import run_trial

    driver = SimulatedDriver(DrakeLcm("memq://"), StationConfig())  # at home, as mico-driver
    scenario = dataclasses.replace(load_scenario("pouring"), duration=0.5)
    scenario = dataclasses.replace(scenario, station=InProcessLcm(lcm_url="memq://", driver=driver))
    handles = build_shared_control_diagram(scenario)
    np.testing.assert_allclose(handles.station.config.home_q, MICO_HOME_Q, atol=1e-9)
    result = run_trial(handles, progress=False)
    assert result.fault == "" and result.time == pytest.approx(0.5)


def test_the_seeded_trial_on_the_wire_matches_the_simulated_one() -> None:
    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.trial import run_trial

    scenario = load_scenario("reaching")
    sim = run_trial(scenario, progress=False)
    handles = build_shared_control_diagram(
        dataclasses.replace(scenario, station=InProcessLcm(lcm_url="memq://"))
    )
    wire = run_trial(handles, progress=False)
    assert wire.fault == "" and wire.success == sim.success and wire.reached_goals == sim.reached_goals
    assert abs(wire.mode_switches - sim.mode_switches) <= 1 and abs(wire.requests - sim.requests) <= 1
    n = min(len(sim.logs["ee_pose"][1]), len(wire.logs["ee_pose"][1]))
    gap = np.linalg.norm(sim.logs["ee_pose"][1][:n, :3] - wire.logs["ee_pose"][1][:n, :3], axis=1)
    assert gap.max() < 0.01, gap.max()


# ----------------------------------------------------------------------------------------------
# Two processes over UDP multicast on loopback: the driver, then the controller.
# ----------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_two_processes_run_the_seeded_trial_as_the_simulation_does() -> None:
    from support import cli_process, wait_for_line

    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.trial import run_trial

    url = multicast_url(7681)
    driver = cli_process("mico-driver", "--lcm-url", url, "--duration", "120")
    try:
        wait_for_line(driver, "mico-driver:", timeout=60)
        # The watchdog's own tests hold it to its 30 ms (3 periods); this one compares the trials, and on
        # a shared 2-core CI runner a process can lose the CPU for longer than that (seen: one fault).
        on_the_wire = load_scenario(
            "reaching", {"station": {"_tag": "!Lcm", "lcm_url": url, "status_timeout": 0.25}}
        )
        wire = run_trial(build_shared_control_diagram(on_the_wire), progress=False)
    finally:
        driver.terminate()
        driver.communicate(timeout=30)
    sim = run_trial(load_scenario("reaching"), progress=False)
    assert wire.fault == "", wire.fault
    assert wire.success and wire.reached_goals == sim.reached_goals
    assert abs(wire.mode_switches - sim.mode_switches) <= 1 and abs(wire.requests - sim.requests) <= 1
    n = min(len(sim.logs["ee_pose"][1]), len(wire.logs["ee_pose"][1]))
    gap = np.linalg.norm(sim.logs["ee_pose"][1][:n, :3] - wire.logs["ee_pose"][1][:n, :3], axis=1)
    assert gap.max() < 0.01, gap.max()


@pytest.mark.slow
def test_killing_the_driver_mid_trial_stops_the_arm_and_the_demo(tmp_path) -> None:  # noqa: ANN001
    import json
    import signal

    from support import cli_process, wait_for_line

    url = multicast_url(7683)
    tap = DrakeLcm(url)
    seen: list[tuple[float, np.ndarray]] = []
    tap.Subscribe(
        DEFAULT_COMMAND_CHANNEL,
        lambda data: seen.append((time.monotonic(), np.array(lcmt_jaco_command.decode(data).joint_velocity))),
    )
    driver = cli_process("mico-driver", "--lcm-url", url, "--duration", "120")
    wait_for_line(driver, "mico-driver:", timeout=60)
    demo = cli_process(
        "demo", "--station", "lcm", "--lcm-url", url, "--no-meshcat", "--quiet", "--out", str(tmp_path)
    )
    try:
        wait_for_line(demo, "running the trial", timeout=120)
        end = time.monotonic() + 2.5
        while time.monotonic() < end:
            tap.HandleSubscriptions(10)
        driver.send_signal(signal.SIGKILL)
        killed = time.monotonic()
        end = killed + 1.0
        while time.monotonic() < end:
            tap.HandleSubscriptions(10)
        _, err = demo.communicate(timeout=60)
    finally:
        driver.kill()
        demo.kill()
    assert demo.returncode == 3, err
    assert "station fault" in err and "commanded to stop" in err
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert "no fresh arm status" in metrics["station_fault"]
    assert any(np.any(c) for t, c in seen if t < killed)  # it was moving
    zero_at = next(t for t, c in seen if t >= killed and not np.any(c))
    assert zero_at - killed <= 3 * PERIOD + 0.02
    assert all(not np.any(c) for t, c in seen if t >= zero_at)


@pytest.mark.slow
def test_the_pouring_task_runs_over_two_processes(tmp_path) -> None:  # noqa: ANN001
    """`mico-driver` starts at home, far from the pouring task's start posture: the controller
    starts from the arm's posture and runs its trial (2 s here: no success yet, no fault)."""
    import json

    from support import cli_process, wait_for_line

    url = multicast_url(7685)
    driver = cli_process("mico-driver", "--lcm-url", url, "--duration", "120")
    demo = None
    try:
        wait_for_line(driver, "mico-driver:", timeout=60)
        demo = cli_process(
            "demo", "--station", "lcm", "--lcm-url", url, "--task", "pouring", "--duration", "2",
            "--no-meshcat", "--quiet", "--out", str(tmp_path),
        )  # fmt: skip
        out, err = demo.communicate(timeout=180)
    finally:
        driver.terminate()
        driver.communicate(timeout=30)
        if demo is not None:
            demo.kill()
    assert demo.returncode == 1, err  # the trial ran to its time limit without success
    assert "running the trial" in out and "station fault" not in err
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["task"] == "pouring" and "station_fault" not in metrics
    assert metrics["time"] == pytest.approx(2.0)


def _demo_against_a_driver(url: str, out: str):  # noqa: ANN202
    """`mico-driver`, then `demo --station lcm --task pouring` (a trial of about 30 s) against it,
    running its trial: the two processes."""
    from support import cli_process, wait_for_line

    driver = cli_process("mico-driver", "--lcm-url", url, "--duration", "120")
    wait_for_line(driver, "mico-driver:", timeout=60)
    demo = cli_process(
        "demo", "--station", "lcm", "--lcm-url", url, "--task", "pouring", "--duration", "60",
        "--no-meshcat", "--quiet", "--out", out,
    )  # fmt: skip
    try:
        wait_for_line(demo, "running the trial", timeout=120)
    except BaseException:
        driver.kill()
        raise
    return driver, demo


@pytest.mark.slow
def test_a_second_driver_on_the_bus_stops_the_controller_within_a_second(tmp_path) -> None:  # noqa: ANN001
    import json

    from drake import lcmt_jaco_status
    from support import cli_process

    url = multicast_url(7687)
    tap = DrakeLcm(url)
    statuses: list[tuple[float, int]] = []
    commands: list[float] = []
    tap.Subscribe(
        DEFAULT_STATUS_CHANNEL,
        lambda data: statuses.append((time.monotonic(), lcmt_jaco_status.decode(data).utime)),
    )
    tap.Subscribe(DEFAULT_COMMAND_CHANNEL, lambda data: commands.append(time.monotonic()))
    driver, demo = _demo_against_a_driver(url, str(tmp_path))
    second = cli_process("mico-driver", "--lcm-url", url, "--duration", "120")
    try:
        end = time.monotonic() + 60
        while demo.poll() is None and time.monotonic() < end:
            tap.HandleSubscriptions(10)
        _, err = demo.communicate(timeout=60)
    finally:
        for proc in (driver, demo, second):
            proc.kill()
    assert demo.returncode == 3, err
    # The second driver's first status: the first whose utime goes back (its clock started later).
    latest = statuses[0][1]
    second_at = None
    for t, utime in statuses:
        if utime < latest:
            second_at = t
            break
        latest = utime
    assert second_at is not None, f"the second driver's statuses never reached the bus: {err}"
    assert commands[-1] - second_at <= 1.0  # the controller's last command (a zero) within a second
    assert "station fault" in err and "two sources on the status channel" in err
    assert "two drivers" in json.loads((tmp_path / "metrics.json").read_text())["station_fault"]


@pytest.mark.slow
def test_a_paused_controller_latches_a_fault_and_says_so(tmp_path) -> None:  # noqa: ANN001
    """SIGSTOP for 0.5 s (longer than the 30 ms status timeout), then SIGCONT: the controller does
    not resume on what it finds on the bus."""
    import json
    import re
    import signal

    url = multicast_url(7689)
    driver, demo = _demo_against_a_driver(url, str(tmp_path))
    try:
        time.sleep(2.0)
        demo.send_signal(signal.SIGSTOP)
        time.sleep(0.5)
        demo.send_signal(signal.SIGCONT)
        _, err = demo.communicate(timeout=60)
    finally:
        driver.kill()
        demo.kill()
    assert demo.returncode == 3, err
    gap = re.search(r"the controller missed its periods: the bus went unwatched for (\d+\.\d+) s", err)
    assert gap is not None and 0.45 <= float(gap.group(1)) <= 1.5, err
    assert "station fault" in err
    assert "missed its periods" in json.loads((tmp_path / "metrics.json").read_text())["station_fault"]


def test_the_page_deadman_releases_every_signal_when_the_page_is_gone() -> None:
    from drake_disamb.interfaces.deadman import PageDeadman

    class Page:
        connections = 1

        def GetNumActiveConnections(self) -> int:  # noqa: N802 (Meshcat's name)
            return self.connections

    page = Page()
    deadman = PageDeadman(page, PERIOD, timeout=0.5)
    simulator = Simulator(deadman)
    ctx = simulator.get_mutable_context()
    deadman.GetInputPort("raw_in").FixValue(ctx, [0.7, 0.0, 0.0, 0.0])
    simulator.AdvanceTo(1.0)
    assert deadman.GetOutputPort("raw").Eval(ctx)[0] == 0.7
    page.connections = 0
    simulator.AdvanceTo(1.45)
    assert deadman.GetOutputPort("raw").Eval(ctx)[0] == 0.7  # not yet
    simulator.AdvanceTo(1.6)
    assert (
        not np.any(deadman.GetOutputPort("raw").Eval(ctx)) and deadman.GetOutputPort("released").Eval(ctx)[0]
    )
    page.connections = 1
    simulator.AdvanceTo(1.7)
    assert deadman.GetOutputPort("raw").Eval(ctx)[0] == 0.7


def test_the_driver_stops_the_arm_when_commands_stop_and_ignores_bad_ones() -> None:
    wire = Wire()
    wire.command([0.05, 0, 0, 0, 0, 0])
    wire.simulator.AdvanceTo(0.5)
    driver = wire.driver
    moving = driver.joint_positions()
    for _ in range(3):
        driver.step()
    assert np.linalg.norm(driver.joint_positions() - moving) > 1e-4  # still obeying the last command
    for _ in range(60):  # no command for 0.6 s: the arm stops (the PD settles)
        driver.step()
    stopped = driver.joint_positions()
    for _ in range(10):
        driver.step()
    assert np.linalg.norm(driver.joint_positions() - stopped) < 1e-5
    bad = lcmt_jaco_command()
    bad.num_joints, bad.joint_position, bad.joint_velocity = 6, [0.0] * 6, [float("nan"), 0.3, 0, 0, 0, 0]
    bad.num_fingers, bad.finger_position, bad.finger_velocity = 2, [0.0] * 2, [0.0] * 2
    dropped = driver.dropped
    for _ in range(10):
        wire.lcm.Publish(DEFAULT_COMMAND_CHANNEL, bad.encode())
        driver.step()
    assert driver.dropped == dropped + 10
    assert np.linalg.norm(driver.joint_positions() - stopped) < 2e-5


def test_the_commands_name_a_bad_station_option(capsys, tmp_path) -> None:  # noqa: ANN001
    from drake_disamb.cli import main

    assert main(["mico-driver", "--lcm-url", "bogus", "--quiet"]) == 2
    assert "--lcm-url: expected a URL such as udpm://" in capsys.readouterr().err
    assert main(["demo", "--lcm-url", "memq://", "--no-meshcat", "--out", str(tmp_path)]) == 2
    assert "--lcm-url: the sim station has no bus (add --station lcm)" in capsys.readouterr().err
    args = ["station-demo", "--station", "lcm", "--lcm-url", "nourl", "--no-meshcat", "--out", str(tmp_path)]
    assert main(args) == 2
    assert "--lcm-url: scenario.station.lcm_url: expected a URL" in capsys.readouterr().err


@pytest.mark.parametrize("stop", ["signal", "exception"])
def test_a_trial_that_stops_sends_zero_several_times(stop: str) -> None:
    """A stop request (Ctrl-C, SIGTERM: the commands' flag) or an exception: zero, several times."""
    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.trial import run_trial

    backend = InProcessLcm(lcm_url="memq://")
    handles = build_shared_control_diagram(dataclasses.replace(load_scenario("reaching"), station=backend))
    seen: list[np.ndarray] = []
    backend.driver.lcm.Subscribe(
        DEFAULT_COMMAND_CHANNEL,
        lambda data: seen.append(np.array(lcmt_jaco_command.decode(data).joint_velocity)),
    )
    calls = [0]

    def stop_requested() -> bool:
        calls[0] += 1
        if calls[0] == 150:
            if stop == "exception":
                raise RuntimeError("a failure in the loop")
            return True
        return False

    if stop == "exception":
        with pytest.raises(RuntimeError, match="a failure in the loop"):
            run_trial(handles, progress=False, stop_requested=stop_requested)
    else:
        assert run_trial(handles, progress=False, stop_requested=stop_requested).interrupted
    backend.driver.lcm.HandleSubscriptions(0)
    repeats = Lcm().zero_command_repeats
    assert any(np.any(c) for c in seen[:-repeats])  # it was moving
    assert len(seen) > repeats and all(not np.any(c) for c in seen[-repeats:])


def test_a_live_input_on_the_wire_passes_through_the_deadman() -> None:
    from pydrake.geometry import Meshcat, MeshcatParams
    from pydrake.systems.framework import LeafSystem

    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario

    class HeldSwitch(LeafSystem):  # a person holding the left switch, as the live page would report
        def __init__(self) -> None:
            super().__init__()
            self.DeclareVectorOutputPort("raw", 4, lambda context, out: out.SetFromVector([1.0, 0, 0, 0]))

    meshcat = Meshcat(MeshcatParams(host="localhost"))
    handles = build_shared_control_diagram(
        dataclasses.replace(load_scenario("reaching"), station=InProcessLcm(lcm_url="memq://")),
        meshcat=meshcat,
        input_source=HeldSwitch(),
    )
    deadman = handles.diagram.GetSubsystemByName("deadman")
    interface = handles.systems["interface"]
    simulator = Simulator(handles.diagram)
    ctx = simulator.get_mutable_context()
    handles.initialize(ctx)
    simulator.AdvanceTo(1.0)  # no browser at the page: released after 0.5 s
    assert deadman.GetOutputPort("released").Eval(deadman.GetMyContextFromRoot(ctx))[0] == 1.0
    assert not np.any(interface.GetInputPort("raw").Eval(interface.GetMyContextFromRoot(ctx)))
    handles.stop_station()
    sim_handles = build_shared_control_diagram(
        load_scenario("reaching"), meshcat=meshcat, input_source=HeldSwitch()
    )
    assert not sim_handles.diagram.HasSubsystemNamed("deadman")  # the simulated arm: unchanged


# ----------------------------------------------------------------------------------------------
# The systems on either end of the wire, alone, and the driver's one diagram.
# ----------------------------------------------------------------------------------------------
def _command(v, fv) -> bytes:  # noqa: ANN001
    from drake_disamb.station.lcm.messages import make_command

    return make_command(0, np.zeros(6), np.asarray(v, float), np.zeros(2), np.asarray(fv, float)).encode()


def test_the_command_receiver_applies_the_latest_command_and_zero_once_they_stop() -> None:
    from drake_disamb.station.lcm.bus import CommandInbox
    from drake_disamb.station.lcm.systems import JacoCommandReceiver

    lcm = DrakeLcm("memq://")
    inbox = CommandInbox(lcm, DEFAULT_COMMAND_CHANNEL)
    receiver = JacoCommandReceiver(inbox, PERIOD, timeout_ticks=3)
    ports = {receiver.get_output_port(k).get_name(): receiver.get_output_port(k).size() for k in range(2)}
    assert receiver.num_input_ports() == 0 and ports == {
        "arm_velocity_command": 6,
        "finger_velocity_command": 2,
    }
    ctx = receiver.CreateDefaultContext()
    simulator = Simulator(receiver, ctx)

    def applied() -> np.ndarray:
        return np.concatenate(
            [receiver.GetOutputPort(n).Eval(ctx) for n in ("arm_velocity_command", "finger_velocity_command")]
        )

    v, fv = [0.1, -0.2, 0.0, 0.0, 0.3, 0.0], [0.01, 0.02]
    lcm.Publish(DEFAULT_COMMAND_CHANNEL, _command([0.5] * 6, [0.0, 0.0]))
    lcm.Publish(DEFAULT_COMMAND_CHANNEL, b"garbage")
    lcm.Publish(DEFAULT_COMMAND_CHANNEL, _command(v, fv))  # a burst: the latest counts
    while lcm.HandleSubscriptions(0) > 0:
        pass
    assert (inbox.received, inbox.dropped) == (2, 1)
    assert not applied().any()  # nothing before the tick
    simulator.AdvanceTo(0.005)  # the tick at t = 0 takes them
    np.testing.assert_allclose(applied(), v + fv, rtol=1e-12, atol=1e-15)  # DH rad/s, slides m/s
    simulator.AdvanceTo(0.025)  # ticks 1 and 2 without a command: still applied
    np.testing.assert_allclose(applied(), v + fv, rtol=1e-12, atol=1e-15)
    simulator.AdvanceTo(0.035)  # the third: zero, the arm stops
    assert not applied().any()


def test_the_status_sender_publishes_the_measurement_when_asked() -> None:
    from drake_disamb.station.lcm.bus import StatusLink
    from drake_disamb.station.lcm.systems import JacoStatusSender

    lcm = DrakeLcm("memq://")
    got: list[bytes] = []
    lcm.Subscribe(DEFAULT_STATUS_CHANNEL, got.append)
    link = StatusLink(lcm, DEFAULT_STATUS_CHANNEL)
    sender = JacoStatusSender(link)
    ports = {sender.get_input_port(k).get_name(): sender.get_input_port(k).size() for k in range(2)}
    assert ports == {"arm_joint_state": 12, "finger_state": 4} and sender.num_output_ports() == 0
    ctx = sender.CreateDefaultContext()
    q = np.array(MICO_HOME_Q) + 0.1
    sender.GetInputPort("arm_joint_state").FixValue(ctx, np.concatenate([q, np.full(6, 0.2)]))
    sender.GetInputPort("finger_state").FixValue(ctx, [0.03, 0.035, 0.01, -0.01])
    ctx.SetTime(1.23)
    sender.ForcedPublish(ctx)
    lcm.HandleSubscriptions(0)
    assert link.sent == 1 and len(got) == 1
    reading, why = read_status(got[0], None, q)
    assert why == "" and reading.utime == 1_230_000
    np.testing.assert_allclose(reading.q, q, atol=1e-12)
    np.testing.assert_allclose(reading.v, np.full(6, 0.2), atol=1e-12)
    np.testing.assert_allclose(reading.finger_q, [0.03, 0.035], atol=1e-12)
    np.testing.assert_allclose(reading.finger_v, [0.01, -0.01], atol=1e-12)


def test_the_command_sender_sends_the_joint_level_inputs_clamped() -> None:
    from drake_disamb.station.lcm.bus import CommandLink, StatusInbox
    from drake_disamb.station.lcm.systems import JacoCommandSender

    lcm = DrakeLcm("memq://")
    got: list[bytes] = []
    lcm.Subscribe(DEFAULT_COMMAND_CHANNEL, got.append)
    vmax = np.array([0.5] * 6)
    sender = JacoCommandSender(
        CommandLink(lcm, DEFAULT_COMMAND_CHANNEL, PERIOD, 5), StatusInbox(lcm, "UNUSED"), vmax, 0.1, PERIOD
    )
    inputs = {sender.get_input_port(k).get_name(): sender.get_input_port(k).size() for k in range(5)}
    assert inputs == {
        "arm_velocity_command": 6,
        "finger_velocity_command": 2,
        "arm_joint_state": 12,
        "finger_state": 4,
        "fault": 1,
    }
    ctx = sender.CreateDefaultContext()
    sender.GetInputPort("arm_velocity_command").FixValue(ctx, [1.0, 0.5, 0, 0, 0, 0])
    sender.GetInputPort("finger_velocity_command").FixValue(ctx, [0.3, -0.05])
    sender.GetInputPort("arm_joint_state").FixValue(ctx, np.concatenate([MICO_HOME_Q, np.zeros(6)]))
    sender.GetInputPort("finger_state").FixValue(ctx, [0.04, 0.04, 0, 0])
    sender.GetInputPort("fault").FixValue(ctx, [0.0])
    # Scaled to the speed limits along the command, the fingers clipped.
    np.testing.assert_allclose(sender.GetOutputPort("command").Eval(ctx), [0.5, 0.25, 0, 0, 0, 0, 0.1, -0.05])
    simulator = Simulator(sender, ctx)
    simulator.Initialize()  # the periodic publish at t = 0
    lcm.HandleSubscriptions(0)
    v, fv = read_command(got[-1])[0]
    np.testing.assert_allclose(v, [0.5, 0.25, 0, 0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(fv, [0.1, -0.05], atol=1e-12)
    sender.GetInputPort("fault").FixValue(ctx, [float(Fault.STATUS_TIMEOUT)])
    assert not sender.GetOutputPort("command").Eval(ctx).any()  # a fault: zero
    sender.GetInputPort("fault").FixValue(ctx, [0.0])
    sender.GetInputPort("arm_velocity_command").FixValue(ctx, [np.nan, 0, 0, 0, 0, 0])
    assert not sender.GetOutputPort("command").Eval(ctx).any()  # not finite: zero


def test_the_drivers_diagram_is_the_simulated_station() -> None:
    """One diagram: the station that build_station makes, its joint-level inputs fed by the
    command receiver, its measurement read by the status sender; nothing else."""
    driver = SimulatedDriver(DrakeLcm("memq://"), StationConfig())
    d = driver.diagram
    station = d.GetSubsystemByName("station")
    assert station is driver.station.diagram
    names = {s.get_name() for s in d.GetSystems()}
    assert names == {"station", "command_receiver", "status_sender"}
    reference = build_station(StationConfig()).diagram
    assert {s.get_name() for s in station.GetSystems()} == {s.get_name() for s in reference.GetSystems()}
    sources = {
        (dst.get_name(), station.get_input_port(i).get_name()): (
            src.get_name(),
            src.get_output_port(o).get_name(),
        )
        for (dst, i), (src, o) in d.connection_map().items()
        if dst is station
    }
    assert sources == {
        ("station", "arm_velocity_command"): ("command_receiver", "arm_velocity_command"),
        ("station", "finger_velocity_command"): ("command_receiver", "finger_velocity_command"),
    }
    assert d.num_input_ports() == 0  # nothing left to fix: the receiver drives the station
