"""The controllers between the shared-control commands and the station: the direction-preserving
differential IK (an end-effector velocity -> the arm's joint velocities, with its safety contract
and its ``ik_status``) and the gripper's opening speed -> the fingers' velocities. They are not
hardware: every station backend takes the joint-level commands they output
(:mod:`drake_disamb.station.ports`), and they sit in the shared-control diagram between the blender
and the station.

Its modules, and where this package sits among the others: docs/architecture.md (Layout).
"""

from drake_disamb.controller.build import (
    CONTROLLER_INPUTS,
    ControlledStation,
    StationController,
    add_station_controller,
    build_controlled_station,
)
from drake_disamb.controller.systems import DifferentialIKIntegrator, GripperController
from drake_disamb.ik import IkStatus

__all__ = [
    "CONTROLLER_INPUTS",
    "ControlledStation",
    "DifferentialIKIntegrator",
    "GripperController",
    "IkStatus",
    "StationController",
    "add_station_controller",
    "build_controlled_station",
]
