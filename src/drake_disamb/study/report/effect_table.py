"""The paradigm-effect table (:func:`drake_disamb.study.analysis.effect.paradigm_effect`) as text:
the cells of ``index.html``'s table and the compact table ``study report --compare`` prints.

A side with no test for a cell shows ``-``; a check that cannot be made shows ``n/a``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from drake_disamb.study.analysis.effect import FACTOR
from drake_disamb.study.analysis.text_table import MISSING, grouped_table, number

__all__ = ["EFFECT_HEADERS", "TEXT_COLUMNS", "effect_cells", "effect_text"]

EFFECT_HEADERS = (
    "metric",
    "interface",
    "task",
    "n",
    "Manual",
    "Disambiguation",
    "change",
    "p",
    "other n",
    "other Manual",
    "other Disambiguation",
    "other change",
    "other p",
    "ratio of changes",
    "check",
)
"""The columns of :func:`effect_cells` (``n``: Manual/Disambiguation trials analysed; ``check``:
``yes``, ``no`` or ``n/a``)."""
TEXT_COLUMNS = tuple(h for h in EFFECT_HEADERS if h not in ("n", "other n"))
"""The columns of the text table (:func:`effect_text`)."""


def _change(v: float | None) -> str:
    return MISSING if v is None or not math.isfinite(v) else f"{100 * v:+.0f}%"


def _p(v: float | None) -> str:
    return MISSING if v is None or not math.isfinite(v) else f"{v:.2g}"


def effect_cells(row: dict[str, Any]) -> dict[str, str]:
    """One row of ``paradigm_effect.json`` as the strings of :data:`EFFECT_HEADERS`."""
    cells = {
        "metric": row["metric"].replace("_", " "),
        "interface": row["interface"],
        "task": "both" if row["task"] == "all" else row["task"],
    }
    for prefix in ("", "other "):
        key = prefix.replace(" ", "_")
        cells[f"{prefix}n"] = f"{row[f'{key}n_manual']}/{row[f'{key}n_disambiguation']}"
        cells[f"{prefix}Manual"] = number(row[f"{key}mean_manual"])
        cells[f"{prefix}Disambiguation"] = number(row[f"{key}mean_disambiguation"])
        cells[f"{prefix}change"] = _change(row[f"{key}relative_change"])
        cells[f"{prefix}p"] = _p(row[f"{key}p_value"])
    cells["ratio of changes"] = number(row["ratio"])
    cells["check"] = "n/a" if row["check"] is None else ("yes" if row["check"] else "no")
    return cells


def effect_text(rows: Sequence[dict[str, Any]], here: str, there: str) -> str:
    """The compact text table of ``rows``: ``here`` and ``there`` name the two folders (a column
    ``sources`` is added where the rows hold more than one pair of sources)."""
    sides = ("man", "dis", "change", "p")
    header = ["metric", "interface", "task", *sides, *sides, "ratio", "check"]
    body = [[effect_cells(r)[k] for k in TEXT_COLUMNS] for r in rows]
    if len({(r["source"], r["other_source"]) for r in rows}) > 1:
        header.insert(0, "sources")
        for r, b in zip(rows, body, strict=True):
            b.insert(0, f"{r['source']}/{r['other_source']}")
    n_label = len(header) - 10  # the label columns, then two sides of 4 and ratio, check
    lo, hi = 1 / FACTOR, FACTOR
    title = [
        "Paradigm effect Manual -> Disambiguation: means, change = (Dis - Man) / Man, two-sided rank-sum p",
        f"left: {here}; right: {there}; ratio = left change / right change; "
        f"check: same direction and within a factor of {FACTOR:g} (ratio in [{lo:g}, {hi:g}])",
    ]
    return "\n".join([*title, *grouped_table(header, body, (n_label, 4, 4, 2))])
