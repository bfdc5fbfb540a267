"""Running a study: trial specs to scenarios, trials behind a ``concurrent.futures.Executor``, records.

The study folder ``DIR``:

- ``study.yaml``: the protocol (plain data), the study seed, the scenario overrides (an ablation
  setting's), the subjects (names and user overrides), the package version, written when the study
  starts. Rerunning into an existing folder resumes it; a different protocol, seed, overrides or
  subjects there is an error (:class:`StudyMismatch`), the version is informative only.
- ``trials.jsonl`` and ``traces/``: a :class:`~drake_disamb.study.data.folder.StudyFolder`, appended by
  the parent process (which holds the folder's writer lock) as each trial finishes, so the lines
  come in completion order: read them as a set keyed by ``trial_id``. Records there without a
  ``study.yaml``, or a record whose seed or condition is not its trial's in this study, are an
  error (:class:`StudyMismatch`): the folder holds something else.

A trial is a pure function of its :class:`~drake_disamb.study.design.protocol.TrialSpec` and the
:class:`StudyContext` (:func:`run_trial_job`, run in a worker: a process of a
``ProcessPoolExecutor`` or a Dask worker), so its record is the same (apart from ``wall_time``)
whatever the executor, the worker count and the order of completion. Resume: the finished
``trial_id`` s of ``trials.jsonl`` (read with ``repair=True``: a half-written last line, which a
kill can leave, is cut and its trial run again) are skipped.

A trial's scenario (:func:`trial_layers`) is layers loaded by the one scenario loader
(:func:`~drake_disamb.config.load_layers`), in this order: the embedded task; the protocol's
system preset (:mod:`drake_disamb.config.system_presets`); the protocol's settings (the
duration, the experimenter's ``give_up_after``, the joystick's mode selection
``interface_mode_selection``, the stages whose target the experimenter names, the mode-selection
method ``disambiguation.method``); the trial's start posture (the task's start posture plus the
start pose's joint offsets); the trial's draws (interface, paradigm, seed, initial mode,
intended goals, request latency); the subject's overrides of ``Scenario.user.config``; last the
study's overrides, one layer each (dotted field paths, ``study ablate --switch``; never a field
of the trial's condition, :data:`CONDITION_FIELDS`). Every value passes the scenario's checks,
and an error names its layer. Each record keeps the scenario that ran (``extra.scenario``), from
which ``study rerun`` runs the trial again.

Subjects come from :func:`drake_disamb.user.population.draw_subjects` (``study.yaml`` names the
population).
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import functools
import os
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from drake_disamb.interfaces import arm_modes
from drake_disamb.study.data.folder import StudyFolder
from drake_disamb.study.data.records import TrialRecord
from drake_disamb.study.design.protocol import (
    Protocol,
    TrialSpec,
    expand_trials,
    protocol_to_dict,
)
from drake_disamb.user.population import draw_subjects

__all__ = [
    "CONDITION_FIELDS",
    "ExecutorLost",
    "StudyContext",
    "StudyMismatch",
    "StudyPlan",
    "StudyResult",
    "TrialOutput",
    "check_overrides",
    "draw_study_subjects",
    "override_layers",
    "plan_study",
    "rerun_trial",
    "run_study",
    "run_trial_job",
    "trial_layers",
    "trial_scenario",
]

STUDY_FORMAT = 1
"""Version of the ``study.yaml`` layout."""


class StudyMismatch(ValueError):
    """The study folder holds another study (protocol, seed, overrides or subjects differ)."""


# -- subjects --------------------------------------------------------------------------------------


def draw_study_subjects(n: int, seed: int) -> tuple[list[tuple[str, dict[str, Any]]], str]:
    """``[(name, user overrides)]`` of ``n`` subjects and the population's provenance.

    The subjects are drawn by :func:`drake_disamb.user.population.draw_subjects`. The
    provenance, part of a study's identity in ``study.yaml``, keeps the name the population had
    before ``study/`` was split by stage (and before the population moved beside the simulated
    user), so that earlier study folders still resume.
    """
    subjects = draw_subjects(n, seed)
    return [(s.name, dict(s.user)) for s in subjects], POPULATION


POPULATION = "drake_disamb.study.population"
"""The population's provenance in ``study.yaml`` (:func:`draw_study_subjects`)."""


