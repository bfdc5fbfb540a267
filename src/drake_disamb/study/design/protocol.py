"""The study protocol: a typed config, and its expansion into one :class:`TrialSpec` per trial.

A :class:`Protocol` says who is tested on what: subjects x interfaces x tasks x paradigms x trials
per condition, the mode-selection method, the request latency, each task's start poses and how
the order of conditions is counterbalanced. The embedded default (``study/protocol.yaml``,
:func:`default_protocol`) is the paper's (Section "Study Methods"): 8 subjects, joystick and head array,
reaching and pouring, Manual 3 + Disambiguation 5 + Automatic 5 trials per condition (416 trials),
Algorithm 1, 3 start poses per task, and a joystick that selects each mode with one press
(``interface_mode_selection: direct``, as the study's did), on the system the study's people used
as its logs show it (``system: tnsre2020_study``, the head array's mode order included) with a
request latency uniform over the logged [2.49, 3.38] s (the paper says 2 to 2.5 s).

Protocol files are read like scenarios: the text hardening of :mod:`drake_disamb.yaml_safety`,
the strict type check :func:`~drake_disamb.config.checks.check_data` (errors name the field path
and the value, e.g. ``protocol.paradigms[1].trials: expected an integer, got 'five'``), then
Drake's :func:`~pydrake.common.yaml.yaml_load_typed`, then :func:`validate_protocol` (values:
known interfaces, tasks, paradigms and methods of *this build's* scenario schema, counts,
ranges). This module has no ``from __future__ import annotations``: Drake's loader reads the
fields' real types.

:func:`expand_trials` turns (protocol, seed) into the trials, deterministically: the trials are
enumerated in a canonical order (subject, interface, task, paradigm, repetition) and each gets its
own seed from ``numpy.random.SeedSequence(seed).spawn(n)``; everything random about a trial (its
intended goals, initial mode, start pose, request latency and the scenario's seed) is drawn from
that seed alone, so a trial does not depend on the others, on the worker count or on the executor.

**Counterbalancing** (``counterbalance: rotation``): subject ``i`` (0-based) takes the interfaces
in the protocol's order rotated by ``i``, the tasks rotated by ``i // n_interfaces``, and the
paradigms in row ``i`` (mod the row count) of a Williams balanced Latin square (each paradigm
precedes every other equally often; for an odd number of paradigms the square and its mirror, so
3 paradigms cycle through 6 orders). Within a subject the blocks run interface-major, then task,
then paradigm, the repetitions of a condition together. A simulated trial does not depend on its
position, but every record keeps it (``extra.order``, 0-based within the subject), so an analysis
of order effects (or a human session's schedule) can use it. ``counterbalance: none`` keeps the
protocol's order for everyone.
"""

import dataclasses
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from pydrake.common.yaml import yaml_load_typed

from drake_disamb.config.checks import check_data, check_duration, check_request_latency, cut, fmt
from drake_disamb.config.schema import to_plain
from drake_disamb.config.system_presets import SYSTEM_PRESETS
from drake_disamb.core.disambiguation import MODE_SELECTION_METHODS
from drake_disamb.interfaces import MODE_SELECTIONS
from drake_disamb.yaml_safety import load_yaml_document, read_yaml_file

__all__ = [
    "COUNTERBALANCE",
    "INITIAL_MODES",
    "METHODS",
    "ParadigmSpec",
    "Protocol",
    "StartPoseSpec",
    "TaskProtocol",
    "TrialSpec",
    "check_study_size",
    "default_protocol",
    "expand_trials",
    "load_protocol",
    "protocol_from_dict",
    "protocol_from_yaml",
    "protocol_to_dict",
    "quick_protocol",
    "validate_protocol",
]

METHODS = MODE_SELECTION_METHODS  # the registry itself: a method registered later is accepted
"""Mode-selection methods of the contract's ``Scenario.disambiguation.method``."""

