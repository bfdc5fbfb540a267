"""The shared-control diagram of a scenario, assembled from its resolved config.

:func:`build_shared_control_diagram` resolves the scenario once
(:func:`~drake_disamb.config.resolve_scenario`: every bound checked there, each message naming the
scenario's field) and then reads only the resolved :class:`~drake_disamb.config.TrialConfig`; each
system gets its typed config from it (the belief-sized ones the loop's
:class:`~drake_disamb.systems.loop.ControlLoop`: the number of goals and the control period). One
short function adds each part: the station (the hardware, joint-level ports: whichever backend the
scenario's ``station`` names), the interface, the task (its manager, the sampled end-effector pose,
the belief's goal set), the belief and the autonomy (inference, autonomy, blender), the user (the
simulated one, or a given input source), the controllers between the blender and the station, the
disambiguation (a request is a value; one ``paused`` signal), the automatic trigger, the visualizer
and the loggers. The wiring (paper Figure "exp_block_diagram")::

    user.raw ------------------------------> interface.raw
    interface.u_h -------------------------> blender.u_h, inference.u_h
    autonomy.u_a --------------------------> blender.u_a, inference.u_a
    inference.belief ----------------------> blender, interface, user, visualizer, panel
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

Every system ticks every ``config.control_period`` (100 Hz by default, the MICO's Cartesian
velocity interface; the simulated user decides at its own decision period, at least that long);
the DFT belief is continuous state, integrated between ticks by the integrator of the scenario's
``simulator_config``; the arm is the station's discrete plant (``plant_config``). Running a trial
is :func:`drake_disamb.trial.run_trial`; this module only wires.

Belief slot ``i`` in stage ``k`` is goal ``i`` of :meth:`Scenario.belief_goals(k)
<drake_disamb.config.Scenario.belief_goals>` (the stage's goals, or every goal of the task); the
simulated user gets the belief slot of its intended goal per stage
(:attr:`~drake_disamb.config.TrialConfig.user_goals`) and the task manager's ``stage``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydrake.geometry import Meshcat
from pydrake.systems.framework import Context, Diagram, DiagramBuilder, OutputPort, System
from pydrake.systems.primitives import LogVectorOutput, VectorLogSink, ZeroOrderHold

from drake_disamb.config import Scenario, TrialConfig, check_start_clearance, resolve_scenario
from drake_disamb.interfaces.system import make_interface
from drake_disamb.systems.autonomy import PotentialFieldAutonomy
from drake_disamb.systems.blending import SharedControlBlender
from drake_disamb.systems.disambiguation import AutomaticTrigger, DisambiguationSystem
from drake_disamb.systems.task import FixedGoalSet, TaskManager
from drake_disamb.user.system import SimulatedUser

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
            ``ee_pose_sampler``, ``task_goal_poses`` (a belief over every goal of a multi-step
            task), ``diff_ik`` and ``gripper_controller`` (the controllers between the blender and
            interface and the station's joint-level inputs), ``deadman`` (an input source driving
            an arm on a wire from the page), ``visualizer`` (with Meshcat only), ``panel`` (the
            operator panel, with Meshcat or an operator page).
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
        """The names of ``stage``'s goals, in the task manager's order."""
        return list(self.config.goal_names[stage])


@dataclass
class _Wiring:
    """What the builder's steps share: the builder, the resolved config, the station, the systems
    added so far by name, and the signals every part reads."""

    builder: DiagramBuilder
    config: TrialConfig
    station: Any
    systems: dict[str, System] = field(default_factory=dict)
    ee_pose: OutputPort | None = None
    """The end-effector pose sampled at the control ticks."""
    goal_poses: OutputPort | None = None
    """The belief's goal set (the task manager's stage goals, or every goal of the task)."""

    def add(self, name: str, system: System) -> System:
        """Add ``system`` named ``name`` to the diagram and to :attr:`systems`."""
        self.systems[name] = self.builder.AddNamedSystem(name, system)
        return system

    def port(self, system: str, port: str) -> OutputPort:
        """The output ``port`` of the added ``system``."""
        return self.systems[system].GetOutputPort(port)

    def connect(self, source: OutputPort, system: str, *ports: str) -> None:
        """Connect ``source`` to the input ``ports`` of the added ``system``."""
        for port in ports:
            self.builder.Connect(source, self.systems[system].GetInputPort(port))


def build_shared_control_diagram(
    scenario: Scenario,
    meshcat: Meshcat | None = None,
    input_source: System | None = None,
    page: Any = None,
) -> SharedControlDiagram:
    """Assemble the full shared-control diagram of ``scenario``.

    Args:
        scenario: The scenario (checked and resolved here, :func:`~drake_disamb.config.resolve_scenario`;
            the diagram is built from the resolved config alone, the scenario kept on the handle).
        meshcat: If given, the arm, table and objects are drawn, plus the goal probabilities, the
            active mode and alpha (:class:`~drake_disamb.systems.visualization.SharedControlVisualizer`).
        input_source: A system with one 4-vector output port ``raw`` to drive the interface
            instead of the simulated user (a recorded log, a live device, a fault injector).
        page: The operator page (:class:`~drake_disamb.operator_page.server.OperatorPage`): the
            panel (:class:`~drake_disamb.systems.panel.PanelVisualizer`) is shown there, and its
            deadman, not Meshcat's page, holds a live input that drives an arm on a wire. With
            Meshcat or a page the diagram has the panel; with Meshcat it also keeps the panel's
            states for the recording.

    The station is the one of the scenario's ``station`` backend (:mod:`drake_disamb.station.backends`).

    Raises:
        ValueError: an invalid scenario, or a goal on top of the gripper's start position.
    """
    from drake_disamb.station.backends import make_station

    config = resolve_scenario(scenario)
    builder = DiagramBuilder()
    station = make_station(config.backend, config.station, meshcat=meshcat)
    builder.AddSystem(station.diagram)
    check_start_clearance(config, start_ee_pose(station)[:3])
    w = _Wiring(builder, config, station)
    # (the interface names itself after its kind)
    interface = w.systems["interface"] = builder.AddSystem(make_interface(config.interface, config.n_goals))
    _add_task(w)
    _add_belief_and_autonomy(w)
    _add_user(w, input_source, meshcat if page is None else page)
    _add_controller(w)
    if config.disambiguation is not None:  # the preset's probing, the live inference's update
        _add_disambiguation(w)
    if config.automatic is not None:
        _add_automatic_trigger(w)
    if meshcat is not None:
        _add_visualizer(w, meshcat, interface.modes)
    if meshcat is not None or page is not None:
        _add_panel(w, scenario, meshcat, page)
    loggers = _add_loggers(w)
    diagram = builder.Build()
    diagram.set_name(f"shared_control_{config.task_name}")
    return SharedControlDiagram(
        diagram=diagram,
        scenario=scenario,
        config=config,
        plant=station.plant,
        station=station,
        systems=w.systems,
        loggers=loggers,
        modes=[list(m) for m in interface.modes],
        meshcat=meshcat,
    )


def _add_task(w: _Wiring) -> None:
    """The task manager, the end-effector pose sampled at the control ticks and the belief's goal
    set (the manager's stage goals, or a constant source of every goal of the task)."""
    config, station = w.config, w.station.diagram
    w.add("task", TaskManager(config.task))
    # The control loop (every control period, 10 ms by default) sees the end-effector pose sampled
    # at its ticks (as the MICO's Cartesian interface reports it); this also keeps plant steps finer
    # than the control period (plant_config.time_step, by default equal to it) and the belief
    # integrator's stages from re-evaluating the autonomy and the belief's inputs between ticks.
    w.add("ee_pose_sampler", ZeroOrderHold(config.control_period, 7))
    w.builder.Connect(station.GetOutputPort("ee_pose"), w.systems["ee_pose_sampler"].get_input_port())
    w.ee_pose = w.systems["ee_pose_sampler"].get_output_port()
    w.goal_poses = w.port("task", "goal_poses")
    if config.task_goal_poses is not None:  # one belief over every goal of the task
        w.add("task_goal_poses", FixedGoalSet(config.task_goal_poses))
        w.goal_poses = w.port("task_goal_poses", "goal_poses")
    w.connect(w.ee_pose, "task", "ee_pose")
    w.connect(station.GetOutputPort("gripper_opening"), "task", "gripper_opening")


def _add_belief_and_autonomy(w: _Wiring) -> None:
    """The autonomy (a command per goal), the inference (the belief; its method and parameters are
    the forward projection's too) and the blender, fed by the interface's ``u_h``."""
    from drake_disamb.systems.inference import inference_system

    config = w.config
    w.add("autonomy", PotentialFieldAutonomy(config.loop, config.autonomy))
    w.add("inference", inference_system(config.inference, config.loop))
    w.add("blender", SharedControlBlender(config.loop, config.blending))
    w.connect(w.ee_pose, "autonomy", "ee_pose")
    w.connect(w.goal_poses, "autonomy", "goal_poses")
    w.connect(w.port("interface", "u_h"), "inference", "u_h")
    w.connect(w.port("interface", "u_h"), "blender", "u_h")
    w.connect(w.ee_pose, "inference", "ee_pose")
    w.connect(w.goal_poses, "inference", "goal_poses")
    w.connect(w.port("autonomy", "u_a"), "inference", "u_a")
    w.connect(w.port("autonomy", "u_a"), "blender", "u_a")
    w.connect(w.port("inference", "belief"), "blender", "belief")


def _add_user(w: _Wiring, input_source: System | None, page: Any) -> None:
    """The simulated user, or ``input_source``, on the interface's ``raw`` input (behind the
    deadman of ``page``, the operator page or Meshcat's, when a person at the page drives an arm on
    a wire)."""
    config = w.config
    if input_source is not None:
        w.systems["user"] = w.builder.AddSystem(input_source)
        if not input_source.get_name():
            input_source.set_name("input_source")
        raw = input_source.GetOutputPort("raw")
        if page is not None and w.station.link is not None:
            # A person at the page drives a real arm: losing the page releases every signal.
            from drake_disamb.interfaces.deadman import PageDeadman

            w.add("deadman", PageDeadman(page, config.control_period))
            w.connect(raw, "deadman", "raw_in")
            raw = w.port("deadman", "raw")
        w.connect(raw, "interface", "raw")
        return
    user = SimulatedUser(
        config.interface, list(config.user_goals), config.n_goals, config.user, releases=config.user_releases
    )
    w.add("user", user)
    w.connect(w.port("interface", "mode"), "user", "mode")
    w.connect(w.port("user", "raw"), "interface", "raw")
    w.connect(w.ee_pose, "user", "ee_pose")
    w.connect(w.goal_poses, "user", "goal_poses")
    w.connect(w.port("inference", "belief"), "user", "belief")
    w.connect(w.port("task", "stage"), "user", "stage")


def _add_controller(w: _Wiring) -> None:
    """The controllers between the shared-control commands and the station's joint-level inputs:
    the differential IK (the blender's ``u``) and the gripper's (the interface's opening speed)."""
    from drake_disamb.controller import add_station_controller

    controller = add_station_controller(w.builder, w.station)
    w.systems["diff_ik"], w.systems["gripper_controller"] = controller.diff_ik, controller.gripper
    w.connect(w.port("blender", "u"), "diff_ik", "ee_velocity_command")
    w.connect(w.port("interface", "gripper_command"), "gripper_controller", "gripper_command")


def _add_disambiguation(w: _Wiring) -> None:
    """The disambiguation system. A request is a value: the interface latches what it is made of at
    the press, the disambiguation system answers it once, and the interface applies the answer.
    With ``hold_while_computing`` the interface's one ``paused`` signal pauses the loop (the
    inference, the blender and the simulated user) while a request is computed."""
    config = w.config
    arm_modes = w.systems["interface"].arm_modes
    w.add(
        "disambiguation",
        DisambiguationSystem(config.loop, arm_modes, config.disambiguation, config.disambiguation_method),
    )
    w.connect(w.port("inference", "belief"), "interface", "belief")
    w.connect(w.ee_pose, "interface", "ee_pose")
    w.connect(w.goal_poses, "interface", "goal_poses")
    w.connect(w.port("interface", "request"), "disambiguation", "request")
    w.connect(w.port("disambiguation", "answer"), "interface", "answer")
    if config.hold_while_computing:
        paused = w.port("interface", "paused")
        w.connect(paused, "inference", "paused")
        w.connect(paused, "blender", "paused")
        if isinstance(w.systems["user"], SimulatedUser):  # the simulated user sees the arm stop and waits
            w.connect(paused, "user", "paused")


def _add_automatic_trigger(w: _Wiring) -> None:
    """The Automatic paradigm's trigger: it counts the moments to disambiguate, which the interface
    starts as it does a request press."""
    config = w.config
    w.add(
        "automatic_trigger", AutomaticTrigger(config.loop, config.automatic, config.interface.request_latency)
    )
    w.connect(w.port("inference", "belief"), "automatic_trigger", "belief")
    w.connect(w.port("interface", "u_h"), "automatic_trigger", "u_h")
    w.connect(w.port("interface", "mode"), "automatic_trigger", "mode")
    w.connect(w.port("automatic_trigger", "automatic_request_count"), "interface", "automatic_request_count")


def _add_visualizer(w: _Wiring, meshcat: Meshcat, modes: list[list[int]]) -> None:
    """The goal probabilities, the active mode and alpha in Meshcat, the workspace framed."""
    from drake_disamb.systems import visualization

    vis = w.add("visualizer", visualization.visualizer_for_trial(meshcat, w.config, modes))
    if vis.HasInputPort("stage"):
        w.connect(w.port("task", "stage"), "visualizer", "stage")
    bounds = visualization.illustration_bounds(w.station.plant, w.station.scene_graph)
    visualization.frame_workspace(meshcat, *bounds, work_height=w.station.geometry.table_top)
    w.connect(w.port("inference", "belief"), "visualizer", "belief")
    w.connect(w.goal_poses, "visualizer", "goal_poses")
    w.connect(w.station.diagram.GetOutputPort("ee_pose"), "visualizer", "ee_pose")
    w.connect(w.port("interface", "mode"), "visualizer", "mode")
    w.connect(w.port("blender", "alpha"), "visualizer", "alpha")


def _add_panel(w: _Wiring, scenario: Scenario, meshcat: Meshcat | None, page: Any) -> None:
    """The operator panel (on ``page``, kept for the recording with Meshcat) and its cues in the
    scene: the belief over the goals by name, the mode and its keys, alpha, and why a request's
    mode is what it is (from the disambiguation system's answer)."""
    from drake_disamb.interfaces.live import AXIS_SLIDERS
    from drake_disamb.systems.panel import PanelConfig, PanelVisualizer

    config, interface = w.config, w.config.interface
    variant = interface.variant
    disambiguation = w.systems.get("disambiguation")
    panel_config = PanelConfig(
        title=f"{config.task_name} \u00b7 {variant.label} \u00b7 {scenario.paradigm}",
        variant=variant,
        modes=tuple(tuple(m) for m in interface.modes),
        goal_names=tuple(tuple(g.name for g in scenario.belief_goals(k)) for k in range(scenario.n_stages)),
        goal_colors=tuple(tuple(tuple(c[:3]) for c in stage) for stage in config.goal_colors),
        stage_names=tuple(stage.name for stage in scenario.stages),
        axis_keys=AXIS_SLIDERS if variant.live_axes else (),
        requests_served=disambiguation is not None and interface.serve_requests,
        mode_selection=interface.mode_selection,
    )
    core_request = None if disambiguation is None else disambiguation.core_request
    panel = PanelVisualizer(
        panel_config,
        [] if page is None else [page],
        meshcat,
        core_request,
        record=meshcat is not None,
        update_period=config.control_period,
    )
    w.add("panel", panel)
    w.connect(w.port("inference", "belief"), "panel", "belief")
    w.connect(w.goal_poses, "panel", "goal_poses")
    w.connect(w.station.diagram.GetOutputPort("ee_pose"), "panel", "ee_pose")
    w.connect(w.port("blender", "alpha"), "panel", "alpha")
    for name in ("mode", "paused", "served_count", "request_count"):
        w.connect(w.port("interface", name), "panel", name)
    if panel.HasInputPort("stage"):
        w.connect(w.port("task", "stage"), "panel", "stage")
    if disambiguation is not None:
        w.connect(w.port("interface", "request"), "panel", "request")
        w.connect(w.port("disambiguation", "last_result"), "panel", "last_result")


def _add_loggers(w: _Wiring) -> dict[str, VectorLogSink]:
    """One VectorLogSink per :data:`LOGGED_SIGNALS` entry, sampled every control period."""
    loggers: dict[str, VectorLogSink] = {}
    for name, system, port in LOGGED_SIGNALS:
        source = w.station.diagram.GetOutputPort(port) if system == "station" else w.port(system, port)
        loggers[name] = LogVectorOutput(source, w.builder, w.config.control_period)
        loggers[name].set_name(f"log_{name}")
    return loggers


def start_ee_pose(station: Any) -> NDArray[np.float64]:
    """``[x, y, z, qw, qx, qy, qz]`` of the end effector at the start: the station's ``ee_pose``
    output in its default context (the simulated arm's home, or the measured arm's pose)."""
    diagram = station.diagram
    return np.asarray(diagram.GetOutputPort("ee_pose").Eval(diagram.CreateDefaultContext())).copy()