# -- scenarios -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class StudyContext:
    """What every trial of a study shares (plain data, cheap to send to a worker).

    Attributes:
        protocol: The protocol (plain data, :func:`~drake_disamb.study.design.protocol.protocol_to_dict`).
        overrides: Scenario overrides ``{dotted path: value}`` applied to every trial last.
        subject_users: Subject name -> overrides of ``Scenario.user.config`` fields.
    """

    protocol: dict[str, Any]
    overrides: dict[str, Any] = field(default_factory=dict)
    subject_users: dict[str, dict[str, Any]] = field(default_factory=dict)


CONDITION_FIELDS: dict[str, str] = {
    "task": "the trial's task, kept as its record's task (the protocol's tasks)",
    "goals": "the task's goals: the record's task names the embedded task and its goals",
    "stages": "the task's stages: the record's task names the embedded task and its stages",
    "interface": "the trial's interface, kept as its record's interface (the protocol's interfaces)",
    "paradigm": "the trial's paradigm, kept as its record's paradigm (the protocol's paradigms)",
    "seed": "drawn per trial from the study seed, kept in its record (seed, extra.scenario_seed; --seed)",
    "initial_mode": "drawn per trial, kept as its record's initial_mode (the protocol's initial_modes)",
    "start_joint_positions": "the trial's start pose, kept as its record's start_pose (the protocol's "
    "start_poses)",
    "user.goals": "drawn per trial, kept as its record's intended_goals",
}
"""The scenario fields that are a trial's condition or identity, which its record keeps: the
protocol sets them per trial, and an override (``study ablate --switch``) of one of them, or of a
section holding one (``user``), is refused: the records would not say what ran. Field path ->
why."""


def _covers(path: str, name: str) -> bool:
    """Whether an override of the dotted ``path`` sets the field ``name`` (it or a section holding it)."""
    return path == name or name.startswith(f"{path}.")


def override_layers(overrides: dict[str, Any], option: str = "overrides") -> list[Any]:
    """One layer per override ``{dotted path: value}``, named ``<option> <path>=<value>``.

    Raises:
        ValueError: a path that is a trial's condition (:data:`CONDITION_FIELDS`), or a path or
            value that does not fit the schema, naming the option, the path and the value.
    """
    from drake_disamb.config import setting_layer

    layers = []
    for path, value in overrides.items():
        for name, why in CONDITION_FIELDS.items():
            if _covers(path, name):
                inside = "" if path == name else f" (it holds {name})"
                raise ValueError(
                    f"{option} {path}: not switchable{inside}: {why}; the records would not say what ran"
                )
        layers.append(setting_layer(path, value, f"{option} {path}={value!r}"))
    return layers


def check_overrides(overrides: dict[str, Any], option: str = "overrides") -> None:
    """Check that every override is a layer (:func:`override_layers`) that every embedded task
    takes (raises ``ValueError`` naming ``option``, the path and the value)."""
    from drake_disamb.config import load_layers, task_layer

    for layer in override_layers(overrides, option):
        for task in ("reaching", "pouring"):
            load_layers([task_layer(task), layer])


@functools.lru_cache(maxsize=8)
def _system_task(task: str, system: str) -> Any:
    """The embedded ``task`` with the ``system`` preset (unchecked: a trial's layers complete it)."""
    from drake_disamb.config import merge_layers, task_layer
    from drake_disamb.config.system_presets import system_layer

    return merge_layers([task_layer(task), system_layer(system)])