COUNTERBALANCE: tuple[str, ...] = ("rotation", "none")
"""Counterbalancing schemes (module docstring)."""

INITIAL_MODES: tuple[str, ...] = ("all", "arm")
"""What a trial's initial mode is drawn from: every mode of the interface, the gripper mode
included (the study's: its trial-order file draws joystick modes 0..4 and head-array modes 0..6),
or the arm modes only."""


def _meta(**kwargs: Any) -> dict[str, Any]:
    return {"check": kwargs}


@dataclass
class StartPoseSpec:
    """One start pose of a task.

    Attributes:
        name: Name of the pose (in records' ``extra.start_pose_name``).
        joint_offsets: Added to the task's own start posture (its ``start_joint_positions``, or the
            station's home posture when it has none), rad per joint; ``None`` = that posture.
    """

    name: str = field(default="", metadata=_meta(required=True))
    joint_offsets: list[float] | None = field(default=None, metadata=_meta(size=(6,)))


@dataclass
class TaskProtocol:
    """A task of the study and its start poses.

    Attributes:
        task: An embedded task (``reaching``, ``pouring``).
        start_poses: The poses a trial starts from (one drawn per trial, uniformly).
        target_stages: Names of the task's stages whose target the experimenter names: they end
            only at the subject's intended goal (``StageSpec.ends_at_target``), as the paper's
            reaching trials went to "the specified reaching target" (Section V). The other
            stages end at whatever goal the arm completes them at.
    """

    task: str = field(default="", metadata=_meta(required=True))
    start_poses: list[StartPoseSpec] = field(default_factory=lambda: [StartPoseSpec(name="default")])
    target_stages: list[str] = field(default_factory=list)


@dataclass
class ParadigmSpec:
    """A paradigm and its trials per (subject, interface, task) condition."""

    name: str = field(default="", metadata=_meta(required=True))
    trials: int = 1


@dataclass
class Protocol:
    """The study protocol (see the module docstring and ``study/protocol.yaml``).

    Attributes:
        subjects: Number of simulated subjects (drawn by ``drake_disamb.user.population``).
        interfaces: Interfaces every subject uses.
        tasks: Tasks and their start poses.
        paradigms: Paradigms and their trials per condition.
        disambiguation_method: Mode-selection method (``Scenario.disambiguation.method``) of the
            paradigms that disambiguate.
        request_latency: ``[min, max]`` s: each trial's request latency (from the request press to
            the mode switch, ``Scenario.disambiguation.request_latency``) is uniform in it;
            ``None`` = the same tick (no latency).
        counterbalance: ``rotation`` or ``none`` (module docstring).
        duration: Simulated-time limit (s) of every trial; ``None`` = the task's.
        give_up_after: The experimenter's rule (``Scenario.success.give_up_after``): a trial in
            which the arm has come no closer to the intended goal for this long (s) is ended as a
            failure; ``None`` = only the time limit.
        interface_mode_selection: How the joystick's mode button selects a mode in every trial
            (``Scenario.interface_mode_selection``): ``cycle`` or ``direct`` (the stick's sector
            picks the mode: one press per change, as the study's joystick did). The head array
            always cycles.
        initial_modes: ``all`` (default): each trial's initial mode is uniform over all the
            interface's modes, the gripper mode included, as the study drew them (its trial-order
            file: joystick 0..4, head array 0..6, each about equally often); ``arm``: over the arm
            modes only.
        system: The system every trial runs (:mod:`drake_disamb.config.system_presets`):
            ``tnsre2020_study`` (default: the paper's study's system, as its logs show it, the
            head array's mode order included) or ``mico`` (the scenario's defaults, our choices
            where the paper is silent), applied before an ablation's overrides.
    """

    subjects: int = 8
    interfaces: list[str] = field(default_factory=lambda: ["joystick", "head_array"])
    tasks: list[TaskProtocol] = field(default_factory=list)
    paradigms: list[ParadigmSpec] = field(default_factory=list)
    disambiguation_method: str = field(default="algorithm1", metadata=_meta(choices=METHODS))
    request_latency: list[float] | None = field(default=None, metadata=_meta(size=(2,)))
    counterbalance: str = field(default="rotation", metadata=_meta(choices=COUNTERBALANCE))
    duration: float | None = None
    give_up_after: float | None = None
    interface_mode_selection: str = field(default="cycle", metadata=_meta(choices=MODE_SELECTIONS))
    initial_modes: str = field(default="all", metadata=_meta(choices=INITIAL_MODES))
    system: str = field(default="tnsre2020_study", metadata=_meta(choices=SYSTEM_PRESETS))

    @property
    def n_trials(self) -> int:
        """Trials in the whole protocol."""
        per_subject = len(self.interfaces) * len(self.tasks) * sum(p.trials for p in self.paradigms)
        return self.subjects * per_subject

    @property
    def simulated_time_bound(self) -> float:
        """Simulated seconds if every trial ran to its duration (the protocol's, or its task's)."""
        return self.time_bound()

    def time_bound(self, duration: float | None = None) -> float:
        """Simulated seconds if every trial ran to ``duration`` (s: a scenario override's, which
        has the last word on every trial's), or with ``None`` to its duration (the protocol's, or
        its task's)."""
        per_task = self.n_trials // len(self.tasks)
        return float(
            sum(per_task * (duration or self.duration or _task_duration(t.task)) for t in self.tasks)
        )


