"""The simulated MICO station: MultibodyPlant arm on a table, joint PD + gravity compensation, and a
differential-IK integrator that turns the paper's end-effector velocity command into joint set points.

Structure (see ``diagrams/station.py`` for the picture)::

    ee_velocity_command ─▶ DifferentialIKIntegrator ─┐ (12: q_d, v_d of the arm)
    gripper_command ─────▶ GripperOpeningIntegrator ─┤ (4: q_d, v_d of the fingers)
                                                     ▼
                                   Multiplexer + MatrixGain (actuator order)
                                                     ▼  desired state
    InverseDynamics (gravity compensation) ──▶ MultibodyPlant (discrete, SAP, gravity on;
                     ▲ actuation feed-forward      joint-actuator PD tracks the desired state)
                     └────────── mico state ◀──────────┘

How to use it
-------------
``build_station(config, scene_objects, meshcat, builder)`` supports two ways, with the same port names:

- **Standalone** (``builder=None``): a new ``DiagramBuilder`` is created, every station port is
  exported under its name and the diagram is built; ``station.diagram`` is the station Diagram and
  ``station.input_ports`` / ``station.output_ports`` are the diagram's exported ports.
- **Embedded** (``builder=...``): every system (plant and scene graph included) is added to the
  caller's builder and nothing is exported or built; ``station.diagram`` is ``None`` and
  ``station.input_ports`` / ``station.output_ports`` are the ports of the subsystems inside that
  builder, ready for ``builder.Connect(...)``. Both inputs must then be connected (or exported).

Station ports (velocities are in the paper's order ``[vx, vy, vz, wx, wy, wz]``, not Drake's
``[w; v]``; W is the world frame, which coincides with ``mico_link_base``):

- input ``ee_velocity_command`` (6): desired spatial velocity of ``mico_end_effector``, m/s and
  rad/s, expressed in W, taken at the end-effector origin.
- input ``gripper_command`` (1): finger opening speed, m/s; positive opens.
- output ``ee_pose`` (7): ``[x, y, z, qw, qx, qy, qz]`` of ``mico_end_effector`` in W (m).
- output ``ee_velocity`` (6): measured spatial velocity of ``mico_end_effector`` (paper order, W, m/s, rad/s).
- output ``arm_joint_state`` (12): measured arm joint positions (rad, the DH angles) then velocities (rad/s).
- output ``gripper_opening`` (1): distance between the fingertip pads, m.
- output ``ik_status`` (1): an :class:`IkStatus` code of the last control step.
- output ``query_object``: the SceneGraph query object (abstract).

Bad run-time commands: a NaN or infinite entry in ``ee_velocity_command`` or ``gripper_command`` is
treated as a zero command, with a ``RuntimeWarning`` at most once per ``StationConfig.warn_interval``
seconds of simulated time; ``ik_status`` reports ``INVALID_COMMAND`` (2) for the arm. A vector of the
wrong length cannot reach the station: Drake rejects it where it enters (``FixValue`` or
``DiagramBuilder.Connect`` raise), so the station's state is untouched.
"""

from __future__ import annotations

import copy
import math
import re
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydrake.common.eigen_geometry import Quaternion
from pydrake.common.value import Value
from pydrake.geometry import (
    Box,
    CollisionFilterDeclaration,
    Cylinder,
    Meshcat,
    Role,
    SceneGraph,
    Sphere,
)
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import LoadModelDirectives, Parser, ProcessModelDirectives
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    CoulombFriction,
    MultibodyPlant,
    MultibodyPlantConfig,
)
from pydrake.multibody.tree import (
    JacobianWrtVariable,
    JointActuatorIndex,
    ModelInstanceIndex,
    PdControllerGains,
    SpatialInertia,
)
from pydrake.systems.controllers import InverseDynamics
from pydrake.systems.framework import (
    BasicVector,
    Context,
    Diagram,
    DiagramBuilder,
    DiscreteValues,
    EventStatus,
    InputPort,
    LeafSystem,
    OutputPort,
)
from pydrake.systems.primitives import MatrixGain, Multiplexer

from drake_disamb.clearance import Solid, gripper_points_in_ee, table_top_z
from drake_disamb.core._validation import TIME_STEP_RANGE, all_finite, check_real_range
from drake_disamb.ik import IkParams, IkStatus, JointLimits, VelocityIkSolver
from drake_disamb.paths import MODELS_PACKAGE, mico_directives, mico_urdf, models_dir

ARM_JOINTS: tuple[str, ...] = tuple(f"mico_joint_{i}" for i in range(1, 7))
"""The six arm joints, base to wrist; their angles are Kinova's classic-DH angles (rad)."""
FINGER_JOINTS: tuple[str, ...] = ("mico_finger_joint_left", "mico_finger_joint_right")
"""The two prismatic finger joints (m); each finger's inner face sits at +/- q from the centre line."""
ARM_MODEL_NAME = "mico"
BASE_FRAME = "mico_link_base"
EE_FRAME = "mico_end_effector"

