"""Trial records: one JSON object per finished trial, appended to ``DIR/trials.jsonl``.

Every producer (the simulated study, ``study import-authors`` for the authors' human logs,
``demo --live --record`` for a person) writes the same :class:`TrialRecord`; the analysis reads them
with :func:`read_records`. A record is written whole, as one line, flushed and ``fsync``-ed when the
trial finishes (:func:`append_record`), so a killed run loses at most the trial it was running: a
half-written last line is what a kill can leave, and :func:`read_records` with ``repair=True`` cuts
it off (the trial is then run again). Any other malformed line is an error naming the file and the
line number. Every record, written or read, passes the one check of its values (types, finite
numbers, ranges, the registered interface, task, paradigm, method and source names, intended and
reached goals that are goals of the task): an error names the field and the value, and a reader
adds the file and line.

Times are seconds from the trial's start. Counts follow the paper (Section "Study Methods", Metrics):
``mode_switches`` are the user's own mode-button presses (switches made by a disambiguation
request or by the Automatic paradigm are not in it), ``requests`` the disambiguation requests,
``button_presses = mode_switches + requests``. Raw counts, before the authors' cleaning (requests
within 3 s merged, repeated joystick presses into the same mode within 2 s dropped), which the
analysis applies from ``request_times``, ``mode_switch_times`` and ``mode_switch_modes``. The
record's ``assistance_onset`` is computed by :func:`assistance_onset`, the one definition every
producer uses.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import os
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "FORMAT",
    "SOURCES",
    "RecordError",
    "TrialRecord",
    "append_line",
    "append_record",
    "assistance_onset",
    "check_goals",
    "check_names",
    "read_json_lines",
    "read_records",
    "write_records",
]

T = TypeVar("T")

FORMAT = 1
"""Version of the record layout, written in every record's ``format`` field."""

SOURCES: tuple[str, ...] = ("simulated", "authors", "human")
"""Who produced a record: the simulated population, the authors' published human logs, or a person
recorded with ``demo --live --record``."""


class RecordError(ValueError):
    """A record file or record that cannot be read; the message names the file and line."""


