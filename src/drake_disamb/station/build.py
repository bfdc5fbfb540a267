"""Assembly of the simulated MICO station: :func:`build_station` returns one Diagram with named
exported ports (Drake's ``MakeHardwareStation(scenario, meshcat)`` pattern) and a :class:`Station`
handle on it. The station is the hardware: its inputs are the joint-level velocities a Kinova Gen2
arm's driver accepts in velocity mode, its outputs what the arm measures; the controllers that turn
the shared-control commands into joint velocities sit outside it (:mod:`drake_disamb.controller`).

Inside the diagram (subsystem names in quotes; see ``diagrams/station.py`` for the picture)::

    arm_velocity_command ────┐
    finger_velocity_command ─┴▶ "joint_velocity_integrator" ─▶ desired state [q_d; v_d] (joint order)
                                   ▲ measured state (initialise,      ▼
                                   │ re-anchor)              "desired_state_to_actuators"
                                   │                                  ▼  desired state
    "gravity_compensation" ─▶ "gravity_to_actuation" ─▶ "plant" (discrete, SAP, gravity on;
     (InverseDynamics on the          actuation             joint-actuator PD tracks the
      control plant) ▲                                      desired state) ──▶ "scene_graph"
                     └──────────────── state ◀────────────────┘
    "plant" state ─▶ "arm_joint_state", "finger_state" ─▶ "gripper_opening"; body poses ─▶ "ee_state"

The set points come from integrating the commanded velocities, as a real arm in velocity mode does
(:class:`~drake_disamb.station.systems.JointVelocityIntegrator`). The selector gains come from Drake
(``MultibodyPlant.MakeStateSelectorMatrix``, ``MakeActuatorSelectorMatrix``,
``MakeActuationMatrixPseudoinverse``). The home posture is the model directives'
``default_joint_positions``; ``StationConfig.home_q`` / ``home_gripper_opening`` are applied over it
with ``Joint.set_default_positions`` (a no-op with the defaults, which are read from the directives).

How to use it::

    station = build_station(config, scene_objects, meshcat)
    builder.AddSystem(station.diagram)                  # or Simulator(station.diagram) on its own
    controller = add_station_controller(builder, station)   # drake_disamb.controller: IK, gripper
    builder.Connect(blender.GetOutputPort("u"), controller.diff_ik.GetInputPort("ee_velocity_command"))

Reaching inside: the :class:`Station` handle holds the plant, the scene graph, the control plant
and the integrator; from the diagram alone, ``GetSubsystemByName`` with the names above gives the
same systems (``"plant"``, ``"scene_graph"``, ``"joint_velocity_integrator"``). A subsystem's
context inside any enclosing root context is ``system.GetMyContextFromRoot(root_context)``
(:meth:`Station.plant_context` for the plant).

Station ports, those every backend provides (:mod:`~drake_disamb.station.ports`) and the
simulation's own ``query_object`` (velocities are in the paper's order ``[vx, vy, vz, wx, wy,
wz]``, not Drake's ``[w; v]``; W is the world frame, which coincides with ``mico_link_base``):

- input ``arm_velocity_command`` (6): the arm's joint velocities, rad/s, in ``ARM_JOINTS`` order
  (Kinova's classic-DH angles).
- input ``finger_velocity_command`` (2): the finger slides' velocities, m/s (``FINGER_JOINTS``
  order; positive opens).
- output ``ee_pose`` (7): ``[x, y, z, qw, qx, qy, qz]`` of ``mico_end_effector`` in W (m).
- output ``ee_velocity`` (6): measured spatial velocity of ``mico_end_effector`` (paper order, W, m/s, rad/s).
- output ``arm_joint_state`` (12): measured arm joint positions (rad, the DH angles) then velocities (rad/s).
- output ``finger_state`` (4): measured finger slides (m) then their velocities (m/s).
- output ``gripper_opening`` (1): distance between the fingertip pads, m.
- output ``query_object``: the SceneGraph query object (abstract).

Both inputs must be connected (or fixed) before simulating. Bad run-time commands: a NaN or
infinite entry in either input is treated as a zero command, with a ``RuntimeWarning`` at most once
per ``StationConfig.warn_interval`` seconds of simulated time. A vector of the wrong length cannot
reach the station: Drake rejects it where it enters (``FixValue`` or ``DiagramBuilder.Connect``
raise), so the station's state is untouched.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from pydrake.geometry import CollisionFilterDeclaration, Meshcat, Role, SceneGraph
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import LoadModelDirectives, ProcessModelDirectives
from pydrake.multibody.plant import AddMultibodyPlant, CoulombFriction, MultibodyPlant
from pydrake.multibody.tree import (
    Frame,
    JointActuatorIndex,
    JointIndex,
    ModelInstanceIndex,
    PdControllerGains,
)
from pydrake.systems.controllers import InverseDynamics
from pydrake.systems.framework import Context, Diagram, DiagramBuilder
from pydrake.systems.primitives import MatrixGain

from drake_disamb.paths import mico_directives, mico_urdf
from drake_disamb.station.config import (
    ARM_JOINTS,
    ARM_MODEL_NAME,
    BASE_FRAME,
    EE_FRAME,
    FINGER_JOINTS,
    FINGER_MAX_OPENING,
    SceneObject,
    StationConfig,
    check_home_q,
    model_parser,
)
from drake_disamb.station.geometry import StationGeometry
from drake_disamb.station.ports import SHARED_INPUTS, SHARED_OUTPUTS, SIMULATION_OUTPUTS
from drake_disamb.station.systems import EndEffectorState, JointVelocityIntegrator

STATION_INPUTS: tuple[str, ...] = SHARED_INPUTS
"""Names of the simulated station diagram's exported input ports."""
STATION_OUTPUTS: tuple[str, ...] = SHARED_OUTPUTS + SIMULATION_OUTPUTS
"""Names of the simulated station diagram's exported output ports."""


