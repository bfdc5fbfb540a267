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

__all__ = ["GiveUpWatch", "TrialResult", "run_trial"]


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


class GiveUpWatch:
    """The experimenter's watch (``scenario.success.give_up_after``): every half second of simulated
    time the experimenter looks at the arm's error to the current stage's intended goal (in
    tolerance units, :meth:`~drake_disamb.systems.task.TaskManager.goal_error`); a new stage, or an
    error a whole unit below the best so far, is progress, and the trial is hopeless once
    ``give_up_after`` seconds pass without any.

    Attributes:
        best: The best goal error so far in the watched stage (tolerance units).
        since: When (s) the last progress was seen.
        stage: The stage watched (-1 before the first look).
        next_look: When (s) the experimenter looks next.
    """

    LOOK_PERIOD = 0.5
    """Seconds between two looks."""

    def __init__(self, task: TaskManager, task_context, intended: list[int], give_up_after: float) -> None:
        self._task = task
        self._task_context = task_context
        self._intended = intended
        self._give_up_after = give_up_after
        self.best = np.inf
        self.since = 0.0
        self.stage = -1
        self.next_look = 0.0

    def hopeless(self, t: float) -> bool:
        """Whether, looking at time ``t`` (s), the experimenter gives up (False between looks)."""
        if t < self.next_look:
            return False
        self.next_look = t + self.LOOK_PERIOD
        stage = self._task.stage(self._task_context)
        if stage >= len(self._intended):
            return False
        error = self._task.goal_error(self._task_context, self._intended[stage])
        if stage != self.stage or error < self.best - 1.0:
            self.best, self.since, self.stage = error, t, stage
        return t - self.since >= self._give_up_after - 1e-9


class _TrialMonitor:
    """The simulator's monitor of one trial: progress, and the trial's end at a stop request, a
    station fault, the task done (with ``stop_at_success``) or the experimenter giving up.

    Attributes:
        stopped: A stop request ended the trial.
        gave_up: The experimenter gave up.
    """

    def __init__(
        self,
        handles: SharedControlDiagram,
        task_context,
        bar: SimulationProgress | None,
        stop_requested: Callable[[], bool] | None,
        stop_at_success: bool,
        watch: GiveUpWatch | None,
    ) -> None:
        self._handles = handles
        self._task: TaskManager = handles.systems["task"]  # type: ignore[assignment]
        self._task_context = task_context
        self._bar = bar
        self._stop_requested = stop_requested
        self._stop_at_success = stop_at_success
        self._watch_fault = "fault" in handles.station.outputs
        self._watch = watch
        self.stopped = False
        self.gave_up = False

    def needed(self) -> bool:
        """Whether the monitor has anything to do (else the simulator runs without one)."""
        return (
            self._bar is not None
            or self._stop_requested is not None
            or self._stop_at_success
            or self._watch_fault
            or self._watch is not None
        )

    def __call__(self, context) -> EventStatus:
        task = self._task
        if self._bar is not None:
            self._bar.update(context.get_time())
        if self._stop_requested is not None and self._stop_requested():
            self.stopped = True
            return EventStatus.ReachedTermination(task, "stop requested")
        if self._watch_fault and self._handles.station_fault(context):
            return EventStatus.ReachedTermination(task, "station fault")
        # ``context`` is the simulator's own root context: its task subcontext is ``task_context``.
        if self._stop_at_success and task.is_done(self._task_context):
            return EventStatus.ReachedTermination(task, "task done")
        if self._watch is not None and self._watch.hopeless(context.get_time()):
            self.gave_up = True
            return EventStatus.ReachedTermination(task, "given up")
        return EventStatus.DidNothing()


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
    give_up = sc.success.give_up_after
    watch = None if give_up is None else GiveUpWatch(task, task_context, list(sc.user.goals), give_up)
    monitor = _TrialMonitor(handles, task_context, bar, stop_requested, stop_at_success, watch)
    if monitor.needed():
        simulator.set_monitor(monitor)
    if record:
        meshcat.StartRecording(frames_per_second=32.0, set_visualizations_while_recording=True)
    start = _time.perf_counter()
    try:
        simulator.Initialize()
        simulator.AdvanceTo(sc.duration)
    except KeyboardInterrupt:
        monitor.stopped = True
    finally:
        handles.stop_station()  # on a wire: the zero command, several times (also on an exception)
    wall = _time.perf_counter() - start
    if bar is not None:
        bar.close()
    if record:
        meshcat.StopRecording()
        meshcat.PublishRecording()
    return _result(handles, root, task_context, monitor, watch, wall)


def _end_reason(done: bool, fault: str, monitor: _TrialMonitor) -> str:
    """Why the trial ended (:attr:`TrialResult.end_reason`)."""
    if done:
        return "done"
    if fault:
        return "station fault"
    if monitor.stopped:
        return "stopped"
    if monitor.gave_up:
        return "given up"
    return "time limit"


def _result(
    handles: SharedControlDiagram,
    root,
    task_context,
    monitor: _TrialMonitor,
    watch: GiveUpWatch | None,
    wall: float,
) -> TrialResult:
    """The :class:`TrialResult` of the trial that ran in the root context ``root`` for ``wall``
    seconds of wall-clock time."""
    sc = handles.scenario
    task: TaskManager = handles.systems["task"]  # type: ignore[assignment]
    intended = list(sc.user.goals)
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
        interrupted=monitor.stopped,
        automatic_switches=len(automatic_switches),
        automatic_switch_times=automatic_switches,
        fault=fault,
        end_reason=_end_reason(done, fault, monitor),
        progress_age=float(t_end - watch.since) if watch is not None else float("nan"),
    )
