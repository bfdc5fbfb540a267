"""Assembly of the station on LCM: the same exported ports as the simulated station, backed by the
arm's status and commands (Drake's ``MakeHardwareStation(..., hardware=True)`` pattern)::

    "status_receiver" (waits for each lcmt_jaco_status) ─▶ arm_joint_state, finger_state, fault
        arm_joint_state ─▶ "ee_state" (our model's kinematics) ─▶ ee_pose, ee_velocity
        finger_state ─▶ "gripper_opening"
    arm_velocity_command, finger_velocity_command, fault, measured state
        ─▶ "command_sender" ─▶ one lcmt_jaco_command per status
    arm and finger angles ─▶ "model_positions" ─▶ "to_geometry_pose" ─▶ "scene_graph" (Meshcat)

Its inputs are what ``lcmt_jaco_command`` carries (the joint and finger velocities); the
controllers (:mod:`drake_disamb.controller`: the differential IK, the gripper's) sit outside it, as
they do in front of the simulated station. The controller is clocked by the status messages: every
control tick the receiver waits for a fresh status (as Drake's Jaco controller waits for each
status), then the tick's systems run and one command answers it. Start checks
(:func:`first_status`): a status must arrive within ``start_timeout``, with 6 joints and 2 fingers,
finite, and every joint inside the model's limits (each angle the 2 pi equivalent inside them
nearest the task's start posture); the model's default posture and the returned configuration's
``home_q`` (which seeds the IK) are the measured ones. Then the driver's announced period
(:func:`status_spacing`: the ``utime`` spacing of its next statuses) must be at most
``max_status_period``; the watchdog's timeout follows it
(:class:`~drake_disamb.station.lcm.systems.JacoStatusReceiver`).
"""

from __future__ import annotations

import atexit
import dataclasses
import time
from collections.abc import Iterable

import numpy as np
from pydrake.geometry import Meshcat, MeshcatVisualizer, MeshcatVisualizerParams, Role, SceneGraph
from pydrake.lcm import DrakeLcm
from pydrake.multibody.parsing import LoadModelDirectives, ProcessModelDirectives
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder, OutputPort
from pydrake.systems.primitives import MatrixGain, Multiplexer
from pydrake.systems.rendering import MultibodyPositionToGeometryPose

from drake_disamb.paths import mico_directives
from drake_disamb.station.build import Station, add_scene_objects, make_control_plant
from drake_disamb.station.config import (
    ARM_JOINTS,
    ARM_MODEL_NAME,
    EE_FRAME,
    FINGER_JOINTS,
    FINGER_MAX_OPENING,
    SceneObject,
    StationConfig,
    arm_velocity_limits,
    model_parser,
)
from drake_disamb.station.geometry import StationGeometry
from drake_disamb.station.lcm.bus import CommandLink, Pump, StatusInbox
from drake_disamb.station.lcm.messages import StatusReading, read_status
from drake_disamb.station.lcm.systems import (
    LIMIT_TOLERANCE,
    JacoCommandSender,
    JacoStatusReceiver,
    ModelEndEffectorState,
)
from drake_disamb.station.ports import HARDWARE_OUTPUTS, SHARED_INPUTS, SHARED_OUTPUTS

LCM_STATION_OUTPUTS: tuple[str, ...] = SHARED_OUTPUTS + HARDWARE_OUTPUTS
"""Names of the LCM station's exported output ports."""


