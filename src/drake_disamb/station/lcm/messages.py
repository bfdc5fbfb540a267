"""Drake's Kinova messages (``lcmt_jaco_status``, ``lcmt_jaco_command``) checked and built in our
model's terms: a status becomes a :class:`StatusReading` (DH angles, finger slides) or the reason
it was dropped; a command is built from DH joint velocities and finger slide speeds.

Units on the wire (Drake's Jaco convention): joint angles rad, joint velocities rad/s (actuator
angles, :mod:`~drake_disamb.station.lcm.mapping`), finger positions in Kinova SDK units x pi/180,
``utime`` in microseconds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from drake import lcmt_jaco_command, lcmt_jaco_status
from numpy.typing import NDArray

from drake_disamb.station.lcm import mapping

NUM_JOINTS = 6
"""Joints of the MICO (Drake's Jaco messages default to 7)."""
NUM_FINGERS = 2
"""Fingers of the MICO (Drake's Jaco messages default to 3)."""


@dataclass(frozen=True)
class StatusReading:
    """A status in our model's terms: DH angles ``q`` (6, rad) and velocities ``v`` (6, rad/s),
    finger slides ``finger_q`` (2, m) and speeds ``finger_v`` (2, m/s), and ``utime`` (us)."""

    utime: int
    q: NDArray[np.float64]
    v: NDArray[np.float64]
    finger_q: NDArray[np.float64]
    finger_v: NDArray[np.float64]


def _vector(values: object, size: int, name: str) -> tuple[NDArray[np.float64] | None, str]:
    arr = np.asarray(values, dtype=float).reshape(-1)
    if arr.size != size:
        return None, f"{name}: expected {size} numbers, got {arr.size}"
    if not np.all(np.isfinite(arr)):
        return None, f"{name}: expected finite numbers, got {arr.tolist()}"
    return arr, ""


def out_of_order(utime: int, last_utime: int | None) -> str:
    """Why a status of ``utime`` (us) cannot follow one of ``last_utime`` (its ``utime`` went back
    or repeated), or ``""`` when it can (always after no status, ``last_utime`` ``None``)."""
    if last_utime is None or utime > last_utime:
        return ""
    word = "repeated" if utime == last_utime else "went back"
    return f"utime {word}: {utime} after {last_utime}"


def read_status(
    data: bytes,
    last_utime: int | None,
    reference: NDArray[np.float64],
    limits: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
) -> tuple[StatusReading | None, str]:
    """Decode and check one status; the reading, or ``None`` and why it was dropped.

    A status is dropped when it does not decode, has not 6 joints and 2 fingers, holds a NaN or an
    infinity, or its ``utime`` is not after ``last_utime`` (gone back or repeated). Joint angles
    are mapped to the DH angles nearest ``reference`` (6, rad), with ``limits`` (lower, upper;
    rad) the nearest among those inside them (:func:`~drake_disamb.station.lcm.mapping.dh_from_actuator`);
    the joint limits are the caller's check (an angle outside them stops the arm rather than
    dropping the message).
    """
    try:
        msg = lcmt_jaco_status.decode(data)
    except Exception as exc:  # noqa: BLE001 (any decoding error means "not a status")
        return None, f"undecodable status ({type(exc).__name__})"
    if msg.num_joints != NUM_JOINTS or msg.num_fingers != NUM_FINGERS:
        return None, (
            f"num_joints / num_fingers: expected {NUM_JOINTS} / {NUM_FINGERS}, "
            f"got {msg.num_joints} / {msg.num_fingers}"
        )
    parts = {}
    for name, size in (
        ("joint_position", NUM_JOINTS),
        ("joint_velocity", NUM_JOINTS),
        ("finger_position", NUM_FINGERS),
        ("finger_velocity", NUM_FINGERS),
    ):
        arr, why = _vector(getattr(msg, name), size, name)
        if arr is None:
            return None, why
        parts[name] = arr
    why = out_of_order(msg.utime, last_utime)
    if why:
        return None, why
    return (
        StatusReading(
            utime=int(msg.utime),
            q=mapping.dh_from_actuator(parts["joint_position"], reference, limits),
            v=mapping.dh_velocity(parts["joint_velocity"]),
            finger_q=mapping.finger_slide(parts["finger_position"]),
            finger_v=mapping.finger_slide_rate(parts["finger_velocity"]),
        ),
        "",
    )


def make_status(
    utime: int,
    q: NDArray[np.float64],
    v: NDArray[np.float64],
    finger_q: NDArray[np.float64],
    finger_v: NDArray[np.float64],
) -> lcmt_jaco_status:
    """A status of our model's state: DH angles and velocities, finger slides and speeds."""
    return wire_status(
        utime,
        mapping.actuator_from_dh(q),
        mapping.dh_velocity(v),
        mapping.finger_units(finger_q),
        mapping.finger_unit_rate(finger_v),
    )


def wire_status(
    utime: int,
    joint_position: NDArray[np.float64],
    joint_velocity: NDArray[np.float64],
    finger_position: NDArray[np.float64],
    finger_velocity: NDArray[np.float64],
) -> lcmt_jaco_status:
    """A status in the wire's own units (module docstring): actuator angles (rad) and velocities
    (rad/s), finger positions and speeds in Kinova SDK units x pi/180 (per second)."""
    msg = lcmt_jaco_status()
    msg.utime = int(utime)
    msg.num_joints = NUM_JOINTS
    msg.joint_position = np.asarray(joint_position, dtype=float).tolist()
    msg.joint_velocity = np.asarray(joint_velocity, dtype=float).tolist()
    msg.joint_torque = [0.0] * NUM_JOINTS
    msg.joint_torque_external = [0.0] * NUM_JOINTS
    msg.joint_current = [0.0] * NUM_JOINTS
    msg.num_fingers = NUM_FINGERS
    msg.finger_position = np.asarray(finger_position, dtype=float).tolist()
    msg.finger_velocity = np.asarray(finger_velocity, dtype=float).tolist()
    msg.finger_torque = [0.0] * NUM_FINGERS
    msg.finger_torque_external = [0.0] * NUM_FINGERS
    msg.finger_current = [0.0] * NUM_FINGERS
    return msg


def make_command(
    utime: int,
    q: NDArray[np.float64],
    v: NDArray[np.float64],
    finger_q: NDArray[np.float64],
    finger_v: NDArray[np.float64],
) -> lcmt_jaco_command:
    """A command of DH joint velocities ``v`` (rad/s) and finger slide speeds ``finger_v`` (m/s);
    the positions ``q`` and ``finger_q`` ride along (the driver uses velocities only)."""
    msg = lcmt_jaco_command()
    msg.utime = int(utime)
    msg.num_joints = NUM_JOINTS
    msg.joint_position = mapping.actuator_from_dh(q).tolist()
    msg.joint_velocity = mapping.dh_velocity(v).tolist()
    msg.num_fingers = NUM_FINGERS
    msg.finger_position = mapping.finger_units(finger_q).tolist()
    msg.finger_velocity = mapping.finger_unit_rate(finger_v).tolist()
    return msg


def read_command(data: bytes) -> tuple[tuple[NDArray[np.float64], NDArray[np.float64]] | None, str]:
    """Decode and check one command: the DH joint velocities (6, rad/s) and finger slide speeds
    (2, m/s), or ``None`` and why it was dropped (not 6 joints and 2 fingers, not finite)."""
    try:
        msg = lcmt_jaco_command.decode(data)
    except Exception as exc:  # noqa: BLE001
        return None, f"undecodable command ({type(exc).__name__})"
    if msg.num_joints != NUM_JOINTS or msg.num_fingers != NUM_FINGERS:
        return None, f"num_joints / num_fingers: expected 6 / 2, got {msg.num_joints} / {msg.num_fingers}"
    v, why = _vector(msg.joint_velocity, NUM_JOINTS, "joint_velocity")
    if v is None:
        return None, why
    fv, why = _vector(msg.finger_velocity, NUM_FINGERS, "finger_velocity")
    if fv is None:
        return None, why
    return (mapping.dh_velocity(v), mapping.finger_slide_rate(fv)), ""
