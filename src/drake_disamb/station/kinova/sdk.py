"""Kinova's Gen2 SDK command layer, loaded at run time, and the session with one arm.

:class:`KinovaSdk` loads the command layer (``Kinova.API.USBCommandLayerUbuntu.so``, or the
Ethernet one, whose functions carry an ``Ethernet_`` prefix) with :mod:`ctypes`, checks that it
has every function the driver calls, declares their C signatures from Kinova's public header
``Kinova.API.UsbCommandLayerUbuntu.h`` (references as pointers, structures by value where the
header takes them by value) and checks each call's result code: a call that does not return
``NO_ERROR_KINOVA`` raises :class:`SdkCallError` naming the call and the code.

:class:`KinovaArm` is the session: :meth:`~KinovaArm.open` (``InitAPI``, the device list, the
first arm checked to be a 6-joint MICO, ``SetActiveDevice``: nothing is sent to an arm that is
refused), :meth:`~KinovaArm.start_control` (``StartControlAPI`` then ``SetAngularControl``,
before any point), velocity points (:meth:`~KinovaArm.send`), :meth:`~KinovaArm.halt` (a zero
point, then ``EraseAllTrajectories``) and :meth:`~KinovaArm.close` (halt, ``StopControlAPI``,
``CloseAPI``, each tried whatever the previous one did).
"""

from __future__ import annotations

import ctypes
import ipaddress
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.station.kinova.structs import (
    ANGULAR_VELOCITY,
    ERROR_NAMES,
    INVALID_DEVICE,
    MAX_KINOVA_DEVICE,
    MICO_6DOF,
    NO_ERROR_KINOVA,
    ROBOT_TYPES,
    VELOCITY_MODE,
    AngularPosition,
    EthernetCommConfig,
    KinovaDevice,
    TrajectoryPoint,
)

ETHERNET_PREFIX = "Ethernet_"
"""The prefix of every function of Kinova's Ethernet command layer."""

CALLS: dict[str, tuple[object, ...]] = {
    "InitAPI": (),
    "CloseAPI": (),
    "GetDevices": (ctypes.POINTER(KinovaDevice), ctypes.POINTER(ctypes.c_int)),
    "SetActiveDevice": (KinovaDevice,),
    "StartControlAPI": (),
    "StopControlAPI": (),
    "SetAngularControl": (),
    "GetAngularPosition": (ctypes.POINTER(AngularPosition),),
    "GetAngularVelocity": (ctypes.POINTER(AngularPosition),),
    "SendAdvanceTrajectory": (TrajectoryPoint,),
    "EraseAllTrajectories": (),
}
"""The functions the driver calls (both layers) and their argument types; each returns ``int``."""
ETHERNET_CALLS: dict[str, tuple[object, ...]] = {
    "InitEthernetAPI": (ctypes.POINTER(EthernetCommConfig),),
    "RefresDevicesList": (),
}
"""The Ethernet layer's own: its start with the connection settings, the device list's refresh."""


class SdkLibraryError(ValueError):
    """The library given is not Kinova's command layer (it does not load, or lacks a function)."""


class SdkCallError(RuntimeError):
    """An SDK call returned another code than ``NO_ERROR_KINOVA``.

    Attributes:
        call: The function's name (without the Ethernet prefix).
        code: The code it returned.
    """

    def __init__(self, call: str, code: int) -> None:
        self.call = call
        self.code = int(code)
        name = ERROR_NAMES.get(self.code)
        super().__init__(f"Kinova SDK: {call} failed with code {self.code}{f' ({name})' if name else ''}")


class ArmRefused(ValueError):
    """No arm found, or the arm found is not the 6-joint MICO our model is."""


@dataclass(frozen=True)
class EthernetSettings:
    """The Ethernet layer's connection (``EthernetCommConfig``): this computer's address on the
    arm's network, the arm's (Kinova's factory address by default), the netmask and Kinova's
    default ports."""

    local_ip: str
    robot_ip: str = "192.168.100.11"
    netmask: str = "255.255.255.0"
    local_command_port: int = 25000
    local_broadcast_port: int = 25025
    robot_port: int = 55000
    receive_timeout_ms: int = 1000

    def config(self) -> EthernetCommConfig:
        """The ``EthernetCommConfig`` (addresses as ``inet_addr`` gives them: network byte order).

        Raises:
            ValueError: an address that is not IPv4 dotted quad (naming it).
        """
        addresses = []
        for name, text in (
            ("local_ip", self.local_ip),
            ("robot_ip", self.robot_ip),
            ("netmask", self.netmask),
        ):
            try:
                packed = ipaddress.IPv4Address(text).packed
            except ValueError:
                raise ValueError(
                    f"{name}: expected an IPv4 address such as 192.168.100.100, got {text!r}"
                ) from None
            addresses.append(int.from_bytes(packed, sys.byteorder))
        return EthernetCommConfig(
            addresses[0],
            addresses[2],
            addresses[1],
            self.local_command_port,
            self.local_broadcast_port,
            self.robot_port,
            self.receive_timeout_ms,
        )