def first_status(
    inbox: StatusInbox,
    timeout: float,
    lower: np.ndarray,
    upper: np.ndarray,
    reference: np.ndarray,
    where: str,
) -> StatusReading:
    """Wait up to ``timeout`` seconds for the first usable status and check it. Each joint's
    angle is the 2 pi equivalent inside the model's limits nearest ``reference`` (the task's start
    posture): an arm anywhere inside its limits is taken as it is, whatever the task's posture.

    Raises:
        RuntimeError: no status within ``timeout`` (naming the channel and ``where``, the bus), a
            status without 6 joints and 2 fingers or not finite (its reason), or a joint outside
            the model's limits (which joint, the angle and the limits).
    """
    deadline = time.monotonic() + timeout
    why = ""
    limits = (lower - LIMIT_TOLERANCE, upper + LIMIT_TOLERANCE)
    while time.monotonic() < deadline:
        inbox.poll(min(0.01, max(deadline - time.monotonic(), 0.0)))
        for data, received in inbox.take():
            reading, why = read_status(data, None, reference, limits)
            if reading is None:
                continue
            for k, (q, lo, hi) in enumerate(zip(reading.q, lower, upper, strict=True)):
                if not lo - LIMIT_TOLERANCE <= q <= hi + LIMIT_TOLERANCE:
                    raise RuntimeError(
                        f"station: the arm's first status puts joint {k + 1} at {q:.4f} rad, outside "
                        f"the model's limits [{lo:.4f}, {hi:.4f}] rad: check the angle mapping and the arm"
                    )
            inbox.last_good = received
            return reading
    extra = f" (the last one was dropped: {why})" if why else ""
    raise RuntimeError(
        f"station: no usable arm status on {inbox.channel!r} at {where} within {timeout:g} s{extra}; "
        "is a driver publishing on that bus (the arm's, or the simulated one)?"
    )


SPACING_STATUSES = 3
"""Statuses after the first whose ``utime`` steps :func:`status_spacing` measures."""


def status_spacing(inbox: StatusInbox, first: StatusReading, timeout: float, slowest: float) -> float:
    """The period (s) the driver announces: the smallest ``utime`` step between the first status
    and the :data:`SPACING_STATUSES` valid ones after it, waited for up to ``timeout`` seconds (a
    status missed in between only lengthens a step).

    Raises:
        RuntimeError: no further status within ``timeout``, or statuses further apart than
            ``slowest`` seconds (``station.max_status_period``): the link is too slow for the
            watchdog this station keeps.
    """
    deadline = time.monotonic() + timeout
    utimes = [first.utime]
    while len(utimes) <= SPACING_STATUSES and time.monotonic() < deadline:
        inbox.poll(min(0.01, max(deadline - time.monotonic(), 0.0)))
        for data, received in inbox.take():
            reading, _ = read_status(data, utimes[-1], first.q)
            if reading is not None:
                utimes.append(reading.utime)
                inbox.last_good = received
    if len(utimes) < 2:
        raise RuntimeError(
            f"station: the arm's statuses on {inbox.channel!r} stopped after the first one "
            f"(none within {timeout:g} s): is the driver still running?"
        )
    spacing = float(np.min(np.diff(utimes))) * 1e-6
    if spacing > slowest:
        raise RuntimeError(
            f"station: the driver's statuses come every {spacing:.3f} s ({1 / spacing:.1f} Hz), slower "
            f"than station.max_status_period ({slowest:g} s): the link to the arm is too slow"
        )
    return spacing


def _model(builder: DiagramBuilder, objects: tuple[SceneObject, ...]) -> tuple[MultibodyPlant, SceneGraph]:
    """The scene graph (in ``builder``) and the plant registered with it (not in ``builder``: it
    only poses the geometry): the arm on its table from the model directives and the scene objects,
    finalized."""
    scene_graph = builder.AddNamedSystem("scene_graph", SceneGraph())
    plant = MultibodyPlant(0.0)
    plant.RegisterAsSourceForSceneGraph(scene_graph)
    ProcessModelDirectives(LoadModelDirectives(str(mico_directives())), plant, model_parser(plant))
    arm = plant.GetModelInstanceByName(ARM_MODEL_NAME)
    add_scene_objects(plant, objects, plant.GetFrameByName(EE_FRAME, arm), only_attached=False)
    plant.Finalize()
    return plant, scene_graph