def trial_layers(spec: TrialSpec, context: StudyContext) -> list[Any]:
    """The layers of a trial's scenario (module docstring), each named by its role in messages:
    the embedded task, the protocol's system preset, the protocol's settings, the trial's start
    pose (``protocol.tasks[k].start_poses[i].joint_offsets``), the trial's draws, the subject's
    user and the study's overrides."""
    from drake_disamb.config import data_layer, task_layer
    from drake_disamb.config.schema import to_plain
    from drake_disamb.config.system_presets import system_layer
    from drake_disamb.station.config import MICO_HOME_Q

    protocol = context.protocol
    system = protocol.get("system", "mico")
    base = _system_task(spec.task, system)
    k = next(i for i, t in enumerate(protocol["tasks"]) if t["task"] == spec.task)
    task = protocol["tasks"][k]
    stages = to_plain(base.stages)
    for stage in stages:
        stage["ends_at_target"] = stage["ends_at_target"] or stage["name"] in task.get("target_stages", [])
    settings: dict[str, Any] = {
        "interface_mode_selection": protocol.get("interface_mode_selection", "cycle"),
        "stages": stages,
    }
    if protocol.get("duration") is not None:
        settings["duration"] = float(protocol["duration"])
    if protocol.get("give_up_after") is not None:
        settings["success"] = {"give_up_after": float(protocol["give_up_after"])}
    if spec.paradigm != "manual":
        settings["disambiguation"] = {"method": protocol["disambiguation_method"]}
    layers = [task_layer(spec.task), system_layer(system), data_layer(settings, "protocol")]
    offsets = task["start_poses"][spec.start_pose].get("joint_offsets")
    if offsets is not None:
        start = base.start_joint_positions or [float(q) for q in MICO_HOME_Q]
        joints = [round(float(q + d), 10) for q, d in zip(start, offsets, strict=True)]
        source = f"protocol.tasks[{k}].start_poses[{spec.start_pose}].joint_offsets"
        layers.append(data_layer({"start_joint_positions": joints}, source))
    draws = {
        "interface": spec.interface,
        "paradigm": spec.paradigm,
        "seed": spec.scenario_seed,
        "initial_mode": spec.initial_mode,
        "user": {"goals": list(spec.goals)},
        "disambiguation": {"request_latency": spec.request_latency or 0.0},
    }
    layers.append(data_layer(draws, f"trial {spec.trial_id}"))
    user = context.subject_users.get(spec.subject, {})
    if user:
        layers.append(data_layer({"user": {"config": dict(user)}}, f"subject {spec.subject}"))
    return layers + override_layers(context.overrides)


def trial_scenario(spec: TrialSpec, context: StudyContext) -> Any:
    """The validated :class:`~drake_disamb.config.Scenario` of a trial: its layers loaded."""
    from drake_disamb.config import load_layers

    return load_layers(trial_layers(spec, context))


# -- one trial -------------------------------------------------------------------------------------


@dataclass
class TrialOutput:
    """What a worker sends back: the record and the trace arrays, or the error the trial raised
    (``record`` None; so that an exception of the executor itself is never taken for a trial's)."""

    record: TrialRecord | None
    trace: dict[str, np.ndarray]
    error: str | None = None


def run_trial_job(spec: TrialSpec, context: StudyContext) -> TrialOutput:
    """Run one trial (in a worker) and make its record and trace (or its error's message)."""
    try:
        return _run_trial(spec, context)
    except Exception as exc:  # the trial's own failure: reported, no record, retried by a rerun
        return TrialOutput(record=None, trace={}, error=f"{type(exc).__name__}: {exc}")


def _run_trial(spec: TrialSpec, context: StudyContext) -> TrialOutput:
    from drake_disamb.study.run.outcome import record_from_result, trace_arrays
    from drake_disamb.trial import run_trial

    scenario = trial_scenario(spec, context)
    result = run_trial(scenario, progress=False)
    trace = trace_arrays(result)
    task = _task_protocol(context, spec.task)
    latency = spec.request_latency
    if any(_covers(path, "disambiguation.request_latency") for path in context.overrides):
        latency = float(scenario.disambiguation.request_latency)  # the override's: what ran
    extra = {
        "order": spec.order,
        "start_pose_name": task["start_poses"][spec.start_pose]["name"],
        "request_latency": latency,
        "scenario_seed": spec.scenario_seed,
    }
    if context.overrides:
        extra["overrides"] = dict(context.overrides)
    record = record_from_result(
        result,
        trial_id=spec.trial_id,
        subject=spec.subject,
        repetition=spec.repetition,
        seed=spec.seed,
        start_pose=spec.start_pose,
        trace=trace,
        extra=extra,
    )
    return TrialOutput(record=record, trace=trace)


