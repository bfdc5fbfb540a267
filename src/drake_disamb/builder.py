"""One function that assembles every shared-control diagram from a :class:`~drake_disamb.config.Scenario`.

:func:`build_shared_control_diagram` wires (paper Figure "exp_block_diagram")::

    user.raw ------------------------------> interface.raw
    interface.u_h -------------------------> blender.u_h, inference.u_h
    autonomy.u_a --------------------------> blender.u_a, inference.u_a
    inference.belief ----------------------> blender, disambiguation, user, visualizer
    disambiguation.disambiguation_mode ----> interface.disambiguation_mode   (disambiguation paradigm)
    interface.mode / request_count --------> disambiguation.current_mode / request_count
    blender.u -----------------------------> station.ee_velocity_command
    interface.gripper_command -------------> station.gripper_command
    station.ee_pose -----------------------> everyone
    task.goal_poses -----------------------> everyone (the goal set switches between stages)

The interface, user, autonomy, blender, disambiguation and task manager tick every
``scenario.control_period`` (100 Hz by default, the MICO's Cartesian velocity interface); the DFT
belief is continuous state, integrated between ticks by the integrator of the scenario's
``simulator_config``; the arm is the station's discrete plant (``plant_config``). Every system's
config comes from :func:`~drake_disamb.config.resolve_scenario`. :func:`run_trial` simulates one
trial until the task is done or the time limit, and returns a :class:`TrialResult` with the metrics
of the paper (success, time, mode switches, requests, button presses) and the logs.

Belief slot ``i`` in stage ``k`` is goal ``i`` of :meth:`Scenario.stage_goals(k)
<drake_disamb.config.Scenario.stage_goals>`; the simulated user gets one intended goal per
stage and the task manager's ``stage``.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import Context, Diagram, DiagramBuilder, EventStatus, System
from pydrake.systems.primitives import LogVectorOutput, VectorLogSink, ZeroOrderHold

from drake_disamb.config import Scenario, TrialConfig, check_start_clearance, resolve_scenario
from drake_disamb.progress import SimulationProgress
from drake_disamb.systems.autonomy import PotentialFieldAutonomy
from drake_disamb.systems.blending import SharedControlBlender
from drake_disamb.systems.disambiguation import DisambiguationSystem
from drake_disamb.systems.interfaces import make_interface
from drake_disamb.systems.task import TaskManager
from drake_disamb.systems.user import SimulatedUser

LOGGED_SIGNALS: tuple[tuple[str, str, str], ...] = (
    ("belief", "inference", "belief"),
    ("alpha", "blender", "alpha"),
    ("u_h", "interface", "u_h"),
    ("u", "blender", "u"),
    ("ee_pose", "station", "ee_pose"),
    ("mode", "interface", "mode"),
    ("stage", "task", "stage"),
)
"""``(log name, subsystem, output port)`` of every VectorLogSink the builder adds."""


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
            ``autonomy``, ``inference``, ``blender``, ``disambiguation`` (disambiguation paradigm
            only), ``task``, ``ee_pose_sampler``, ``diff_ik`` (the station's), ``visualizer``
            (with Meshcat only).
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

    def goal_names(self, stage: int) -> list[str]:
        """Goal names in belief-slot order for ``stage``."""
        return [g.name for g in self.scenario.stage_goals(stage)]


@dataclass
class TrialResult:
    """Outcome and logs of one trial.

    Attributes:
        scenario: The scenario run.
        success: Every stage completed at the user's intended goal within the time limit.
        done: Every stage completed (at some goal).
        time: Simulated time (s) at the end (completion time when ``done``).
        stage_times: Completion time (s) of each stage (NaN if not completed).
        reached_goals: Per stage, the scenario goal index (within the stage) reached, or -1.
        intended_goals: Per stage, the user's intended goal index (within the stage).
        intended_goal_names, reached_goal_names: The same as names.
        mode_switches: Manual mode switches (mode-button presses).
        requests: Disambiguation requests.
        button_presses: ``mode_switches + requests`` (the paper's metric).
        request_times, mode_switch_times: Event times (s).
        disambiguation_switch_times: Times (s) a request changed the mode.
        events: The interface's event log.
        mean_alpha: Mean alpha over the samples where the user commanded the arm.
        wall_time: Wall-clock seconds of the simulation.
        realtime_rate: ``time / wall_time``.
        logs: ``{name: (times (T,), values (T, size))}`` for every logged signal.
        rho1: The assistance threshold used.
        interrupted: The trial was stopped early by a stop request or ``KeyboardInterrupt``
            (:func:`run_trial`); the metrics and logs cover the trial up to ``time``.
    """

    scenario: Scenario
    success: bool
    done: bool
    time: float
    stage_times: list[float]
    reached_goals: list[int]
    intended_goals: list[int]
    intended_goal_names: list[str]
    reached_goal_names: list[str]
    mode_switches: int
    requests: int
    button_presses: int
    request_times: list[float]
    mode_switch_times: list[float]
    disambiguation_switch_times: list[float]
    events: tuple
    mean_alpha: float
    wall_time: float
    realtime_rate: float
    rho1: float
    logs: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]] = field(repr=False)
    interrupted: bool = False


def _make_inference(config: TrialConfig, control_period: float) -> System:
    from drake_disamb.systems import inference as inf

    n = config.n_goals
    if config.inference_method == "dft":
        return inf.FieldTheoreticIntentInference(n, config.dft, control_period)
    if config.inference_method == "bayes":  # sigma and transition: the forward projection's too
        return inf.RecursiveBayesIntentInference(n, control_period=control_period)
    return inf.MemoryBasedIntentInference(n, control_period=control_period)


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

    Raises:
        ValueError: an invalid scenario, or a goal on top of the gripper's start position.
    """
    from drake_disamb.station import build_station

    config = resolve_scenario(scenario)
    n = config.n_goals
    builder = DiagramBuilder()

    station = build_station(config.station, meshcat=meshcat)
    builder.AddSystem(station.diagram)
    plant = station.plant
    check_start_clearance(scenario, start_ee_pose(station)[:3])

    interface = builder.AddSystem(make_interface(config.interface))
    modes = [list(m) for m in interface.modes]

    task = builder.AddSystem(
        TaskManager(
            [scenario.stage_goal_poses(k) for k in range(scenario.n_stages)],
            position_tolerance=scenario.success.position_tolerance,
            orientation_tolerance=scenario.success.orientation_tolerance,
            hold_times=[scenario.hold_time(k) for k in range(scenario.n_stages)],
            period=scenario.control_period,
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
        user = builder.AddSystem(SimulatedUser(config.interface, list(scenario.user.goals), n, config.user))
        user.set_name("user")
        builder.Connect(interface.GetOutputPort("mode"), user.GetInputPort("mode"))
    else:
        user = builder.AddSystem(input_source)
        if not user.get_name():
            user.set_name("input_source")
    builder.Connect(user.GetOutputPort("raw"), interface.GetInputPort("raw"))

    # The control loop (every scenario.control_period, 10 ms by default) sees the end-effector pose
    # sampled at its ticks (as the MICO's Cartesian interface reports it); this also keeps plant
    # steps finer than the control period (scenario.plant_config.time_step, by default equal to it) and the
    # belief integrator's stages from re-evaluating the autonomy and the belief's inputs between ticks.
    sampler = builder.AddSystem(ZeroOrderHold(scenario.control_period, 7))
    sampler.set_name("ee_pose_sampler")
    builder.Connect(station.diagram.GetOutputPort("ee_pose"), sampler.get_input_port())
    ee_pose = sampler.get_output_port()
    goal_poses = task.GetOutputPort("goal_poses")
    builder.Connect(ee_pose, task.GetInputPort("ee_pose"))
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
    builder.Connect(blender.GetOutputPort("u"), station.diagram.GetInputPort("ee_velocity_command"))
    builder.Connect(
        interface.GetOutputPort("gripper_command"), station.diagram.GetInputPort("gripper_command")
    )

    systems: dict[str, System] = {
        "user": user,
        "interface": interface,
        "autonomy": autonomy,
        "inference": inference,
        "blender": blender,
        "task": task,
        "diff_ik": station.diff_ik,
        "ee_pose_sampler": sampler,
    }
    if config.disambiguation is not None:  # the preset's probing, the live inference's update
        disamb = builder.AddSystem(
            DisambiguationSystem(
                n, interface.arm_modes, config.disambiguation, control_period=scenario.control_period
            )
        )
        disamb.set_name("disambiguation")
        builder.Connect(inference.GetOutputPort("belief"), disamb.GetInputPort("belief"))
        builder.Connect(ee_pose, disamb.GetInputPort("ee_pose"))
        builder.Connect(goal_poses, disamb.GetInputPort("goal_poses"))
        builder.Connect(interface.GetOutputPort("mode"), disamb.GetInputPort("current_mode"))
        builder.Connect(interface.GetOutputPort("request_count"), disamb.GetInputPort("request_count"))
        builder.Connect(
            disamb.GetOutputPort("disambiguation_mode"), interface.GetInputPort("disambiguation_mode")
        )
        systems["disambiguation"] = disamb

    if meshcat is not None:
        from drake_disamb.clearance import table_top_z
        from drake_disamb.systems import visualization

        vis = builder.AddSystem(visualization.visualizer_for_scenario(meshcat, scenario, modes))
        vis.set_name("visualizer")
        if vis.HasInputPort("stage"):
            builder.Connect(task.GetOutputPort("stage"), vis.GetInputPort("stage"))
        bounds = visualization.illustration_bounds(plant, station.scene_graph)
        visualization.frame_workspace(meshcat, *bounds, work_height=table_top_z())
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
    """``[x, y, z, qw, qx, qy, qz]`` of the end effector in the station's default (start) state."""
    from drake_disamb.station import EE_FRAME

    plant = station.plant
    X = plant.GetFrameByName(EE_FRAME).CalcPoseInWorld(plant.CreateDefaultContext())
    return np.concatenate((X.translation(), X.rotation().ToQuaternion().wxyz()))


# ----------------------------------------------------------------------------------------------
# Running a trial
# ----------------------------------------------------------------------------------------------


def _log(
    handles: SharedControlDiagram, context, name: str
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    logger = handles.loggers[name]
    log = logger.FindLog(context)
    return np.asarray(log.sample_times()).copy(), np.asarray(log.data()).T.copy()


def run_trial(
    scenario: Scenario | SharedControlDiagram,
    meshcat: Meshcat | None = None,
    progress: bool | SimulationProgress = True,
    realtime_rate: float | None = None,
    stop_at_success: bool = True,
    recording: bool | None = None,
    stop_requested: Callable[[], bool] | None = None,
) -> TrialResult:
    """Simulate one trial until the task is done (or ``scenario.duration``).

    Args:
        scenario: A scenario (a diagram is built for it) or a built :class:`SharedControlDiagram`.
        meshcat: Meshcat for a scenario argument (ignored for a built diagram, which has its own).
        progress: Show the simulated time while running: ``True`` makes a
            :class:`~drake_disamb.progress.SimulationProgress` on stderr (an in-place line on a
            terminal, a line per second of wall time elsewhere); pass one to choose its stream
            (it is closed at the end); ``False`` shows nothing.
        realtime_rate: Target real-time rate (0 = as fast as possible); ``None`` keeps the
            scenario's ``simulator_config.target_realtime_rate``.
        stop_at_success: Stop once every stage is done (else run to ``scenario.duration``).
        recording: Record the Meshcat animation (default: whenever there is Meshcat). The
            recording is published at the end (:func:`save_recording` writes it to HTML).
        stop_requested: Checked after every simulator step; once it returns True the trial stops
            there (a signal handler's flag). A ``KeyboardInterrupt`` raised during the simulation
            stops it the same way. Either way the result has ``interrupted=True`` and holds the
            metrics, logs and Meshcat recording up to the stop.
    """
    handles = (
        scenario
        if isinstance(scenario, SharedControlDiagram)
        else build_shared_control_diagram(scenario, meshcat)
    )
    sc = handles.scenario
    meshcat = handles.meshcat
    record = (meshcat is not None) if recording is None else (recording and meshcat is not None)
    simulator = Simulator(handles.diagram)
    ApplySimulatorConfig(handles.config.simulator, simulator)  # the integrator of the continuous belief
    if realtime_rate is not None:
        simulator.set_target_realtime_rate(realtime_rate)
    root = simulator.get_mutable_context()
    handles.initialize(root)
    task: TaskManager = handles.systems["task"]  # type: ignore[assignment]
    task_context = task.GetMyContextFromRoot(root)

    bar = SimulationProgress(sc.duration) if progress is True else (progress or None)
    stopped = [False]

    def monitor(context) -> EventStatus:
        if bar is not None:
            bar.update(context.get_time())
        if stop_requested is not None and stop_requested():
            stopped[0] = True
            return EventStatus.ReachedTermination(task, "stop requested")
        if stop_at_success and task.is_done(task.GetMyContextFromRoot(context)):
            return EventStatus.ReachedTermination(task, "task done")
        return EventStatus.DidNothing()

    simulator.set_monitor(monitor)
    if record:
        meshcat.StartRecording(frames_per_second=32.0, set_visualizations_while_recording=True)
    start = _time.perf_counter()
    try:
        simulator.Initialize()
        simulator.AdvanceTo(sc.duration)
    except KeyboardInterrupt:
        stopped[0] = True
    wall = _time.perf_counter() - start
    if bar is not None:
        bar.close()
    if record:
        meshcat.StopRecording()
        meshcat.PublishRecording()

    t_end = root.get_time()
    interface = handles.systems["interface"]
    events = tuple(interface.get_event_log(interface.GetMyContextFromRoot(root)))
    switches = [e.time for e in events if e.kind == "mode_switch"]
    requests = [e.time for e in events if e.kind == "disambiguation_request"]
    disamb_switches = [e.time for e in events if e.kind == "disambiguation_switch"]
    reached = task.reached_goals(task_context)
    done = task.is_done(task_context)
    intended = list(sc.user.goals)
    success = done and reached == intended
    logs = {name: _log(handles, root, name) for name, _, _ in LOGGED_SIGNALS}
    _, uh = logs["u_h"]
    _, alpha = logs["alpha"]
    commanding = np.any(np.abs(uh) > 1e-9, axis=1)
    mean_alpha = float(np.mean(alpha[commanding, 0])) if np.any(commanding) else 0.0
    rho1 = handles.config.rhos[0]
    return TrialResult(
        scenario=sc,
        success=bool(success),
        done=bool(done),
        time=float(t_end),
        stage_times=task.stage_end_times(task_context),
        reached_goals=reached,
        intended_goals=intended,
        intended_goal_names=[sc.stage_goals(k)[i].name for k, i in enumerate(intended)],
        reached_goal_names=[sc.stage_goals(k)[i].name for k, i in enumerate(reached) if i >= 0],
        mode_switches=len(switches),
        requests=len(requests),
        button_presses=len(switches) + len(requests),
        request_times=requests,
        mode_switch_times=switches,
        disambiguation_switch_times=disamb_switches,
        events=events,
        mean_alpha=mean_alpha,
        wall_time=wall,
        realtime_rate=float(t_end / wall) if wall > 0 else float("inf"),
        rho1=rho1,
        logs=logs,
        interrupted=stopped[0],
    )


def save_recording(meshcat: Meshcat, path: str | Path, legend: Any = None, title: str = "") -> Path:
    """Write Meshcat's current scene and published recording as a self-contained HTML file.

    ``legend`` (rows of :func:`drake_disamb.display.legend_rows`) is laid over the page, headed by
    ``title``: Meshcat's HTML leaves out the control panel where a live page shows it."""
    from drake_disamb.display import add_legend_to_html

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    page = meshcat.StaticHtml()
    if legend:
        page = add_legend_to_html(page, legend, title)
    out.write_text(page, encoding="utf-8")
    return out


def write_trial_figures(
    result: TrialResult, handles: SharedControlDiagram, out_dir: str | Path
) -> list[Path]:
    """Write the goal-probability figure, the Meshcat recording (if any) and the diagram picture."""
    from drake_disamb.diagram_io import write_diagram_graph
    from drake_disamb.display import legend_rows
    from drake_disamb.plotting import write_trial_figure

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    sc = result.scenario
    written = [write_trial_figure(result, out / "goal_probabilities.png")]
    if handles.meshcat is not None:
        title = f"{sc.task}, {sc.interface.replace('_', ' ')}, {sc.paradigm} paradigm"
        written.append(save_recording(handles.meshcat, out / "recording.html", legend_rows(sc), title))
    written.extend(Path(p) for p in _as_list(write_diagram_graph(handles.diagram, out / "diagram")))
    return written


def _as_list(value: Any) -> list[Any]:
    if value is None:
        return []
    if isinstance(value, list | tuple):
        return list(value)
    return [value]