def _start(
    settings: object,
    config: StationConfig,
    inbox: StatusInbox,
    limits: tuple[np.ndarray, np.ndarray],
    measure_spacing: bool,
) -> tuple[StatusReading, float]:
    """The start checks: the first status (:func:`first_status`) and the period the driver
    announces (:func:`status_spacing`, with ``measure_spacing``; else the control period)."""
    lower, upper = limits
    first = first_status(
        inbox,
        settings.start_timeout,  # type: ignore[attr-defined]
        lower,
        upper,
        np.asarray(config.home_q),
        settings.lcm_url,  # type: ignore[attr-defined]
    )
    spacing = config.control_period
    if measure_spacing:
        spacing = status_spacing(
            inbox,
            first,
            settings.start_timeout,  # type: ignore[attr-defined]
            settings.max_status_period,  # type: ignore[attr-defined]
        )
    return first, spacing


def _pose_at(plant: MultibodyPlant, first: StatusReading) -> None:
    """The plant's default posture: the arm's and the fingers' measured in the ``first`` status (the
    fingers within their travel)."""
    arm = plant.GetModelInstanceByName(ARM_MODEL_NAME)
    for name, q in zip(ARM_JOINTS, first.q, strict=True):
        plant.GetJointByName(name, arm).set_default_positions([q])
    for name, q in zip(FINGER_JOINTS, first.finger_q, strict=True):
        plant.GetJointByName(name, arm).set_default_positions(
            [float(np.clip(q, 0.0, FINGER_MAX_OPENING / 2))]
        )


def _add_posed_geometry(
    builder: DiagramBuilder,
    plant: MultibodyPlant,
    scene_graph: SceneGraph,
    arm_state: OutputPort,
    finger_state: OutputPort,
) -> None:
    """The model posed by the measurement (the ``arm_state`` and ``finger_state`` output ports):
    ``[arm q (6), finger q (2)]`` -> the plant's q -> the geometry's poses in ``scene_graph``."""
    arm = plant.GetModelInstanceByName(ARM_MODEL_NAME)
    P = np.zeros((plant.num_positions(), 8))
    for k, name in enumerate(ARM_JOINTS + FINGER_JOINTS):
        P[plant.GetJointByName(name, arm).position_start(), k] = 1.0
    S = np.zeros((8, 16))  # [arm q; arm v; finger q; finger v] -> [arm q; finger q]
    S[:6, :6] = np.eye(6)
    S[6:, 12:14] = np.eye(2)
    measured = builder.AddNamedSystem("measured_state", Multiplexer([12, 4]))
    positions = builder.AddNamedSystem("model_positions", MatrixGain(P @ S))
    builder.Connect(arm_state, measured.get_input_port(0))
    builder.Connect(finger_state, measured.get_input_port(1))
    builder.Connect(measured.get_output_port(), positions.get_input_port())
    to_pose = builder.AddNamedSystem("to_geometry_pose", MultibodyPositionToGeometryPose(plant))
    builder.Connect(positions.get_output_port(), to_pose.get_input_port())
    builder.Connect(to_pose.get_output_port(), scene_graph.get_source_pose_port(plant.get_source_id()))


