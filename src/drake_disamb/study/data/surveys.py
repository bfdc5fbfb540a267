"""The questionnaires of a study folder: ``DIR/surveys.jsonl``, one subject's answers a line.

A session (``drake-disamb study session``) appends a subject's answers to the paper's
questionnaire (:mod:`drake_disamb.study.design.survey`) beside the subject's trials, as a
:class:`SurveyRecord` on one line, flushed and ``fsync``-ed (:func:`append_survey`), so the folder
holds the subject's records and answers together. :func:`read_surveys` reads them back, each line
checked: an error names the file, the line and the field. A subject answers once.
"""

from __future__ import annotations

import dataclasses
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drake_disamb.study.data.records import _SAFE_SUBJECT, RecordError, append_line, read_json_lines

__all__ = ["SURVEYS_FILE", "SurveyRecord", "append_survey", "read_surveys"]

SURVEYS_FILE = "surveys.jsonl"
"""The file of a study folder that holds its questionnaires."""

FORMAT = 1
"""Version of a survey record's layout."""

_QUESTION = re.compile(r"Q[1-9][0-9]?")
_SAFE = re.compile(r"[A-Za-z0-9_/.-]{1,128}")


@dataclass(frozen=True)
class SurveyRecord:
    """One subject's answers.

    Attributes:
        subject: The subject (as in the subject's trial records).
        ratings: Statement id (``Q1``) -> phase (``interface/task``) -> rating (1 to 7).
        preferences: Question id (``Q4``) -> the interface or paradigm chosen.
        submitted: When the answers were sent (ISO 8601, UTC).
        format: :data:`FORMAT`.
    """

    subject: str
    ratings: dict[str, dict[str, int]]
    preferences: dict[str, str]
    submitted: str
    format: int = FORMAT

    def __post_init__(self) -> None:
        if not isinstance(self.subject, str) or not _SAFE_SUBJECT.fullmatch(self.subject):
            raise RecordError(f"field subject: expected a subject's id, got {self.subject!r}")
        if not isinstance(self.ratings, dict) or not all(
            isinstance(q, str) and _QUESTION.fullmatch(q) and isinstance(by, dict)
            for q, by in self.ratings.items()
        ):
            raise RecordError(
                f"field ratings: expected {{question: {{phase: rating}}}}, got {self.ratings!r}"
            )
        for q, by in self.ratings.items():
            for phase, value in by.items():
                if not (isinstance(phase, str) and _SAFE.fullmatch(phase)):
                    raise RecordError(f"field ratings.{q}: expected phase names, got {phase!r}")
                if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 7:
                    raise RecordError(
                        f"field ratings.{q}.{phase}: expected a rating from 1 to 7, got {value!r}"
                    )
        if not isinstance(self.preferences, dict) or not all(
            isinstance(q, str) and _QUESTION.fullmatch(q) and isinstance(v, str) and _SAFE.fullmatch(v)
            for q, v in self.preferences.items()
        ):
            raise RecordError(f"field preferences: expected {{question: answer}}, got {self.preferences!r}")
        if not isinstance(self.submitted, str) or len(self.submitted) > 64:
            raise RecordError(f"field submitted: expected a time, got {self.submitted!r}")
        if self.format != FORMAT:
            raise RecordError(f"field format: expected {FORMAT}, got {self.format!r}")

    def to_json(self) -> str:
        """The record as one line of JSON (no newline)."""
        return json.dumps(dataclasses.asdict(self), separators=(",", ":"))

    @classmethod
    def from_dict(cls, data: Any) -> SurveyRecord:
        """A record from its JSON object (:class:`RecordError` naming what is wrong)."""
        names = {f.name for f in dataclasses.fields(cls)}
        if (
            not isinstance(data, dict)
            or set(data) - names
            or {"subject", "ratings", "preferences"} - set(data)
        ):
            raise RecordError(f"expected an object with the fields {sorted(names)}")
        try:
            return cls(**data)
        except TypeError as err:
            raise RecordError(str(err)) from None


def append_survey(folder: str | Path, record: SurveyRecord) -> Path:
    """Append ``record`` to ``folder/surveys.jsonl`` as one line
    (:func:`~drake_disamb.study.data.records.append_line`); returns the file."""
    path = Path(folder) / SURVEYS_FILE
    append_line(path, record.to_json())
    return path


def read_surveys(folder: str | Path) -> list[SurveyRecord]:
    """The questionnaires of ``folder`` (``[]`` without ``surveys.jsonl``), read as the records are
    (:func:`~drake_disamb.study.data.records.read_json_lines`).

    Raises:
        RecordError: A line that is not a survey record, a last line a killed writer left
            half-written, or a subject twice (file and line named).
    """
    path = Path(folder) / SURVEYS_FILE
    if not path.exists():
        return []
    return read_json_lines(
        path,
        SurveyRecord.from_dict,
        lambda r: r.subject,
        what="the questionnaires",
        twice="subject {} answered twice",
    )