def rerun_trial(
    record: TrialRecord, source: str = "the record", progress: bool = False
) -> tuple[TrialRecord, dict[str, np.ndarray]]:
    """Run a simulated trial again from its record alone: the scenario it keeps
    (:func:`~drake_disamb.study.run.outcome.record_scenario`), the record's identity and its
    producer's ``extra`` (the order, the start pose's name...). Returns the new record and trace;
    a trial is a pure function of its scenario, so both equal the first run's but ``wall_time``.

    Raises:
        ValueError: a person's trial (the person's commands are not in the scenario), or a record
            that keeps no scenario, naming ``source``.
    """
    from drake_disamb.study.run.outcome import record_from_result, record_scenario, trace_arrays
    from drake_disamb.trial import run_trial

    if record.source != "simulated":
        raise ValueError(
            f"{source}: a {record.source} trial (source {record.source}) cannot be rerun: the person's "
            "commands are not in its scenario"
        )
    result = run_trial(record_scenario(record, source), progress=progress)
    trace = trace_arrays(result)
    fresh = record_from_result(
        result,
        trial_id=record.trial_id,
        subject=record.subject,
        repetition=record.repetition,
        seed=record.seed,
        start_pose=record.start_pose,
        source=record.source,
        trace=trace,
    )
    producer = {k: v for k, v in record.extra.items() if k not in fresh.extra}
    return dataclasses.replace(fresh, extra={**fresh.extra, **producer}), trace


# -- the study -------------------------------------------------------------------------------------


@dataclass
class StudyPlan:
    """A study ready to run: its folder, context and the trials still to run.

    Attributes:
        out: The study folder.
        protocol: The protocol.
        seed: The study seed.
        context: Shared by every trial.
        specs: Every trial of the protocol (session order).
        pending: The trials without a record yet.
        finished: The records already in ``trials.jsonl``.
        population: Where the subjects came from (:func:`draw_study_subjects`).
    """

    out: Path
    protocol: Protocol
    seed: int
    context: StudyContext
    specs: list[TrialSpec]
    pending: list[TrialSpec]
    finished: list[TrialRecord]
    population: str

    @property
    def folder(self) -> StudyFolder:
        return StudyFolder(self.out)

    @property
    def records_path(self) -> Path:
        return self.folder.records_path

    @property
    def traces_dir(self) -> Path:
        return self.folder.traces_dir


def _study_header(
    protocol: Protocol, seed: int, overrides: dict[str, Any], subjects: list, population: str
) -> dict:
    from drake_disamb import __version__

    return {
        "format": STUDY_FORMAT,
        "package": "drake-disamb",
        "version": __version__,
        "seed": seed,
        "population": population,
        "subjects": [{"name": n, "user": u} for n, u in subjects],
        "overrides": dict(overrides),
        "protocol": protocol_to_dict(protocol),
    }


_IDENTITY = ("format", "seed", "population", "subjects", "overrides", "protocol")


def _check_header(path: Path, header: dict[str, Any]) -> None:
    try:
        old = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError, UnicodeDecodeError) as exc:
        raise StudyMismatch(f"{path}: cannot read the existing study's description ({exc})") from None
    if not isinstance(old, dict):
        raise StudyMismatch(f"{path}: not a study description (expected a mapping)")
    for key in _IDENTITY:
        if old.get(key) != header[key]:
            raise StudyMismatch(
                f"{path}: this folder holds another study ({key} differs: {_short(old.get(key))} there, "
                f"{_short(header[key])} now); choose another folder, or rerun with the same protocol and seed"
            )


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 120 else text[:117] + "..."