def build_lcm_station(
    settings: object,
    config: StationConfig,
    scene_objects: Iterable[SceneObject] = (),
    meshcat: Meshcat | None = None,
    lcm: DrakeLcm | None = None,
    pump: Pump | None = None,
) -> Station:
    """Build the station on LCM (module docstring) with the backend ``settings``
    (:class:`~drake_disamb.station.backends.lcm.Lcm`).

    Args:
        settings: The backend's settings (URL, channels, timeouts, repeats, finger speed).
        config: The station settings (control period, joint speed limits; the IK's, which
            the returned station's configuration carries with ``home_q`` the measured posture).
        scene_objects: Drawn in Meshcat and, when held, part of the gripper for the floor.
        meshcat: Draws the arm posed by the statuses.
        lcm: The bus (default: a ``DrakeLcm`` of ``settings.lcm_url``).
        pump: Called before every poll (the in-process driver's step; its period is the
            station's, so the start does not measure it).

    Raises:
        RuntimeError: the start checks (:func:`first_status`, :func:`status_spacing`).
    """
    objects = tuple(config.scene_objects) + tuple(scene_objects)
    lcm = lcm if lcm is not None else DrakeLcm(settings.lcm_url)  # type: ignore[attr-defined]
    period = config.control_period
    builder = DiagramBuilder()
    plant, scene_graph = _model(builder, objects)
    arm = plant.GetModelInstanceByName(ARM_MODEL_NAME)
    geometry = StationGeometry.from_plant(plant, scene_graph, arm)
    lower, upper = geometry.joint_limits()

    inbox = StatusInbox(lcm, settings.status_channel, pump)  # type: ignore[attr-defined]
    first, spacing = _start(settings, config, inbox, (lower, upper), measure_spacing=pump is None)
    _pose_at(plant, first)  # the model starts where the arm is
    link = CommandLink(lcm, settings.command_channel, period, settings.zero_command_repeats)  # type: ignore[attr-defined]

    control_plant, control_arm = make_control_plant(objects)
    seeded = dataclasses.replace(
        config,
        home_q=tuple(first.q.tolist()),
        nominal_posture=config.nominal_posture if config.nominal_posture is not None else config.home_q,
    )
    receiver = builder.AddNamedSystem(
        "status_receiver",
        JacoStatusReceiver(
            inbox,
            first,
            lower,
            upper,
            period,
            settings.status_timeout,
            config.warn_interval,  # type: ignore[attr-defined]
            real_time=pump is None,
            spacing=spacing,
            max_spacing=max(period, settings.max_status_period),  # type: ignore[attr-defined]
        ),
    )
    ee_state = builder.AddNamedSystem("ee_state", ModelEndEffectorState(control_plant, control_arm))
    sender = builder.AddNamedSystem(
        "command_sender",
        JacoCommandSender(
            link,
            inbox,
            arm_velocity_limits(config, plant, arm),
            settings.finger_speed_limit,  # type: ignore[attr-defined]
            period,
        ),
    )
    arm_state = receiver.GetOutputPort("arm_joint_state")
    finger_state = receiver.GetOutputPort("finger_state")
    builder.Connect(arm_state, ee_state.GetInputPort("arm_joint_state"))
    builder.Connect(arm_state, sender.GetInputPort("arm_joint_state"))
    builder.Connect(finger_state, sender.GetInputPort("finger_state"))
    builder.Connect(receiver.GetOutputPort("fault"), sender.GetInputPort("fault"))
    gripper_opening = builder.AddNamedSystem("gripper_opening", MatrixGain(np.array([[1.0, 1.0, 0.0, 0.0]])))
    builder.Connect(finger_state, gripper_opening.get_input_port())

    _add_posed_geometry(builder, plant, scene_graph, arm_state, finger_state)
    if meshcat is not None:
        MeshcatVisualizer.AddToBuilder(
            builder, scene_graph, meshcat, MeshcatVisualizerParams(role=Role.kIllustration, prefix="station")
        )

    for name in SHARED_INPUTS:
        builder.ExportInput(sender.GetInputPort(name), name)
    outputs = {
        "ee_pose": ee_state.GetOutputPort("ee_pose"),
        "ee_velocity": ee_state.GetOutputPort("ee_velocity"),
        "arm_joint_state": arm_state,
        "finger_state": finger_state,
        "gripper_opening": gripper_opening.get_output_port(),
        "fault": receiver.GetOutputPort("fault"),
    }
    for name, port in outputs.items():
        builder.ExportOutput(port, name)
    diagram = builder.Build()
    diagram.set_name("station")
    atexit.register(link.stop_arm)
    return Station(
        diagram=diagram,
        plant=plant,
        scene_graph=scene_graph,
        arm=arm,
        control_plant=control_plant,
        config=seeded,
        scene_objects=objects,
        meshcat=meshcat,
        geometry=geometry,
        outputs=tuple(outputs),
        link=link,
    )