@dataclass(frozen=True)
class Station:
    """A built station (any backend): its Diagram and typed handles on the systems inside it.

    Attributes:
        diagram: The station Diagram (named ``"station"``) with the exported ports
            :data:`~drake_disamb.station.ports.SHARED_INPUTS`, and ``outputs``; add it to a builder,
            or simulate it on its own.
        plant: The station's MultibodyPlant (subsystem ``"plant"``): the simulated arm (discrete,
            SAP, gravity on), or on a wire the model that the measured angles pose.
        scene_graph: Its SceneGraph (subsystem ``"scene_graph"``).
        arm: Model instance of the MICO (arm and gripper) in ``plant``.
        control_plant: Arm-only continuous plant (plus objects held in the gripper) that the
            gravity compensation (and, outside the station, the differential IK) computes on;
            not a subsystem.
        config: The configuration used (on a wire, ``home_q`` is the arm's measured start posture).
        scene_objects: All scene objects added (the config's first).
        meshcat: The Meshcat instance the station draws into, if any.
        geometry: The clearance geometry of ``plant`` (the IK's floor uses it).
        outputs: Names of the exported output ports (:data:`STATION_OUTPUTS` for the simulation).
        integrator: The simulated arm's
            :class:`~drake_disamb.station.systems.JointVelocityIntegrator` (subsystem
            ``"joint_velocity_integrator"``); ``None`` on a wire.
        link: On a wire, the :class:`~drake_disamb.station.lcm.bus.CommandLink` (its
            ``stop_arm()`` sends the zero command several times); ``None`` in simulation.
    """

    diagram: Diagram
    plant: MultibodyPlant
    scene_graph: SceneGraph
    arm: ModelInstanceIndex
    control_plant: MultibodyPlant
    config: StationConfig
    scene_objects: tuple[SceneObject, ...]
    meshcat: Meshcat | None = None
    geometry: StationGeometry | None = None
    outputs: tuple[str, ...] = STATION_OUTPUTS
    integrator: JointVelocityIntegrator | None = None
    link: Any = None

    def plant_context(self, root_context: Context) -> Context:
        """The plant's context inside ``root_context`` (the station's or any enclosing diagram's)."""
        return self.plant.GetMyContextFromRoot(root_context)