def plan_study(
    out: str | Path,
    protocol: Protocol,
    seed: int,
    overrides: dict[str, Any] | None = None,
    *,
    check_scenarios: bool = True,
) -> StudyPlan:
    """Prepare (or resume) the study in ``out``; nothing runs yet.

    Checks, before any trial: ``out`` is a writable folder no other process writes (its writer lock
    is taken, first, and held), the overrides and every condition's scenario are valid (one scenario
    per task, interface, paradigm and start pose, and one per subject), an existing ``study.yaml``
    describes the same study, and every record there is one of this study's trials with its seed.
    Then writes ``study.yaml`` (when new), repairs ``trials.jsonl`` and lists the pending trials.

    Raises:
        ValueError: naming the field, file or folder; :class:`StudyMismatch` for another study;
            :class:`~drake_disamb.study.data.folder.FolderBusy` when another process writes ``out``.
    """
    overrides = dict(overrides or {})
    folder = StudyFolder(out).prepare()  # first: a second writer is refused at once
    out = folder.path
    if overrides:
        check_overrides(overrides)
    subjects, population = draw_study_subjects(protocol.subjects, seed)
    specs = expand_trials(protocol, seed, [n for n, _ in subjects])
    context = StudyContext(
        protocol=protocol_to_dict(protocol), overrides=overrides, subject_users={n: u for n, u in subjects}
    )
    if check_scenarios:
        _check_conditions(specs, context)
    header = _study_header(protocol, seed, overrides, subjects, population)
    study_yaml = out / "study.yaml"
    if study_yaml.exists():
        _check_header(study_yaml, header)
    elif folder.has_records():
        raise StudyMismatch(
            f"{folder.records_path}: records without {study_yaml.name}: which study they belong to is "
            "unknown, so they cannot be resumed; restore study.yaml or choose another folder"
        )
    finished = folder.read_records(repair=True)
    _check_finished(folder.records_path, finished, specs)
    if not study_yaml.exists():
        tmp = out / ".study.yaml.tmp"
        tmp.write_text(yaml.safe_dump(header, sort_keys=False), encoding="utf-8")
        tmp.replace(study_yaml)
    done = {r.trial_id for r in finished}
    pending = [s for s in specs if s.trial_id not in done]
    return StudyPlan(out, protocol, seed, context, specs, pending, finished, population)


_SPEC_FIELDS = ("subject", "interface", "task", "paradigm", "repetition", "seed", "start_pose")
"""The fields a record shares with its :class:`TrialSpec`: resume refuses a record that differs."""


def _check_finished(path: Path, finished: list[TrialRecord], specs: list[TrialSpec]) -> None:
    """Every record of ``path`` is a trial of ``specs`` with its seed and condition."""
    by_id = {s.trial_id: s for s in specs}
    for line, record in enumerate(finished, start=1):
        spec = by_id.get(record.trial_id)
        if spec is None:
            raise StudyMismatch(
                f"{path}:{line}: trial_id {record.trial_id!r} is not a trial of this study (another "
                "study's records)"
            )
        for name in _SPEC_FIELDS:
            if getattr(record, name) != getattr(spec, name):
                raise StudyMismatch(
                    f"{path}:{line}: {name}: the record has {getattr(record, name)!r}, this study's trial "
                    f"{record.trial_id} has {getattr(spec, name)!r} (another study's records)"
                )


def _task_protocol(context: StudyContext, task: str) -> dict[str, Any]:
    return next(t for t in context.protocol["tasks"] if t["task"] == task)


def _check_conditions(specs: list[TrialSpec], context: StudyContext) -> None:
    """Build one scenario per (task, interface, paradigm, start pose) and one per subject."""
    seen: set[Any] = set()
    for spec in specs:
        for pose in range(len(_task_protocol(context, spec.task)["start_poses"])):
            key = (spec.task, spec.interface, spec.paradigm, pose)
            if key not in seen:
                seen.add(key)
                trial_scenario(dataclasses.replace(spec, start_pose=pose), context)
        if spec.subject not in seen:
            seen.add(spec.subject)
            trial_scenario(spec, context)


class ExecutorLost(RuntimeError):
    """The executor failed, not a trial: a worker process died, the Dask scheduler was lost.
    Every record written before is kept; a rerun resumes."""


@dataclass
class StudyResult:
    """Outcome of :func:`run_study`.

    Attributes:
        ran: Records of the trials run now.
        skipped: Trials already finished before (resume).
        errors: ``(trial_id, message)`` of trials that raised (no record; a rerun retries them).
        wall_time: Seconds :func:`run_study` took.
        stopped: ``stop()`` became true: the pending trials were cancelled (a rerun runs them).
    """

    ran: list[TrialRecord]
    skipped: int
    errors: list[tuple[str, str]]
    wall_time: float
    stopped: bool = False


