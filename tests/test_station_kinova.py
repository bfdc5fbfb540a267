"""A real arm through Kinova's Gen2 SDK (``mico-driver --kinova-sdk``), against a stand-in SDK.

The stand-in (``tests/kinova_standin/standin.c``, built here with the system's C compiler) exports
the SDK's functions with the layouts of Kinova's header, runs the velocity points it is sent as a
Gen2 arm does (a FIFO, a 10 ms cycle each, joint velocities reported at half their value) and logs
every call with its time on the system's monotonic clock (``time.monotonic()`` here), so the tests
check the order of the calls, the units, the bounds, the stop on every way out and a slow link.
"""

from __future__ import annotations

import ctypes
import math
import os
import shutil
import signal
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from drake import lcmt_jaco_command, lcmt_jaco_status
from pydrake.lcm import DrakeLcm

from drake_disamb.station import MICO_HOME_GRIPPER_OPENING, MICO_HOME_Q
from drake_disamb.station.kinova import driver as kinova_driver
from drake_disamb.station.kinova import structs
from drake_disamb.station.kinova.driver import (
    HOLD_PERIODS,
    PERIOD_CHECK,
    SdkDriver,
    held_period,
    model_speed_limits,
    serve,
)
from drake_disamb.station.kinova.sdk import EthernetSettings, KinovaArm, KinovaSdk, SdkLibraryError
from drake_disamb.station.lcm import mapping
from drake_disamb.station.lcm.driver import DEFAULT_COMMAND_CHANNEL, DEFAULT_STATUS_CHANNEL
from drake_disamb.station.lcm.messages import make_command, read_status

STANDIN = Path(__file__).resolve().parent / "kinova_standin" / "standin.c"
HOME_DEG = np.degrees(mapping.actuator_from_dh(MICO_HOME_Q))
"""The MICO's home posture in the SDK's actuator angles (deg): the simulated arm's start."""
HOME_FINGERS = np.degrees(mapping.finger_units([MICO_HOME_GRIPPER_OPENING / 2] * 2))
"""The simulated arm's start fingers in SDK finger units."""
V = np.array([0.1, -0.2, 0.05, 0.3, -0.1, -0.4])
"""A joint velocity command within the limits (DH, rad/s)."""


# ----------------------------------------------------------------------------------------------
# The stand-in, its log.
# ----------------------------------------------------------------------------------------------
def _compiler() -> str:
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if cc is None:
        pytest.skip("no C compiler (cc, gcc or clang) here to build the stand-in for Kinova's SDK")
    return cc


def _build(folder: Path, name: str, source: Path, *flags: str) -> Path:
    out = folder / name
    subprocess.run(
        [_compiler(), "-shared", "-fPIC", "-O2", *flags, "-o", str(out), str(source), "-lm"],
        check=True,
        capture_output=True,
        text=True,
    )
    return out


