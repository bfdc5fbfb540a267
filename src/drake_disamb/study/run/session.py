"""A session with a person: the subject's counterbalanced schedule of the protocol, resumed where a
killed session stopped, and the records it appends (``drake-disamb study session``).

A sessions folder ``DIR`` is a study folder (:class:`~drake_disamb.study.data.folder.StudyFolder`:
``trials.jsonl``, ``traces/``, the writer's lock) of one protocol's sessions with people, one
subject after another:

- ``sessions.yaml``: the protocol (plain data), the seed of the trials' draws, and the subjects in
  the order of their first session (``subjects``): the ``i``-th subject (0-based) takes the
  protocol's counterbalanced order of subject ``i``
  (:func:`~drake_disamb.study.design.protocol.condition_order`; past the protocol's ``subjects``
  the rows repeat) and the draws of that subject's trials (intended goals, initial modes, start
  poses, request latencies: :func:`~drake_disamb.study.design.protocol.expand_trials`);
- ``trials.jsonl`` and ``traces/``: one record (``source: human``) and trace per finished trial,
  with its ``trial_id`` the schedule's (``<subject>-<interface>-<task>-<paradigm>-r<repetition>``);
- ``surveys.jsonl``: each subject's answers to the paper's questionnaire
  (:mod:`drake_disamb.study.data.surveys`).

**Resume.** The trials run in the schedule's order and a trial is recorded when it ends, so the
first trial of the schedule without a record is the one a killed session was in: a session of
the same subject starts there (that trial again from its start), and once every trial has its
record, at the questionnaire.

**What is refused** (:func:`plan_session`, before anything is written; ``ValueError`` naming the
option and the value): a subject id that is not letters, digits, ``_`` or ``-`` (no path
characters); a folder of a simulated study, a folder whose ``sessions.yaml`` holds another protocol
or seed, a folder of records without ``sessions.yaml`` (another command's); records of the subject
that are not trials of the subject's schedule; a subject whose session is complete; and a second
session while one runs in the folder (its lock,
:class:`~drake_disamb.study.data.folder.FolderBusy`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from drake_disamb.study.data.folder import SIMULATED_STUDY_FILES, StudyFolder, write_atomic
from drake_disamb.study.data.records import RecordError, TrialRecord, check_names, read_records
from drake_disamb.study.data.surveys import SURVEYS_FILE, read_surveys
from drake_disamb.study.design.protocol import Protocol, TrialSpec, expand_trials, protocol_to_dict
from drake_disamb.study.design.survey import Questionnaire, questionnaire
from drake_disamb.study.run.runner import StudyContext

__all__ = [
    "SESSIONS_FILE",
    "SessionPlan",
    "check_subject",
    "plan_session",
    "session_record",
    "subject_schedule",
]

SESSIONS_FILE = "sessions.yaml"
"""The file that makes a folder a sessions folder (module docstring)."""

FORMAT = 1
"""Version of ``sessions.yaml``."""


def check_subject(subject: str) -> str:
    """``subject`` if it is a subject's id a record takes (ASCII letters, digits, ``_``, ``-``; at
    most 64), else a ``ValueError`` naming ``--subject`` and the value."""
    try:
        check_names(
            trial_id="x",
            subject=subject,
            interface="joystick",
            task="reaching",
            paradigm="manual",
            disambiguation_method=None,
            source="human",
        )
    except RecordError:
        raise ValueError(
            f"--subject: expected letters, digits, '_' or '-' (ASCII, at most 64), got {subject!r}"
        ) from None
    return subject


def _header(protocol: Protocol, seed: int, subjects: list[str]) -> dict[str, Any]:
    return {"format": FORMAT, "seed": seed, "subjects": subjects, "protocol": protocol_to_dict(protocol)}


def _read_header(path: Path) -> dict[str, Any]:
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError, UnicodeDecodeError) as exc:
        raise ValueError(f"--out: {path}: cannot read the sessions' description ({exc})") from None
    if not isinstance(data, dict) or not isinstance(data.get("subjects"), list):
        raise ValueError(f"--out: {path}: not a sessions' description (expected a mapping with subjects)")
    return data


def subject_schedule(protocol: Protocol, seed: int, subjects: list[str], index: int) -> list[TrialSpec]:
    """The trials of subject ``index`` (0-based, named ``subjects[index]``) in session order: the
    protocol's counterbalanced order and draws of subject ``index`` (module docstring)."""
    n = max(protocol.subjects, index + 1)
    names = [subjects[i] if i < len(subjects) else f"slot{i}" for i in range(n)]
    specs = expand_trials(dataclasses.replace(protocol, subjects=n), seed, names)
    return [s for s in specs if s.subject_index == index]