MICO_HOME_Q: NDArray[np.float64] = np.array([-1.3837, 1.0972, 5.7374, 2.4721, -1.1269, -0.8566])
"""Home joint angles (rad, DH). The gripper points straight down (z_E = -z_W, fingers opening along
x_W) with the end effector at (0.000, -0.350, 0.300) m in W, elbow up; found with a numerical IK on
the DH model (best smallest singular value of J among gripper-down solutions there, 0.07). Joint
limits are far, but with the orientation held fixed the curved wrist reaches its theta_5 = 0
singularity after about 7 cm straight up or 9 cm along -y; the study's goals (FACTS section 8) are
reachable with the gripper pointing forward (-y), not straight down."""
MICO_HOME_Q.setflags(write=False)

FINGER_MAX_OPENING = 0.12
"""Largest distance between the fingertip pads (m): each finger travels 0 .. 0.06 m."""


# ---------------------------------------------------------------------------------------------------
# Configuration
# ---------------------------------------------------------------------------------------------------
_SHAPE_SIZES = {"box": 3, "cylinder": 2, "sphere": 1}
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
        if self.shape not in _SHAPE_SIZES:
            raise ValueError(f"{owner}.shape: expected one of {sorted(_SHAPE_SIZES)}, got {self.shape!r}")
        size = _finite_vector(owner, "size", self.size, _SHAPE_SIZES[self.shape])
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
    joint-actuator PD implicitly) and point contact (the fast choice); Drake's defaults otherwise."""
    return MultibodyPlantConfig(
        time_step=time_step, discrete_contact_approximation="sap", contact_model="point"
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
        control_period: Period of the differential IK and gripper integrators (s), 0.01 = 100 Hz.
            Both it and ``plant_config.time_step`` must lie in [1 ms, 100 ms] (``TIME_STEP_RANGE``).
        home_q: Initial arm joint angles (rad, DH); must be inside the joint limits.
        home_gripper_opening: Initial distance between the fingertips (m).
        joint_velocity_limits: Per-joint speed limits for the IK (rad/s); ``None`` takes the
            model's limits (36 deg/s for joints 1-3, 48 deg/s for 4-6).
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
            measured joint angles, it is reset to them (status ``RESEEDED``).
        limited_alpha: Report ``LIMITED`` (or ``SINGULAR``) when the IK achieves less than this
            fraction of the command along it, or misses it by more than ``1 - limited_alpha``.
        warn_interval: Minimum simulated time (s) between two warnings about bad commands.
        scene_objects: Objects to add (in addition to those passed to :func:`build_station`).
    """

    plant_config: MultibodyPlantConfig = field(default_factory=default_plant_config)
    control_period: float = 0.01
    home_q: tuple[float, ...] = tuple(MICO_HOME_Q.tolist())
    home_gripper_opening: float = 0.08
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


# ---------------------------------------------------------------------------------------------------
# Small helpers
# ---------------------------------------------------------------------------------------------------
def _instance_local_indices(
    plant: MultibodyPlant, instance: ModelInstanceIndex, joint_names: Sequence[str]
) -> tuple[list[int], list[int]]:
    """Indices of single-dof joints inside the instance's position and velocity vectors."""
    q_global: list[int] = []
    v_global: list[int] = []
    for j in plant.GetJointIndices(instance):
        joint = plant.get_joint(j)
        q_global += range(joint.position_start(), joint.position_start() + joint.num_positions())
        v_global += range(joint.velocity_start(), joint.velocity_start() + joint.num_velocities())
    q_global.sort()
    v_global.sort()
    qi, vi = [], []
    for name in joint_names:
        joint = plant.GetJointByName(name, instance)
        qi.append(q_global.index(joint.position_start()))
        vi.append(v_global.index(joint.velocity_start()))
    return qi, vi


class _RateLimitedWarner:
    """Issues a RuntimeWarning at most once per ``interval`` seconds of simulated time."""

    def __init__(self, who: str, interval: float) -> None:
        self._who = who
        self._interval = interval
        self._last: float | None = None
        self._suppressed = 0

    def warn(self, time: float, message: str) -> None:
        if self._last is not None and 0.0 <= time - self._last < self._interval:
            self._suppressed += 1
            return
        extra = f" ({self._suppressed} similar warnings suppressed)" if self._suppressed else ""
        self._last = time
        self._suppressed = 0
        warnings.warn(f"{self._who} at t = {time:.3f} s: {message}{extra}", RuntimeWarning, stacklevel=3)


def _read_command(port: InputPort, context: Context, size: int) -> tuple[NDArray[np.float64], bool]:
    """The command on ``port`` and whether it is valid (finite, right size); invalid -> zeros."""
    value = np.asarray(port.Eval(context), dtype=float).reshape(-1)
    if value.size != size or not all_finite(value):
        return np.zeros(size), False
    return value, True


# ---------------------------------------------------------------------------------------------------
# Leaf systems
# ---------------------------------------------------------------------------------------------------
class DifferentialIKIntegrator(LeafSystem):
    """Turns a commanded end-effector spatial velocity into arm joint set points, at a fixed rate.

    Every ``control_period`` it (1) reads ``ee_velocity_command`` (paper order), (2) computes the
    Jacobian of ``mico_end_effector`` at the integrated set point q_d (rows in the paper's order)
    and solves :meth:`drake_disamb.ik.VelocityIkSolver.solve` there, with the joint position,
    velocity and acceleration limits and the floor ``StationConfig.table_clearance`` under every
    point of the gripper, (3) sets
    ``v_d`` to the solution and integrates ``q_d += v_d * period`` (inside the joint limits by
    construction; clamped against rounding).

    **Motion only where commanded.** The set point's end effector moves along the commanded twist
    and nowhere else: where the command cannot be met in full (a joint limit, a singularity, the
    floor) it is slowed along its own direction or stopped, never bent, and ``ik_status`` says
    why (``LIMITED``, ``SINGULAR``, ``WORKSPACE``, ``STOPPED``); :mod:`drake_disamb.ik` states the
    bound (rounding plus a null-space pull under 0.2 mm/s). On the simulated arm, which tracks
    the set points through its PD, every single-axis command held 10 s from the tested postures
    (home, near the wrist singularity, a joint on its limit, ...) moves the end effector off the
    command by at most 2 cm in total and 1 cm/s (``tests/test_station_safety.py``). The integrator
    is initialised from ``arm_joint_state`` when the simulator initialises and re-seeded from it
    when the set point drifts more than ``reseed_tolerance`` away.

    @system
    name: DifferentialIKIntegrator
    input_ports:
    - ee_velocity_command (6): desired V_WE, [vx, vy, vz, wx, wy, wz] (m/s, rad/s; paper order,
      NOT Drake's [w; v]), expressed in W at the origin of mico_end_effector
    - arm_joint_state (12): measured arm q (rad) then v (rad/s)
    output_ports:
    - desired_state (12): set point q_d (rad) then v_d (rad/s), held between control steps
    - ik_status (1): IkStatus code of the last control step
    @endsystem

    Discrete state: one group ``[q_d (6), v_d (6), status (1)]``.
    """

    def __init__(
        self,
        control_plant: MultibodyPlant,
        config: StationConfig,
        arm_instance: ModelInstanceIndex | None = None,
        held_objects: Sequence[SceneObject] = (),
    ) -> None:
        super().__init__()
        self._plant = control_plant
        self._context = control_plant.CreateDefaultContext()
        instance = (
            arm_instance if arm_instance is not None else control_plant.GetModelInstanceByName(ARM_MODEL_NAME)
        )
        joints = [control_plant.GetJointByName(n, instance) for n in ARM_JOINTS]
        self._q_idx = [j.position_start() for j in joints]
        self._v_idx = [j.velocity_start() for j in joints]
        self._frame_E = control_plant.GetFrameByName(EE_FRAME, instance)
        self._world = control_plant.world_frame()
        self._period = float(config.control_period)
        self._reseed_tol = float(config.reseed_tolerance)
        self._limited_alpha = float(config.limited_alpha)
        self._warner = _RateLimitedWarner(
            "DifferentialIKIntegrator: ee_velocity_command", config.warn_interval
        )

        lower = np.array([j.position_lower_limits()[0] for j in joints])
        upper = np.array([j.position_upper_limits()[0] for j in joints])
        vmax = (
            np.array(config.joint_velocity_limits)
            if config.joint_velocity_limits is not None
            else np.array([j.velocity_upper_limits()[0] for j in joints])
        )
        amax = np.array(config.joint_acceleration_limits)
        self._lower, self._upper = lower, upper
        self._vmax, self._amax = vmax, amax
        home = np.array(config.home_q)
        if np.any(home < lower) or np.any(home > upper):
            raise ValueError(
                f"StationConfig.home_q: outside the joint limits [{lower}, {upper}], got {home.tolist()}"
            )
        nominal = np.array(config.nominal_posture) if config.nominal_posture is not None else home

        self._floor = None if config.table_clearance is None else table_top_z() + config.table_clearance
        self._floor_time_constant = max(0.1, self._period)
        held = [
            Solid(o.name, o.shape, tuple(o.size), o.transform().GetAsMatrix4())
            for o in held_objects
            if o.attached_to_gripper
        ]
        self._gripper_points = gripper_points_in_ee(held)
        self._ik = VelocityIkSolver(
            JointLimits(lower, upper, vmax, amax),
            self._period,
            IkParams(nominal_gain=config.nominal_posture_gain, limited_alpha=self._limited_alpha),
            nominal,
        )

        x0 = np.concatenate([home, np.zeros(6), [float(IkStatus.OK)]])
        self._state = self.DeclareDiscreteState(x0)
        self._command_port = self.DeclareVectorInputPort("ee_velocity_command", 6)
        self._measured_port = self.DeclareVectorInputPort("arm_joint_state", 12)
        ticket = {self.discrete_state_ticket(self._state)}
        self.DeclareVectorOutputPort("desired_state", 12, self._calc_desired, prerequisites_of_calc=ticket)
        self.DeclareVectorOutputPort("ik_status", 1, self._calc_status, prerequisites_of_calc=ticket)
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._update)
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)

    @property
    def joint_position_limits(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Lower and upper joint limits (rad) the integrator respects."""
        return self._lower.copy(), self._upper.copy()

    def _calc_desired(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._state).get_value()[:12])

    def _calc_status(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._state).get_value()[12:13])

    def _initialize(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        meas = np.asarray(self._measured_port.Eval(context), dtype=float)
        x = discrete_state.get_mutable_vector(self._state)
        if meas.size == 12 and np.all(np.isfinite(meas[:6])):
            q = np.clip(meas[:6], self._lower, self._upper)
            x.SetFromVector(np.concatenate([q, np.zeros(6), [float(IkStatus.OK)]]))
        return EventStatus.Succeeded()

    def _solve(self, q: NDArray[np.float64], v_prev: NDArray[np.float64], V: NDArray[np.float64]):
        """Joint velocities for the paper-order command V at q, and the status code."""
        plant, ctx = self._plant, self._context
        q_full = plant.GetPositions(ctx)
        q_full[self._q_idx] = q
        plant.SetPositions(ctx, q_full)
        J = plant.CalcJacobianSpatialVelocity(
            ctx, JacobianWrtVariable.kV, self._frame_E, np.zeros(3), self._world, self._world
        )[:, self._v_idx]
        rows = lower = None
        if self._floor is not None:
            X_WE = self._frame_E.CalcPoseInWorld(ctx)
            r_W = self._gripper_points @ X_WE.rotation().matrix().T  # from the EE origin, in W
            height = X_WE.translation()[2] + r_W[:, 2] - self._floor
            near = height < 0.2  # the points that could reach the floor within this step
            if near.any():
                # Vertical speed of point i: vz + wx r_y - wy r_x (paper order [v; w]); it may not
                # be below -height / tau: the floor is approached exponentially and never crossed.
                r = r_W[near]
                rows = np.zeros((r.shape[0], 6))
                rows[:, 2] = 1.0
                rows[:, 3] = r[:, 1]
                rows[:, 4] = -r[:, 0]
                lower = -np.maximum(height[near], 0.0) / self._floor_time_constant
        solution = self._ik.solve(J[[3, 4, 5, 0, 1, 2]], V, q, v_prev, rows, lower)  # paper order [v; w]
        return solution.v, solution.status

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        x = context.get_discrete_state(self._state).get_value()
        q, v_prev = x[:6].copy(), x[6:12].copy()
        V, valid = _read_command(self._command_port, context, 6)
        status = IkStatus.OK
        if not valid:
            status = IkStatus.INVALID_COMMAND
            self._warner.warn(
                context.get_time(), "non-finite command treated as zero (ik_status = INVALID_COMMAND)"
            )
        meas = np.asarray(self._measured_port.Eval(context), dtype=float)[:6]
        # The largest drift; NaN or inf when the measurement is not finite (then no reseed).
        drift = float(np.max(np.abs(q - meas)))
        if self._reseed_tol < drift < math.inf:
            q = np.clip(meas, self._lower, self._upper)
            v = np.zeros(6)
            if status == IkStatus.OK:
                status = IkStatus.RESEEDED
        elif not V.any():
            v = np.zeros(6)
        else:
            v, status = self._solve(q, v_prev, V)
        # np.clip without its Python-level dispatch (the same values, NaN propagating alike).
        q_next = np.minimum(np.maximum(q + v * self._period, self._lower), self._upper)
        discrete_state.get_mutable_vector(self._state).SetFromVector(
            np.concatenate([q_next, v, [float(status)]])
        )
        return EventStatus.Succeeded()


class GripperOpeningIntegrator(LeafSystem):
    """Integrates the finger opening-speed command into symmetric finger set points.

    @system
    name: GripperOpeningIntegrator
    input_ports:
    - gripper_command (1): opening speed, m/s (positive opens); NaN/inf is treated as 0 with a warning
    - finger_state (4): measured finger q_left, q_right (m) then v_left, v_right (m/s)
    output_ports:
    - finger_desired_state (4): q_left, q_right (m) then v_left, v_right (m/s); each finger is at
      half the desired opening
    - desired_opening (1): desired distance between the fingertips, m
    @endsystem

    Discrete state ``[opening_d (m), speed_d (m/s)]``; the opening is clamped to
    ``[0, max_opening]``, initialised from ``finger_state`` when the simulator initialises.
    """

    def __init__(
        self, control_period: float, max_opening: float, initial_opening: float, warn_interval: float = 1.0
    ):
        super().__init__()
        if not (math.isfinite(control_period) and control_period > 0):
            raise ValueError(f"GripperOpeningIntegrator.control_period: expected > 0, got {control_period!r}")
        if not (math.isfinite(max_opening) and max_opening > 0):
            raise ValueError(f"GripperOpeningIntegrator.max_opening: expected > 0, got {max_opening!r}")
        if not (0 <= initial_opening <= max_opening):
            raise ValueError(
                f"GripperOpeningIntegrator.initial_opening: expected a number in [0, {max_opening}], "
                f"got {initial_opening!r}"
            )
        self._period = float(control_period)
        self._max = float(max_opening)
        self._warner = _RateLimitedWarner("GripperOpeningIntegrator: gripper_command", warn_interval)
        self._state = self.DeclareDiscreteState(np.array([initial_opening, 0.0]))
        self._command_port = self.DeclareVectorInputPort("gripper_command", 1)
        self._finger_port = self.DeclareVectorInputPort("finger_state", 4)
        ticket = {self.discrete_state_ticket(self._state)}
        self.DeclareVectorOutputPort(
            "finger_desired_state", 4, self._calc_desired, prerequisites_of_calc=ticket
        )
        self.DeclareVectorOutputPort("desired_opening", 1, self._calc_opening, prerequisites_of_calc=ticket)
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._update)
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)

    def _calc_desired(self, context: Context, output: BasicVector) -> None:
        opening, speed = context.get_discrete_state(self._state).get_value()
        output.SetFromVector([opening / 2, opening / 2, speed / 2, speed / 2])

    def _calc_opening(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(context.get_discrete_state(self._state).get_value()[:1])

    def _initialize(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        meas = np.asarray(self._finger_port.Eval(context), dtype=float)
        if np.all(np.isfinite(meas[:2])):
            opening = float(np.clip(meas[0] + meas[1], 0.0, self._max))
            discrete_state.get_mutable_vector(self._state).SetFromVector([opening, 0.0])
        return EventStatus.Succeeded()

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        opening = context.get_discrete_state(self._state).get_value()[0].item()
        cmd = self._command_port.Eval(context)[0].item()
        if not math.isfinite(cmd):
            cmd = 0.0
            self._warner.warn(context.get_time(), "non-finite command treated as zero")
        new = min(max(opening + cmd * self._period, 0.0), self._max)  # np.clip of a finite number
        discrete_state.get_mutable_vector(self._state).SetFromVector([new, (new - opening) / self._period])
        return EventStatus.Succeeded()


class EndEffectorState(LeafSystem):
    """Pose and spatial velocity of one body, in the project's vector conventions.

    @system
    name: EndEffectorState
    input_ports:
    - body_poses (abstract): list of RigidTransform X_WB (MultibodyPlant body_poses output)
    - body_spatial_velocities (abstract): list of SpatialVelocity V_WB (MultibodyPlant output)
    output_ports:
    - ee_pose (7): [x, y, z, qw, qx, qy, qz] of the body frame in W (m)
    - ee_velocity (6): [vx, vy, vz, wx, wy, wz] of the body origin in W (m/s, rad/s; paper order)
    @endsystem
    """

    def __init__(self, body_index: int) -> None:
        super().__init__()
        self._index = int(body_index)
        self._poses = self.DeclareAbstractInputPort("body_poses", Value([RigidTransform()]))
        from pydrake.multibody.math import SpatialVelocity

        self._vels = self.DeclareAbstractInputPort("body_spatial_velocities", Value([SpatialVelocity()]))
        self.DeclareVectorOutputPort(
            "ee_pose", 7, self._calc_pose, prerequisites_of_calc={self._poses.ticket()}
        )
        self.DeclareVectorOutputPort(
            "ee_velocity", 6, self._calc_velocity, prerequisites_of_calc={self._vels.ticket()}
        )

    def _calc_pose(self, context: Context, output: BasicVector) -> None:
        X = self._poses.Eval(context)[self._index]
        output.SetFromVector(np.concatenate([X.translation(), X.rotation().ToQuaternion().wxyz()]))

    def _calc_velocity(self, context: Context, output: BasicVector) -> None:
        V = self._vels.Eval(context)[self._index]
        output.SetFromVector(np.concatenate([V.translational(), V.rotational()]))


# ---------------------------------------------------------------------------------------------------
# Station assembly
# ---------------------------------------------------------------------------------------------------
STATION_INPUTS: tuple[str, ...] = ("ee_velocity_command", "gripper_command")
STATION_OUTPUTS: tuple[str, ...] = (
    "ee_pose",
    "ee_velocity",
    "arm_joint_state",
    "gripper_opening",
    "ik_status",
    "query_object",
)


@dataclass
class Station:
    """Handle on a built station (see the module docstring for the two ways to build one).

    Attributes:
        builder: The DiagramBuilder holding the station's systems (already built when ``diagram``
            is set: do not add to it then).
        diagram: The station Diagram with exported ports (standalone build), else ``None``.
        plant: The simulated MultibodyPlant (discrete, SAP, gravity on).
        scene_graph: Its SceneGraph.
        arm: Model instance of the MICO (arm and gripper).
        control_plant: Arm-only plant (plus attached objects) used for IK and gravity compensation.
        diff_ik: The DifferentialIKIntegrator.
        gripper: The GripperOpeningIntegrator.
        input_ports: Station input ports by name (diagram ports or subsystem ports, see above).
        output_ports: Station output ports by name.
        config: The configuration used.
        scene_objects: All scene objects added (config's first).
        meshcat: The Meshcat instance the station draws into, if any.
    """

    builder: DiagramBuilder
    diagram: Diagram | None
    plant: MultibodyPlant
    scene_graph: SceneGraph
    arm: ModelInstanceIndex
    control_plant: MultibodyPlant
    diff_ik: DifferentialIKIntegrator
    gripper: GripperOpeningIntegrator
    input_ports: dict[str, InputPort]
    output_ports: dict[str, OutputPort]
    config: StationConfig
    scene_objects: tuple[SceneObject, ...]
    meshcat: Meshcat | None = None

    def input_port(self, name: str) -> InputPort:
        """The station input port ``name`` (one of :data:`STATION_INPUTS`)."""
        if name not in self.input_ports:
            raise ValueError(f"Station input port: expected one of {sorted(self.input_ports)}, got {name!r}")
        return self.input_ports[name]

    def output_port(self, name: str) -> OutputPort:
        """The station output port ``name`` (one of :data:`STATION_OUTPUTS`)."""
        if name not in self.output_ports:
            raise ValueError(
                f"Station output port: expected one of {sorted(self.output_ports)}, got {name!r}"
            )
        return self.output_ports[name]

    def plant_context(self, root_context: Context) -> Context:
        """The plant's context inside ``root_context`` (the context of the station or enclosing diagram)."""
        return self.plant.GetMyContextFromRoot(root_context)


def _parser(plant: MultibodyPlant) -> Parser:
    parser = Parser(plant)
    parser.package_map().Add(MODELS_PACKAGE, str(models_dir()))
    return parser


def _add_objects(
    plant: MultibodyPlant, objects: Iterable[SceneObject], ee_frame, only_attached: bool
) -> None:
    instance = None
    for obj in objects:
        if only_attached and not obj.attached_to_gripper:
            continue
        if instance is None:
            instance = plant.AddModelInstance("scene_objects")
        body = plant.AddRigidBody(obj.name, instance, obj.spatial_inertia())
        if plant.geometry_source_is_registered():
            shape = obj.drake_shape()
            plant.RegisterVisualGeometry(
                body, RigidTransform(), shape, f"{obj.name}_visual", np.array(obj.rgba)
            )
            plant.RegisterCollisionGeometry(
                body, RigidTransform(), shape, f"{obj.name}_collision", CoulombFriction(0.6, 0.5)
            )
        parent = ee_frame if obj.attached_to_gripper else plant.world_frame()
        plant.WeldFrames(parent, body.body_frame(), obj.transform())


def _make_control_plant(objects: Sequence[SceneObject]) -> tuple[MultibodyPlant, ModelInstanceIndex]:
    plant = MultibodyPlant(time_step=0.0)
    (arm,) = _parser(plant).AddModels(str(mico_urdf()))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(BASE_FRAME, arm))
    _add_objects(plant, objects, plant.GetFrameByName(EE_FRAME, arm), only_attached=True)
    plant.Finalize()
    return plant, arm