def add_scene_objects(
    plant: MultibodyPlant, objects: Iterable[SceneObject], ee_frame: Frame, only_attached: bool
) -> None:
    """Add ``objects`` to ``plant`` (not finalized), each a rigid body welded to the world or, when
    ``attached_to_gripper``, to ``ee_frame``; ``only_attached`` adds the held ones only. Geometry
    (visual and collision) is registered when ``plant`` is a SceneGraph source."""
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


def make_control_plant(objects: Sequence[SceneObject]) -> tuple[MultibodyPlant, ModelInstanceIndex]:
    """The arm-only continuous plant (base welded to the world) with the objects of ``objects``
    held in the gripper, finalized, and the MICO's model instance in it."""
    plant = MultibodyPlant(time_step=0.0)
    (arm,) = model_parser(plant).AddModels(str(mico_urdf()))
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(BASE_FRAME, arm))
    add_scene_objects(plant, objects, plant.GetFrameByName(EE_FRAME, arm), only_attached=True)
    plant.Finalize()
    return plant, arm


def _check_same_layout(plant: MultibodyPlant, control_plant: MultibodyPlant) -> None:
    """The control plant's state and actuation vectors must be the plant's, entry for entry.

    The gravity compensation reads the plant's state as the control plant's and its actuation goes
    back into the plant's; both hold when nothing but the MICO moves (the table and every scene
    object are welded) and both plants parse the same URDF.
    """

    def layout(p: MultibodyPlant) -> tuple:
        joints = [p.GetJointByName(name) for name in ARM_JOINTS + FINGER_JOINTS]
        actuated = [p.get_joint_actuator(a).joint().name() for a in p.GetJointActuatorIndices()]
        return (
            p.num_positions(),
            p.num_velocities(),
            [(j.position_start(), j.velocity_start()) for j in joints],
            actuated,
        )

    if layout(plant) != layout(control_plant):
        raise RuntimeError(
            "station: the control plant's state or actuation layout differs from the plant's: "
            f"{layout(control_plant)} vs {layout(plant)}"
        )


def _checked_objects(config: StationConfig, scene_objects: Iterable[SceneObject]) -> tuple[SceneObject, ...]:
    """``config.scene_objects`` then ``scene_objects``, checked: each a :class:`SceneObject`, the
    names unique (``ValueError`` naming the entry otherwise)."""
    objects = tuple(config.scene_objects) + tuple(scene_objects)
    names = [o.name for o in objects]
    for k, obj in enumerate(objects):
        if not isinstance(obj, SceneObject):
            raise ValueError(f"build_station.scene_objects[{k}]: expected a SceneObject, got {obj!r}")
        if names.count(obj.name) > 1:
            raise ValueError(f"build_station.scene_objects: duplicate name {obj.name!r}")
    return objects