@dataclass
class SessionPlan:
    """A subject's session, ready to run (:func:`plan_session`).

    Attributes:
        folder: The sessions folder (its lock held).
        protocol: The protocol.
        subject: The subject's id.
        index: The subject's place among the folder's subjects (its counterbalancing row).
        specs: The subject's trials, in session order.
        done: The subject's records already in the folder.
        survey_done: Whether the subject's questionnaire is in the folder.
        context: What the trials' scenarios are made from (the protocol, no overrides).
    """

    folder: StudyFolder
    protocol: Protocol
    subject: str
    index: int
    specs: list[TrialSpec]
    done: list[TrialRecord]
    survey_done: bool
    context: StudyContext

    @property
    def pending(self) -> list[TrialSpec]:
        """The trials without a record, in session order (the first is where the session starts)."""
        ids = {r.trial_id for r in self.done}
        return [s for s in self.specs if s.trial_id not in ids]

    def questionnaire(self) -> Questionnaire:
        """The subject's questionnaire: its (interface, task) phases, the protocol's choices."""
        return questionnaire(
            [(s.interface, s.task) for s in self.specs],
            self.protocol.interfaces,
            [p.name for p in self.protocol.paradigms],
        )


def _existing(out: Path, protocol: Protocol, seed: int, subject: str) -> list[str]:
    """The subjects of an existing folder ``out`` (``[]`` for a new one), after the checks of the
    module docstring that need no lock (nothing is written)."""
    if not out.exists():
        return []
    if not out.is_dir():
        raise ValueError(f"--out: {out} is a file, expected a folder")
    for name in SIMULATED_STUDY_FILES:
        if (out / name).exists():
            raise ValueError(
                f"--out: {out} holds a simulated study ({out / name}); sessions with people go into a folder "
                "of their own"
            )
    header_path = out / SESSIONS_FILE
    if not header_path.exists():
        if StudyFolder(out).has_records() or (out / SURVEYS_FILE).exists():
            raise ValueError(
                f"--out: {out} holds records but no {SESSIONS_FILE}: not a folder of sessions (another "
                "command's records); choose another folder"
            )
        return []
    header = _read_header(header_path)
    want = _header(protocol, seed, [])
    for key in ("format", "seed", "protocol"):
        if header.get(key) != want[key]:
            raise ValueError(
                f"--out: {out} holds the sessions of another protocol ({key} differs from "
                f"{SESSIONS_FILE}'s); run them with that protocol, or choose another folder"
            )
    subjects = [str(s) for s in header["subjects"]]
    return subjects


def _check_records(path: Path, records: list[TrialRecord], specs: list[TrialSpec]) -> list[TrialRecord]:
    """The subject's records, each a trial of its schedule with its condition (``ValueError``)."""
    by_id = {s.trial_id: s for s in specs}
    for record in records:
        spec = by_id.get(record.trial_id)
        same = spec is not None and all(
            getattr(record, k) == getattr(spec, k) for k in ("interface", "task", "paradigm", "repetition")
        )
        if not same or record.source != "human":
            raise ValueError(
                f"--out: {path}: record {record.trial_id!r} of {record.subject} is not a trial of the "
                "subject's schedule in this protocol (another session's records)"
            )
    return records


def plan_session(out: str | Path, protocol: Protocol, subject: str, seed: int = 0) -> SessionPlan:
    """Check everything (module docstring: ``ValueError`` naming the option and the value, nothing
    written), then take the folder's lock and register the subject in ``sessions.yaml``.

    Raises:
        ValueError: Refused input; :class:`~drake_disamb.study.data.folder.FolderBusy` (a
            ``ValueError``) when a session runs in the folder.
    """
    check_subject(subject)
    out = Path(out)
    subjects = _existing(out, protocol, seed, subject)
    index = subjects.index(subject) if subject in subjects else len(subjects)
    specs = subject_schedule(
        protocol, seed, [*subjects, subject] if index == len(subjects) else subjects, index
    )
    records_path = out / "trials.jsonl"
    found = read_records(records_path, skip_incomplete=True) if records_path.exists() else []
    mine = [r for r in found if r.subject == subject]
    done = _check_records(records_path, mine, specs)
    surveyed = any(s.subject == subject for s in read_surveys(out)) if out.exists() else False
    if surveyed and len(done) == len(specs):
        raise ValueError(
            f"--subject {subject}: the subject's session in {out} is complete ({len(specs)} trials and the "
            "questionnaire); a second session is refused"
        )
    try:
        folder = StudyFolder(out).prepare()
    except ValueError as exc:
        raise ValueError(f"--out: {exc}") from None
    if index == len(subjects):
        header = _header(protocol, seed, [*subjects, subject])
        text = yaml.safe_dump(header, sort_keys=False).encode("utf-8")
        write_atomic(out / SESSIONS_FILE, lambda f: f.write(text))
    folder.read_records(repair=True)  # a half-written last line (a kill mid-write) is cut
    context = StudyContext(protocol=protocol_to_dict(protocol))
    return SessionPlan(folder, protocol, subject, index, specs, done, surveyed, context)


