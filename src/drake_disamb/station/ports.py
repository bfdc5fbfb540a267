"""The station's port names: those every backend provides, and those only one kind of backend has.

The shared-control systems connect only to :data:`SHARED_INPUTS` and :data:`SHARED_OUTPUTS`, so
any backend (the in-process simulation, the arm behind LCM) can stand behind them. Velocities are
in the paper's order ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s), expressed in the world frame W
(which coincides with ``mico_link_base``), taken at the end-effector origin; poses are
``[x, y, z, qw, qx, qy, qz]`` in W.
"""

from __future__ import annotations

SHARED_INPUTS: tuple[str, ...] = ("ee_velocity_command", "gripper_command")
"""Inputs of every backend: ``ee_velocity_command`` (6, the desired end-effector twist) and
``gripper_command`` (1, finger opening speed, m/s; positive opens)."""

SHARED_OUTPUTS: tuple[str, ...] = ("ee_pose", "ee_velocity", "arm_joint_state", "gripper_opening")
"""Outputs of every backend: ``ee_pose`` (7), ``ee_velocity`` (6), ``arm_joint_state`` (12: the
measured arm angles, rad, DH, then velocities, rad/s) and ``gripper_opening`` (1, m)."""

SIMULATION_OUTPUTS: tuple[str, ...] = ("ik_status", "query_object")
"""Outputs of the simulated station only: ``ik_status`` (1, the IK's
:class:`~drake_disamb.ik.IkStatus` code) and ``query_object`` (the SceneGraph's, abstract)."""

HARDWARE_OUTPUTS: tuple[str, ...] = ("fault",)
"""Outputs of a station on a wire only: ``fault`` (1, a latched
:class:`~drake_disamb.station.lcm.faults.Fault` code; 0 while none)."""

OUTPUT_SIZES: dict[str, int] = {
    "ee_pose": 7,
    "ee_velocity": 6,
    "arm_joint_state": 12,
    "gripper_opening": 1,
    "ik_status": 1,
    "fault": 1,
}
"""Sizes of the vector output ports."""
