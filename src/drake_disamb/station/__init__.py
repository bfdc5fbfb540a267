"""The simulated MICO station: a MultibodyPlant arm on a table, joint PD plus gravity compensation,
and a differential-IK integrator that turns the paper's end-effector velocity command into joint
set points; built as one Diagram with named exported ports (Drake's ``MakeHardwareStation``
pattern).

Modules:

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
