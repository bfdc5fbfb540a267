"""The paper's findings beside ours, and one study folder's means beside another's.

:func:`findings` is the table "the paper's finding / ours / agree?" of ``study report`` (paper
Section "Results" and the data README's manual means; one function per finding, in the table
:data:`FINDINGS`); :func:`compare_summaries` is its ``--compare``
section (the criterion for a simulated population: its means within 50 % of the people's).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_disamb.interfaces import INTERFACES
from drake_disamb.study.measures.metrics import TrialMetrics, request_time_skewness

__all__ = [
    "COMPARED",
    "FINDINGS",
    "INTERFACE_NAMES",
    "PAPER_MANUAL_SWITCHES",
    "PAPER_SKEWNESS",
    "TASK_NAMES",
    "WITHIN",
    "compare_summaries",
    "find_ranksum",
    "findings",
    "fmt",
    "select_trials",
]

INTERFACE_NAMES = {**{name: kind.label for name, kind in INTERFACES.items()}, "all": "all interfaces"}
TASK_NAMES = {"reaching": "Single-step (reaching)", "pouring": "Multi-step (pouring)", "all": "both tasks"}

PAPER_SKEWNESS = {
    ("joystick", "reaching"): 0.63,
    ("joystick", "pouring"): 0.57,
    ("head_array", "reaching"): 0.35,
    ("head_array", "pouring"): 0.22,
}
"""The paper's request-time skewness (paper Section "Results", Table "skewness")."""

PAPER_MANUAL_SWITCHES = {
    ("joystick", "reaching"): 2.38,
    ("joystick", "pouring"): 6.88,
    ("head_array", "reaching"): 14.30,
    ("head_array", "pouring"): 34.48,
}
"""Manual user-mode-switch means over the paper's 8 subjects (data README)."""

WITHIN = 0.5
"""``--compare`` flags a ratio outside ``[1 - WITHIN, 1 + WITHIN]`` (within 50 %)."""


def select_trials(
    trials: Sequence[TrialMetrics], interface: str = "all", task: str = "all"
) -> list[TrialMetrics]:
    """The analysed trials of ``interface`` and ``task`` (``"all"``: any)."""
    return [
        m
        for m in trials
        if m.analysed
        and (interface == "all" or m.record.interface == interface)
        and (task == "all" or m.record.task == task)
    ]


def find_ranksum(
    tests: Sequence[dict[str, Any]], metric: str, interface: str, task: str, a: str, b: str, source: str
) -> dict[str, Any] | None:
    """The rank-sum test of ``metric``, paradigm ``a`` against ``b``, among ``tests`` (None: none)."""
    for t in tests:
        if (
            t["test"] == "ranksum"
            and t["metric"] == metric
            and t["interface"] == interface
            and t["task"] == task
            and t["a"] == a
            and t["b"] == b
            and t["source"] == source
        ):
            return t
    return None


def fmt(v: float | None, digits: int = 2) -> str:
    """``v`` with ``digits`` decimals; ``"n/a"`` for None, NaN or inf."""
    return "n/a" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.{digits}f}"


def _p(t: dict[str, Any] | None) -> str:
    if t is None or t["p_value"] is None:
        return "no test"
    return f"p = {t['p_value']:.3g} {t['stars']}"


def _fewer(t: dict[str, Any] | None) -> bool | None:
    """Significantly fewer with ``b`` than ``a`` (lower mean and p < 0.05); None without a test."""
    if t is None or t["p_value"] is None:
        return None
    return t["mean_b"] < t["mean_a"] and t["p_value"] < 0.05


def _verdict(ok: bool | None) -> str:
    return "n/a" if ok is None else ("yes" if ok else "no")


@dataclass(frozen=True)
class _Evidence:
    """What the findings read: the ``trials`` of one ``source`` and the ``tests`` of the folder."""

    trials: Sequence[TrialMetrics]
    tests: Sequence[dict[str, Any]]
    source: str

    def test(self, metric: str, interface: str, task: str) -> dict[str, Any] | None:
        """The rank-sum test of ``metric``, Manual against Disambiguation (None: none)."""
        return find_ranksum(self.tests, metric, interface, task, "manual", "disambiguation", self.source)