def _task_duration(task: str) -> float:
    from drake_disamb.config import load_scenario

    return float(load_scenario(task).duration)


def _stage_names(task: str) -> list[str]:
    from drake_disamb.config import load_scenario

    return [stage.name for stage in load_scenario(task).stages]


MAX_TRIALS = 100_000
"""Most trials a protocol may have (every trial is expanded, and recorded, before the first runs),
and an ablation (``study ablate``: its settings times the protocol's trials)."""

MAX_SIMULATED_HOURS = 10_000.0
"""Most simulated time (h) a protocol or an ablation may ask for: its trials times their duration."""


def _check_choices(path: str, items: list[Any], choices: tuple[str, ...], what: str, attr: str = "") -> None:
    """``items`` (or their ``attr``) are a non-empty list of distinct ``choices``; ``what`` names one
    (with its article) in the messages, which name ``path``."""
    keys = [getattr(item, attr) for item in items] if attr else list(items)
    if not keys:
        raise ValueError(f"{path}: expected at least one {what.split(' ', 1)[1]}, got []")
    for i, key in enumerate(keys):
        if key not in choices:
            field_path = f"{path}[{i}].{attr}" if attr else f"{path}[{i}]"
            raise ValueError(f"{field_path}: expected one of {', '.join(choices)}, got {fmt(key)}")
    if len(set(keys)) != len(keys):
        raise ValueError(f"{path}: {what} is listed twice: {keys}")


