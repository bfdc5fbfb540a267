"""Kinova's Gen2 SDK structures and constants, as :mod:`ctypes` declarations.

The layouts are those of the SDK's public headers (``KinovaTypes.h`` and the communication
layer's header, e.g. in Kinovarobotics/kinova-ros, ``kinova_driver/include/kinova/``): C structs
of ``float``, ``int`` and ``char`` fields in declaration order, the C++ enums as ``int``. Only what
the driver uses is declared. Units are the SDK's: degrees, degrees per second, finger units
(0 open, about 6800 closed).
"""

from __future__ import annotations

import ctypes

NO_ERROR_KINOVA = 1
"""The result code of a call that succeeded."""
MAX_KINOVA_DEVICE = 20
"""Length of the device array ``GetDevices`` fills."""
SERIAL_LENGTH = 20
"""Length of a device's serial number and model strings."""

ANGULAR_VELOCITY = 8
"""``POSITION_TYPE`` of a trajectory point that holds joint velocities (deg/s)."""
VELOCITY_MODE = 2
"""``HAND_MODE`` whose finger values are velocities."""

ROBOT_TYPES: dict[int, tuple[str, int]] = {
    0: ("JACO v1 assistive", 6),
    1: ("MICO 6-DoF service", 6),
    2: ("MICO 4-DoF service", 4),
    3: ("JACO v2 6-DoF service", 6),
    4: ("JACO v2 4-DoF service", 4),
    5: ("MICO 6-DoF assistive", 6),
    6: ("JACO v2 6-DoF assistive", 6),
    7: ("JACO v2 6-DoF spherical", 6),
    8: ("JACO v2 7-DoF spherical", 7),
}
"""Kinova's robot types (``RobotTypeEnum``, which a device's ``DeviceType`` holds): name, joints."""
MICO_6DOF = (1, 5)
"""The robot types of a 6-joint MICO (service and assistive), the arm our model is."""
INVALID_DEVICE = 255
"""``DeviceType`` of an entry the SDK lists but failed to fill (``eRobotType_Error``)."""

ERROR_NAMES: dict[int, str] = {
    666: "UNKNOWN_ERROR",
    1001: "ERROR_LOAD_USB_LIBRARY",
    1002: "ERROR_OPEN_METHOD",
    1003: "ERROR_WRITE_METHOD",
    1004: "ERROR_READ_METHOD",
    1005: "ERROR_READ_INT_METHOD",
    1006: "ERROR_FREE_LIBRARY",
    1007: "ERROR_JACO_CONNECTION",
    1008: "ERROR_CLAIM_INTERFACE",
    1009: "ERROR_UNKNOWN_DEVICE",
    1010: "ERROR_NOT_INITIALIZED",
    1011: "ERROR_LIBUSB_NO_DEVICE",
    1012: "ERROR_LIBUSB_BUSY",
    1013: "ERROR_LIBUSB_NOT_SUPPORTED",
    1014: "ERROR_SENDPACKET_UNKNOWN",
    1015: "ERROR_NO_DEVICE_FOUND",
    1016: "ERROR_OPERATION_INCOMPLETED",
    1020: "ERROR_RS485_TIMEOUT",
    1021: "ERROR_FUNCTION_NOT_ACCESSIBLE",
    1022: "ERROR_COMM_TIMEOUT",
    2001: "ERROR_INIT_API",
    2002: "ERROR_LOAD_COMM_DLL",
    2003: "JACO_NACK_FIRST",
    2004: "JACO_COMM_FAILED",
    2005: "JACO_NACK_NORMAL",
    2006: "ERROR_INIT_COMM_METHOD",
    2100: "ERROR_INVALID_PARAM",
    2101: "ERROR_API_NOT_INITIALIZED",
    9999: "ERROR_NACK_RECEIVED",
}
"""Names of the SDK's result codes (its headers' ``#define``s), for the messages."""


