"""The paradigm effect of one study folder beside another's: population beside people.

:func:`paradigm_effect` is ``study report DIR --compare OTHER``'s ``paradigm_effect.json``. For each
metric of :data:`EFFECT_METRICS`, each interface the records hold (both tasks together, ``task =
"all"``) and each interface and task, the Manual -> Disambiguation effect (:data:`EFFECT_PAIR`) in
``DIR`` and in ``OTHER``, taken from the report's own rank-sum tests
(:func:`drake_disamb.study.analysis.stats.run_tests`, the rows of ``stats.json``): the same analysed
trials (valid and not failed), after the authors' cleaning, as every mean and test of the report.

One object per metric, interface, task and pair of sources (one source per folder: one row per
cell), with the keys:

- ``metric``, ``interface``, ``task`` (``"all"``: both tasks), ``source``, ``other_source``;
- for ``DIR`` (and, prefixed ``other_``, for ``OTHER``): ``n_manual``, ``n_disambiguation`` (the
  analysed trials with a value), ``mean_manual``, ``mean_disambiguation`` (the rank-sum test's
  ``mean_a`` and ``mean_b``), ``relative_change`` = (Disambiguation - Manual) / Manual (None where
  the Manual mean is 0) and ``p_value`` (the two-sided rank-sum p); all None where the side has
  no test for the cell (no analysed trials of one paradigm or of both);
- ``ratio`` = ``relative_change / other_relative_change`` (None where either is None or the
  other is 0) and ``check``: the effect has the same direction and is within a factor of
  :data:`FACTOR` of the other's (``ratio`` in ``[1 / FACTOR, FACTOR]``); None ("n/a") where
  ``ratio`` is None.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from drake_disamb.interfaces import interfaces_in
from drake_disamb.study.analysis.findings import find_ranksum
from drake_disamb.study.analysis.stats import PAIRS, TASKS, run_tests, values_of
from drake_disamb.study.data.records import TrialRecord
from drake_disamb.study.measures.metrics import TrialMetrics, trial_metrics

__all__ = ["EFFECT_METRICS", "EFFECT_PAIR", "FACTOR", "SIDE_KEYS", "paradigm_effect"]

EFFECT_METRICS = ("button_presses", "mode_switches")
"""The metrics whose paradigm effect is compared: button presses and user mode switches (cleaned)."""
EFFECT_PAIR = PAIRS[0]
"""The paradigms compared: ``("manual", "disambiguation")``."""
FACTOR = 2.0
"""``check`` passes where the ratio of the relative changes is within ``[1 / FACTOR, FACTOR]``."""
SIDE_KEYS = (
    "n_manual",
    "n_disambiguation",
    "mean_manual",
    "mean_disambiguation",
    "relative_change",
    "p_value",
)
"""The keys of one side of a row (``other_<key>`` for ``OTHER``)."""


def _side(
    trials: Sequence[TrialMetrics],
    tests: Sequence[dict[str, Any]],
    source: str,
    metric: str,
    cell: tuple[str, str],
) -> dict[str, Any]:
    """One folder's side of a row: ``trials`` are its trials of ``source``."""
    interface, task = cell
    a, b = EFFECT_PAIR
    t = find_ranksum(tests, metric, interface, task, a, b, source)
    side: dict[str, Any] = {
        "n_manual": len(values_of(trials, metric, interface, task, a)),
        "n_disambiguation": len(values_of(trials, metric, interface, task, b)),
        "mean_manual": None,
        "mean_disambiguation": None,
        "relative_change": None,
        "p_value": None,
    }
    if t is not None:
        side.update(
            mean_manual=t["mean_a"],
            mean_disambiguation=t["mean_b"],
            relative_change=(t["mean_b"] - t["mean_a"]) / t["mean_a"] if t["mean_a"] else None,
            p_value=t["p_value"],
        )
    return side


def _cells(records: Sequence[TrialRecord]) -> list[tuple[str, str]]:
    """``(interface, task)`` of every interface the records hold, ``"all"`` tasks first, then each
    task they hold (in :data:`~drake_disamb.study.analysis.stats.TASKS` order)."""
    tasks = [t for t in TASKS if t != "all" and t in {r.task for r in records}]
    return [(i, t) for i in interfaces_in(r.interface for r in records) for t in ("all", *tasks)]


def paradigm_effect(
    records: Sequence[TrialRecord],
    other: Sequence[TrialRecord],
    tests: Sequence[dict[str, Any]] | None = None,
    other_tests: Sequence[dict[str, Any]] | None = None,
) -> list[dict[str, Any]]:
    """The Manual -> Disambiguation effect of ``records`` beside ``other``'s (module docstring).

    Args:
        records: This folder's trials.
        other: The other folder's trials.
        tests: ``run_tests(records)`` if already made (the report's ``stats.json``); made here
            (the rank-sum tests of :data:`EFFECT_METRICS`) if None.
        other_tests: The same for ``other``.
    """
    if tests is None:
        tests = run_tests(records, EFFECT_METRICS, per_subject=False)
    if other_tests is None:
        other_tests = run_tests(other, EFFECT_METRICS, per_subject=False)
    cells = _cells([*records, *other])
    ours_all, theirs_all = [trial_metrics(r) for r in records], [trial_metrics(r) for r in other]
    rows = []
    for source in sorted({r.source for r in records}):
        mine_trials = [m for m in ours_all if m.record.source == source]
        for other_source in sorted({r.source for r in other}):
            their_trials = [m for m in theirs_all if m.record.source == other_source]
            for metric in EFFECT_METRICS:
                for cell in cells:
                    mine = _side(mine_trials, tests, source, metric, cell)
                    theirs = _side(their_trials, other_tests, other_source, metric, cell)
                    x, y = mine["relative_change"], theirs["relative_change"]
                    ratio = x / y if x is not None and y not in (None, 0) else None
                    rows.append(
                        {
                            "metric": metric,
                            "interface": cell[0],
                            "task": cell[1],
                            "source": source,
                            "other_source": other_source,
                            **mine,
                            **{f"other_{k}": v for k, v in theirs.items()},
                            "ratio": ratio,
                            "check": None if ratio is None else 1 / FACTOR <= ratio <= FACTOR,
                        }
                    )
    return rows
