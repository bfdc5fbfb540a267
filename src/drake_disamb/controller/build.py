"""Wiring the controllers to a station: :func:`add_station_controller` adds the differential IK and
the gripper controller to a diagram builder beside a station (any backend) and connects them to its
joint-level inputs; :func:`build_controlled_station` makes a Diagram of a station and its
controllers that takes the shared-control commands (an end-effector velocity, a gripper speed), for
driving the arm on its own (``station-demo``, the safety measurements, the benchmarks)::

    ee_velocity_command ─▶ "diff_ik" ─── arm_velocity_command ───▶ "station"
                              ▲ arm_joint_state ◀──────────────────────┘
    gripper_command ─▶ "gripper_controller" ─ finger_velocity_command ─▶ "station"

The shared-control diagram (:func:`drake_disamb.builder.build_shared_control_diagram`) adds them
with :func:`add_station_controller` between its blender and interface and the station.
"""

from __future__ import annotations

from dataclasses import dataclass

from pydrake.systems.framework import Context, Diagram, DiagramBuilder

from drake_disamb.controller.systems import DifferentialIKIntegrator, GripperController
from drake_disamb.station.build import Station

CONTROLLER_INPUTS: tuple[str, ...] = ("ee_velocity_command", "gripper_command")
"""The controllers' command inputs: ``ee_velocity_command`` (6, the desired end-effector twist,
paper order ``[vx, vy, vz, wx, wy, wz]`` in W, m/s and rad/s) of ``"diff_ik"`` and
``gripper_command`` (1, the fingers' opening speed, m/s; positive opens) of
``"gripper_controller"``."""


@dataclass(frozen=True)
class StationController:
    """The controllers of one station, added to a builder (:func:`add_station_controller`).

    Attributes:
        diff_ik: The :class:`DifferentialIKIntegrator` (subsystem ``"diff_ik"``): its input
            ``ee_velocity_command`` takes the end-effector command.
        gripper: The :class:`GripperController` (subsystem ``"gripper_controller"``): its input
            ``gripper_command`` takes the opening speed.
    """

    diff_ik: DifferentialIKIntegrator
    gripper: GripperController


def add_station_controller(builder: DiagramBuilder, station: Station) -> StationController:
    """Add the controllers of ``station`` (already added to ``builder``) and connect them: the IK
    reads the station's ``arm_joint_state`` and drives its ``arm_velocity_command``, the gripper
    controller its ``finger_velocity_command``. The IK computes on the station's control plant,
    with its configuration (on a wire, seeded with the arm's measured posture), its scene objects
    (a held one is part of the gripper for the floor) and its geometry; both tick every
    ``station.config.control_period``. Their command inputs (:data:`CONTROLLER_INPUTS`) are left
    for the caller to connect."""
    config = station.config
    diff_ik = builder.AddNamedSystem(
        "diff_ik",
        DifferentialIKIntegrator(
            station.control_plant, config, held_objects=station.scene_objects, geometry=station.geometry
        ),
    )
    gripper = builder.AddNamedSystem("gripper_controller", GripperController(config))
    arm = station.diagram
    builder.Connect(arm.GetOutputPort("arm_joint_state"), diff_ik.GetInputPort("arm_joint_state"))
    builder.Connect(diff_ik.GetOutputPort("arm_velocity_command"), arm.GetInputPort("arm_velocity_command"))
    builder.Connect(
        gripper.GetOutputPort("finger_velocity_command"), arm.GetInputPort("finger_velocity_command")
    )
    return StationController(diff_ik=diff_ik, gripper=gripper)


@dataclass(frozen=True)
class ControlledStation:
    """A station and its controllers in one Diagram (:func:`build_controlled_station`).

    Attributes:
        diagram: The Diagram (named ``"controlled_station"``): inputs :data:`CONTROLLER_INPUTS`,
            outputs every output of the station (``station.outputs``) and the IK's ``ik_status``.
        station: The station inside it (subsystem ``"station"``).
        controller: Its controllers (subsystems ``"diff_ik"`` and ``"gripper_controller"``).
    """

    diagram: Diagram
    station: Station
    controller: StationController

    @property
    def diff_ik(self) -> DifferentialIKIntegrator:
        """The differential IK (subsystem ``"diff_ik"``)."""
        return self.controller.diff_ik

    def plant_context(self, root_context: Context) -> Context:
        """The station plant's context inside ``root_context``."""
        return self.station.plant_context(root_context)


def build_controlled_station(station: Station) -> ControlledStation:
    """A Diagram of ``station`` (any backend) behind its controllers (module docstring) that takes
    the shared-control commands on its inputs :data:`CONTROLLER_INPUTS` and exports every station
    output and ``ik_status``. Both inputs must be connected (or fixed) before simulating."""
    builder = DiagramBuilder()
    builder.AddSystem(station.diagram)
    controller = add_station_controller(builder, station)
    builder.ExportInput(controller.diff_ik.GetInputPort("ee_velocity_command"), "ee_velocity_command")
    builder.ExportInput(controller.gripper.GetInputPort("gripper_command"), "gripper_command")
    for name in station.outputs:
        builder.ExportOutput(station.diagram.GetOutputPort(name), name)
    builder.ExportOutput(controller.diff_ik.GetOutputPort("ik_status"), "ik_status")
    diagram = builder.Build()
    diagram.set_name("controlled_station")
    return ControlledStation(diagram=diagram, station=station, controller=controller)
