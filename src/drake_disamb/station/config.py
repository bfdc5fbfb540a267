"""Configuration of the MICO station: names of the model's joints and frames, the home posture,
:class:`SceneObject` (an object welded into the scene or held in the gripper) and
:class:`StationConfig` (every setting of the station, SI units).

The home posture lives in the model directives (``default_joint_positions`` in
``models/mico/mico_on_table.dmd.yaml``, where its derivation is written down); :data:`MICO_HOME_Q`
and :data:`MICO_HOME_GRIPPER_OPENING` are read from there, and ``StationConfig.home_q`` /
``home_gripper_opening`` default to them (a config that sets them overrides the directives).
"""

from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydrake.common.eigen_geometry import Quaternion
from pydrake.geometry import Box, Cylinder, Sphere
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import LoadModelDirectives, Parser
from pydrake.multibody.plant import MultibodyPlant, MultibodyPlantConfig
from pydrake.multibody.tree import ModelInstanceIndex, SpatialInertia

from drake_disamb.core.layout import SHAPE_SIZES
from drake_disamb.core.validation import TIME_STEP_RANGE, check_real_range
from drake_disamb.paths import MODELS_PACKAGE, mico_directives, models_dir

ARM_JOINTS: tuple[str, ...] = tuple(f"mico_joint_{i}" for i in range(1, 7))
"""The six arm joints, base to wrist; their angles are Kinova's classic-DH angles (rad)."""
FINGER_JOINTS: tuple[str, ...] = ("mico_finger_joint_left", "mico_finger_joint_right")
"""The two prismatic finger joints (m); each finger's inner face sits at +/- q from the centre line."""
ARM_MODEL_NAME = "mico"
"""Model instance name of the MICO (arm and gripper) in the model directives."""
BASE_FRAME = "mico_link_base"
EE_FRAME = "mico_end_effector"

FINGER_MAX_OPENING = 0.12
"""Largest distance between the fingertip pads (m): each finger travels 0 .. 0.06 m."""


def model_parser(plant: MultibodyPlant) -> Parser:
    """A Parser into ``plant`` that resolves our models' package (never the network)."""
    parser = Parser(plant)
    parser.package_map().Add(MODELS_PACKAGE, str(models_dir()))
    return parser


def _directive_home() -> tuple[NDArray[np.float64], float]:
    """Arm joint angles (rad) and gripper opening (m) of the MICO's ``default_joint_positions``."""
    path = mico_directives()
    for directive in LoadModelDirectives(str(path)).directives:
        model = directive.add_model
        if model is None or model.name != ARM_MODEL_NAME:
            continue
        defaults = model.default_joint_positions
        missing = [j for j in ARM_JOINTS + FINGER_JOINTS if j not in defaults]
        if missing:
            raise RuntimeError(
                f"{path}: add_model {ARM_MODEL_NAME!r} has no default_joint_positions for {missing}"
            )
        q = np.array([float(defaults[j][0]) for j in ARM_JOINTS])
        return q, float(sum(defaults[j][0] for j in FINGER_JOINTS))
    raise RuntimeError(f"{path}: no add_model directive named {ARM_MODEL_NAME!r}")  # pragma: no cover


MICO_HOME_Q, MICO_HOME_GRIPPER_OPENING = _directive_home()
"""Home arm joint angles (rad, DH; read-only) and gripper opening (m), from the model directives'
``default_joint_positions``. The gripper points straight down with the end effector at
(0.000, -0.350, 0.300) m in W, elbow up; the directives file says how the posture was found and
where its singularities are."""
MICO_HOME_Q.setflags(write=False)


_NAME_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def _finite_vector(owner: str, field_name: str, value: Any, size: int | None = None) -> NDArray[np.float64]:
    try:
        arr = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{owner}.{field_name}: expected numbers, got {value!r}") from None
    if size is not None and arr.size != size:
        raise ValueError(f"{owner}.{field_name}: expected {size} numbers, got {list(np.atleast_1d(value))}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{owner}.{field_name}: expected finite numbers, got {arr.tolist()}")
    return arr