def session_record(
    result: Any, spec: TrialSpec, context: StudyContext, ended_by: str
) -> tuple[TrialRecord, Any]:
    """The record (``source: human``) and trace of a session's trial ``spec`` that ran as
    ``result`` (a :class:`~drake_disamb.trial.TrialResult`); ``ended_by`` says who or what ended
    it (``task``, ``time limit``, ``experimenter``, ...). An experimenter's end is the
    experimenter's rule's (``end_reason`` "given up", a failure)."""
    from drake_disamb.study.run.outcome import record_from_result, trace_arrays

    if ended_by == "experimenter":
        result = dataclasses.replace(result, interrupted=False, end_reason="given up")
    task = next(t for t in context.protocol["tasks"] if t["task"] == spec.task)
    trace = trace_arrays(result)
    record = record_from_result(
        result,
        trial_id=spec.trial_id,
        subject=spec.subject,
        repetition=spec.repetition,
        seed=None,
        start_pose=spec.start_pose,
        source="human",
        trace=trace,
        wall_time=0.0,
        extra={
            "order": spec.order,
            "start_pose_name": task["start_poses"][spec.start_pose]["name"],
            "request_latency": spec.request_latency,
            "scenario_seed": spec.scenario_seed,
            "trial_seed": spec.seed,
            "live": True,
            "session": True,
            "ended_by": ended_by,
        },
    )
    return record, trace


_PARADIGM_TEXT = {
    "manual": "You change the mode yourself. The robot helps you once it is sure of your goal.",
    "disambiguation": (
        "When you like, press {request} to ask the robot to choose the mode that helps it tell your goal "
        "from the others; choosing takes a few seconds, and the panel says why it chose the mode."
    ),
    "automatic": (
        "The robot changes the mode by itself when it is unsure of your goal; the panel says why. "
        "You can change the mode yourself too."
    ),
}


def _goal_words(scenario: Any) -> str:
    names = [
        scenario.stage_goals(k)[int(g)].name.replace("_", " ") for k, g in enumerate(scenario.user.goals)
    ]
    if len(names) == 1:
        return f"Your goal: the {names[0]}. Bring the gripper to it and hold it there."
    steps = [f"{stage.name} at the {name}" for stage, name in zip(scenario.stages, names, strict=True)]
    return "Your goals, in order: " + "; then ".join(steps) + "."


def trial_screen(plan: SessionPlan, spec: TrialSpec, scenario: Any) -> dict[str, Any]:
    """The screen before trial ``spec`` (of ``scenario``): the trial's place in the session, a rest
    before a new block, the goal, what the condition means, and the start (a page screen)."""
    from drake_disamb.interfaces import INTERFACES

    position = plan.specs.index(spec)
    before = plan.specs[position - 1] if position > 0 else None
    block = (spec.interface, spec.task, spec.paradigm)
    new_block = before is None or (before.interface, before.task, before.paradigm) != block
    variant = INTERFACES[spec.interface]
    request = next(
        (c.label.split("[")[-1].rstrip("]") for c in variant.live_controls if c.role == "request"), ""
    )
    lines = []
    if new_block and before is not None:
        lines.append("Rest as long as you like: a new block starts.")
    block_trials = sum(1 for s in plan.specs if (s.interface, s.task, s.paradigm) == block)
    if block_trials > 1:
        lines.append(f"Trial {spec.repetition + 1} of {block_trials} of this block.")
    lines += [
        _goal_words(scenario),
        _PARADIGM_TEXT[spec.paradigm].format(request=request),
        "The panel on the right says what the robot thinks and what each key does now.",
        "Press Enter (or click Start) when you are ready. The experimenter can end a trial with Esc.",
    ]
    title = f"Trial {position + 1} of {len(plan.specs)}: {variant.label}, {spec.task}, {spec.paradigm}"
    return {
        "id": f"trial-{spec.trial_id}",
        "kind": "message",
        "title": title,
        "lines": lines,
        "button": "Start (Enter)",
        "action": "start",
    }