Row = dict[str, str]


def _row(paper: str, ours: str, ok: bool | None, criterion: str) -> Row:
    return {"paper": paper, "ours": ours, "agree": _verdict(ok), "criterion": criterion}


def _means(t: dict[str, Any] | None) -> str:
    return "no data" if t is None else f"Manual {fmt(t['mean_a'])} vs Disambiguation {fmt(t['mean_b'])}"


Finding = Callable[[_Evidence], list[Row]]
"""One of the paper's findings: its rows of the table from the evidence."""


def _fewer_with_disambiguation(metric: str, interface: str, paper: str, criterion: str) -> Finding:
    """The finding ``paper``: significantly fewer ``metric`` with Disambiguation than Manual on
    ``interface`` (both tasks; ``criterion`` says so)."""

    def finding(ev: _Evidence) -> list[Row]:
        t = ev.test(metric, interface, "all")
        return [_row(paper, f"{_means(t)}, {_p(t)}", _fewer(t), criterion)]

    return finding


def _joystick_presses(ev: _Evidence) -> list[Row]:
    t = ev.test("button_presses", "joystick", "all")
    return [
        _row(
            "Joystick: the gain is offset by the requests (no significant decrease in button presses)",
            f"button presses {_means(t)}, {_p(t)}",
            None if _fewer(t) is None else not _fewer(t),
            "no significant decrease in button presses",
        )
    ]


def _decrease_by_task(ev: _Evidence) -> list[Row]:
    tr, tp = ev.test("button_presses", "all", "reaching"), ev.test("button_presses", "all", "pouring")
    ok: bool | None = None
    if tr is not None and tp is not None:
        dr, dp = tr["mean_a"] - tr["mean_b"], tp["mean_a"] - tp["mean_b"]
        ours = (
            f"decrease Manual - Disambiguation: pouring {fmt(dp)} ({fmt(100 * dp / tp['mean_a'], 0)} %, "
            f"{_p(tp)}), reaching {fmt(dr)} ({fmt(100 * dr / tr['mean_a'], 0)} %, {_p(tr)})"
            if tp["mean_a"] and tr["mean_a"]
            else f"decrease pouring {fmt(dp)}, reaching {fmt(dr)}"
        )
        ok = dp > dr
    else:
        ours = "no data for both tasks"
    return [
        _row(
            "The decrease in button presses is larger for the multi-step task",
            ours,
            ok,
            "mean decrease (both interfaces) larger for pouring than for reaching",
        )
    ]


def _completion_time(ev: _Evidence) -> list[Row]:
    parts, sig, seen = [], False, False
    for interface, task in (
        ("joystick", "all"),
        ("head_array", "all"),
        ("all", "reaching"),
        ("all", "pouring"),
    ):
        t = ev.test("completion_time", interface, task)
        if t is None or t["p_value"] is None:
            continue
        seen = True
        sig = sig or t["p_value"] < 0.05
        name = INTERFACE_NAMES[interface] if task == "all" else TASK_NAMES[task]
        parts.append(f"{name}: {fmt(t['mean_a'], 1)} s vs {fmt(t['mean_b'], 1)} s, {_p(t)}")
    return [
        _row(
            "No significant difference in completion time between Manual and Disambiguation",
            "; ".join(parts) or "no data",
            (not sig) if seen else None,
            "no rank-sum p < 0.05 by interface or by task",
        )
    ]


def _success(ev: _Evidence) -> list[Row]:
    rate = {}
    for paradigm in ("disambiguation", "manual"):
        known = [m.success for m in ev.trials if m.record.paradigm == paradigm and m.success is not None]
        rate[paradigm] = (sum(known), len(known))
    ok: bool | None = None
    if all(n for _, n in rate.values()):
        (sd, nd), (sm, nm) = rate["disambiguation"], rate["manual"]
        ours = f"Disambiguation {100 * sd / nd:.2f} % ({sd}/{nd}) vs Manual {100 * sm / nm:.2f} % ({sm}/{nm})"
        ok = sd / nd <= sm / nm
    else:
        ours = "success not known for both paradigms"
    return [
        _row(
            "Success 92.50 % (148/160) with Disambiguation vs 97.92 % (94/96) Manual",
            ours,
            ok,
            "success rate not higher with Disambiguation",
        )
    ]


