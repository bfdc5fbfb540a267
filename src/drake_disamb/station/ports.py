"""The station's port names: those every backend provides, and those only one kind of backend has.

A station is the hardware: its inputs are what the arm's driver accepts (the joint-level velocities
of a Kinova Gen2 arm in velocity mode, what ``lcmt_jaco_command`` carries) and its outputs what it
measures, plus the end effector's pose and velocity computed from the measurement. The controllers
(:mod:`drake_disamb.controller`) connect only to :data:`SHARED_INPUTS` and :data:`SHARED_OUTPUTS`,
so any backend (the in-process simulation, the arm behind LCM) can stand behind them.

Joint quantities are in our model's order and terms: the six arm joints of ``ARM_JOINTS`` (Kinova's
classic-DH angles, rad, rad/s), then the two finger slides of ``FINGER_JOINTS`` (m, m/s; each
finger's inner face at +/- q from the centre line, 0 closed, 0.06 open). End-effector velocities
are in the paper's order ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s), expressed in the world frame W
(which coincides with ``mico_link_base``), taken at the end-effector origin; poses are
``[x, y, z, qw, qx, qy, qz]`` in W.
"""

from __future__ import annotations

SHARED_INPUTS: tuple[str, ...] = ("arm_velocity_command", "finger_velocity_command")
"""Inputs of every backend: ``arm_velocity_command`` (6, the arm's joint velocities, rad/s, DH
joint order) and ``finger_velocity_command`` (2, the finger slides' velocities, m/s; positive
opens). A NaN or infinite entry is read as a zero command."""

SHARED_OUTPUTS: tuple[str, ...] = (
    "ee_pose",
    "ee_velocity",
    "arm_joint_state",
    "finger_state",
    "gripper_opening",
)
"""Outputs of every backend, all from the measurement: ``ee_pose`` (7), ``ee_velocity`` (6),
``arm_joint_state`` (12: the measured arm angles, rad, DH, then velocities, rad/s),
``finger_state`` (4: the finger slides, m, then their velocities, m/s) and ``gripper_opening`` (1,
m: the distance between the fingertip pads, the sum of the two slides)."""

SIMULATION_OUTPUTS: tuple[str, ...] = ("query_object",)
"""Outputs of the simulated station only: ``query_object`` (the SceneGraph's, abstract)."""

HARDWARE_OUTPUTS: tuple[str, ...] = ("fault",)
"""Outputs of a station on a wire only: ``fault`` (1, a latched
:class:`~drake_disamb.station.lcm.faults.Fault` code; 0 while none)."""

INPUT_SIZES: dict[str, int] = {"arm_velocity_command": 6, "finger_velocity_command": 2}
"""Sizes of the input ports."""

OUTPUT_SIZES: dict[str, int] = {
    "ee_pose": 7,
    "ee_velocity": 6,
    "arm_joint_state": 12,
    "finger_state": 4,
    "gripper_opening": 1,
    "fault": 1,
}
"""Sizes of the vector output ports."""
