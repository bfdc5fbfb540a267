"""Running one trial of a shared-control diagram: the simulator set up from the scenario's
``SimulatorConfig``, a monitor that ends the trial (task done, a stop request, Ctrl-C), and the
paper's metrics (success, time, mode switches, requests, button presses, mean alpha) with the logs,
in a :class:`TrialResult`. The diagram itself is wired by
:func:`drake_disamb.builder.build_shared_control_diagram`; figures and recordings are written by
:mod:`drake_disamb.plotting`.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from pydrake.geometry import Meshcat
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import EventStatus

from drake_disamb.builder import SharedControlDiagram, build_shared_control_diagram
from drake_disamb.config import Scenario
from drake_disamb.progress import SimulationProgress
from drake_disamb.systems.task import TaskManager

__all__ = ["TrialResult", "run_trial"]


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
        mode_switches: Manual mode switches (mode-button presses; the user's own only).
        requests: Disambiguation requests (request-button presses).
        button_presses: ``mode_switches + requests`` (the paper's metric).
        request_times, mode_switch_times: Event times (s).
        disambiguation_switch_times: Times (s) a request changed the mode (the switch, which comes
            ``disambiguation.request_latency`` after the press).
        automatic_switches: Mode changes the Automatic paradigm's trigger caused (no press; not in
            ``button_presses``); 0 in the other paradigms.
        automatic_switch_times: Their times (s).
        events: The interface's event log.
        mean_alpha: Mean alpha over the samples where the user commanded the arm.
        wall_time: Wall-clock seconds of the simulation.
        realtime_rate: ``time / wall_time``.
        logs: ``{name: (times (T,), values (T, size))}`` for every logged signal.
        rho1: The assistance threshold used.
        interrupted: The trial was stopped early by a stop request or ``KeyboardInterrupt``
            (:func:`run_trial`); the metrics and logs cover the trial up to ``time``.
        fault: Why a station on a wire stopped the trial (its latched fault), or ``""``.
        end_reason: Why the trial ended: ``"done"`` (every stage), ``"time limit"``
            (``scenario.duration``), ``"given up"`` (the experimenter's rule,
            ``scenario.success.give_up_after``), ``"stopped"`` (a stop request) or
            ``"station fault"``.
        progress_age: With the experimenter's watch (``scenario.success.give_up_after``), the
            seconds from the last time the arm came closer to the intended goal (by one position or
            orientation tolerance, the watch's step) to the trial's end: under ``give_up_after``
            for a trial that ran to its time limit still approaching its goal, not stuck. NaN
            without the watch.
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
    automatic_switches: int = 0
    automatic_switch_times: list[float] = field(default_factory=list)
    fault: str = ""
    end_reason: str = ""
    progress_age: float = float("nan")


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
    watch_fault = "fault" in handles.station.outputs
    give_up = sc.success.give_up_after
    intended = list(sc.user.goals)
    # The experimenter's watch: [best goal error so far (tolerance units), since when, stage, next look].
    watch = [np.inf, 0.0, -1, 0.0]
    gave_up = [False]

    def hopeless(t: float) -> bool:
        if t < watch[3]:
            return False
        watch[3] = t + 0.5  # the experimenter looks every half second
        stage = task.stage(task_context)
        if stage >= len(intended):
            return False
        error = task.goal_error(task_context, intended[stage])
        if stage != watch[2] or error < watch[0] - 1.0:
            watch[0], watch[1], watch[2] = error, t, stage
        return t - watch[1] >= give_up - 1e-9

    def monitor(context) -> EventStatus:
        if bar is not None:
            bar.update(context.get_time())
        if stop_requested is not None and stop_requested():
            stopped[0] = True
            return EventStatus.ReachedTermination(task, "stop requested")
        if watch_fault and handles.station_fault(context):
            return EventStatus.ReachedTermination(task, "station fault")
        # ``context`` is the simulator's own root context: its task subcontext is ``task_context``.
        if stop_at_success and task.is_done(task_context):
            return EventStatus.ReachedTermination(task, "task done")
        if give_up is not None and hopeless(context.get_time()):
            gave_up[0] = True
            return EventStatus.ReachedTermination(task, "given up")
        return EventStatus.DidNothing()

    if bar is not None or stop_requested is not None or stop_at_success or watch_fault or give_up is not None:
        simulator.set_monitor(monitor)
    if record:
        meshcat.StartRecording(frames_per_second=32.0, set_visualizations_while_recording=True)
    start = _time.perf_counter()
    try:
        simulator.Initialize()
        simulator.AdvanceTo(sc.duration)
    except KeyboardInterrupt:
        stopped[0] = True
    finally:
        handles.stop_station()  # on a wire: the zero command, several times (also on an exception)
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
    automatic_switches = [e.time for e in events if e.kind == "automatic_switch"]
    reached = task.reached_goals(task_context)
    done = task.is_done(task_context)
    fault = handles.station_fault(root)
    if done:
        end_reason = "done"
    elif fault:
        end_reason = "station fault"
    elif stopped[0]:
        end_reason = "stopped"
    elif gave_up[0]:
        end_reason = "given up"
    else:
        end_reason = "time limit"
    success = done and reached == intended
    logs = {name: _log(handles, root, name) for name in handles.loggers}
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
        automatic_switches=len(automatic_switches),
        automatic_switch_times=automatic_switches,
        fault=fault,
        end_reason=end_reason,
        progress_age=float(t_end - watch[1]) if give_up is not None else float("nan"),
    )