def _failures(ev: _Evidence) -> list[Row]:
    failed = [m for m in ev.trials if m.success is False]
    ok: bool | None = None
    if [m for m in ev.trials if m.success is not None]:
        n_pour = sum(1 for m in failed if m.record.task == "pouring")
        ours = f"{n_pour} of {len(failed)} unsuccessful trials in pouring"
        ok = n_pour > len(failed) / 2 if failed else None
    else:
        ours = "success not known"
    return [
        _row(
            "13 of the 14 unsuccessful trials were multi-step",
            ours,
            ok,
            "most failures in the multi-step task",
        )
    ]


def _alpha_sd(trials: Sequence[TrialMetrics], paradigm: str) -> float:
    """The standard deviation of the analysed ``paradigm`` trials' mean alpha."""
    return float(
        np.std(
            [
                m.mean_alpha
                for m in select_trials(trials)
                if m.record.paradigm == paradigm and m.mean_alpha is not None
            ]
        )
    )


def _alpha(ev: _Evidence) -> list[Row]:
    t = ev.test("mean_alpha", "all", "all")
    ok: bool | None = None
    if t is not None:
        sa, sb = _alpha_sd(ev.trials, "manual"), _alpha_sd(ev.trials, "disambiguation")
        ours = (
            f"Disambiguation {fmt(t['mean_b'])} +/- {fmt(sb)} vs "
            f"Manual {fmt(t['mean_a'])} +/- {fmt(sa)}, {_p(t)}"
        )
        ok = None if t["p_value"] is None else t["mean_b"] > t["mean_a"] and t["p_value"] >= 0.05
    else:
        ours = "no data"
    return [
        _row(
            "alpha higher with Disambiguation (0.27 +/- 0.16 vs 0.25 +/- 0.16), not significant",
            ours,
            ok,
            "higher mean alpha with Disambiguation, p >= 0.05",
        )
    ]


def _skewness_of(trials: Sequence[TrialMetrics], interface: str, task: str) -> float | None:
    """The request-time skewness of the analysed Disambiguation trials of ``interface`` and ``task``."""
    sel = [m for m in select_trials(trials, interface, task) if m.record.paradigm == "disambiguation"]
    return request_time_skewness(sel)


def _skewness(ev: _Evidence) -> list[Row]:
    rows = []
    for (interface, task), paper in PAPER_SKEWNESS.items():
        s = _skewness_of(ev.trials, interface, task)
        rows.append(
            _row(
                f"Request-time skewness {INTERFACE_NAMES[interface]}, {TASK_NAMES[task]}: "
                f"{paper:.2f} (requests early)",
                fmt(s),
                None if s is None else s > 0,
                "positive skewness (requests concentrated early)",
            )
        )
    return rows


def _head_array_less_skewed(ev: _Evidence) -> list[Row]:
    tasks = ("reaching", "pouring")
    pairs = [
        (_skewness_of(ev.trials, "head_array", k), _skewness_of(ev.trials, "joystick", k)) for k in tasks
    ]
    return [
        _row(
            "Head-array requests less skewed than joystick requests (both tasks)",
            ", ".join(
                f"{k}: head array {fmt(h)} vs joystick {fmt(j)}"
                for k, (h, j) in zip(tasks, pairs, strict=True)
            ),
            None if any(h is None or j is None for h, j in pairs) else all(h < j for h, j in pairs),
            "head-array skewness below joystick skewness for both tasks",
        )
    ]


