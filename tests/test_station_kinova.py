"""A real arm through Kinova's Gen2 SDK (``mico-driver --kinova-sdk``), against a stand-in SDK.

The stand-in (``tests/kinova_standin/standin.c``, built here with the system's C compiler) exports
the SDK's functions with the layouts of Kinova's header, runs the velocity points it is sent as a
Gen2 arm does (a FIFO, a 10 ms cycle each, joint velocities reported at half their value) and logs
every call with its time on the system's monotonic clock (``time.monotonic()`` here), so the tests
check the order of the calls, the units, the bounds, the stop on every way out and a slow link.
"""

from __future__ import annotations

import ctypes
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from drake_disamb.station import MICO_HOME_GRIPPER_OPENING, MICO_HOME_Q
from drake_disamb.station.kinova import structs
from drake_disamb.station.kinova.sdk import KinovaArm, KinovaSdk, SdkLibraryError
from drake_disamb.station.lcm import mapping

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
