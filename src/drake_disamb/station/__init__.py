"""The MICO station: the hardware, as one Diagram with named exported ports, built from a backend
choice (Drake's ``MakeHardwareStation(scenario, meshcat, hardware=...)`` pattern): the in-process
simulation (a MultibodyPlant arm on a table, joint PD plus gravity compensation, its set points
integrated from the commanded velocities) or a real or simulated arm behind LCM. Every backend
takes joint-level commands (the arm's joint velocities, the fingers' velocities: what a Kinova Gen2
arm's driver accepts) and gives the measured joint state and fingers; the controllers that turn the
shared-control commands into joint velocities are :mod:`drake_disamb.controller`'s.
:func:`~drake_disamb.station.backends.make_station` is the one entry point.

Every public name is re-exported here: ``from drake_disamb.station import build_station``.

Its modules, and where this package sits among the others: docs/architecture.md (Layout).
"""

from drake_disamb.station.build import (
    STATION_INPUTS,
    STATION_OUTPUTS,
    Station,
    add_scene_objects,
    build_station,
    make_control_plant,
)
from drake_disamb.station.config import (
    ARM_JOINTS,
    ARM_MODEL_NAME,
    BASE_FRAME,
    EE_FRAME,
    FINGER_JOINTS,
    FINGER_MAX_OPENING,
    MICO_HOME_GRIPPER_OPENING,
    MICO_HOME_Q,
    PLANT_CONFIG_CHOICES,
    SceneObject,
    StationConfig,
    arm_velocity_limits,
    check_home_q,
    check_plant_config,
    default_plant_config,
)
from drake_disamb.station.systems import EndEffectorState, JointVelocityIntegrator

__all__ = [
    "ARM_JOINTS",
    "ARM_MODEL_NAME",
    "BASE_FRAME",
    "EE_FRAME",
    "FINGER_JOINTS",
    "FINGER_MAX_OPENING",
    "MICO_HOME_GRIPPER_OPENING",
    "MICO_HOME_Q",
    "PLANT_CONFIG_CHOICES",
    "STATION_INPUTS",
    "STATION_OUTPUTS",
    "EndEffectorState",
    "JointVelocityIntegrator",
    "SceneObject",
    "Station",
    "StationConfig",
    "add_scene_objects",
    "arm_velocity_limits",
    "build_station",
    "check_home_q",
    "check_plant_config",
    "default_plant_config",
    "make_control_plant",
]