@dataclass
class TrialRecord:
    """The outcome of one trial.

    Attributes:
        trial_id: Unique within a study (also the trace file's stem: ``traces/<trial_id>.npz``).
        subject: Subject name (``S01`` for simulated users, ``H2`` for the authors' subjects).
        interface: ``joystick`` or ``head_array``.
        task: ``reaching`` or ``pouring``.
        paradigm: ``manual``, ``disambiguation`` or ``automatic``.
        disambiguation_method: Mode-selection method (``algorithm1``, ``entropy``, ``kl``), or None
            where no disambiguation can happen (Manual) or it is unknown.
        repetition: 0-based repetition of the (subject, interface, task, paradigm) condition.
        seed: The trial's seed (None for human trials).
        start_pose: 0-based index of the start pose (the paper's 3 home positions).
        initial_mode: Name of the mode at the start (``vx_vy``, ``vx``, ... as in
            :data:`drake_disamb.interfaces`), or None if unknown.
        intended_goals: Per stage, the user's intended goal index (0-based within the stage); the
            people's logs of a multi-step task name one target: one index into all its goals.
            Every index is one of the task's goals (the embedded task's).
        reached_goals: Per stage, the goal index reached (-1 if none), or None where not logged.
        success: Every stage completed at the intended goal (None where not logged).
        done: Every stage completed at some goal (None where not logged).
        duration: Length of the trial (s): the completion time, or the time limit if not done.
        completion_time: Time (s) at which the task was done, or None if it was not.
        mode_switches: The user's own mode switches.
        requests: Disambiguation requests.
        automatic_switches: Mode switches made by the Automatic paradigm.
        button_presses: ``mode_switches + requests``.
        request_times: Time (s) of each request.
        mode_switch_times: Time (s) of each user mode switch.
        mode_switch_modes: The mode (name) each user mode switch entered, in order.
        automatic_switch_times: Time (s) of each automatic switch.
        mean_alpha: Mean blending factor: over the control ticks where the user commanded the arm
            (simulated and recorded trials; the blender gives 0 without a command), or over every
            logged sample (the authors' logs, whose command and alpha are not sampled together).
        assistance_onset: First time (s) from which the belief's argmax is the intended goal with
            alpha above 0 and stays so to the end of the stage, or None if never.
        wall_time: Wall-clock seconds the trial took to simulate (0 for human trials).
        valid: False for a trial the analysis must leave out (the authors' failed trials).
        source: One of :data:`SOURCES`.
        extra: Anything else a producer wants to keep (JSON values). A record made from a trial
            it ran (:func:`~drake_disamb.study.run.outcome.record_from_result`) keeps the trial's
            scenario there, ``scenario``: its YAML, from which ``study rerun`` runs the trial
            again (records of an older release, and the authors', have none).
        format: :data:`FORMAT`.
    """

    trial_id: str
    subject: str
    interface: str
    task: str
    paradigm: str
    disambiguation_method: str | None
    repetition: int
    seed: int | None
    start_pose: int | None
    initial_mode: str | None
    intended_goals: list[int]
    reached_goals: list[int] | None
    success: bool | None
    done: bool | None
    duration: float
    completion_time: float | None
    mode_switches: int
    requests: int
    automatic_switches: int
    button_presses: int
    request_times: list[float]
    mode_switch_times: list[float]
    mode_switch_modes: list[str]
    automatic_switch_times: list[float]
    mean_alpha: float | None
    assistance_onset: float | None
    wall_time: float
    valid: bool = True
    source: str = "simulated"
    extra: dict[str, Any] = field(default_factory=dict)
    format: int = FORMAT

    def __post_init__(self) -> None:
        _check_fields(self)
        if self.button_presses != self.mode_switches + self.requests:
            raise RecordError(
                f"TrialRecord {self.trial_id!r}: button_presses ({self.button_presses}) must be "
                f"mode_switches + requests ({self.mode_switches} + {self.requests})"
            )
        for times, count in (
            ("mode_switch_times", "mode_switches"),
            ("mode_switch_modes", "mode_switches"),
            ("request_times", "requests"),
            ("automatic_switch_times", "automatic_switches"),
        ):
            if len(getattr(self, times)) != getattr(self, count):
                raise RecordError(
                    f"TrialRecord {self.trial_id!r}: {len(getattr(self, times))} {times} for "
                    f"{count}={getattr(self, count)}"
                )
        if self.reached_goals is not None and len(self.reached_goals) != len(self.intended_goals):
            raise RecordError(
                f"field reached_goals: {len(self.reached_goals)} stages, intended_goals has "
                f"{len(self.intended_goals)}"
            )

    def to_json(self) -> str:
        """The record as one line of JSON (no newline), keys in field order."""
        return json.dumps(dataclasses.asdict(self), allow_nan=False, separators=(",", ":"))

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TrialRecord:
        """A record from its JSON object; raises :class:`RecordError` on a wrong format or field set."""
        if not isinstance(data, dict):
            raise RecordError(f"expected a JSON object, got {type(data).__name__}")
        fmt = data.get("format")
        if fmt != FORMAT:
            raise RecordError(
                f"record format {fmt!r} is not this version's format {FORMAT} "
                "(records of an older drake-disamb: run the study again or convert them)"
            )
        names = {f.name for f in dataclasses.fields(cls)}
        missing = sorted(n for n in names if n not in data and _required(cls, n))
        unknown = sorted(set(data) - names)
        if missing or unknown:
            raise RecordError(f"record fields: missing {missing}, unknown {unknown}")
        try:
            return cls(**data)
        except TypeError as err:
            raise RecordError(str(err)) from None


@functools.lru_cache(maxsize=1)
def _names() -> dict[str, tuple[str, ...]]:
    """The registered names a record's fields take."""
    from drake_disamb.config.schema import INTERFACES, PARADIGMS
    from drake_disamb.config.yaml_io import EMBEDDED_TASKS
    from drake_disamb.core.disambiguation import MODE_SELECTION_METHODS

    return {
        "interface": INTERFACES,
        "task": EMBEDDED_TASKS,
        "paradigm": PARADIGMS,
        "disambiguation_method": MODE_SELECTION_METHODS,
        "source": SOURCES,
    }