def _expected_length(spec: TrialSpec) -> tuple[int, int]:
    """What makes a trial long, for the submission order: its task's stages, its interface's arm
    modes (a head array's cycling takes more presses per change than a joystick's selection)."""
    return len(spec.goals), len(arm_modes(spec.interface))


POLL = 0.2
"""Seconds between two looks at ``stop()`` while waiting for trials."""


def _lost(exc: BaseException) -> ExecutorLost:
    if isinstance(exc, cf.BrokenExecutor):
        what = f"a worker process died ({exc})" if str(exc) else "a worker process died"
    elif isinstance(exc, cf.CancelledError):
        what = "the executor cancelled the trials (the Dask scheduler was lost?)"
    else:
        what = f"the executor failed ({type(exc).__name__}: {exc})"
    return ExecutorLost(what)


def run_study(
    plan: StudyPlan,
    executor: cf.Executor,
    on_result: Callable[[TrialRecord | None, str | None], None] | None = None,
    stop: Callable[[], bool] = lambda: False,
) -> StudyResult:
    """Run the plan's pending trials on ``executor``; the parent writes each result as it completes.

    Args:
        plan: From :func:`plan_study`.
        executor: Any ``concurrent.futures.Executor`` (a process pool, Dask's ``get_executor()``).
        on_result: Called after each trial with its record (or ``None`` and the error message).
        stop: Looked at every :data:`POLL` seconds; once true, no further result is written and
            the result says ``stopped`` (what was written is kept; never mid-write).

    After a stop or an exception the pending trials are left to the executor's owner, who ends it
    (``study run`` ends its worker processes; a pool in Python 3.11 must not have its pending
    futures cancelled before its workers are terminated, or its manager thread fails on them).

    Raises:
        ExecutorLost: The executor failed.
        FolderWriteError: A record or trace could not be written (a full disk...).
    """
    start = time.perf_counter()
    # Longest first (a trial's length is unknown, its task's stage count and its interface's arm
    # mode count are what make it long): a worker that draws a long trial last leaves the others
    # idle at the end. Only the submission order changes: every trial has its own seed.
    order = sorted(plan.pending, key=_expected_length, reverse=True)
    futures = {executor.submit(run_trial_job, spec, plan.context): spec for spec in order}
    ran: list[TrialRecord] = []
    errors: list[tuple[str, str]] = []
    waiting = set(futures)
    stopped = False
    while waiting:
        if stop():
            stopped = True
            break
        done, waiting = cf.wait(waiting, timeout=POLL, return_when=cf.FIRST_COMPLETED)
        failure: BaseException | None = None  # the executor's: raised once the batch's results are written
        for future in sorted(done, key=lambda f: futures[f].trial_id):
            spec = futures[future]
            try:
                output: TrialOutput = future.result()
            except (KeyboardInterrupt, SystemExit):
                raise
            except BaseException as exc:
                failure = failure or exc
                continue
            if output.record is None:
                errors.append((spec.trial_id, output.error or "no record"))
                if on_result is not None:
                    on_result(None, f"{spec.trial_id}: {output.error}")
                continue
            write_output(plan, output)
            ran.append(output.record)
            if on_result is not None:
                on_result(output.record, None)
        if failure is not None:
            raise _lost(failure) from None
    return StudyResult(
        ran, len(plan.specs) - len(plan.pending), errors, time.perf_counter() - start, stopped=stopped
    )


def write_output(plan: StudyPlan, output: TrialOutput) -> None:
    """Write a trial's trace, then append its record (:meth:`StudyFolder.append`)."""
    plan.folder.append(output.record, output.trace)


def records_by_id(
    records: Iterable[TrialRecord], ignore: tuple[str, ...] = ("wall_time",)
) -> dict[str, dict]:
    """Records as ``{trial_id: fields}`` without the ``ignore`` fields, for comparing studies."""
    out = {}
    for r in records:
        data = dataclasses.asdict(r)
        for name in ignore:
            data.pop(name, None)
        out[r.trial_id] = data
    return out


def default_workers() -> int:
    """The process pool's default size: the core count."""
    return os.cpu_count() or 1
