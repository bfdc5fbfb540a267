"""The paper's questionnaire (Section "Study Methods", Study protocol), as a session asks it.

The paper's subjects rated three statements on a 7-point Likert scale (1 strongly disagree, 7
strongly agree) "at the end of each testing phase", and its table reports them per task (across
tasks, single-step, multi-step); they also answered four preference questions. A session
(``drake-disamb study session``) asks, at its end, each statement once for every (interface, task)
phase the subject did (so the ratings can be summarised overall, per interface and per task) and
each preference question once, among the protocol's interfaces (Q4, Q5) or schemes (paradigms:
Q6, Q7).

:func:`questionnaire` makes a subject's questionnaire from its schedule; :meth:`Questionnaire.check`
turns the answers the page sends into :class:`Answers`, or raises ``ValueError`` naming the first
question without a valid answer.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from drake_disamb.interfaces import INTERFACES

__all__ = [
    "LIKERT_POINTS",
    "PREFERENCES",
    "SCALE_WORDS",
    "STATEMENTS",
    "Answers",
    "Questionnaire",
    "phase_key",
    "questionnaire",
]

LIKERT_POINTS = 7
"""The rating scale: 1 to 7."""

SCALE_WORDS = {1: "strongly disagree", 4: "neither agree nor disagree", 7: "strongly agree"}
"""The words beside some points of the scale."""

STATEMENTS: tuple[tuple[str, str], ...] = (
    ("Q1", "Control modes chosen by the system made task execution easier."),
    ("Q2", "The robot and I worked together to accomplish the task."),
    ("Q3", "I liked operating the robot in the control modes chosen by the system."),
)
"""The statements rated on the Likert scale (the paper's Q1 to Q3, word for word)."""

PREFERENCES: tuple[tuple[str, str, str], ...] = (
    ("Q4", "Which interface was the hardest to operate?", "interface"),
    ("Q5", "For which interface was the assistance paradigm the most useful?", "interface"),
    ("Q6", "Which one of the schemes do you prefer the most?", "paradigm"),
    ("Q7", "Which one of the schemes is the most user-friendly?", "paradigm"),
)
"""The preference questions (the paper's Q4 to Q7, word for word) and what they choose among."""

_PARADIGM_LABELS = {"manual": "Manual", "disambiguation": "Disambiguation", "automatic": "Automatic"}


def phase_key(interface: str, task: str) -> str:
    """The key of an (interface, task) phase in a rating's answers (``joystick/reaching``)."""
    return f"{interface}/{task}"


@dataclass(frozen=True)
class Answers:
    """One subject's answers.

    Attributes:
        ratings: Statement id -> phase key (:func:`phase_key`) -> rating (1 to 7).
        preferences: Question id -> the chosen interface or paradigm name.
    """

    ratings: dict[str, dict[str, int]]
    preferences: dict[str, str]


@dataclass(frozen=True)
class Questionnaire:
    """A subject's questionnaire.

    Attributes:
        phases: The (interface, task) phases the subject did, in session order.
        interfaces: The interfaces Q4 and Q5 choose among (the protocol's).
        paradigms: The schemes Q6 and Q7 choose among (the protocol's paradigms).
    """

    phases: tuple[tuple[str, str], ...]
    interfaces: tuple[str, ...]
    paradigms: tuple[str, ...]

    def options(self, among: str) -> list[tuple[str, str]]:
        """``(value, label)`` of the choices of a preference question choosing ``among``."""
        if among == "interface":
            return [(name, INTERFACES[name].label) for name in self.interfaces]
        return [(name, _PARADIGM_LABELS.get(name, name)) for name in self.paradigms]

    def for_page(self) -> list[dict[str, Any]]:
        """The questions as the operator page draws them (its survey form)."""
        items = [{"key": phase_key(i, t), "label": f"{INTERFACES[i].label}, {t}"} for i, t in self.phases]
        questions: list[dict[str, Any]] = [
            {"id": qid, "kind": "likert", "text": text, "items": items, "scale": SCALE_WORDS}
            for qid, text in STATEMENTS
        ]
        questions += [
            {
                "id": qid,
                "kind": "choice",
                "text": text,
                "options": [{"value": v, "label": label} for v, label in self.options(among)],
            }
            for qid, text, among in PREFERENCES
        ]
        return questions

    def check(self, answers: Mapping[str, Any]) -> Answers:
        """The page's ``answers`` (``{"Q1": {phase key: "5", ...}, "Q4": "head_array", ...}``)
        checked.

        Raises:
            ValueError: A question without a valid answer (names it and the phase).
        """
        ratings: dict[str, dict[str, int]] = {}
        for qid, _ in STATEMENTS:
            given = answers.get(qid)
            given = given if isinstance(given, Mapping) else {}
            ratings[qid] = {}
            for interface, task in self.phases:
                key = phase_key(interface, task)
                ratings[qid][key] = _rating(given.get(key), f"{qid} ({INTERFACES[interface].label}, {task})")
        preferences: dict[str, str] = {}
        for qid, _, among in PREFERENCES:
            value = answers.get(qid)
            names = [v for v, _ in self.options(among)]
            if value not in names:
                raise ValueError(f"{qid}: choose one of {', '.join(names)}, got {_shown(value)}")
            preferences[qid] = str(value)
        return Answers(ratings, preferences)


def _shown(value: Any) -> str:
    return "no answer" if value in (None, "") else repr(value)


def _rating(value: Any, where: str) -> int:
    text = str(value).strip() if isinstance(value, str | int) and not isinstance(value, bool) else ""
    if not (text.isdigit() and 1 <= int(text) <= LIKERT_POINTS):
        raise ValueError(f"{where}: choose a rating from 1 to {LIKERT_POINTS}, got {_shown(value)}")
    return int(text)


def questionnaire(
    phases: Sequence[tuple[str, str]], interfaces: Sequence[str], paradigms: Sequence[str]
) -> Questionnaire:
    """The questionnaire of a subject who did ``phases`` ((interface, task), in order; repeats are
    asked once) in a protocol of ``interfaces`` and ``paradigms``."""
    return Questionnaire(tuple(dict.fromkeys(phases)), tuple(interfaces), tuple(paradigms))
