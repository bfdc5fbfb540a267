"""Kinova's actuator angles and finger units on the wire <-> our model's DH angles and finger slides.

A Kinova Gen2 arm reports (and its LCM driver publishes, in rad) the *actuator* angles ``q_i``; our
model's joints are the classic-DH angles ``theta_i`` of Kinova's "DH Parameters of Mico" (v1.0.1,
2013). The relation is Kinova's, as its ROS driver computes its forward kinematics from the
actuator angles (kinova-ros, ``kinova_driver/src/kinova_arm_kinematics.cpp``, ``updateForward``)::

    theta_1 = -q_1,   theta_2 = q_2 - pi/2,   theta_3 = q_3 + pi/2,
    theta_4 =  q_4,   theta_5 = q_5 - pi,     theta_6 = q_6 + pi/2

i.e. ``theta = sign * q + offset`` per joint, and for velocities ``theta_dot = sign * q_dot``
(:data:`JOINT_SIGNS`, :data:`JOINT_OFFSETS`). An actuator angle is defined modulo 2 pi (the SDK
reports [0, 360) degrees): :func:`dh_from_actuator` picks, per joint, the equivalent angle nearest
a reference: the previous measurement, or at the start the task's start posture among the
equivalents inside the model's joint limits (a joint whose limits span more than 2 pi has several).

Fingers: Drake's Jaco messages carry a finger's position in Kinova SDK finger units x pi/180, and
Drake's Jaco receivers scale them by 1.34 / 118.68 to the URDF's finger angle (118.68 = 6800
units, the closed finger, x pi/180). Our MICO's fingers are prismatic slides (m, 0 = closed, 0.06
= open): a finger at a fraction ``c`` of its closing travel (``c = units / FINGER_CLOSED``) sits at
``(1 - c) * FINGER_TRAVEL``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.station.config import FINGER_MAX_OPENING

JOINT_SIGNS = np.array([-1.0, 1.0, 1.0, 1.0, 1.0, 1.0])
"""``theta = sign * q + offset``: the sign per joint (base to wrist)."""
JOINT_OFFSETS = np.array([0.0, -math.pi / 2, math.pi / 2, 0.0, -math.pi, math.pi / 2])
"""``theta = sign * q + offset``: the offset (rad) per joint (base to wrist)."""
JOINT_SIGNS.setflags(write=False)
JOINT_OFFSETS.setflags(write=False)

FINGER_CLOSED = 6800.0 * math.pi / 180.0
"""A closed finger's position in the message's finger units (6800 SDK units x pi/180 = 118.68)."""
FINGER_TRAVEL = FINGER_MAX_OPENING / 2
"""Travel (m) of each of our model's finger slides (open at 0.06, closed at 0)."""


def dh_from_actuator(
    q: ArrayLike, reference: ArrayLike, limits: tuple[ArrayLike, ArrayLike] | None = None
) -> NDArray[np.float64]:
    """Our model's DH angles (6, rad) of the actuator angles ``q`` (6, rad), each the 2 pi
    equivalent nearest ``reference`` (6, rad).

    With ``limits`` (the lower and upper joint limits, 6 each, rad), a joint's angle is the
    equivalent nearest ``reference`` among those inside its limits; a joint with no equivalent
    inside them keeps the one nearest ``reference`` (the caller's limit check then names it).
    """
    theta = JOINT_SIGNS * np.asarray(q, dtype=float) + JOINT_OFFSETS
    turns = np.round((np.asarray(reference, dtype=float) - theta) / (2 * math.pi))
    if limits is not None:  # |theta + 2 pi n - reference| is convex in n: clip the nearest n
        low = np.ceil((np.asarray(limits[0], dtype=float) - theta) / (2 * math.pi))
        high = np.floor((np.asarray(limits[1], dtype=float) - theta) / (2 * math.pi))
        turns = np.where(low <= high, np.clip(turns, low, high), turns)
    return theta + 2 * math.pi * turns


def actuator_from_dh(theta: ArrayLike) -> NDArray[np.float64]:
    """The actuator angles (6, rad) of our model's DH angles ``theta`` (6, rad)."""
    return (np.asarray(theta, dtype=float) - JOINT_OFFSETS) * JOINT_SIGNS


def dh_velocity(q_dot: ArrayLike) -> NDArray[np.float64]:
    """DH joint velocities (rad/s) of actuator velocities ``q_dot`` (rad/s); the map is its own inverse."""
    return JOINT_SIGNS * np.asarray(q_dot, dtype=float)


def finger_slide(units: ArrayLike) -> NDArray[np.float64]:
    """Our finger slides (m) of finger positions in the message's units."""
    return (1.0 - np.asarray(units, dtype=float) / FINGER_CLOSED) * FINGER_TRAVEL


def finger_units(slide: ArrayLike) -> NDArray[np.float64]:
    """Finger positions in the message's units of our finger slides (m)."""
    return (1.0 - np.asarray(slide, dtype=float) / FINGER_TRAVEL) * FINGER_CLOSED


def finger_slide_rate(unit_rate: ArrayLike) -> NDArray[np.float64]:
    """Finger slide speeds (m/s) of finger speeds in the message's units per second."""
    return -np.asarray(unit_rate, dtype=float) * (FINGER_TRAVEL / FINGER_CLOSED)


def finger_unit_rate(slide_rate: ArrayLike) -> NDArray[np.float64]:
    """Finger speeds in the message's units per second of finger slide speeds (m/s)."""
    return -np.asarray(slide_rate, dtype=float) * (FINGER_CLOSED / FINGER_TRAVEL)