@pytest.fixture(scope="module")
def standin(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The stand-in for Kinova's USB command layer."""
    return _build(tmp_path_factory.mktemp("kinova"), "libstandin.so", STANDIN)


@pytest.fixture(scope="module")
def standin_ethernet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The stand-in for Kinova's Ethernet command layer (its functions prefixed ``Ethernet_``)."""
    return _build(tmp_path_factory.mktemp("kinova"), "libstandin_eth.so", STANDIN, "-DSTANDIN_ETHERNET")


@pytest.fixture
def log(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The stand-in's log, and its arm: one MICO at home (read at ``InitAPI``)."""
    path = tmp_path / "standin.log"
    monkeypatch.setenv("STANDIN_LOG", str(path))
    monkeypatch.setenv("STANDIN_DEVICES", "mico")
    monkeypatch.setenv("STANDIN_START", ",".join(f"{a:.9f}" for a in HOME_DEG))
    monkeypatch.setenv("STANDIN_FINGERS", ",".join(f"{f:.9f}" for f in HOME_FINGERS))
    for name in ("STANDIN_FAIL", "STANDIN_DELAY_MS", "STANDIN_VELOCITY_REPORT"):
        monkeypatch.delenv(name, raising=False)
    return path


@pytest.fixture
def in_process(monkeypatch: pytest.MonkeyPatch) -> None:
    """The loop run in the test process: no ``prepare_loop`` (it freezes the heap and holds BLAS to
    one thread for the rest of the process; its own test runs it in a child process)."""
    monkeypatch.setattr(kinova_driver, "prepare_loop", lambda kernels=True: None)


@dataclass(frozen=True)
class Call:
    t: float
    name: str
    rest: str


@dataclass(frozen=True)
class Point:
    t: float
    kind: int
    hand: int
    limited: int
    actuators: np.ndarray
    fingers: np.ndarray


def calls(path: Path) -> list[Call]:
    """The stand-in's log: one call a line."""
    out = []
    for line in path.read_text().splitlines():
        t, name, *rest = line.split(" ", 2)
        out.append(Call(float(t), name.removeprefix("Ethernet_"), rest[0] if rest else ""))
    return out


def points(log_calls: list[Call]) -> list[Point]:
    """The trajectory points sent (``SendAdvanceTrajectory``, ``SendBasicTrajectory``)."""
    out = []
    for c in log_calls:
        if c.name in ("SendAdvanceTrajectory", "SendBasicTrajectory"):
            fields = dict(part.split("=") for part in c.rest.split())
            out.append(
                Point(
                    c.t,
                    int(fields["type"]),
                    int(fields["hand"]),
                    int(fields["limited"]),
                    np.array(fields["actuators"].split(","), dtype=float),
                    np.array(fields["fingers"].split(","), dtype=float),
                )
            )
    return out


def names(log_calls: list[Call]) -> list[str]:
    return [c.name for c in log_calls]


def moving(p: Point) -> bool:
    return bool(np.any(p.actuators) or np.any(p.fingers))


def assert_closed_in_order(log_calls: list[Call]) -> None:
    """The session ended as it must: a zero point, ``EraseAllTrajectories``, ``StopControlAPI``,
    ``CloseAPI``, nothing after."""
    tail = log_calls[-4:]
    assert names(tail) == ["SendAdvanceTrajectory", "EraseAllTrajectories", "StopControlAPI", "CloseAPI"]
    assert not moving(points(tail)[0])


def assert_started_before_any_point(log_calls: list[Call]) -> None:
    order = names(log_calls)
    first_point = order.index("SendAdvanceTrajectory")
    assert order.index("StartControlAPI") < order.index("SetAngularControl") < first_point
    assert order[: order.index("StartControlAPI")] == ["InitAPI", "GetDevices", "SetActiveDevice"]


# ----------------------------------------------------------------------------------------------
# The library, its structures, the session.
# ----------------------------------------------------------------------------------------------
def test_the_structures_are_laid_out_as_kinovas_header(standin: Path) -> None:
    """Our ctypes declarations against C's own layout of the header's field lists."""
    lib = ctypes.CDLL(str(standin))
    layout = lib.standin_layout
    layout.argtypes, layout.restype = [ctypes.c_char_p], ctypes.c_long
    for name in (
        "AngularInfo",
        "FingersPosition",
        "AngularPosition",
        "CartesianInfo",
        "UserPosition",
        "Limitation",
        "TrajectoryPoint",
        "KinovaDevice",
        "EthernetCommConfig",
    ):
        assert layout(name.encode()) == ctypes.sizeof(getattr(structs, name)), name
    for struct, field in (
        ("AngularPosition", "Fingers"),
        ("UserPosition", "Delay"),
        ("UserPosition", "CartesianPosition"),
        ("UserPosition", "Actuators"),
        ("UserPosition", "HandMode"),
        ("UserPosition", "Fingers"),
        ("TrajectoryPoint", "LimitationsActive"),
        ("TrajectoryPoint", "SynchroType"),
        ("TrajectoryPoint", "Limitations"),
        ("KinovaDevice", "Model"),
        ("KinovaDevice", "VersionMajor"),
        ("KinovaDevice", "DeviceType"),
        ("KinovaDevice", "DeviceID"),
        ("EthernetCommConfig", "subnetMask"),
        ("EthernetCommConfig", "robotIpAddress"),
        ("EthernetCommConfig", "localCmdport"),
        ("EthernetCommConfig", "robotPort"),
        ("EthernetCommConfig", "rxTimeOutInMs"),
    ):
        assert layout(f"{struct}.{field}".encode()) == getattr(getattr(structs, struct), field).offset


def test_a_library_that_is_not_kinovas_command_layer_is_refused_by_name(
    tmp_path: Path, standin: Path, standin_ethernet: Path
) -> None:
    with pytest.raises(SdkLibraryError, match=r"^cannot load /no/such/Kinova\.so: .*No such file"):
        KinovaSdk("/no/such/Kinova.so")
    source = tmp_path / "other.c"
    source.write_text("int InitAPI(void) { return 1; }\n")
    other = _build(tmp_path, "libother.so", source)
    with pytest.raises(
        SdkLibraryError,
        match=r"libother\.so is not Kinova's Gen2 SDK command layer: it has no function CloseAPI, "
        r"GetDevices, .*, EraseAllTrajectories \(give Kinova\.API\.USBCommandLayerUbuntu\.so",
    ):
        KinovaSdk(other)
    assert not KinovaSdk(standin).ethernet and KinovaSdk(standin_ethernet).ethernet


def test_no_point_before_control_is_started(standin: Path, log: Path) -> None:
    arm = KinovaArm(KinovaSdk(standin))
    assert arm.open().startswith("MICO 6-DoF service (MICO, serial PJ00000001, firmware 6.2.5)")
    with pytest.raises(RuntimeError, match="before the control API and angular control were started"):
        arm.send(np.ones(6), np.zeros(2))
    assert arm.close() == []
    assert names(calls(log)) == ["InitAPI", "GetDevices", "SetActiveDevice", "CloseAPI"]


# ----------------------------------------------------------------------------------------------
# The driver's periods (in this process, on one memq:// bus).
# ----------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def limits() -> tuple[np.ndarray, float]:
    return model_speed_limits()


class Rig:
    """An SDK session on the stand-in with angular control started, the driver on a memq:// bus,
    and a tap on its statuses; the test plays the controller."""

    def __init__(self, lib: Path, limits: tuple[np.ndarray, float], velocity_factor: float = 2.0) -> None:
        self.arm = KinovaArm(KinovaSdk(lib))
        self.arm.open()
        self.arm.start_control()
        self.lcm = DrakeLcm("memq://")
        self.statuses: list[lcmt_jaco_status] = []
        self.lcm.Subscribe(DEFAULT_STATUS_CHANNEL, lambda d: self.statuses.append(lcmt_jaco_status.decode(d)))
        self.driver = SdkDriver(self.arm, self.lcm, *limits, velocity_factor=velocity_factor)

    def command(self, v, finger_v=(0.0, 0.0)) -> None:  # noqa: ANN001
        msg = make_command(0, np.zeros(6), np.asarray(v, float), np.zeros(2), np.asarray(finger_v, float))
        self.lcm.Publish(DEFAULT_COMMAND_CHANNEL, msg.encode())

    def step(self, periods: int = 1, period: float = 0.01) -> None:
        for _ in range(periods):
            self.driver.step(time.monotonic() + period)


def test_a_command_is_one_velocity_point_in_degrees_within_the_limits(
    standin: Path, log: Path, limits: tuple[np.ndarray, float]
) -> None:
    rig = Rig(standin, limits)
    rig.command(V, [0.02, -0.01])
    rig.step()
    (p,) = points(calls(log))
    assert (p.kind, p.hand, p.limited) == (structs.ANGULAR_VELOCITY, structs.VELOCITY_MODE, 0)
    # Actuator deg/s (the DH-to-actuator signs), nothing for a seventh actuator; finger units/s.
    np.testing.assert_allclose(p.actuators[:6], np.degrees(mapping.JOINT_SIGNS * V), rtol=1e-5)
    units_per_m = mapping.FINGER_CLOSED / mapping.FINGER_TRAVEL * 180 / math.pi
    np.testing.assert_allclose(p.fingers[:2], [-0.02 * units_per_m, 0.01 * units_per_m], rtol=1e-5)
    assert p.actuators[6] == 0 and p.fingers[2] == 0

    # Beyond the model's limits (36 deg/s for joints 1-3, 48 for 4-6): scaled, the direction kept.
    joints, finger = limits
    rig.command([2.0, 0, 0, 0, 0, 1.0], [0.5, -0.5])
    rig.step()
    p = points(calls(log))[-1]
    scale = joints[0] / 2.0
    np.testing.assert_allclose(
        p.actuators[:6], np.degrees(mapping.JOINT_SIGNS * np.array([2.0, 0, 0, 0, 0, 1.0]) * scale), rtol=1e-5
    )
    assert abs(p.actuators[0]) == pytest.approx(36.0, rel=1e-5)
    np.testing.assert_allclose(p.fingers[:2], [-finger * units_per_m, finger * units_per_m], rtol=1e-5)

    # Two commands in one period: one point, the latest.
    rig.command(V)
    rig.command(-V)
    rig.step()
    assert len(points(calls(log))) == 3
    np.testing.assert_allclose(
        points(calls(log))[-1].actuators[:6], np.degrees(-mapping.JOINT_SIGNS * V), rtol=1e-5
    )


def test_a_status_is_the_arm_in_the_wires_units_its_velocities_doubled(
    standin: Path, log: Path, limits: tuple[np.ndarray, float]
) -> None:
    """Gen2 firmware reports joint velocities at half their value (the stand-in does): the driver
    doubles them (``--kinova-velocity-factor 2``), so a status carries the velocity commanded."""
    rig = Rig(standin, limits)
    rig.step()
    status = rig.statuses[-1]
    assert (status.num_joints, status.num_fingers) == (6, 2)
    home = np.radians(np.mod(HOME_DEG, 360.0))  # the SDK reports angles in [0, 360)
    np.testing.assert_allclose(status.joint_position, home, atol=1e-5)
    np.testing.assert_allclose(status.finger_position, np.radians(HOME_FINGERS), rtol=1e-5)
    assert not np.any(status.joint_velocity)
    reading, why = read_status(status.encode(), None, np.array(MICO_HOME_Q))
    assert why == "" and np.allclose(reading.q, MICO_HOME_Q, atol=1e-5)

    for _ in range(5):  # (periods of 5 ms: the status reads the arm in the middle of a point's run)
        rig.command(V)
        rig.step(period=0.005)
    reading, _ = read_status(rig.statuses[-1].encode(), None, np.array(MICO_HOME_Q))
    np.testing.assert_allclose(reading.v, V, atol=1e-5)  # the DH velocities commanded
    assert np.all(reading.q != MICO_HOME_Q)
    steps = np.diff([s.utime for s in rig.statuses]) * 1e-6
    assert np.all(steps > 0.004) and np.all(steps < 0.03)  # us of the monotonic clock, a period apart

    rig.arm.close()
    halved = Rig(standin, limits, velocity_factor=1.0)
    for _ in range(3):
        halved.command(V)
        halved.step(period=0.005)
    reading, _ = read_status(halved.statuses[-1].encode(), None, np.array(MICO_HOME_Q))
    np.testing.assert_allclose(reading.v, V / 2, atol=1e-5)


def test_no_fresh_command_for_three_periods_stops_the_arm_once(
    standin: Path, log: Path, limits: tuple[np.ndarray, float]
) -> None:
    rig = Rig(standin, limits)
    rig.command(V)
    rig.step(HOLD_PERIODS)  # the period with the command, then HOLD_PERIODS - 1 without
    assert [moving(p) for p in points(calls(log))] == [True]
    assert "EraseAllTrajectories" not in names(calls(log))
    rig.step()  # the HOLD_PERIODS-th without: a zero point at once, then the FIFO erased
    order = names(calls(log))
    assert order[-2:] == ["SendAdvanceTrajectory", "EraseAllTrajectories"]
    assert [moving(p) for p in points(calls(log))] == [True, False]
    rig.step(10)  # once only
    assert names(calls(log)).count("EraseAllTrajectories") == 1 and len(points(calls(log))) == 2
    assert rig.driver.halts == {"no fresh command": 1, "a malformed command": 0}
    rig.command(V)  # a fresh command moves the arm again
    rig.step()
    assert moving(points(calls(log))[-1])


def _malformed(kind: str) -> bytes:
    if kind == "not finite":
        return make_command(
            0, np.zeros(6), np.array([0.1, np.nan, 0, 0, 0, 0]), np.zeros(2), np.zeros(2)
        ).encode()
    if kind == "seven joints":
        msg = lcmt_jaco_command()
        msg.num_joints, msg.num_fingers = 7, 3
        msg.joint_position = msg.joint_velocity = [0.1] * 7
        msg.finger_position = msg.finger_velocity = [0.0] * 3
        return msg.encode()
    return b"\x00garbage"


@pytest.mark.parametrize("kind", ["not finite", "seven joints", "undecodable"])
def test_a_malformed_command_stops_the_arm_at_once(
    kind: str, standin: Path, log: Path, limits: tuple[np.ndarray, float]
) -> None:
    rig = Rig(standin, limits)
    rig.command(V)
    rig.step()
    rig.command(V)  # a valid command that came with the malformed one is not sent
    rig.lcm.Publish(DEFAULT_COMMAND_CHANNEL, _malformed(kind))
    rig.step()
    assert [moving(p) for p in points(calls(log))] == [True, False]
    assert names(calls(log))[-2:] == ["SendAdvanceTrajectory", "EraseAllTrajectories"]
    assert rig.driver.halts["a malformed command"] == 1 and rig.driver.dropped == 1
    rig.command(V)
    rig.step()
    assert moving(points(calls(log))[-1])


class Controller:
    """``serve``'s stop request, called once a period, playing the controller: a command each
    period, the end after ``periods`` (or ``raises`` then)."""

    def __init__(self, lcm: DrakeLcm, periods: int, raises: BaseException | None = None) -> None:
        self.lcm, self.periods, self.raises = lcm, periods, raises
        self.calls = 0

    def __call__(self) -> bool:
        self.calls += 1
        if self.calls > self.periods:
            if self.raises is not None:
                raise self.raises
            return True
        msg = make_command(0, np.zeros(6), V, np.zeros(2), np.zeros(2))
        self.lcm.Publish(DEFAULT_COMMAND_CHANNEL, msg.encode())
        return False


def test_the_session_starts_control_before_any_point_and_closes_in_order(
    standin: Path, log: Path, in_process: None
) -> None:
    lcm = DrakeLcm("memq://")
    started = []
    driver = serve(
        KinovaArm(KinovaSdk(standin)), lcm, Controller(lcm, 20), on_start=lambda d, arm: started.append(arm)
    )
    log_calls = calls(log)
    assert_started_before_any_point(log_calls)
    assert_closed_in_order(log_calls)
    sent = points(log_calls)
    assert all(p.kind == structs.ANGULAR_VELOCITY and p.actuators[6] == 0 for p in sent)
    assert sum(moving(p) for p in sent) >= 18 and driver.statuses >= 20
    assert started == ["MICO 6-DoF service (MICO, serial PJ00000001, firmware 6.2.5)"]


@pytest.mark.parametrize("raised", [RuntimeError("a bug in the loop"), KeyboardInterrupt()])
def test_an_exception_in_the_loop_stops_the_arm_and_closes_the_session(
    raised: BaseException, standin: Path, log: Path, in_process: None
) -> None:
    lcm = DrakeLcm("memq://")
    with pytest.raises(type(raised)):
        serve(KinovaArm(KinovaSdk(standin)), lcm, Controller(lcm, 10, raises=raised))
    log_calls = calls(log)
    assert sum(moving(p) for p in points(log_calls)) >= 8  # it was moving
    assert_closed_in_order(log_calls)


# ----------------------------------------------------------------------------------------------
# The command line: bad input, a failing call, the Ethernet layer.
# ----------------------------------------------------------------------------------------------
def _main(*argv: str) -> int:
    from drake_disamb.cli import main

    return main(["mico-driver", "--lcm-url", "memq://", *argv])


@pytest.mark.parametrize(
    ("case", "devices", "argv", "message"),
    [
        ("missing", "mico", ["--kinova-sdk", "/no/such/Kinova.so"], r"--kinova-sdk: cannot load /no/such"),
        ("not the SDK", "mico", ["--kinova-sdk", "OTHER"], r"--kinova-sdk: .*libother\.so is not Kinova's"),
        ("no arm", "", [], r"no arm found: Kinova's SDK lists none"),
        ("unfilled", "unfilled", [], r"no arm found"),
        (
            "7 joints",
            "jaco7",
            [],
            r"a JACO v2 7-DoF spherical .*, with 7 joints: this driver drives a 6-joint",
        ),
        (
            "JACO2",
            "jaco6",
            [],
            r"a JACO v2 6-DoF service .*: it has 6 joints, but its links are not the MICO's",
        ),
        ("factor", "mico", ["--kinova-velocity-factor", "0"], r"--kinova-velocity-factor: expected a number"),
        (
            "USB address",
            "mico",
            ["--kinova-local-ip", "10.0.0.2"],
            r"--kinova-local-ip: .* USB command layer",
        ),
        ("USB robot", "mico", ["--kinova-robot-ip", "10.0.0.3"], r"--kinova-robot-ip: .* USB command layer"),
        ("meshcat", "mico", ["--meshcat"], r"--meshcat draws the simulated arm: not with --kinova-sdk"),
        (
            "simulated",
            "mico",
            ["NOSDK", "--kinova-velocity-factor", "1"],
            r"--kinova-velocity-factor: only with",
        ),
        (
            "no Ethernet address",
            "mico",
            ["--kinova-sdk", "ETHERNET"],
            r"--kinova-local-ip: .* Ethernet command",
        ),
        (
            "bad address",
            "mico",
            ["--kinova-sdk", "ETHERNET", "--kinova-local-ip", "300.1.2.3"],
            r"--kinova-local-ip: expected an IPv4 address .*, got '300\.1\.2\.3'",
        ),
    ],
)
def test_bad_input_is_one_line_exit_status_2_and_nothing_sent(  # noqa: PLR0913
    case: str,
    devices: str,
    argv: list[str],
    message: str,
    standin: Path,
    standin_ethernet: Path,
    log: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    in_process: None,
) -> None:
    import re

    monkeypatch.setenv("STANDIN_DEVICES", devices)
    if "OTHER" in argv:
        source = tmp_path / "other.c"
        source.write_text("int InitAPI(void) { return 1; }\n")
        argv = [str(_build(tmp_path, "libother.so", source)) if a == "OTHER" else a for a in argv]
    argv = [str(standin_ethernet) if a == "ETHERNET" else a for a in argv]
    if "NOSDK" in argv:  # the simulated arm
        argv = [a for a in argv if a != "NOSDK"]
    elif "--kinova-sdk" not in argv:
        argv = ["--kinova-sdk", str(standin), *argv]
    assert _main(*argv) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and err.startswith("drake-disamb mico-driver: error: "), err
    assert re.search(message, err), err
    log_calls = calls(log) if log.exists() else []
    assert not {"StartControlAPI", "SetAngularControl", "SendAdvanceTrajectory"} & set(names(log_calls))
    if log_calls:  # the SDK was started: it was closed
        assert names(log_calls)[0] == "InitAPI" and names(log_calls)[-1] == "CloseAPI"


@pytest.mark.parametrize(
    ("fail", "line"),
    [
        ("GetAngularVelocity:2004:30", "GetAngularVelocity failed with code 2004 (JACO_COMM_FAILED)"),
        ("SendAdvanceTrajectory:1015", "SendAdvanceTrajectory failed with code 1015 (ERROR_NO_DEVICE_FOUND)"),
    ],
)
def test_a_failing_sdk_call_is_named_with_its_code_and_the_arm_stopped(
    fail: str,
    line: str,
    standin: Path,
    log: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    in_process: None,
) -> None:
    """A read that fails mid-run; a point that cannot be sent (only the stop's zero point here: no
    controller): exit status 3, one line, and the stop still tried in full."""
    monkeypatch.setenv("STANDIN_FAIL", fail)
    assert _main("--kinova-sdk", str(standin), "--duration", "1", "--quiet") == 3
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1, err
    assert err.startswith(f"drake-disamb mico-driver: Kinova SDK: {line}") and "the arm was stopped" in err
    order = names(calls(log))
    assert order[-4:] == ["SendAdvanceTrajectory", "EraseAllTrajectories", "StopControlAPI", "CloseAPI"]


def test_the_ethernet_layer_is_driven_with_its_connection_settings(
    standin_ethernet: Path, log: Path, in_process: None
) -> None:
    lcm = DrakeLcm("memq://")
    serve(
        KinovaArm(KinovaSdk(standin_ethernet)),
        lcm,
        Controller(lcm, 5),
        ethernet=EthernetSettings("192.168.100.100"),
    )
    lines = log.read_text().splitlines()
    assert lines[0].split(" ", 1)[1] == (
        "Ethernet_InitEthernetAPI local=192.168.100.100 netmask=255.255.255.0 robot=192.168.100.11 "
        "ports=25000,25025,55000 timeout=1000"
    )
    log_calls = calls(log)
    assert names(log_calls)[1:4] == ["RefresDevicesList", "GetDevices", "SetActiveDevice"]
    assert all(line.split(" ")[1].startswith("Ethernet_") for line in lines)
    assert_closed_in_order(log_calls)


# ----------------------------------------------------------------------------------------------
# The period the link allows.
# ----------------------------------------------------------------------------------------------
def test_the_driver_holds_the_period_the_link_allows_and_lengthens_it_when_the_link_slows(
    standin: Path,
    log: Path,
    monkeypatch: pytest.MonkeyPatch,
    limits: tuple[np.ndarray, float],
    in_process: None,
) -> None:
    assert held_period(0.0) == 0.01 and held_period(0.015) == 0.022  # 1.25 x 15 ms + 3 ms
    monkeypatch.setenv("STANDIN_DELAY_MS", "5")
    slow = Rig(standin, limits)
    assert slow.driver.calibrate() == pytest.approx(0.023, abs=0.0035)
    assert slow.driver.call_time == pytest.approx(0.005, abs=0.001)
    slow.arm.close()

    monkeypatch.setenv("STANDIN_DELAY_MS", "0")
    rig = Rig(standin, limits)
    assert rig.driver.calibrate() == 0.01
    lengthened = []

    def stop() -> bool:  # the link slows down after 20 periods
        if rig.driver.statuses == 20:
            os.environ["STANDIN_DELAY_MS"] = "5"
        return rig.driver.statuses >= PERIOD_CHECK + 5

    rig.driver.run(stop, on_period=lengthened.append)
    assert lengthened and 0.02 <= lengthened[0] <= 0.028 and rig.driver.period == lengthened[-1]


# ----------------------------------------------------------------------------------------------
# Two processes: the driver on the stand-in, the controller (UDP multicast on loopback).
# ----------------------------------------------------------------------------------------------
def _driver(lib: Path, url: str):  # noqa: ANN202
    """``mico-driver --kinova-sdk LIB`` (its environment: this one's), ready; its first lines."""
    from support import cli_process, wait_for_line

    proc = cli_process("mico-driver", "--kinova-sdk", str(lib), "--lcm-url", url, "--duration", "120")
    return proc, wait_for_line(proc, "mico-driver:", timeout=60)


def _stop(proc: subprocess.Popen) -> tuple[str, str]:
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    return out, err


def _demo(url: str, out: Path, *extra: str) -> subprocess.Popen:
    from support import cli_process

    return cli_process(
        "demo",
        "--station",
        "lcm",
        "--lcm-url",
        url,
        "--seed",
        "3",
        "--no-meshcat",
        "--quiet",
        "--out",
        str(out),
        *extra,
    )


@pytest.fixture(scope="module")
def in_process_trial():  # noqa: ANN201
    """The seeded trial (``--seed 3``) on the in-process wire (the simulated driver, memq://)."""
    import dataclasses

    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.station.backends import InProcessLcm
    from drake_disamb.trial import run_trial

    scenario = dataclasses.replace(load_scenario("reaching"), seed=3, station=InProcessLcm(lcm_url="memq://"))
    return run_trial(build_shared_control_diagram(scenario), progress=False)


def _metrics(out: Path) -> dict:
    import json

    return json.loads((out / "metrics.json").read_text())


@pytest.mark.slow
def test_the_seeded_trial_through_the_sdk_is_the_in_process_one(
    standin: Path,
    log: Path,
    tmp_path: Path,
    in_process_trial,  # noqa: ANN001
) -> None:
    from support import multicast_url

    url = multicast_url(7753)
    driver, lines = _driver(standin, url)
    try:
        demo = _demo(url, tmp_path / "out")
        _, err = demo.communicate(timeout=180)
    finally:
        _, driver_err = _stop(driver)
    assert "at 100.0 Hz (period 10 ms" in lines[-1]
    assert demo.returncode == 0, err
    m, ref = _metrics(tmp_path / "out"), in_process_trial
    assert "station_fault" not in m and m["success"] and ref.success
    assert m["reached_goals"] == list(ref.reached_goals)
    assert (m["mode_switches"], m["disambiguation_requests"]) == (ref.mode_switches, ref.requests)
    assert m["time"] == pytest.approx(ref.time, abs=0.05)

    log_calls = calls(log)
    assert_started_before_any_point(log_calls)
    assert_closed_in_order(log_calls)
    sent = points(log_calls)
    assert {(p.kind, p.hand, p.limited) for p in sent} == {
        (structs.ANGULAR_VELOCITY, structs.VELOCITY_MODE, 0)
    }
    assert "SendBasicTrajectory" not in names(log_calls)
    assert all(p.actuators[6] == 0 and p.fingers[2] == 0 for p in sent)  # nothing for a 7th actuator
    # About 100 Hz while the trial ran (a point answers each status, a zero one too).
    moved = [p.t for p in sent if moving(p)]
    during = [p.t for p in sent if moved[0] <= p.t <= moved[-1]]
    assert 0.009 <= float(np.median(np.diff(during))) <= 0.011
    assert 90 <= (len(during) - 1) / (during[-1] - during[0]) <= 110


@pytest.mark.slow
def test_killing_the_controller_mid_trial_leaves_no_motion_after_0_1_s(
    standin: Path, log: Path, tmp_path: Path
) -> None:
    from support import multicast_url, wait_for_line

    url = multicast_url(7754)
    driver, _ = _driver(standin, url)
    demo = _demo(url, tmp_path / "out")
    try:
        wait_for_line(demo, "running the trial", timeout=120)
        time.sleep(2.0)
        demo.send_signal(signal.SIGKILL)
        killed = time.monotonic()
        time.sleep(1.0)
    finally:
        demo.kill()
        demo.communicate(timeout=30)
        out, _ = _stop(driver)
    sent = points(calls(log))
    assert any(moving(p) for p in sent if p.t < killed)  # it was moving
    assert not any(moving(p) for p in sent if p.t > killed + 0.1)
    halted = [c.t for c in calls(log) if c.name == "EraseAllTrajectories" and c.t > killed]
    assert halted and halted[0] - killed <= 0.1  # the driver's own stop: no fresh command
    assert "halts: 1 for no fresh command" in out


@pytest.mark.slow
def test_a_slow_link_slows_the_trial_without_a_station_fault(
    standin: Path,
    log: Path,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    in_process_trial,  # noqa: ANN001
) -> None:
    """5 ms per SDK call: the driver holds about 40 Hz, the controller follows it."""
    import re

    from support import multicast_url

    monkeypatch.setenv("STANDIN_DELAY_MS", "5")
    url = multicast_url(7755)
    driver, lines = _driver(standin, url)
    try:
        demo = _demo(url, tmp_path / "out")
        _, err = demo.communicate(timeout=300)
    finally:
        _stop(driver)
    rate = float(re.search(r"KINOVA_JACO_STATUS at (\d+\.\d) Hz", lines[-1]).group(1))
    assert 30 <= rate <= 50, lines[-1]
    assert demo.returncode == 0 and "station fault" not in err, err
    m = _metrics(tmp_path / "out")
    assert "station_fault" not in m and m["success"]
    assert m["reached_goals"] == list(in_process_trial.reached_goals)
    assert m["realtime_rate"] < 0.6  # the loop slowed down with the link
    sent = points(calls(log))
    moved = [p.t for p in sent if moving(p)]
    during = [p.t for p in sent if moved[0] <= p.t <= moved[-1]]
    assert float(np.median(np.diff(during))) == pytest.approx(1 / rate, rel=0.15)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("sig", "port"), [(signal.SIGINT, 7756), (signal.SIGTERM, 7757)], ids=["SIGINT", "SIGTERM"]
)
def test_a_signal_stops_the_arm_then_closes_the_session(
    sig: signal.Signals, port: int, standin: Path, log: Path
) -> None:
    from support import multicast_url

    url = multicast_url(port)
    driver, _ = _driver(standin, url)
    lcm = DrakeLcm(url)
    command = make_command(0, np.zeros(6), V, np.zeros(2), np.zeros(2)).encode()
    try:
        signalled = None
        end = time.monotonic() + 1.5
        while time.monotonic() < end:
            lcm.Publish(DEFAULT_COMMAND_CHANNEL, command)  # a controller that keeps commanding
            time.sleep(0.01)
            if signalled is None and time.monotonic() > end - 0.5:
                driver.send_signal(sig)
                signalled = time.monotonic()
        out, err = driver.communicate(timeout=30)
    finally:
        driver.kill()
    assert driver.returncode == 0, err
    assert "the session was closed" in out
    log_calls = calls(log)
    assert_closed_in_order(log_calls)
    sent = points(log_calls)
    assert any(moving(p) for p in sent if p.t < signalled)
    assert not any(moving(p) for p in sent if p.t > signalled + 0.05)