def validate_protocol(protocol: Protocol, name: str = "protocol") -> Protocol:
    """Check the protocol's values; returns it. Raises ``ValueError`` naming the field and value."""
    from drake_disamb.config.schema import INTERFACES, PARADIGMS
    from drake_disamb.config.yaml_io import EMBEDDED_TASKS

    if not (isinstance(protocol.subjects, int) and 1 <= protocol.subjects <= 999):
        raise ValueError(f"{name}.subjects: expected an integer in [1, 999], got {fmt(protocol.subjects)}")
    _check_choices(f"{name}.interfaces", protocol.interfaces, INTERFACES, "an interface")
    _check_choices(f"{name}.tasks", protocol.tasks, EMBEDDED_TASKS, "a task", attr="task")
    for i, t in enumerate(protocol.tasks):
        if not t.start_poses:
            raise ValueError(f"{name}.tasks[{i}].start_poses: expected at least one start pose, got []")
        pose_names = [p.name for p in t.start_poses]
        if len(set(pose_names)) != len(pose_names):
            raise ValueError(f"{name}.tasks[{i}].start_poses: a name is used twice: {pose_names}")
        stages = _stage_names(t.task)
        for k, stage in enumerate(t.target_stages):
            if stage not in stages:
                raise ValueError(
                    f"{name}.tasks[{i}].target_stages[{k}]: expected a stage of the {t.task} task "
                    f"({', '.join(stages)}), got {fmt(stage)}"
                )
    _check_choices(f"{name}.paradigms", protocol.paradigms, PARADIGMS, "a paradigm", attr="name")
    for i, p in enumerate(protocol.paradigms):
        if not (isinstance(p.trials, int) and 1 <= p.trials <= 1000):
            raise ValueError(
                f"{name}.paradigms[{i}].trials: expected an integer in [1, 1000], got {fmt(p.trials)}"
            )
    if protocol.disambiguation_method not in METHODS:
        raise ValueError(
            f"{name}.disambiguation_method: expected one of {', '.join(METHODS)}, "
            f"got {fmt(protocol.disambiguation_method)}"
        )
    if protocol.interface_mode_selection not in MODE_SELECTIONS:
        raise ValueError(
            f"{name}.interface_mode_selection: expected one of {', '.join(MODE_SELECTIONS)}, "
            f"got {fmt(protocol.interface_mode_selection)}"
        )
    if protocol.initial_modes not in INITIAL_MODES:
        raise ValueError(
            f"{name}.initial_modes: expected one of {', '.join(INITIAL_MODES)}, "
            f"got {fmt(protocol.initial_modes)}"
        )
    lat = protocol.request_latency
    if lat is not None:
        if len(lat) != 2 or not lat[0] <= lat[1]:
            raise ValueError(f"{name}.request_latency: expected [min, max] s with min <= max, got {lat}")
        for k, value in enumerate(lat):
            check_request_latency(value, f"{name}.request_latency[{k}]")
    if protocol.duration is not None:
        check_duration(protocol.duration, f"{name}.duration")
    if protocol.give_up_after is not None:
        check_duration(protocol.give_up_after, f"{name}.give_up_after")
    check_study_size(
        protocol.n_trials,
        protocol.simulated_time_bound,
        name,
        "subjects x interfaces x tasks x paradigms' trials",
    )
    return protocol


def check_study_size(n_trials: int, simulated_time: float, name: str, made_of: str) -> None:
    """Refuse a study (a protocol, an ablation) of more than :data:`MAX_TRIALS` trials or
    :data:`MAX_SIMULATED_HOURS` simulated hours (``simulated_time`` s, every trial run to its
    duration): a ``ValueError`` naming ``name``, and ``made_of`` saying what the trials are."""
    if n_trials > MAX_TRIALS:
        raise ValueError(f"{name}: {n_trials} trials ({made_of}), expected at most {MAX_TRIALS}")
    hours = simulated_time / 3600.0
    if hours > MAX_SIMULATED_HOURS:
        raise ValueError(
            f"{name}: up to {hours:.0f} h of simulated time ({n_trials} trials x their duration), "
            f"expected at most {MAX_SIMULATED_HOURS:g} h"
        )


# -- reading and writing ---------------------------------------------------------------------------


def protocol_from_dict(data: Any, source: str = "protocol") -> Protocol:
    """A validated protocol from plain data (as parsed from YAML); errors name ``source`` and the field."""
    check_data(Protocol, data, "protocol")
    text = yaml.safe_dump(data)
    try:
        protocol = yaml_load_typed(schema=Protocol, data=text, allow_yaml_with_no_schema=False)
    except (RuntimeError, ValueError, TypeError) as exc:  # not expected once check_data has passed
        raise ValueError(f"{source}: Drake's YAML loader failed: {cut(str(exc))}") from None
    return validate_protocol(protocol)


