"""The questionnaire's table beside the paper's (Table "Subjective Survey Results").

:func:`survey_rows` summarises a folder's questionnaires (:mod:`drake_disamb.study.data.surveys`) as
the paper does: for each statement (Q1 to Q3) the mean and the standard deviation of the ratings
(sample standard deviation, ``n - 1``) over every phase, per interface and per task; for each
preference question (Q4 to Q7) the most frequent answer (ties joined by ``/``, as the paper's
"Disamb/Manual"). Each row carries the paper's value where the paper reports one
(:data:`PAPER_RATINGS`: across tasks and per task; :data:`PAPER_PREFERENCES`). :func:`survey_text`
is the table ``study report`` prints.
"""

from __future__ import annotations

import math
import statistics
from collections import Counter
from collections.abc import Sequence
from typing import Any

from drake_disamb.interfaces import INTERFACES
from drake_disamb.study.analysis.text_table import MISSING, grouped_table
from drake_disamb.study.data.surveys import SurveyRecord
from drake_disamb.study.design.survey import PREFERENCES, STATEMENTS

__all__ = ["PAPER_PREFERENCES", "PAPER_RATINGS", "survey_rows", "survey_text"]

PAPER_RATINGS: dict[str, dict[str, tuple[float, float]]] = {
    "Q1": {"all": (4.88, 0.95), "reaching": (4.88, 0.99), "pouring": (4.88, 0.99)},
    "Q2": {"all": (6.19, 0.75), "reaching": (6.25, 0.89), "pouring": (6.13, 0.64)},
    "Q3": {"all": (5.00, 1.15), "reaching": (5.25, 1.28), "pouring": (4.75, 1.03)},
}
"""The paper's ratings, mean and standard deviation, across tasks (``all``) and per task (single-step:
reaching; multi-step: pouring); the paper gives none per interface."""

PAPER_PREFERENCES: dict[str, str] = {
    "Q4": "head_array",
    "Q5": "head_array",
    "Q6": "disambiguation",
    "Q7": "disambiguation/manual",
}
"""The paper's most frequent answers (every column of its table the same)."""


def _mean_sd(values: Sequence[int]) -> tuple[float | None, float | None]:
    if not values:
        return None, None
    mean = statistics.fmean(values)
    return mean, (statistics.stdev(values) if len(values) > 1 else None)


def _groups(surveys: Sequence[SurveyRecord]) -> list[tuple[str, str]]:
    """``(group, label)``: every phase, each interface answered, each task answered."""
    phases = [p for s in surveys for by in s.ratings.values() for p in by]
    interfaces = [name for name in INTERFACES if any(p.split("/")[0] == name for p in phases)]
    tasks = list(dict.fromkeys(sorted(p.split("/", 1)[1] for p in phases if "/" in p)))
    return [("all", "all"), *[(f"interface:{i}", INTERFACES[i].label) for i in interfaces]] + [
        (f"task:{t}", t) for t in tasks
    ]


def _in_group(phase: str, group: str) -> bool:
    if group == "all":
        return True
    kind, name = group.split(":", 1)
    interface, _, task = phase.partition("/")
    return (interface if kind == "interface" else task) == name


def _most_frequent(answers: Sequence[str]) -> str | None:
    if not answers:
        return None
    counts = Counter(answers)
    top = max(counts.values())
    return "/".join(sorted(a for a, n in counts.items() if n == top))


def survey_rows(surveys: Sequence[SurveyRecord]) -> list[dict[str, Any]]:
    """The table's rows (module docstring): for a rating ``question``, ``group`` (``all``,
    ``interface:<name>``, ``task:<name>``), ``n`` (ratings), ``mean``, ``sd``, ``paper_mean``,
    ``paper_sd``; for a preference ``question``, ``group`` ``all``, ``n`` (answers), ``answer``
    (most frequent), ``counts`` and ``paper``."""
    rows: list[dict[str, Any]] = []
    groups = _groups(surveys)
    for qid, text in STATEMENTS:
        for group, label in groups:
            values = [
                v for s in surveys for phase, v in s.ratings.get(qid, {}).items() if _in_group(phase, group)
            ]
            mean, sd = _mean_sd(values)
            paper = PAPER_RATINGS[qid].get(group.split(":", 1)[-1])
            rows.append(
                {
                    "question": qid,
                    "text": text,
                    "group": group,
                    "label": label,
                    "n": len(values),
                    "mean": mean,
                    "sd": sd,
                    "paper_mean": None if paper is None else paper[0],
                    "paper_sd": None if paper is None else paper[1],
                }
            )
    for qid, text, _ in PREFERENCES:
        answers = [s.preferences[qid] for s in surveys if qid in s.preferences]
        rows.append(
            {
                "question": qid,
                "text": text,
                "group": "all",
                "label": "all",
                "n": len(answers),
                "answer": _most_frequent(answers),
                "counts": dict(sorted(Counter(answers).items())),
                "paper": PAPER_PREFERENCES[qid],
            }
        )
    return rows


def _pm(mean: float | None, sd: float | None) -> str:
    if mean is None or not math.isfinite(mean):
        return MISSING
    return f"{mean:.2f} \u00b1 {sd:.2f}" if sd is not None else f"{mean:.2f}"


def survey_text(rows: Sequence[dict[str, Any]], folder: str) -> str:
    """The rows as the table ``study report`` prints: ours beside the paper's."""
    header = ["question", "group", "n", "ours", "paper"]
    body = []
    for r in rows:
        if "answer" in r:
            counts = ", ".join(f"{k} {v}" for k, v in r["counts"].items())
            ours = f"{r['answer'] or MISSING}" + (f" ({counts})" if counts else "")
            body.append([r["question"], r["label"], str(r["n"]), ours, r["paper"]])
        else:
            paper = _pm(r["paper_mean"], r["paper_sd"])
            body.append([r["question"], r["label"], str(r["n"]), _pm(r["mean"], r["sd"]), paper])
    title = f"Questionnaire ({folder}): ratings 1-7, mean \u00b1 sd; preferences: the most frequent answer"
    questions = [f"  {q}: {t}" for q, t in STATEMENTS] + [f"  {q}: {t}" for q, t, _ in PREFERENCES]
    return "\n".join([title, *grouped_table(header, body, (2, 3)), *questions])