@dataclass(frozen=True)
class SceneObject:
    """A rigid object in the scene: welded to the world, or held rigidly in the gripper.

    Attributes:
        name: Body name (a Python-identifier-like string, unique in the station).
        shape: ``"box"`` (size = x, y, z lengths), ``"cylinder"`` (size = radius, length along its z)
            or ``"sphere"`` (size = radius); metres.
        size: Dimensions as described for ``shape``.
        pose: ``[x, y, z, qw, qx, qy, qz]`` of the object frame (its geometric centre) in W, or in
            ``mico_end_effector`` when ``attached_to_gripper``; the quaternion is normalised.
        rgba: Colour, four numbers in [0, 1].
        welded: Must be True: objects are static (welded) visual + collision bodies.
        attached_to_gripper: Weld the object to ``mico_end_effector`` instead of the world (e.g. the
            cup held for pouring). Its mass then loads the arm and is gravity-compensated.
        mass: Mass (kg) of an attached object (a welded one's mass has no effect).
    """

    name: str
    shape: str
    size: tuple[float, ...]
    pose: tuple[float, ...] = (0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
    rgba: tuple[float, float, float, float] = (0.8, 0.35, 0.2, 1.0)
    welded: bool = True
    attached_to_gripper: bool = False
    mass: float = 0.2

    def __post_init__(self) -> None:
        owner = f"SceneObject({self.name!r})"
        if not isinstance(self.name, str) or not _NAME_RE.match(self.name):
            raise ValueError(f"SceneObject.name: expected an identifier-like string, got {self.name!r}")
        if self.shape not in SHAPE_SIZES:
            raise ValueError(f"{owner}.shape: expected one of {sorted(SHAPE_SIZES)}, got {self.shape!r}")
        size = _finite_vector(owner, "size", self.size, SHAPE_SIZES[self.shape])
        if np.any(size <= 0):
            raise ValueError(f"{owner}.size: expected positive numbers, got {size.tolist()}")
        pose = _finite_vector(owner, "pose", self.pose, 7)
        qn = float(np.linalg.norm(pose[3:]))
        if qn < 1e-9:
            raise ValueError(
                f"{owner}.pose: quaternion [qw, qx, qy, qz] must be non-zero, got {pose[3:].tolist()}"
            )
        pose[3:] /= qn
        rgba = _finite_vector(owner, "rgba", self.rgba, 4)
        if np.any(rgba < 0) or np.any(rgba > 1):
            raise ValueError(f"{owner}.rgba: expected 4 numbers in [0, 1], got {rgba.tolist()}")
        if self.welded is not True:
            raise ValueError(f"{owner}.welded: free bodies are not supported, got {self.welded!r}")
        if not (np.isfinite(self.mass) and self.mass > 0):
            raise ValueError(f"{owner}.mass: expected a finite positive number, got {self.mass!r}")
        object.__setattr__(self, "size", tuple(size.tolist()))
        object.__setattr__(self, "pose", tuple(pose.tolist()))
        object.__setattr__(self, "rgba", tuple(rgba.tolist()))

    def drake_shape(self) -> Box | Cylinder | Sphere:
        """The Drake shape of the object."""
        if self.shape == "box":
            return Box(*self.size)
        if self.shape == "cylinder":
            return Cylinder(self.size[0], self.size[1])
        return Sphere(self.size[0])

    def transform(self) -> RigidTransform:
        """The object's pose as a RigidTransform (in W, or in the EE frame when attached)."""
        p = np.asarray(self.pose)
        return RigidTransform(Quaternion(p[3:]), p[:3])

    def spatial_inertia(self) -> SpatialInertia:
        """Uniform-density spatial inertia about the object's origin (its centre)."""
        if self.shape == "box":
            return SpatialInertia.SolidBoxWithMass(self.mass, *self.size)
        if self.shape == "cylinder":
            return SpatialInertia.SolidCylinderWithMass(
                self.mass, self.size[0], self.size[1], [0.0, 0.0, 1.0]
            )
        return SpatialInertia.SolidSphereWithMass(self.mass, self.size[0])


def default_plant_config(time_step: float = 0.01) -> MultibodyPlantConfig:
    """The station's MultibodyPlantConfig: discrete steps of ``time_step`` (s), SAP (it integrates the
    joint-actuator PD implicitly), point contact (the fast choice) and live output ports
    (``use_sampled_output_ports=False``); Drake's defaults otherwise.

    Live ports: with Drake's default (sampled) the plant's step is an *unrestricted* update, and a
    diagram applies the unrestricted updates of all its subsystems at every tick at which any
    of them writes, even of those that returned ``DidNothing``: the belief, the interface's and
    the disambiguation system's states would be rewritten every 10 ms and everything computed from
    them (the blending step, the belief's projection) computed twice per tick. The station reads
    only the plant's state ports, whose values are the same either way.
    """
    return MultibodyPlantConfig(
        time_step=time_step,
        discrete_contact_approximation="sap",
        contact_model="point",
        use_sampled_output_ports=False,
    )


PLANT_CONFIG_CHOICES: dict[str, tuple[str, ...]] = {
    "contact_model": ("point", "hydroelastic", "hydroelastic_with_fallback"),
    "discrete_contact_approximation": ("sap", "similar", "lagged"),
    "contact_surface_representation": ("triangle", "polygon"),
}
"""Accepted values of the MultibodyPlantConfig's string fields. The discrete contact approximation
must be one of SAP's: only SAP evaluates the joint actuators' PD controllers the station uses."""


def check_plant_config(config: MultibodyPlantConfig, path: str) -> None:
    """Raise ``ValueError`` naming ``path.<field>`` and the value unless the station can use ``config``.

    The plant is discrete, ``time_step`` in [1 ms, 100 ms] (``TIME_STEP_RANGE``); the string
    fields take the values of :data:`PLANT_CONFIG_CHOICES`; the tolerances are finite and positive
    (``sap_near_rigid_threshold`` may be 0).
    """
    check_real_range(config.time_step, f"{path}.time_step", *TIME_STEP_RANGE, unit="s")
    for name, choices in PLANT_CONFIG_CHOICES.items():
        value = getattr(config, name)
        if value not in choices:
            raise ValueError(f"{path}.{name}: expected one of {', '.join(choices)}, got {value!r}")
    for name in ("penetration_allowance", "stiction_tolerance"):
        value = getattr(config, name)
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{path}.{name}: expected a finite number > 0, got {value!r}")
    if not (math.isfinite(config.sap_near_rigid_threshold) and config.sap_near_rigid_threshold >= 0):
        raise ValueError(
            f"{path}.sap_near_rigid_threshold: expected a finite number >= 0, "
            f"got {config.sap_near_rigid_threshold!r}"
        )


@dataclass(frozen=True)
class StationConfig:
    """Settings of the station (SI units).

    Attributes:
        plant_config: Drake's ``MultibodyPlantConfig`` of the arm's plant (checked by
            :func:`check_plant_config`; the default is :func:`default_plant_config`). Its
            ``time_step`` (s) defaults to 0.01 s, the default ``control_period``: the arm receives
            new joint set points only once per control tick, and SAP integrates the joint-actuator
            PD implicitly (stable at large steps), so one physics step per tick tracks the set
            points as well as finer steps do (the station's tests pass unchanged at 2, 5 and 10 ms)
            while costing a fifth of a 2 ms plant. Choose a smaller step (e.g. 0.001) to resolve
            contact with the table or objects more finely.
        control_period: Period of the controllers (the differential IK, the gripper's) and of the
            simulated arm's set-point integrator (s), 0.01 = 100 Hz.
            Both it and ``plant_config.time_step`` must lie in [1 ms, 100 ms] (``TIME_STEP_RANGE``).
        home_q: Initial arm joint angles (rad, DH); must be inside the joint limits. The default,
            :data:`MICO_HOME_Q`, is the model directives' ``default_joint_positions``; another value
            overrides them.
        home_gripper_opening: Initial distance between the fingertips (m); the default,
            :data:`MICO_HOME_GRIPPER_OPENING`, is the directives' (0.08 m).
        joint_velocity_limits: Per-joint speed limits (rad/s) for the IK and for the commands the
            station on LCM sends; ``None`` takes the model's limits (36 deg/s for joints 1-3, 48
            deg/s for 4-6).
        joint_acceleration_limits: Per-joint acceleration limits for the IK (rad/s^2). A change of
            command ramps the joints at their limit along the new command's direction, and a joint
            approaching a position limit brakes at it. They give way only to the command's
            direction (a sudden turn while moving fast changes direction at once) and a zero
            command stops at once. The default, 5 rad/s^2 (a wrist joint reaches full speed in
            0.17 s, the joint speeds of a 0.1 m/s command in about 0.06 s), keeps the physical
            arm's lag during a ramp from moving the end effector off the command by more than
            about 0.5 cm/s; at 20 rad/s^2 that transient reached 1.7 cm/s.
        table_clearance: Floor (m) above the table top (z = 0) for every point of the gripper
            (link 6 and both fingers, open or closed, plus a held cup): a command that would take
            any of them lower, by translating or by turning, is slowed along its own direction
            and stops there (status ``WORKSPACE``) instead of pushing the gripper into the table.
            The default equals the scenario validation's ``MIN_TABLE_CLEARANCE`` (5 mm), so
            every goal that validation accepts is above the floor. ``None`` disables the floor.
        nominal_posture: Posture (rad) the IK pulls towards in the null space of the task; ``None``
            uses ``home_q``.
        nominal_posture_gain: Gain (1/s) of that pull.
        kp, kd: Arm joint PD gains (N m/rad, N m s/rad) of the plant's joint actuators.
        finger_kp, finger_kd: Finger PD gains (N/m, N s/m).
        reseed_tolerance: When the integrated set point is farther than this (rad, any joint) from the
            measured joint angles, it is reset to them: the IK's (status ``RESEEDED``), and the
            simulated arm's own, which integrates the same joint velocities.
        limited_alpha: Report ``LIMITED`` (or ``SINGULAR``) when the IK achieves less than this
            fraction of the command along it, or misses it by more than ``1 - limited_alpha``.
        warn_interval: Minimum simulated time (s) between two warnings about bad commands.
        scene_objects: Objects to add (in addition to those passed to :func:`build_station`).
    """

    plant_config: MultibodyPlantConfig = field(default_factory=default_plant_config)
    control_period: float = 0.01
    home_q: tuple[float, ...] = tuple(MICO_HOME_Q.tolist())
    home_gripper_opening: float = MICO_HOME_GRIPPER_OPENING
    joint_velocity_limits: tuple[float, ...] | None = None
    joint_acceleration_limits: tuple[float, ...] = (5.0,) * 6
    table_clearance: float | None = 0.005
    nominal_posture: tuple[float, ...] | None = None
    nominal_posture_gain: float = 0.5
    kp: tuple[float, ...] = (300.0, 300.0, 300.0, 60.0, 60.0, 60.0)
    kd: tuple[float, ...] = (30.0, 30.0, 30.0, 4.0, 4.0, 4.0)
    finger_kp: float = 500.0
    finger_kd: float = 20.0
    reseed_tolerance: float = 0.15
    limited_alpha: float = 0.95
    warn_interval: float = 1.0
    scene_objects: tuple[SceneObject, ...] = field(default=())

    def __post_init__(self) -> None:
        o = "StationConfig"
        for name in ("control_period", "warn_interval", "reseed_tolerance"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"{o}.{name}: expected a finite positive number, got {v!r}")
        if not isinstance(self.plant_config, MultibodyPlantConfig):
            raise ValueError(f"{o}.plant_config: expected a MultibodyPlantConfig, got {self.plant_config!r}")
        object.__setattr__(self, "plant_config", copy.copy(self.plant_config))  # not the caller's object
        check_plant_config(self.plant_config, f"{o}.plant_config")
        check_real_range(self.control_period, f"{o}.control_period", *TIME_STEP_RANGE, unit="s")
        time_step = self.plant_config.time_step
        if self.control_period < time_step * (1 - 1e-9):
            raise ValueError(
                f"{o}.control_period: must be >= plant_config.time_step ({time_step}), "
                f"got {self.control_period!r}"
            )
        object.__setattr__(self, "home_q", tuple(_finite_vector(o, "home_q", self.home_q, 6).tolist()))
        if not (0.0 <= self.home_gripper_opening <= FINGER_MAX_OPENING):
            raise ValueError(
                f"{o}.home_gripper_opening: expected a number in [0, {FINGER_MAX_OPENING}] m, "
                f"got {self.home_gripper_opening!r}"
            )
        for name in ("joint_velocity_limits", "nominal_posture"):
            v = getattr(self, name)
            if v is not None:
                arr = _finite_vector(o, name, v, 6)
                if name == "joint_velocity_limits" and np.any(arr <= 0):
                    raise ValueError(f"{o}.{name}: expected positive numbers, got {arr.tolist()}")
                object.__setattr__(self, name, tuple(arr.tolist()))
        if self.table_clearance is not None and not (
            isinstance(self.table_clearance, int | float)
            and not isinstance(self.table_clearance, bool)
            and 0.0 <= self.table_clearance <= 0.5
        ):
            raise ValueError(
                f"{o}.table_clearance: expected None or a number in [0, 0.5] m, got {self.table_clearance!r}"
            )
        for name in ("joint_acceleration_limits", "kp", "kd"):
            arr = _finite_vector(o, name, getattr(self, name), 6)
            if np.any(arr <= 0):
                raise ValueError(f"{o}.{name}: expected positive numbers, got {arr.tolist()}")
            object.__setattr__(self, name, tuple(arr.tolist()))
        for name in ("finger_kp", "finger_kd"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise ValueError(f"{o}.{name}: expected a finite positive number, got {v!r}")
        if not (isinstance(self.nominal_posture_gain, int | float) and 0 <= self.nominal_posture_gain < 1e3):
            raise ValueError(
                f"{o}.nominal_posture_gain: expected a number in [0, 1000), got {self.nominal_posture_gain!r}"
            )
        if not (0 < self.limited_alpha <= 1):
            raise ValueError(f"{o}.limited_alpha: expected a number in (0, 1], got {self.limited_alpha!r}")
        objs = tuple(self.scene_objects)
        for k, obj in enumerate(objs):
            if not isinstance(obj, SceneObject):
                raise ValueError(f"{o}.scene_objects[{k}]: expected a SceneObject, got {obj!r}")
        object.__setattr__(self, "scene_objects", objs)


def check_home_q(config: StationConfig, lower: NDArray[np.float64], upper: NDArray[np.float64]) -> None:
    """Raise ``ValueError`` naming ``StationConfig.home_q`` unless it lies inside the joint limits
    ``[lower, upper]`` (rad, six each)."""
    home = np.asarray(config.home_q)
    if np.any(home < lower) or np.any(home > upper):
        raise ValueError(
            f"StationConfig.home_q: outside the joint limits [{lower}, {upper}], got {home.tolist()}"
        )


def arm_velocity_limits(
    config: StationConfig, plant: MultibodyPlant, instance: ModelInstanceIndex
) -> NDArray[np.float64]:
    """The arm's joint speed limits (rad/s, six, base to wrist): ``config.joint_velocity_limits``,
    or the model's (the joints of ``instance`` in ``plant``) when it is ``None``."""
    if config.joint_velocity_limits is not None:
        return np.array(config.joint_velocity_limits)
    return np.array([plant.GetJointByName(n, instance).velocity_upper_limits()[0] for n in ARM_JOINTS])
