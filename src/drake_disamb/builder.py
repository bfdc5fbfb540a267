"""One function that assembles every shared-control diagram from a :class:`~drake_disamb.config.Scenario`.

:func:`build_shared_control_diagram` wires (paper Figure "exp_block_diagram")::

    user.raw ------------------------------> interface.raw
    interface.u_h -------------------------> blender.u_h, inference.u_h
    autonomy.u_a --------------------------> blender.u_a, inference.u_a
    inference.belief ----------------------> blender, interface, user, visualizer
    interface.request ---------------------> disambiguation.request          (disambiguation, automatic)
    disambiguation.answer -----------------> interface.answer                (disambiguation, automatic)
    interface.paused ----------------------> inference, blender, user .paused  (hold_while_computing)
    inference.belief, interface.u_h, mode -> automatic_trigger              (automatic paradigm)
    automatic_trigger.automatic_request_count -> interface.automatic_request_count
    blender.u -----------------------------> diff_ik.ee_velocity_command   (the IK: end-effector
    diff_ik.arm_velocity_command ----------> station.arm_velocity_command   velocity -> joints)
    interface.gripper_command -------------> gripper_controller.gripper_command
    gripper_controller.finger_velocity_command -> station.finger_velocity_command
    station.arm_joint_state ---------------> diff_ik.arm_joint_state
    station.ee_pose -----------------------> everyone (the interface latches it, and the belief and
                                             goal poses, into a request at a press)
    station.gripper_opening ---------------> task.gripper_opening      (stages that end with a release)
    task.goal_poses -----------------------> everyone (the goal set switches between stages)
      (inference.goal_set "task": a constant source of every goal instead; the task manager still
      completes a stage only at one of its own goals)

The interface, user, autonomy, blender, disambiguation and task manager tick every
``scenario.control_period`` (100 Hz by default, the MICO's Cartesian velocity interface); the DFT
belief is continuous state, integrated between ticks by the integrator of the scenario's
``simulator_config``; the arm is the station's discrete plant (``plant_config``). Every system's
config comes from :func:`~drake_disamb.config.resolve_scenario`. Running a trial is
:func:`drake_disamb.trial.run_trial`; this module only wires.

Belief slot ``i`` in stage ``k`` is goal ``i`` of :meth:`Scenario.belief_goals(k)
<drake_disamb.config.Scenario.belief_goals>` (the stage's goals, or every goal of the task); the
simulated user gets the belief slot of its intended goal per stage
(:attr:`~drake_disamb.config.TrialConfig.user_goals`) and the task manager's ``stage``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydrake.geometry import Meshcat
from pydrake.systems.framework import Context, Diagram, DiagramBuilder, System
from pydrake.systems.primitives import LogVectorOutput, VectorLogSink, ZeroOrderHold

from drake_disamb.config import Scenario, TrialConfig, check_start_clearance, resolve_scenario
from drake_disamb.systems.autonomy import PotentialFieldAutonomy
from drake_disamb.systems.blending import SharedControlBlender
from drake_disamb.systems.disambiguation import AutomaticTrigger, DisambiguationSystem
from drake_disamb.systems.interfaces import make_interface
from drake_disamb.systems.task import FixedGoalSet, TaskManager
from drake_disamb.systems.user import SimulatedUser

LOGGED_SIGNALS: tuple[tuple[str, str, str], ...] = (
    ("belief", "inference", "belief"),
    ("alpha", "blender", "alpha"),
    ("u_h", "interface", "u_h"),
    ("u", "blender", "u"),
    ("ee_pose", "station", "ee_pose"),
    ("mode", "interface", "mode"),
    ("stage", "task", "stage"),
    ("ik_status", "diff_ik", "ik_status"),
)
"""``(log name, subsystem, output port)`` of every VectorLogSink the builder adds (``ik_status``:
an :class:`~drake_disamb.ik.IkStatus` code per control step, whatever the station's backend)."""


@dataclass
class SharedControlDiagram:
    """Handles on a built shared-control diagram.

    Attributes:
        diagram: The built Diagram.
        scenario: The scenario it was built from.
        config: The frozen configs resolved from it.
        plant: The station's MultibodyPlant.
        station: The :class:`drake_disamb.station.Station` handle; its diagram is the subsystem
            ``"station"`` of ``diagram``.
        systems: Named subsystems: ``user`` (or the given input source), ``interface``,
            ``autonomy``, ``inference``, ``blender``, ``disambiguation`` (disambiguation and
            automatic paradigms), ``automatic_trigger`` (automatic paradigm only), ``task``,
            ``ee_pose_sampler``, ``diff_ik`` and ``gripper_controller`` (the controllers between
            the blender and interface and the station's joint-level inputs), ``visualizer`` (with
            Meshcat only).
        loggers: VectorLogSinks by name (see :data:`LOGGED_SIGNALS`).
        modes: The interface's control modes (dimension lists; gripper mode last).
        meshcat: The Meshcat instance, or ``None``.
    """

    diagram: Diagram
    scenario: Scenario
    config: TrialConfig
    plant: Any
    station: Any
    systems: dict[str, System]
    loggers: dict[str, VectorLogSink]
    modes: list[list[int]]
    meshcat: Meshcat | None = None

    def initialize(self, root_context: Context) -> None:
        """Latch the start end-effector pose into the pose sampler (call before simulating).

        The sampler (a ZeroOrderHold) would otherwise output zeros until its first tick.
        """
        station = self.station.diagram
        station_pose = station.GetOutputPort("ee_pose").Eval(station.GetMyContextFromRoot(root_context))
        sampler = self.systems["ee_pose_sampler"]
        sampler.GetMyMutableContextFromRoot(root_context).SetDiscreteState(np.asarray(station_pose))

    def station_fault(self, root_context: Context) -> str:
        """The reason of the station's latched fault in ``root_context``, or ``""`` (a simulated
        station has no ``fault`` port and never faults)."""
        if "fault" not in self.station.outputs:
            return ""
        from drake_disamb.station.lcm.faults import Fault

        diagram = self.station.diagram
        code = diagram.GetOutputPort("fault").Eval(diagram.GetMyContextFromRoot(root_context))[0]
        return Fault(int(code)).reason

    def stop_station(self) -> None:
        """Command the arm to stop (the zero command, several times) if the station is on a wire."""
        if self.station.link is not None:
            self.station.link.stop_arm()

    def goal_names(self, stage: int) -> list[str]:
        """Goal names in belief-slot order for ``stage``."""
        return [g.name for g in self.scenario.stage_goals(stage)]


def _make_inference(config: TrialConfig, control_period: float) -> System:
    from drake_disamb.systems.inference import inference_system

    # The method and its parameters are the forward projection's too.
    return inference_system(config.inference, config.n_goals, control_period)


def build_shared_control_diagram(
    scenario: Scenario,
    meshcat: Meshcat | None = None,
    input_source: System | None = None,
) -> SharedControlDiagram:
    """Assemble the full shared-control diagram of ``scenario``.

    Args:
        scenario: The scenario (checked and resolved here, :func:`~drake_disamb.config.resolve_scenario`).
        meshcat: If given, the arm, table and objects are drawn, plus the goal probabilities, the
            active mode and alpha (:class:`~drake_disamb.systems.visualization.SharedControlVisualizer`).
        input_source: A system with one 4-vector output port ``raw`` to drive the interface
            instead of the simulated user (a recorded log, a live device, a fault injector).

    The station is the one of the scenario's ``station`` backend (:mod:`drake_disamb.station.backends`).

    Raises:
        ValueError: an invalid scenario, or a goal on top of the gripper's start position.
    """
    from drake_disamb.controller import add_station_controller
    from drake_disamb.station.backends import make_station

    config = resolve_scenario(scenario)
    n = config.n_goals
    builder = DiagramBuilder()

    station = make_station(config.backend, config.station, meshcat=meshcat)
    builder.AddSystem(station.diagram)
    plant = station.plant
    check_start_clearance(scenario, start_ee_pose(station)[:3])

    interface = builder.AddSystem(make_interface(config.interface, n))
    modes = [list(m) for m in interface.modes]

    task = builder.AddSystem(
        TaskManager(
            [scenario.stage_goal_poses(k) for k in range(scenario.n_stages)],
            position_tolerance=scenario.success.position_tolerance,
            orientation_tolerance=scenario.success.orientation_tolerance,
            hold_times=[scenario.hold_time(k) for k in range(scenario.n_stages)],
            period=scenario.control_period,
            release_openings=[stage.release_opening for stage in scenario.stages],
            targets=[
                scenario.user.goals[k] if stage.ends_at_target else None
                for k, stage in enumerate(scenario.stages)
            ],
        )
    )
    task.set_name("task")
    autonomy = builder.AddSystem(PotentialFieldAutonomy(n, config.autonomy, scenario.control_period))
    autonomy.set_name("autonomy")
    inference = builder.AddSystem(_make_inference(config, scenario.control_period))
    inference.set_name("inference")
    blender = builder.AddSystem(SharedControlBlender(n, config.blending, scenario.control_period))
    blender.set_name("blender")

    if input_source is None:
        user = builder.AddSystem(
            SimulatedUser(
                config.interface, list(config.user_goals), n, config.user, releases=scenario.releases()
            )
        )
        user.set_name("user")
        builder.Connect(interface.GetOutputPort("mode"), user.GetInputPort("mode"))
    else:
        user = builder.AddSystem(input_source)
        if not user.get_name():
            user.set_name("input_source")
    raw = user.GetOutputPort("raw")
    if input_source is not None and meshcat is not None and station.link is not None:
        # A person at the page drives a real arm: losing the page releases every signal.
        from drake_disamb.systems.deadman import PageDeadman

        deadman = builder.AddNamedSystem("deadman", PageDeadman(meshcat, scenario.control_period))
        builder.Connect(raw, deadman.GetInputPort("raw_in"))
        raw = deadman.GetOutputPort("raw")
    builder.Connect(raw, interface.GetInputPort("raw"))

    # The control loop (every scenario.control_period, 10 ms by default) sees the end-effector pose
    # sampled at its ticks (as the MICO's Cartesian interface reports it); this also keeps plant
    # steps finer than the control period (scenario.plant_config.time_step, by default equal to it) and the
    # belief integrator's stages from re-evaluating the autonomy and the belief's inputs between ticks.
    sampler = builder.AddSystem(ZeroOrderHold(scenario.control_period, 7))
    sampler.set_name("ee_pose_sampler")
    builder.Connect(station.diagram.GetOutputPort("ee_pose"), sampler.get_input_port())
    ee_pose = sampler.get_output_port()
    goal_poses = task.GetOutputPort("goal_poses")
    if scenario.inference.goal_set == "task" and scenario.n_stages > 1:  # one belief over every goal
        goal_source = builder.AddNamedSystem("task_goal_poses", FixedGoalSet(scenario.belief_goal_poses(0)))
        goal_poses = goal_source.get_output_port()
    builder.Connect(ee_pose, task.GetInputPort("ee_pose"))
    builder.Connect(station.diagram.GetOutputPort("gripper_opening"), task.GetInputPort("gripper_opening"))
    if input_source is None:
        builder.Connect(ee_pose, user.GetInputPort("ee_pose"))
        builder.Connect(goal_poses, user.GetInputPort("goal_poses"))
        builder.Connect(inference.GetOutputPort("belief"), user.GetInputPort("belief"))
        builder.Connect(task.GetOutputPort("stage"), user.GetInputPort("stage"))
    builder.Connect(ee_pose, autonomy.GetInputPort("ee_pose"))
    builder.Connect(goal_poses, autonomy.GetInputPort("goal_poses"))
    builder.Connect(interface.GetOutputPort("u_h"), inference.GetInputPort("u_h"))
    builder.Connect(interface.GetOutputPort("u_h"), blender.GetInputPort("u_h"))
    builder.Connect(ee_pose, inference.GetInputPort("ee_pose"))
    builder.Connect(goal_poses, inference.GetInputPort("goal_poses"))
    builder.Connect(autonomy.GetOutputPort("u_a"), inference.GetInputPort("u_a"))
    builder.Connect(autonomy.GetOutputPort("u_a"), blender.GetInputPort("u_a"))
    builder.Connect(inference.GetOutputPort("belief"), blender.GetInputPort("belief"))
    controller = add_station_controller(builder, station)  # the IK and the gripper's, joint-level out
    builder.Connect(blender.GetOutputPort("u"), controller.diff_ik.GetInputPort("ee_velocity_command"))
    builder.Connect(
        interface.GetOutputPort("gripper_command"), controller.gripper.GetInputPort("gripper_command")
    )

    systems: dict[str, System] = {
        "user": user,
        "interface": interface,
        "autonomy": autonomy,
        "inference": inference,
        "blender": blender,
        "task": task,
        "diff_ik": controller.diff_ik,
        "gripper_controller": controller.gripper,
        "ee_pose_sampler": sampler,
    }
    if config.disambiguation is not None:  # the preset's probing, the live inference's update
        disamb = builder.AddSystem(
            DisambiguationSystem(
                n,
                interface.arm_modes,
                config.disambiguation,
                control_period=scenario.control_period,
                method=config.disambiguation_method,
            )
        )
        disamb.set_name("disambiguation")
        # A request is a value: the interface latches what it is made of at the press, the
        # disambiguation system answers it once, and the interface applies the answer.
        builder.Connect(inference.GetOutputPort("belief"), interface.GetInputPort("belief"))
        builder.Connect(ee_pose, interface.GetInputPort("ee_pose"))
        builder.Connect(goal_poses, interface.GetInputPort("goal_poses"))
        builder.Connect(interface.GetOutputPort("request"), disamb.GetInputPort("request"))
        builder.Connect(disamb.GetOutputPort("answer"), interface.GetInputPort("answer"))
        systems["disambiguation"] = disamb
        if scenario.disambiguation.hold_while_computing:  # the loop pauses while a request is computed
            paused = interface.GetOutputPort("paused")
            builder.Connect(paused, inference.GetInputPort("paused"))
            builder.Connect(paused, blender.GetInputPort("paused"))
            if input_source is None:  # the simulated user sees the arm stop and waits
                builder.Connect(paused, user.GetInputPort("paused"))
    if config.automatic is not None:
        trigger = builder.AddSystem(
            AutomaticTrigger(n, config.automatic, scenario.control_period, config.interface.request_latency)
        )
        trigger.set_name("automatic_trigger")
        builder.Connect(inference.GetOutputPort("belief"), trigger.GetInputPort("belief"))
        builder.Connect(interface.GetOutputPort("u_h"), trigger.GetInputPort("u_h"))
        builder.Connect(interface.GetOutputPort("mode"), trigger.GetInputPort("mode"))
        builder.Connect(
            trigger.GetOutputPort("automatic_request_count"),
            interface.GetInputPort("automatic_request_count"),
        )
        systems["automatic_trigger"] = trigger

    if meshcat is not None:
        from drake_disamb.systems import visualization

        vis = builder.AddSystem(visualization.visualizer_for_scenario(meshcat, scenario, modes))
        vis.set_name("visualizer")
        if vis.HasInputPort("stage"):
            builder.Connect(task.GetOutputPort("stage"), vis.GetInputPort("stage"))
        bounds = visualization.illustration_bounds(plant, station.scene_graph)
        visualization.frame_workspace(meshcat, *bounds, work_height=station.geometry.table_top)
        builder.Connect(inference.GetOutputPort("belief"), vis.GetInputPort("belief"))
        builder.Connect(goal_poses, vis.GetInputPort("goal_poses"))
        builder.Connect(station.diagram.GetOutputPort("ee_pose"), vis.GetInputPort("ee_pose"))
        builder.Connect(interface.GetOutputPort("mode"), vis.GetInputPort("mode"))
        builder.Connect(blender.GetOutputPort("alpha"), vis.GetInputPort("alpha"))
        systems["visualizer"] = vis

    loggers: dict[str, VectorLogSink] = {}
    for name, sys_name, port in LOGGED_SIGNALS:
        system = station.diagram if sys_name == "station" else systems[sys_name]
        source = system.GetOutputPort(port)
        logger = LogVectorOutput(source, builder, scenario.control_period)
        logger.set_name(f"log_{name}")
        loggers[name] = logger

    diagram = builder.Build()
    diagram.set_name(f"shared_control_{scenario.task}")
    return SharedControlDiagram(
        diagram=diagram,
        scenario=scenario,
        config=config,
        plant=plant,
        station=station,
        systems=systems,
        loggers=loggers,
        modes=modes,
        meshcat=meshcat,
    )


def start_ee_pose(station: Any) -> NDArray[np.float64]:
    """``[x, y, z, qw, qx, qy, qz]`` of the end effector at the start: the station's ``ee_pose``
    output in its default context (the simulated arm's home, or the measured arm's pose)."""
    diagram = station.diagram
    return np.asarray(diagram.GetOutputPort("ee_pose").Eval(diagram.CreateDefaultContext())).copy()