def protocol_from_yaml(text: str | bytes, source: str = "<string>") -> Protocol:
    """Parse and validate a protocol's YAML text; errors name ``source``, the line or the field."""
    data = load_yaml_document(text, source, root="protocol")
    if not isinstance(data, dict):
        raise ValueError(f"{source}: expected a mapping of Protocol fields, got {fmt(data)}")
    try:
        return protocol_from_dict(data, source)
    except ValueError as exc:
        raise ValueError(f"{source}: {exc}") from None


def load_protocol(path: str | Path | None = None) -> Protocol:
    """The protocol in the YAML file ``path``, or the embedded default for ``None``."""
    if path is None:
        return default_protocol()
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"protocol file {fmt(str(path))}: no such file")
    return protocol_from_yaml(read_yaml_file(p), str(p))


def default_protocol_text() -> str:
    """The YAML text of the embedded default protocol (the paper's)."""
    return resources.files("drake_disamb.study.design").joinpath("protocol.yaml").read_text(encoding="utf-8")


def default_protocol() -> Protocol:
    """The paper's protocol (``study/protocol.yaml``).

    Raises:
        ValueError: this build's scenario schema lacks something the paper's protocol needs (the
            Automatic paradigm, the request latency): the message names the field.
    """
    return protocol_from_yaml(default_protocol_text(), "<embedded study/protocol.yaml>")


def _default_data() -> dict[str, Any]:
    return yaml.safe_load(default_protocol_text())


def quick_protocol(base: Protocol | None = None) -> Protocol:
    """``--quick``: 2 subjects, the protocol's interfaces, reaching only, one trial per paradigm."""
    data = protocol_to_dict(base) if base is not None else _default_data()
    data["subjects"] = 2
    data["tasks"] = [t for t in data["tasks"] if t["task"] == "reaching"] or data["tasks"][:1]
    for p in data["paradigms"]:
        p["trials"] = 1
    return protocol_from_dict(data, "the quick protocol")


def protocol_to_dict(protocol: Protocol) -> dict[str, Any]:
    """Plain data of a protocol (loads back with :func:`protocol_from_dict`)."""
    return to_plain(protocol)


# -- expansion -------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TrialSpec:
    """Everything that defines one trial (plain values; JSON-able with :func:`dataclasses.asdict`).

    Attributes:
        trial_id: ``<subject>-<interface>-<task>-<paradigm>-r<repetition>``.
        subject: Subject name (``S01``...).
        subject_index: 0-based subject index.
        interface, task, paradigm: The condition.
        repetition: 0-based repetition within the condition.
        seed: The trial's own seed (from the study's SeedSequence); every draw below comes from it.
        scenario_seed: The scenario's ``seed`` (the simulated user's randomness).
        goals: Intended goal per stage.
        initial_mode: Index into the interface's mode list (the gripper mode is the last).
        start_pose: Index into the task's ``start_poses``.
        request_latency: s, or ``None`` (no latency).
        order: 0-based position of the trial in its subject's session (counterbalanced).
    """

    trial_id: str
    subject: str
    subject_index: int
    interface: str
    task: str
    paradigm: str
    repetition: int
    seed: int
    scenario_seed: int
    goals: tuple[int, ...]
    initial_mode: int
    start_pose: int
    request_latency: float | None
    order: int


def _rotate(items: list[Any], k: int) -> list[Any]:
    k %= len(items)
    return items[k:] + items[:k]


def williams_rows(n: int) -> list[list[int]]:
    """Rows of a Williams balanced Latin square of order ``n`` (with its mirror for odd ``n``)."""
    first = [0]
    lo, hi = 1, n - 1
    for j in range(1, n):
        if j % 2 == 1:
            first.append(lo)
            lo += 1
        else:
            first.append(hi)
            hi -= 1
    rows = [[(v + r) % n for v in first] for r in range(n)]
    if n % 2 == 1:
        rows += [list(reversed(row)) for row in rows]
    return rows