def build_station(
    config: StationConfig | None = None,
    scene_objects: Iterable[SceneObject] = (),
    meshcat: Meshcat | None = None,
    builder: DiagramBuilder | None = None,
) -> Station:
    """Build the MICO station (see the module docstring for ports and the two ways to use it).

    Args:
        config: Station settings; ``None`` uses the defaults.
        scene_objects: Objects added after ``config.scene_objects``; names must be unique.
        meshcat: When given, a MeshcatVisualizer (illustration role) draws the scene into it.
        builder: Build into this DiagramBuilder (embedded use) instead of a new one (standalone use).

    Returns:
        The :class:`Station` handle.
    """
    config = config or StationConfig()
    objects = tuple(config.scene_objects) + tuple(scene_objects)
    names = [o.name for o in objects]
    for k, obj in enumerate(objects):
        if not isinstance(obj, SceneObject):
            raise ValueError(f"build_station.scene_objects[{k}]: expected a SceneObject, got {obj!r}")
        if names.count(obj.name) > 1:
            raise ValueError(f"build_station.scene_objects: duplicate name {obj.name!r}")
    standalone = builder is None
    if builder is None:
        builder = DiagramBuilder()

    plant, scene_graph = AddMultibodyPlant(config.plant_config, builder)
    parser = _parser(plant)
    ProcessModelDirectives(LoadModelDirectives(str(mico_directives())), plant, parser)
    arm = plant.GetModelInstanceByName(ARM_MODEL_NAME)
    ee_frame = plant.GetFrameByName(EE_FRAME, arm)
    _add_objects(plant, objects, ee_frame, only_attached=False)

    # Joint-actuator PD (evaluated implicitly by SAP) on every arm and finger actuator.
    gains = {name: (kp, kd) for name, kp, kd in zip(ARM_JOINTS, config.kp, config.kd, strict=True)}
    gains.update({name: (config.finger_kp, config.finger_kd) for name in FINGER_JOINTS})
    actuator_joints = []
    for a in range(plant.num_actuators()):  # GetJointActuatorIndices() needs a finalized plant
        actuator = plant.get_joint_actuator(JointActuatorIndex(a))
        if actuator.model_instance() != arm:
            continue
        kp, kd = gains[actuator.joint().name()]
        actuator.set_controller_gains(PdControllerGains(p=kp, d=kd))
        actuator_joints.append(actuator.joint().name())
    plant.Finalize()

    # Arm + attached objects never collide with each other (the arm's own links are adjacent or
    # far apart; self-contact would only cost time).
    arm_bodies = [plant.get_body(b) for b in plant.GetBodyIndices(arm)]
    arm_bodies += [plant.GetBodyByName(o.name) for o in objects if o.attached_to_gripper]
    scene_graph.collision_filter_manager().Apply(
        CollisionFilterDeclaration().ExcludeWithin(plant.CollectRegisteredGeometries(arm_bodies))
    )

    # Initial configuration.
    q_local, v_local = _instance_local_indices(plant, arm, ARM_JOINTS)
    f_local, fv_local = _instance_local_indices(plant, arm, FINGER_JOINTS)
    q0 = plant.GetDefaultPositions(arm)
    q0[q_local] = config.home_q
    q0[f_local] = config.home_gripper_opening / 2
    plant.SetDefaultPositions(arm, q0)

    control_plant, control_arm = _make_control_plant(objects)
    cq, cv = _instance_local_indices(control_plant, control_arm, ARM_JOINTS + FINGER_JOINTS)
    mq, mv = _instance_local_indices(plant, arm, ARM_JOINTS + FINGER_JOINTS)
    if cq != mq or cv != mv:
        raise RuntimeError("station: the control plant orders the MICO joints differently from the plant")
    nq = plant.num_positions(arm)
    nv = plant.num_velocities(arm)

    # Measured signals from the MICO state [q (nq), v (nv)].
    def selector(rows: Sequence[int], width: int) -> NDArray[np.float64]:
        S = np.zeros((len(rows), width))
        S[np.arange(len(rows)), rows] = 1.0
        return S

    arm_state_rows = list(q_local) + [nq + i for i in v_local]
    finger_state_rows = list(f_local) + [nq + i for i in fv_local]
    arm_state = builder.AddNamedSystem("arm_joint_state", MatrixGain(selector(arm_state_rows, nq + nv)))
    finger_state = builder.AddNamedSystem("finger_state", MatrixGain(selector(finger_state_rows, nq + nv)))
    opening = np.zeros((1, nq + nv))
    opening[0, f_local] = 1.0  # inner faces at +/- q: opening = q_left + q_right
    gripper_opening = builder.AddNamedSystem("gripper_opening", MatrixGain(opening))
    mico_state = plant.get_state_output_port(arm)
    for sys in (arm_state, finger_state, gripper_opening):
        builder.Connect(mico_state, sys.get_input_port())

    diff_ik = builder.AddNamedSystem(
        "diff_ik", DifferentialIKIntegrator(control_plant, config, control_arm, held_objects=objects)
    )
    gripper = builder.AddNamedSystem(
        "gripper_integrator",
        GripperOpeningIntegrator(
            config.control_period, FINGER_MAX_OPENING, config.home_gripper_opening, config.warn_interval
        ),
    )
    builder.Connect(arm_state.get_output_port(), diff_ik.GetInputPort("arm_joint_state"))
    builder.Connect(finger_state.get_output_port(), gripper.GetInputPort("finger_state"))

    # Desired state [q_d; v_d] in actuator order, from [arm q_d, arm v_d, finger q_d, finger v_d].
    mux = builder.AddNamedSystem("desired_state_mux", Multiplexer([12, 4]))
    builder.Connect(diff_ik.GetOutputPort("desired_state"), mux.get_input_port(0))
    builder.Connect(gripper.GetOutputPort("finger_desired_state"), mux.get_input_port(1))
    source = {name: (i, 6 + i) for i, name in enumerate(ARM_JOINTS)}
    source.update({name: (12 + i, 14 + i) for i, name in enumerate(FINGER_JOINTS)})
    nu = len(actuator_joints)
    P = np.zeros((2 * nu, 16))
    for k, name in enumerate(actuator_joints):
        P[k, source[name][0]] = 1.0
        P[nu + k, source[name][1]] = 1.0
    to_actuators = builder.AddNamedSystem("desired_state_to_actuators", MatrixGain(P))
    builder.Connect(mux.get_output_port(), to_actuators.get_input_port())
    builder.Connect(to_actuators.get_output_port(), plant.get_desired_state_input_port(arm))

    # Gravity compensation feed-forward, computed on the control plant from the measured state.
    gravity = builder.AddNamedSystem(
        "gravity_compensation",
        InverseDynamics(control_plant, InverseDynamics.InverseDynamicsMode.kGravityCompensation),
    )
    builder.Connect(mico_state, gravity.get_input_port_estimated_state())
    B = control_plant.MakeActuationMatrix()  # tau = B u; B is a permutation here
    gravity_to_u = builder.AddNamedSystem("gravity_to_actuation", MatrixGain(B.T))
    builder.Connect(gravity.get_output_port_generalized_force(), gravity_to_u.get_input_port())
    builder.Connect(gravity_to_u.get_output_port(), plant.get_actuation_input_port(arm))

    ee_state = builder.AddNamedSystem("ee_state", EndEffectorState(int(ee_frame.body().index())))
    builder.Connect(plant.get_body_poses_output_port(), ee_state.GetInputPort("body_poses"))
    builder.Connect(
        plant.get_body_spatial_velocities_output_port(), ee_state.GetInputPort("body_spatial_velocities")
    )

    if meshcat is not None:
        from pydrake.geometry import MeshcatVisualizer, MeshcatVisualizerParams

        MeshcatVisualizer.AddToBuilder(
            builder, scene_graph, meshcat, MeshcatVisualizerParams(role=Role.kIllustration, prefix="station")
        )

    inputs: dict[str, InputPort] = {
        "ee_velocity_command": diff_ik.GetInputPort("ee_velocity_command"),
        "gripper_command": gripper.GetInputPort("gripper_command"),
    }
    outputs: dict[str, OutputPort] = {
        "ee_pose": ee_state.GetOutputPort("ee_pose"),
        "ee_velocity": ee_state.GetOutputPort("ee_velocity"),
        "arm_joint_state": arm_state.get_output_port(),
        "gripper_opening": gripper_opening.get_output_port(),
        "ik_status": diff_ik.GetOutputPort("ik_status"),
        "query_object": scene_graph.get_query_output_port(),
    }
    diagram = None
    if standalone:
        for name, port in inputs.items():
            builder.ExportInput(port, name)
        for name, port in outputs.items():
            builder.ExportOutput(port, name)
        diagram = builder.Build()
        diagram.set_name("station")
        inputs = {name: diagram.GetInputPort(name) for name in inputs}
        outputs = {name: diagram.GetOutputPort(name) for name in outputs}

    return Station(
        builder=builder,
        diagram=diagram,
        plant=plant,
        scene_graph=scene_graph,
        arm=arm,
        control_plant=control_plant,
        diff_ik=diff_ik,
        gripper=gripper,
        input_ports=inputs,
        output_ports=outputs,
        config=config,
        scene_objects=objects,
        meshcat=meshcat,
    )


__all__ = [
    "ARM_JOINTS",
    "BASE_FRAME",
    "EE_FRAME",
    "FINGER_JOINTS",
    "FINGER_MAX_OPENING",
    "MICO_HOME_Q",
    "STATION_INPUTS",
    "STATION_OUTPUTS",
    "DifferentialIKIntegrator",
    "EndEffectorState",
    "GripperOpeningIntegrator",
    "IkStatus",
    "SceneObject",
    "Station",
    "StationConfig",
    "build_station",
]