def _bad(name: str, expected: str, value: Any) -> RecordError:
    text = repr(value)
    return RecordError(
        f"field {name}: expected {expected}, got {text if len(text) <= 80 else text[:77] + '...'}"
    )


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_real(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def check_names(
    *,
    trial_id: Any,
    subject: Any,
    interface: Any,
    task: Any,
    paradigm: Any,
    disambiguation_method: Any,
    source: Any,
) -> None:
    """The one check of a record's names: its ``trial_id``, ``subject`` and condition names
    (:class:`RecordError` naming the field and the value).

    :class:`TrialRecord` applies it to every record; a producer whose names come from its user
    (``demo --live --record``) calls it with the record's names before the trial runs, so the
    record it makes afterwards is never refused for them.
    """
    if not isinstance(subject, str) or not _SAFE_SUBJECT.fullmatch(subject):
        raise _bad("subject", "letters, digits, '_' or '-' (ASCII), at most 64 characters", subject)
    values = {
        "interface": interface,
        "task": task,
        "paradigm": paradigm,
        "disambiguation_method": disambiguation_method,
        "source": source,
    }
    for name, choices in _names().items():
        value = values[name]
        if value is None and name == "disambiguation_method":
            continue
        if not isinstance(value, str) or value not in choices:
            raise _bad(name, f"one of {', '.join(choices)}", value)
    if not isinstance(trial_id, str) or not _SAFE_ID.fullmatch(trial_id):
        raise _bad(
            "trial_id", "letters, digits, '_', '-' or '.' (not first), at most 128 characters", trial_id
        )


def _check_fields(r: TrialRecord) -> None:
    """The one check of a record's values: its names (:func:`check_names`), types, finite numbers
    and ranges (:class:`RecordError` naming the field; a reader adds the file and line)."""
    from drake_disamb.config.schema import MAX_GOALS

    check_names(
        trial_id=r.trial_id,
        subject=r.subject,
        interface=r.interface,
        task=r.task,
        paradigm=r.paradigm,
        disambiguation_method=r.disambiguation_method,
        source=r.source,
    )
    for name in ("repetition", "mode_switches", "requests", "automatic_switches", "button_presses", "format"):
        value = getattr(r, name)
        if not (_is_int(value) and value >= 0):
            raise _bad(name, "an integer >= 0", value)
    for name in ("seed", "start_pose"):
        value = getattr(r, name)
        if value is not None and not (_is_int(value) and value >= 0):
            raise _bad(name, "an integer >= 0 or null", value)
    if r.initial_mode is not None and not isinstance(r.initial_mode, str):
        raise _bad("initial_mode", "a mode name or null", r.initial_mode)
    if not (isinstance(r.intended_goals, list) and r.intended_goals):
        raise _bad("intended_goals", "a non-empty list of goal indices", r.intended_goals)
    for name, lowest in (("intended_goals", 0), ("reached_goals", -1)):
        value = getattr(r, name)
        if value is None and name == "reached_goals":
            continue
        if not isinstance(value, list) or not all(_is_int(g) and lowest <= g < MAX_GOALS for g in value):
            raise _bad(name, f"a list of goal indices in [{lowest}, {MAX_GOALS})", value)
    check_goals(r.task, r.intended_goals, r.reached_goals)
    for name in ("success", "done"):
        value = getattr(r, name)
        if value is not None and not isinstance(value, bool):
            raise _bad(name, "true, false or null", value)
    if not isinstance(r.valid, bool):
        raise _bad("valid", "true or false", r.valid)
    for name in ("duration", "wall_time"):
        value = getattr(r, name)
        if not (_is_real(value) and value >= 0):
            raise _bad(name, "a finite number >= 0", value)
    for name in ("completion_time", "assistance_onset"):
        value = getattr(r, name)
        if value is not None and not (_is_real(value) and value >= 0):
            raise _bad(name, "a finite number >= 0 or null", value)
    if r.mean_alpha is not None and not (_is_real(r.mean_alpha) and 0.0 <= r.mean_alpha <= 1.0):
        raise _bad("mean_alpha", "a number in [0, 1] or null", r.mean_alpha)
    for name in ("request_times", "mode_switch_times", "automatic_switch_times"):
        value = getattr(r, name)
        if not isinstance(value, list) or not all(_is_real(t) for t in value):
            raise _bad(name, "a list of finite times (s)", value)
    if not isinstance(r.mode_switch_modes, list) or not all(isinstance(m, str) for m in r.mode_switch_modes):
        raise _bad("mode_switch_modes", "a list of mode names", r.mode_switch_modes)
    if not isinstance(r.extra, dict):
        raise _bad("extra", "an object", r.extra)


def check_goals(task: Any, intended_goals: Any, reached_goals: Any) -> None:
    """The one check that a record's intended and reached goals are goals of its (embedded) task:
    one index per stage within the stage's goals, or one index into all the task's goals (the
    people's logs of a multi-step task name one target) (:class:`RecordError` naming the field).

    :class:`TrialRecord` applies it to every record; ``demo --live --record`` calls it before the
    trial with the scenario's intended goals and the largest index each stage could reach."""
    from drake_disamb.config.yaml_io import embedded_stage_goals

    per_stage = embedded_stage_goals(task)
    if len(intended_goals) == len(per_stage):
        sizes = per_stage
    elif len(intended_goals) == 1:
        sizes = (sum(per_stage),)
    else:
        raise _bad(
            "intended_goals",
            f"one goal index per stage of the {task} task ({len(per_stage)}) or one index into its "
            f"{sum(per_stage)} goals",
            intended_goals,
        )
    where = (
        f"{sizes[0]} goals: 0 to {sizes[0] - 1}"
        if len(sizes) == 1
        else "per stage: " + ", ".join(f"0 to {n - 1}" for n in sizes)
    )
    for name, value in (("intended_goals", intended_goals), ("reached_goals", reached_goals)):
        if value is not None and any(g >= n for g, n in zip(value, sizes, strict=False)):
            none = " or -1" if name == "reached_goals" else ""
            raise _bad(name, f"indices of the {task} task's goals ({where}{none})", value)


_SAFE_ID = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9_.-]{0,127}")
"""A ``trial_id`` is also its trace file's stem: no path separator, not hidden."""

