"""Trial records: one JSON object per finished trial, appended to ``DIR/trials.jsonl``.

Every producer (the simulated study, ``study import-authors`` for the authors' human logs,
``demo --live --record`` for a person) writes the same :class:`TrialRecord`; the analysis reads them
with :func:`read_records`. A record is written whole, as one line, flushed and ``fsync``-ed when the
trial finishes (:func:`append_record`), so a killed run loses at most the trial it was running: a
half-written last line is what a kill can leave, and :func:`read_records` with ``repair=True`` cuts
it off (the trial is then run again). Any other malformed line is an error naming the file and the
line number.

Times are seconds from the trial's start. Counts follow the paper (Section "Study Methods", Metrics):
``mode_switches`` are the user's own mode-button presses (switches made by a disambiguation
request or by the Automatic paradigm are not in it), ``requests`` the disambiguation requests,
``button_presses = mode_switches + requests``. Raw counts, before the authors' cleaning (requests
within 3 s merged, repeated joystick presses into the same mode within 2 s dropped), which the
analysis applies from ``request_times``, ``mode_switch_times`` and ``mode_switch_modes``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = [
    "FORMAT",
    "SOURCES",
    "RecordError",
    "TrialRecord",
    "append_record",
    "read_records",
    "write_records",
]

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
            :data:`drake_disamb.core.interfaces`), or None if unknown.
        intended_goals: Per stage, the user's intended goal index (0-based within the stage).
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
        extra: Anything else a producer wants to keep (JSON values).
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
        if self.source not in SOURCES:
            raise RecordError(f"TrialRecord.source: expected one of {SOURCES}, got {self.source!r}")
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
        for name in ("duration", "wall_time"):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value >= 0):
                raise RecordError(
                    f"TrialRecord {self.trial_id!r}: {name} must be a finite number >= 0, got {value!r}"
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


def _required(cls: type, name: str) -> bool:
    f = next(f for f in dataclasses.fields(cls) if f.name == name)
    return f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING


def append_record(path: str | Path, record: TrialRecord) -> None:
    """Append ``record`` as one line to ``path``, flushed and fsync-ed before returning.

    The line is written with one ``write`` call on a file opened for appending, so a reader never
    sees two records interleaved; a kill can only leave the last line half-written.
    """
    line = record.to_json() + "\n"
    with open(path, "a", encoding="utf-8") as f:
        f.write(line)
        f.flush()
        os.fsync(f.fileno())


def read_records(path: str | Path, *, repair: bool = False) -> list[TrialRecord]:
    """Read every record of a ``trials.jsonl`` file.

    Args:
        path: The file.
        repair: A last line without its newline is what a killed writer leaves: with ``repair``
            the file is truncated to drop it (its trial is run again); without, it is an error.

    Raises:
        RecordError: The file cannot be read, or a line is not a record of this format; the message
            names the file and the 1-based line number. Nothing is modified except by ``repair``.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except OSError as err:
        raise RecordError(f"{path}: cannot read the records: {err.strerror or err}") from None
    if raw and not raw.endswith(b"\n"):
        cut = raw.rfind(b"\n") + 1
        if not repair:
            line_no = raw.count(b"\n") + 1
            raise RecordError(
                f"{path}:{line_no}: the last line is incomplete (a run was killed while writing)"
            )
        with open(path, "r+b") as f:
            f.truncate(cut)
            f.flush()
            os.fsync(f.fileno())
        raw = raw[:cut]
    records: list[TrialRecord] = []
    seen: set[str] = set()
    for line_no, line in enumerate(raw.split(b"\n")[:-1] if raw else [], start=1):
        if not line.strip():
            raise RecordError(f"{path}:{line_no}: empty line")
        try:
            data = json.loads(line.decode("utf-8"))
            record = TrialRecord.from_dict(data)
        except (UnicodeDecodeError, json.JSONDecodeError) as err:
            raise RecordError(f"{path}:{line_no}: not a JSON record: {err}") from None
        except RecordError as err:
            raise RecordError(f"{path}:{line_no}: {err}") from None
        if record.trial_id in seen:
            raise RecordError(f"{path}:{line_no}: trial_id {record.trial_id!r} appears twice")
        seen.add(record.trial_id)
        records.append(record)
    return records


def write_records(path: str | Path, records: Iterable[TrialRecord]) -> None:
    """Append several records (each flushed as by :func:`append_record`)."""
    for record in records:
        append_record(path, record)