def condition_order(protocol: Protocol, subject_index: int) -> list[tuple[str, str, str]]:
    """The (interface, task, paradigm) blocks of a subject in session order (module docstring)."""
    interfaces = list(protocol.interfaces)
    tasks = [t.task for t in protocol.tasks]
    paradigms = [p.name for p in protocol.paradigms]
    if protocol.counterbalance == "rotation":
        interfaces = _rotate(interfaces, subject_index)
        tasks = _rotate(tasks, subject_index // len(protocol.interfaces))
        rows = williams_rows(len(paradigms))
        paradigms = [paradigms[j] for j in rows[subject_index % len(rows)]]
    return [(i, t, p) for i in interfaces for t in tasks for p in paradigms]


def _n_initial_modes(interface: str, initial_modes: str) -> int:
    from drake_disamb.interfaces import arm_modes, interface_modes

    return len(interface_modes(interface) if initial_modes == "all" else arm_modes(interface))


def expand_trials(protocol: Protocol, seed: int, subject_names: list[str] | None = None) -> list[TrialSpec]:
    """Every trial of ``protocol`` with its draws, deterministically from ``seed``.

    Returned in session order (subject by subject, each in its counterbalanced order). Trial ``k``
    of the canonical enumeration (subject, interface, task, paradigm, repetition in the protocol's
    order) takes child ``k`` of ``SeedSequence(seed)``; its draws, in this order: one goal per
    stage (uniform), the initial mode (uniform over the interface's modes, or its arm modes:
    ``initial_modes``), the start pose (uniform), the request latency (uniform in
    ``protocol.request_latency``; drawn even when ``None``, so the other draws do not depend on
    it), the scenario seed (a 31-bit integer).
    """
    from drake_disamb.config.yaml_io import embedded_stage_goals

    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed: expected a non-negative integer, got {seed!r}")
    names = subject_names or [f"S{i + 1:02d}" for i in range(protocol.subjects)]
    if len(names) != protocol.subjects:
        raise ValueError(f"subject_names: expected {protocol.subjects} names, got {len(names)}")
    stages = {t.task: embedded_stage_goals(t.task) for t in protocol.tasks}
    poses = {t.task: len(t.start_poses) for t in protocol.tasks}
    canonical = [
        (s, i, t.task, p.name, r)
        for s in range(protocol.subjects)
        for i in protocol.interfaces
        for t in protocol.tasks
        for p in protocol.paradigms
        for r in range(p.trials)
    ]
    children = np.random.SeedSequence(seed).spawn(len(canonical))
    specs: dict[tuple[int, str, str, str, int], TrialSpec] = {}
    for (s, itf, task, par, rep), child in zip(canonical, children, strict=True):
        trial_seed = int(child.generate_state(1, np.uint32)[0])
        rng = np.random.default_rng(trial_seed)
        goals = tuple(int(rng.integers(n)) for n in stages[task])
        mode = int(rng.integers(_n_initial_modes(itf, protocol.initial_modes)))
        pose = int(rng.integers(poses[task]))
        latency = float(rng.uniform(0.0, 1.0))
        scenario_seed = int(rng.integers(2**31 - 1))
        lat = protocol.request_latency
        specs[(s, itf, task, par, rep)] = TrialSpec(
            trial_id=f"{names[s]}-{itf}-{task}-{par}-r{rep}",
            subject=names[s],
            subject_index=s,
            interface=itf,
            task=task,
            paradigm=par,
            repetition=rep,
            seed=trial_seed,
            scenario_seed=scenario_seed,
            goals=goals,
            initial_mode=mode,
            start_pose=pose,
            request_latency=None if lat is None else float(lat[0] + latency * (lat[1] - lat[0])),
            order=-1,
        )
    ordered: list[TrialSpec] = []
    reps = {p.name: p.trials for p in protocol.paradigms}
    for s in range(protocol.subjects):
        k = 0
        for itf, task, par in condition_order(protocol, s):
            for r in range(reps[par]):
                ordered.append(dataclasses.replace(specs[(s, itf, task, par, r)], order=k))
                k += 1
    return ordered