class KinovaSdk:
    """Kinova's Gen2 command layer loaded from ``path`` (module docstring).

    Attributes:
        path: The library.
        ethernet: Whether it is the Ethernet layer (its functions prefixed ``Ethernet_``).
        calls: Calls made, by function name.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = str(path)
        try:
            lib = ctypes.CDLL(self.path)
        except OSError as exc:
            reason = str(exc).removeprefix(f"{self.path}: ")
            raise SdkLibraryError(f"cannot load {self.path}: {reason}") from None
        self.ethernet = not hasattr(lib, "InitAPI") and hasattr(lib, ETHERNET_PREFIX + "InitAPI")
        prefix = ETHERNET_PREFIX if self.ethernet else ""
        wanted = {**CALLS, **(ETHERNET_CALLS if self.ethernet else {})}
        missing = [prefix + name for name in wanted if not hasattr(lib, prefix + name)]
        if missing:
            raise SdkLibraryError(
                f"{self.path} is not Kinova's Gen2 SDK command layer: it has no function "
                f"{', '.join(missing)} (give Kinova.API.USBCommandLayerUbuntu.so or the Ethernet one)"
            )
        self._functions = {}
        for name, argtypes in wanted.items():
            function = getattr(lib, prefix + name)
            function.argtypes = argtypes
            function.restype = ctypes.c_int
            self._functions[name] = function
        self.calls: dict[str, int] = dict.fromkeys(wanted, 0)

    def call(self, name: str, *args: object) -> None:
        """Call ``name`` with ``args``.

        Raises:
            SdkCallError: it did not return ``NO_ERROR_KINOVA``.
        """
        self.calls[name] += 1
        code = self._functions[name](*args)
        if code != NO_ERROR_KINOVA:
            raise SdkCallError(name, code)

    def devices(self) -> list[KinovaDevice]:
        """The arms the SDK lists (``GetDevices``; its count, the result through the reference).

        Raises:
            SdkCallError: the listing failed.
        """
        found = (KinovaDevice * MAX_KINOVA_DEVICE)()
        result = ctypes.c_int(0)
        self.calls["GetDevices"] += 1
        count = self._functions["GetDevices"](found, ctypes.byref(result))
        if result.value != NO_ERROR_KINOVA:
            raise SdkCallError("GetDevices", result.value)
        return [found[k] for k in range(max(0, min(int(count), MAX_KINOVA_DEVICE)))]


def describe(device: KinovaDevice) -> str:
    """The arm in words: its type, model string, serial number and firmware."""
    name = ROBOT_TYPES.get(device.DeviceType, (f"robot of unknown type {device.DeviceType}", 0))[0]
    model = device.Model.decode(errors="replace").strip()
    serial = device.SerialNumber.decode(errors="replace").strip()
    firmware = f"{device.VersionMajor}.{device.VersionMinor}.{device.VersionRelease}"
    return f"{name} ({model or 'no model'}, serial {serial or 'not set'}, firmware {firmware})"


def check_device(devices: list[KinovaDevice]) -> KinovaDevice:
    """The arm to drive: the first the SDK filled in (an entry of type 255 is one it failed to
    fill), which must be a 6-joint MICO.

    Raises:
        ArmRefused: none listed, or the first is not a 6-joint MICO (its type and joint count).
    """
    listed = [d for d in devices if d.DeviceType != INVALID_DEVICE]
    if not listed:
        raise ArmRefused(
            "no arm found: Kinova's SDK lists none (is the arm powered on and connected, and may "
            "this user open its USB device?)"
        )
    device = listed[0]
    if device.DeviceType in MICO_6DOF:
        return device
    joints = ROBOT_TYPES.get(device.DeviceType, ("", 0))[1]
    if joints != 6:
        what = f"{joints} joints" if joints else "an unknown number of joints"
        raise ArmRefused(
            f"the arm found is a {describe(device)}, with {what}: this driver drives a 6-joint MICO"
        )
    raise ArmRefused(
        f"the arm found is a {describe(device)}: it has 6 joints, but its links are not the MICO's our "
        "model has (this driver drives a 6-joint MICO)"
    )


class KinovaArm:
    """The SDK's session with one arm (module docstring).

    Attributes:
        sdk: The command layer.
        device: The arm driven (after :meth:`open`).
        points: Velocity points sent.
    """

    def __init__(self, sdk: KinovaSdk) -> None:
        self.sdk = sdk
        self.device: KinovaDevice | None = None
        self.points = 0
        self._opened = self._controlling = self._angular = False

    def open(self, ethernet: EthernetSettings | None = None) -> str:
        """Start the API, list the arms, check the first (:func:`check_device`) and make it the
        active one; the arm in words. Nothing is sent to the arm.

        Raises:
            ValueError: the Ethernet layer without ``ethernet``, or a bad address in it.
            ArmRefused: no arm, or not a 6-joint MICO.
            SdkCallError: a call failed.
        """
        if self.sdk.ethernet:
            if ethernet is None:
                raise ValueError(
                    "the Ethernet command layer needs this computer's address on the arm's network"
                )
            config = ethernet.config()
            self._opened = True
            self.sdk.call("InitEthernetAPI", ctypes.byref(config))
            self.sdk.call("RefresDevicesList")
        else:
            self._opened = True
            self.sdk.call("InitAPI")
        device = check_device(self.sdk.devices())
        self.sdk.call("SetActiveDevice", device)
        self.device = device
        return describe(device)

    def start_control(self) -> None:
        """``StartControlAPI`` (the API takes the arm over), then ``SetAngularControl`` (joint
        velocities): both before any point."""
        self._controlling = True  # (a start that failed is still stopped)
        self.sdk.call("StartControlAPI")
        self.sdk.call("SetAngularControl")
        self._angular = True

    def read(
        self,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The arm's actuator angles (6, deg) and finger positions (2, finger units), then as
        reported their velocities (6, deg/s) and the fingers' (2, finger units/s)."""
        position, velocity = AngularPosition(), AngularPosition()
        self.sdk.call("GetAngularPosition", ctypes.byref(position))
        self.sdk.call("GetAngularVelocity", ctypes.byref(velocity))
        return (*_values(position), *_values(velocity))

    def send(self, joint_velocity: ArrayLike, finger_velocity: ArrayLike) -> None:
        """One ``ANGULAR_VELOCITY`` point (``SendAdvanceTrajectory``): actuator velocities (6,
        deg/s), the seventh actuator's zero, finger velocities (2, finger units/s; the third
        finger's zero), no limitations.

        Raises:
            RuntimeError: angular control was not started (:meth:`start_control`).
            SdkCallError: the call failed.
        """
        if not self._angular:
            raise RuntimeError("a velocity point before the control API and angular control were started")
        v = np.asarray(joint_velocity, dtype=float).reshape(6)
        f = np.asarray(finger_velocity, dtype=float).reshape(2)
        point = TrajectoryPoint()
        point.Position.Type = ANGULAR_VELOCITY
        point.Position.HandMode = VELOCITY_MODE
        for k in range(6):
            setattr(point.Position.Actuators, f"Actuator{k + 1}", float(v[k]))
        point.Position.Fingers.Finger1, point.Position.Fingers.Finger2 = float(f[0]), float(f[1])
        self.points += 1
        self.sdk.call("SendAdvanceTrajectory", point)

    def halt(self) -> None:
        """A zero point at once, then ``EraseAllTrajectories`` (nothing queued left to run); the
        erase is tried even when the zero point failed.

        Raises:
            SdkCallError: the first call that failed.
        """
        failed = self._halt()
        if failed:
            raise failed[0]

    def _halt(self) -> list[SdkCallError]:
        failed = []
        for step in (
            lambda: self.send(np.zeros(6), np.zeros(2)),
            lambda: self.sdk.call("EraseAllTrajectories"),
        ):
            try:
                step()
            except SdkCallError as exc:
                failed.append(exc)
        return failed

    def close(self) -> list[SdkCallError]:
        """End the session: :meth:`halt` (when angular control was started), ``StopControlAPI``
        (when the control API was started), ``CloseAPI`` (when the API was): each tried whatever
        the previous one did. Idempotent. The calls that failed (empty: all went through)."""
        failed = self._halt() if self._angular else []
        self._angular = False
        for name, started in (("StopControlAPI", self._controlling), ("CloseAPI", self._opened)):
            if started:
                try:
                    self.sdk.call(name)
                except SdkCallError as exc:
                    failed.append(exc)
        self._opened = self._controlling = False
        return failed


def _values(reading: AngularPosition) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    a, f = reading.Actuators, reading.Fingers
    joints = np.array([getattr(a, f"Actuator{k}") for k in range(1, 7)], dtype=float)
    return joints, np.array([f.Finger1, f.Finger2], dtype=float)


__all__ = [
    "CALLS",
    "ETHERNET_CALLS",
    "ETHERNET_PREFIX",
    "ArmRefused",
    "EthernetSettings",
    "KinovaArm",
    "KinovaSdk",
    "SdkCallError",
    "SdkLibraryError",
    "check_device",
    "describe",
]
