"""The MICO station: one Diagram with named exported ports that turns the paper's end-effector
velocity command into arm motion through a differential-IK integrator, built from a backend
choice (Drake's ``MakeHardwareStation(scenario, meshcat, hardware=...)`` pattern): the in-process
simulation (a MultibodyPlant arm on a table, joint PD plus gravity compensation) or a real or
simulated arm behind LCM.

Modules:

- :mod:`~drake_disamb.station.backends`: the registry of backends (one module each) and
  :func:`~drake_disamb.station.backends.make_station`, the one entry point.
- :mod:`~drake_disamb.station.ports`: the ports every backend provides, and the ones only the
  simulation (or only a wire) has.
- :mod:`~drake_disamb.station.geometry`: the clearance geometry read from a station's own plant.

- :mod:`~drake_disamb.station.config`: joint and frame names, the home posture (read from the
  model directives), :class:`SceneObject` and :class:`StationConfig`.
- :mod:`~drake_disamb.station.systems`: the three LeafSystems (:class:`DifferentialIKIntegrator`,
  :class:`GripperOpeningIntegrator`, :class:`EndEffectorState`) and their state layouts.
- :mod:`~drake_disamb.station.build`: :func:`build_station`, which returns a :class:`Station`
  (the Diagram and typed handles on the plant, control plant and integrators); its docstring
  lists the ports, the subsystem names and how to use it.

Every public name is re-exported here: ``from drake_disamb.station import build_station``.
"""

from drake_disamb.ik import IkStatus
from drake_disamb.station.build import STATION_INPUTS, STATION_OUTPUTS, Station, build_station
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
    check_plant_config,
    default_plant_config,
)
from drake_disamb.station.systems import (
    IK_Q_D,
    IK_V_D,
    DifferentialIKIntegrator,
    EndEffectorState,
    GripperIntegratorState,
    GripperOpeningIntegrator,
    IkIntegratorState,
)

__all__ = [
    "ARM_JOINTS",
    "ARM_MODEL_NAME",
    "BASE_FRAME",
    "EE_FRAME",
    "FINGER_JOINTS",
    "FINGER_MAX_OPENING",
    "IK_Q_D",
    "IK_V_D",
    "MICO_HOME_GRIPPER_OPENING",
    "MICO_HOME_Q",
    "PLANT_CONFIG_CHOICES",
    "STATION_INPUTS",
    "STATION_OUTPUTS",
    "DifferentialIKIntegrator",
    "EndEffectorState",
    "GripperIntegratorState",
    "GripperOpeningIntegrator",
    "IkIntegratorState",
    "IkStatus",
    "SceneObject",
    "Station",
    "StationConfig",
    "check_plant_config",
    "default_plant_config",
    "build_station",
]