def _add_plant(
    builder: DiagramBuilder, config: StationConfig, objects: tuple[SceneObject, ...]
) -> tuple[MultibodyPlant, SceneGraph, ModelInstanceIndex, Frame]:
    """The station's plant and scene graph in ``builder``: the arm on its table from the model
    directives, the scene objects, the home posture, the joint-actuator PD gains, finalized, and
    the arm with its attached objects never colliding with itself. Returns ``(plant, scene_graph,
    arm, end-effector frame)``."""
    plant, scene_graph = AddMultibodyPlant(config.plant_config, builder)
    ProcessModelDirectives(LoadModelDirectives(str(mico_directives())), plant, model_parser(plant))
    arm = plant.GetModelInstanceByName(ARM_MODEL_NAME)
    ee_frame = plant.GetFrameByName(EE_FRAME, arm)
    add_scene_objects(plant, objects, ee_frame, only_attached=False)

    # The directives set the home posture; the config's values go over it (the same by default).
    for name, q in zip(ARM_JOINTS, config.home_q, strict=True):
        plant.GetJointByName(name, arm).set_default_positions([q])
    for name in FINGER_JOINTS:  # inner faces at +/- q: each finger at half the opening
        plant.GetJointByName(name, arm).set_default_positions([config.home_gripper_opening / 2])

    # Joint-actuator PD (evaluated implicitly by SAP) on every arm and finger actuator.
    gains = {name: (kp, kd) for name, kp, kd in zip(ARM_JOINTS, config.kp, config.kd, strict=True)}
    gains.update({name: (config.finger_kp, config.finger_kd) for name in FINGER_JOINTS})
    for a in range(plant.num_actuators()):  # GetJointActuatorIndices() needs a finalized plant
        actuator = plant.get_joint_actuator(JointActuatorIndex(a))
        if actuator.model_instance() == arm:
            kp, kd = gains[actuator.joint().name()]
            actuator.set_controller_gains(PdControllerGains(p=kp, d=kd))
    plant.Finalize()

    # Arm + attached objects never collide with each other (the arm's own links are adjacent or
    # far apart; self-contact would only cost time).
    arm_bodies = [plant.get_body(b) for b in plant.GetBodyIndices(arm)]
    arm_bodies += [plant.GetBodyByName(o.name) for o in objects if o.attached_to_gripper]
    scene_graph.collision_filter_manager().Apply(
        CollisionFilterDeclaration().ExcludeWithin(plant.CollectRegisteredGeometries(arm_bodies))
    )
    return plant, scene_graph, arm, ee_frame


def _add_set_points(
    builder: DiagramBuilder,
    config: StationConfig,
    plant: MultibodyPlant,
    arm: ModelInstanceIndex,
    joints: list[JointIndex],
    limits: tuple[np.ndarray, np.ndarray],
    measured: tuple[MatrixGain, MatrixGain],
) -> JointVelocityIntegrator:
    """The set points, ``[q_d; v_d]`` in ``ARM_JOINTS + FINGER_JOINTS`` order (``joints``, their
    indices), integrated from the commanded velocities within the joint ``limits`` (lower, upper)
    from the ``measured`` arm and finger states' systems, then mapped to the plant's actuator order
    (each actuator drives one of those joints) into the arm's desired-state input."""
    lower, upper = limits
    arm_state, finger_state = measured
    half = config.home_gripper_opening / 2
    integrator = builder.AddNamedSystem(
        "joint_velocity_integrator",
        JointVelocityIntegrator(
            config.control_period,
            lower,
            upper,
            FINGER_MAX_OPENING / 2,
            config.home_q,
            (half, half),
            config.reseed_tolerance,
            config.warn_interval,
        ),
    )
    builder.Connect(arm_state.get_output_port(), integrator.GetInputPort("arm_joint_state"))
    builder.Connect(finger_state.get_output_port(), integrator.GetInputPort("finger_state"))
    if plant.num_actuators() != plant.num_actuators(arm):  # pragma: no cover (objects are welded)
        raise RuntimeError("station: only the MICO may have actuators")
    S = plant.MakeActuatorSelectorMatrix(joints)  # u = S u_joints
    zeros = np.zeros_like(S)
    to_actuators = builder.AddNamedSystem(
        "desired_state_to_actuators", MatrixGain(np.block([[S, zeros], [zeros, S]]))
    )
    builder.Connect(integrator.GetOutputPort("desired_state"), to_actuators.get_input_port())
    builder.Connect(to_actuators.get_output_port(), plant.get_desired_state_input_port(arm))
    return integrator