def _more_requests(ev: _Evidence) -> list[Row]:
    req = {}
    for key in ("joystick", "head_array", "reaching", "pouring"):
        sel = select_trials(ev.trials, *((key, "all") if key in INTERFACE_NAMES else ("all", key)))
        v = [m.requests for m in sel if m.record.paradigm == "disambiguation"]
        req[key] = float(np.mean(v)) if v else None
    return [
        _row(
            "More requests with the more limited interface and the more complex task",
            f"mean requests: head array {fmt(req['head_array'])} vs joystick {fmt(req['joystick'])}; "
            f"pouring {fmt(req['pouring'])} vs reaching {fmt(req['reaching'])}",
            None
            if None in req.values()
            else req["head_array"] > req["joystick"] and req["pouring"] > req["reaching"],
            "more requests with the head array and with pouring",
        )
    ]


def _manual_switches(ev: _Evidence) -> list[Row]:
    rows = []
    for (interface, task), paper in PAPER_MANUAL_SWITCHES.items():
        v = [
            m.mode_switches
            for m in select_trials(ev.trials, interface, task)
            if m.record.paradigm == "manual"
        ]
        ok: bool | None = None
        if v:
            mean = float(np.mean(v))
            ours, ok = f"{mean:.2f} (ratio {mean / paper:.2f})", abs(mean / paper - 1) <= WITHIN
        else:
            ours = "no Manual trials"
        rows.append(
            _row(
                f"Manual user mode switches, {INTERFACE_NAMES[interface]}, {TASK_NAMES[task]}: {paper:.2f} "
                "(8 subjects, data README)",
                ours,
                ok,
                "within 50 %",
            )
        )
    return rows


FINDINGS: tuple[Finding, ...] = (
    _fewer_with_disambiguation(
        "button_presses",
        "head_array",
        "Head array: significantly fewer button presses with Disambiguation than Manual",
        "fewer with Disambiguation and p < 0.05 (rank-sum, both tasks)",
    ),
    _fewer_with_disambiguation(
        "mode_switches",
        "joystick",
        "Joystick: significantly fewer user mode switches with Disambiguation (p < 0.05)",
        "fewer with Disambiguation and p < 0.05",
    ),
    _joystick_presses,
    _decrease_by_task,
    _completion_time,
    _success,
    _failures,
    _alpha,
    _skewness,
    _head_array_less_skewed,
    _more_requests,
    _manual_switches,
)
"""The paper's findings in the order of the table: each a function of the evidence giving its rows."""


def findings(
    trials: Sequence[TrialMetrics], tests: Sequence[dict[str, Any]], source: str
) -> list[dict[str, str]]:
    """The table "the paper's finding / ours / agree?": one row per result of the paper's
    Section "Results" (and the data README's manual means, :data:`FINDINGS`), each computed from
    ``trials`` of ``source`` with the criterion used for "agree"."""
    evidence = _Evidence(trials, tests, source)
    return [row for finding in FINDINGS for row in finding(evidence)]


# ----------------------------------------------------------------------------------------------
# Comparison with another folder


COMPARED = ("mean_mode_switches", "mean_requests", "mean_button_presses", "mean_completion_time")


def compare_summaries(
    ours: Sequence[dict[str, Any]], other: Sequence[dict[str, Any]]
) -> list[dict[str, Any]]:
    """Per interface, task and paradigm in both: each of :data:`COMPARED` here and there, the ratio
    (here / there) and ``within`` (ratio within 50 %, None where undefined)."""

    def index(rows: Sequence[dict[str, Any]]) -> dict[tuple[str, str, str], dict[str, Any]]:
        out: dict[tuple[str, str, str], dict[str, Any]] = {}
        for r in rows:
            out.setdefault((r["interface"], r["task"], r["paradigm"]), r)
        return out

    a, b = index(ours), index(other)
    result = []
    for key in sorted(set(a) & set(b)):
        ra, rb = a[key], b[key]
        row: dict[str, Any] = {
            "interface": key[0],
            "task": key[1],
            "paradigm": key[2],
            "source": ra["source"],
            "other_source": rb["source"],
        }
        for name in COMPARED:
            x, y = ra.get(name), rb.get(name)
            ratio = x / y if x is not None and y not in (None, 0) else None
            row[name] = x
            row[f"other_{name}"] = y
            row[f"ratio_{name}"] = ratio
            row[f"within_{name}"] = None if ratio is None else abs(ratio - 1) <= WITHIN
        result.append(row)
    return result