_SAFE_SUBJECT = re.compile(r"[A-Za-z0-9_-]{1,64}")
"""A ``subject`` is part of a person's ``trial_id`` (``demo --live --record``): ASCII letters,
digits, ``_`` and ``-``, short enough to leave the id room for its condition."""


def _required(cls: type, name: str) -> bool:
    f = next(f for f in dataclasses.fields(cls) if f.name == name)
    return f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING


def append_line(path: str | Path, line: str) -> None:
    """Append ``line`` (JSON, no newline) and its newline to ``path``, flushed and fsync-ed before
    returning.

    The line is written with one ``write`` call on a file opened for appending, so a reader never
    sees two lines interleaved; a kill can only leave the last line half-written
    (:func:`read_json_lines` says so, or repairs it).
    """
    with open(path, "a", encoding="utf-8") as f:
        f.write(line + "\n")
        f.flush()
        os.fsync(f.fileno())


def append_record(path: str | Path, record: TrialRecord) -> None:
    """Append ``record`` as one line to ``path`` (:func:`append_line`)."""
    append_line(path, record.to_json())


def read_json_lines(
    path: str | Path,
    parse: Callable[[Any], T],
    key: Callable[[T], str],
    *,
    what: str,
    twice: str,
    repair: bool = False,
    skip_incomplete: bool = False,
) -> list[T]:
    """Every line of a JSON-lines file written by :func:`append_line`, each parsed by ``parse``
    (which raises :class:`RecordError`), no two with the same ``key``.

    Args:
        path: The file.
        parse: A line's JSON value to its record.
        key: What must not repeat (a record's ``trial_id``, a questionnaire's subject).
        what: What the file holds, for the error of an unreadable file (``"the records"``).
        twice: The error of a repeated key, with ``{}`` for its repr (``"trial_id {} appears twice"``).
        repair: A last line without its newline is what a killed writer leaves: with ``repair``
            the file is truncated to drop it; without, it is an error.
        skip_incomplete: Read past such a line without an error, leaving the file as it is (a
            reader without the folder's lock that repairs it later).

    Raises:
        RecordError: The file cannot be read, or a line is not a record; the message names the file
            and the 1-based line number. Nothing is modified except by ``repair``.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as err:
        raise RecordError(f"{path}: cannot read {what}: {err.strerror or err}") from None
    if raw and not raw.endswith(b"\n"):
        cut = raw.rfind(b"\n") + 1
        if skip_incomplete and not repair:
            raw = raw[:cut]
        elif not repair:
            line_no = raw.count(b"\n") + 1
            raise RecordError(
                f"{path}:{line_no}: the last line is incomplete (a run was killed while writing)"
            )
        else:
            with open(path, "r+b") as f:
                f.truncate(cut)
                f.flush()
                os.fsync(f.fileno())
            raw = raw[:cut]
    records: list[T] = []
    seen: set[str] = set()
    for line_no, line in enumerate(raw.split(b"\n")[:-1] if raw else [], start=1):
        if not line.strip():
            raise RecordError(f"{path}:{line_no}: empty line")
        try:
            record = parse(json.loads(line.decode("utf-8")))
        except (UnicodeDecodeError, json.JSONDecodeError) as err:
            raise RecordError(f"{path}:{line_no}: not a JSON record: {err}") from None
        except RecordError as err:
            raise RecordError(f"{path}:{line_no}: {err}") from None
        if key(record) in seen:
            raise RecordError(f"{path}:{line_no}: " + twice.format(repr(key(record))))
        seen.add(key(record))
        records.append(record)
    return records


def read_records(
    path: str | Path, *, repair: bool = False, skip_incomplete: bool = False
) -> list[TrialRecord]:
    """Read every record of a ``trials.jsonl`` file (:func:`read_json_lines`: ``repair`` drops a
    last line a killed writer left half-written, ``skip_incomplete`` reads past it; a ``trial_id``
    twice is an error).

    Raises:
        RecordError: The file cannot be read, or a line is not a record of this format; the message
            names the file and the 1-based line number. Nothing is modified except by ``repair``.
    """
    return read_json_lines(
        path,
        TrialRecord.from_dict,
        lambda r: r.trial_id,
        what="the records",
        twice="trial_id {} appears twice",
        repair=repair,
        skip_incomplete=skip_incomplete,
    )


def write_records(path: str | Path, records: Iterable[TrialRecord]) -> None:
    """Append several records (each flushed as by :func:`append_record`)."""
    for record in records:
        append_record(path, record)


def assistance_onset(times: ArrayLike, belief: ArrayLike, alpha: ArrayLike, goal: int) -> float | None:
    """First time from which the belief's argmax is ``goal`` with alpha above 0, and stays so to
    the last sample; None if the last sample is not such.

    Args:
        times: ``(T,)`` sample times (s), increasing.
        belief: ``(T, n_goals)`` goal probabilities.
        alpha: ``(T,)`` blending factor.
        goal: Index of the intended goal.
    """
    t = np.asarray(times, dtype=float)
    p = np.asarray(belief, dtype=float)
    a = np.asarray(alpha, dtype=float)
    if p.ndim != 2 or len(p) != len(t) or a.shape != t.shape:
        raise ValueError(f"assistance_onset: times {t.shape}, belief {p.shape}, alpha {a.shape} do not match")
    if not (0 <= goal < p.shape[1]):
        raise ValueError(f"assistance_onset: goal {goal} is not one of the {p.shape[1]} goals")
    ok = (np.argmax(p, axis=1) == goal) & (a > 0.0)
    if len(ok) == 0 or not ok[-1]:
        return None
    bad = np.flatnonzero(~ok)
    return float(t[bad[-1] + 1] if len(bad) else t[0])