def _add_gravity_compensation(
    builder: DiagramBuilder, plant: MultibodyPlant, control_plant: MultibodyPlant, arm: ModelInstanceIndex
) -> None:
    """Gravity compensation feed-forward into the arm's actuation, computed on the control plant
    from the measured state."""
    gravity = builder.AddNamedSystem(
        "gravity_compensation",
        InverseDynamics(control_plant, InverseDynamics.InverseDynamicsMode.kGravityCompensation),
    )
    builder.Connect(plant.get_state_output_port(), gravity.get_input_port_estimated_state())
    gravity_to_u = builder.AddNamedSystem(
        "gravity_to_actuation", MatrixGain(control_plant.MakeActuationMatrixPseudoinverse().toarray())
    )
    builder.Connect(gravity.get_output_port_generalized_force(), gravity_to_u.get_input_port())
    builder.Connect(gravity_to_u.get_output_port(), plant.get_actuation_input_port(arm))


def build_station(
    config: StationConfig | None = None,
    scene_objects: Iterable[SceneObject] = (),
    meshcat: Meshcat | None = None,
) -> Station:
    """Build the simulated MICO station Diagram (see the module docstring for its ports and subsystems).

    Args:
        config: Station settings; ``None`` uses the defaults.
        scene_objects: Objects added after ``config.scene_objects``; names must be unique.
        meshcat: When given, a MeshcatVisualizer (illustration role, prefix ``station``) inside the
            station draws the scene into it.

    Returns:
        The :class:`Station`: ``station.diagram`` plus typed handles on its systems.

    Raises:
        ValueError: a scene object that is not a :class:`SceneObject`, a duplicate object name, or
            ``config.home_q`` outside the joint limits.
    """
    config = config or StationConfig()
    objects = _checked_objects(config, scene_objects)
    builder = DiagramBuilder()
    plant, scene_graph, arm, ee_frame = _add_plant(builder, config, objects)

    control_plant, _ = make_control_plant(objects)
    _check_same_layout(plant, control_plant)
    arm_joints = [plant.GetJointByName(name, arm).index() for name in ARM_JOINTS]
    finger_joints = [plant.GetJointByName(name, arm).index() for name in FINGER_JOINTS]
    state = plant.get_state_output_port()

    # Measured signals: [q; v] of the arm's and the fingers' joints, and the opening q_l + q_r.
    arm_state = builder.AddNamedSystem(
        "arm_joint_state", MatrixGain(plant.MakeStateSelectorMatrix(arm_joints))
    )
    finger_state = builder.AddNamedSystem(
        "finger_state", MatrixGain(plant.MakeStateSelectorMatrix(finger_joints))
    )
    gripper_opening = builder.AddNamedSystem("gripper_opening", MatrixGain(np.array([[1.0, 1.0, 0.0, 0.0]])))
    builder.Connect(state, arm_state.get_input_port())
    builder.Connect(state, finger_state.get_input_port())
    builder.Connect(finger_state.get_output_port(), gripper_opening.get_input_port())

    geometry = StationGeometry.from_plant(plant, scene_graph, arm)
    lower, upper = geometry.joint_limits()
    check_home_q(config, lower, upper)
    integrator = _add_set_points(
        builder, config, plant, arm, arm_joints + finger_joints, (lower, upper), (arm_state, finger_state)
    )
    _add_gravity_compensation(builder, plant, control_plant, arm)

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

    for name in SHARED_INPUTS:
        builder.ExportInput(integrator.GetInputPort(name), name)
    outputs = {
        "ee_pose": ee_state.GetOutputPort("ee_pose"),
        "ee_velocity": ee_state.GetOutputPort("ee_velocity"),
        "arm_joint_state": arm_state.get_output_port(),
        "finger_state": finger_state.get_output_port(),
        "gripper_opening": gripper_opening.get_output_port(),
        "query_object": scene_graph.get_query_output_port(),
    }
    for name, port in outputs.items():
        builder.ExportOutput(port, name)
    diagram = builder.Build()
    diagram.set_name("station")

    return Station(
        diagram=diagram,
        plant=plant,
        scene_graph=scene_graph,
        arm=arm,
        control_plant=control_plant,
        config=config,
        scene_objects=objects,
        meshcat=meshcat,
        geometry=geometry,
        outputs=tuple(outputs),
        integrator=integrator,
    )