class AngularInfo(ctypes.Structure):
    """One value per actuator (``Actuator1`` .. ``Actuator7``; deg or deg/s by context)."""

    _fields_ = [(f"Actuator{k}", ctypes.c_float) for k in range(1, 8)]


class FingersPosition(ctypes.Structure):
    """One value per finger (``Finger1`` .. ``Finger3``; finger units, or per second)."""

    _fields_ = [(f"Finger{k}", ctypes.c_float) for k in range(1, 4)]


class AngularPosition(ctypes.Structure):
    """What ``GetAngularPosition`` / ``GetAngularVelocity`` fill: actuators then fingers."""

    _fields_ = [("Actuators", AngularInfo), ("Fingers", FingersPosition)]


class CartesianInfo(ctypes.Structure):
    """A Cartesian value (m, rad; unused by the driver, part of a point's layout)."""

    _fields_ = [(name, ctypes.c_float) for name in ("X", "Y", "Z", "ThetaX", "ThetaY", "ThetaZ")]


class UserPosition(ctypes.Structure):
    """A point's target: its ``POSITION_TYPE``, a delay, the Cartesian and actuator values, the
    ``HAND_MODE`` and the fingers."""

    _fields_ = [
        ("Type", ctypes.c_int),
        ("Delay", ctypes.c_float),
        ("CartesianPosition", CartesianInfo),
        ("Actuators", AngularInfo),
        ("HandMode", ctypes.c_int),
        ("Fingers", FingersPosition),
    ]


class Limitation(ctypes.Structure):
    """A point's speed, force and acceleration limitations (used when ``LimitationsActive``)."""

    _fields_ = [
        (f"{kind}Parameter{k}", ctypes.c_float)
        for kind in ("speed", "force", "acceleration")
        for k in range(1, 4)
    ]


class TrajectoryPoint(ctypes.Structure):
    """One point of the arm's trajectory FIFO (``SendAdvanceTrajectory`` takes it by value)."""

    _fields_ = [
        ("Position", UserPosition),
        ("LimitationsActive", ctypes.c_int),
        ("SynchroType", ctypes.c_int),
        ("Limitations", Limitation),
    ]


class KinovaDevice(ctypes.Structure):
    """One arm of ``GetDevices``'s list (``SetActiveDevice`` takes it by value)."""

    _fields_ = [
        ("SerialNumber", ctypes.c_char * SERIAL_LENGTH),
        ("Model", ctypes.c_char * SERIAL_LENGTH),
        ("VersionMajor", ctypes.c_int),
        ("VersionMinor", ctypes.c_int),
        ("VersionRelease", ctypes.c_int),
        ("DeviceType", ctypes.c_int),
        ("DeviceID", ctypes.c_int),
    ]


class EthernetCommConfig(ctypes.Structure):
    """The Ethernet command layer's connection settings (``InitEthernetAPI``): IPv4 addresses in
    network byte order (``inet_addr``), ports, the receive timeout (ms)."""

    _fields_ = [
        ("localIpAddress", ctypes.c_ulong),
        ("subnetMask", ctypes.c_ulong),
        ("robotIpAddress", ctypes.c_ulong),
        ("localCmdport", ctypes.c_ushort),
        ("localBcastPort", ctypes.c_ushort),
        ("robotPort", ctypes.c_ushort),
        ("rxTimeOutInMs", ctypes.c_ulong),
    ]


__all__ = [
    "ANGULAR_VELOCITY",
    "ERROR_NAMES",
    "INVALID_DEVICE",
    "MAX_KINOVA_DEVICE",
    "MICO_6DOF",
    "NO_ERROR_KINOVA",
    "ROBOT_TYPES",
    "SERIAL_LENGTH",
    "VELOCITY_MODE",
    "AngularInfo",
    "AngularPosition",
    "CartesianInfo",
    "EthernetCommConfig",
    "FingersPosition",
    "KinovaDevice",
    "Limitation",
    "TrajectoryPoint",
    "UserPosition",
]
