"""``study report``: the paper's analysis of a study folder, as a self-contained HTML page.

:func:`write_report` reads ``DIR/trials.jsonl`` (and ``DIR/traces/``) and writes, in
``DIR/report/`` only:

- ``summary.json``: :func:`drake_disamb.study.metrics.summarize` (one object per source,
  interface, task and paradigm);
- ``stats.json``: :func:`drake_disamb.study.stats.run_tests`;
- the figures as PNG (matplotlib, Agg): ``button_presses.png`` (the paper's figure: by interface
  and by task, with the rank-sum test's stars), ``switches_requests.png`` (mean user mode switches
  and requests stacked), ``completion_times.png``, ``raster.png`` (every button press of every
  trial on normalised trial time, per subject), ``alpha.png`` (per-trial mean alpha),
  ``traces_<interface>_<task>_<paradigm>.png`` (one example goal-probability trace per condition
  from ``traces/``); with several sources in the folder each figure is drawn per source
  (``<name>_<source>.png``);
- ``index.html``: every table (summary, skewness, tests, "the paper's finding / ours / agree?")
  and every figure embedded as base64 PNG; no network, no script.

``--compare OTHER_DIR`` adds ``compare.json`` and a section setting this folder's means beside
the other's per interface, task and paradigm, with their ratio and whether it is within 50 %
(issue 13's acceptance for simulated versus human users).

On an ablation folder (``DIR/ablation.json``, written by ``study ablate``), :func:`write_report`
writes the combined report instead: for every setting, the paradigm effect on button presses
and completion time with its rank-sum test (``stats.json`` and ``summary.json`` rows carry a
``setting`` field).

Nothing outside ``DIR/report/`` is written; bad records stop the report with
:class:`drake_disamb.study.records.RecordError` naming the file and line.
"""

from __future__ import annotations

import base64
import html
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from drake_disamb.study.metrics import TrialMetrics, request_time_skewness, summarize, trial_metrics
from drake_disamb.study.records import RecordError, TrialRecord, read_records
from drake_disamb.study.stats import MIXED_METRICS, run_tests

__all__ = [
    "PAPER_MANUAL_SWITCHES",
    "PAPER_SKEWNESS",
    "ReportFiles",
    "compare_summaries",
    "findings",
    "load_study",
    "write_report",
]

PARADIGMS = ("manual", "disambiguation", "automatic")
PARADIGM_COLORS = {"manual": "#9e9e9e", "disambiguation": "#1f77b4", "automatic": "#2ca02c"}
INTERFACE_NAMES = {"joystick": "Joystick", "head_array": "Head array", "all": "both interfaces"}
TASK_NAMES = {"reaching": "Single-step (reaching)", "pouring": "Multi-step (pouring)", "all": "both tasks"}

PAPER_SKEWNESS = {
    ("joystick", "reaching"): 0.63,
    ("joystick", "pouring"): 0.57,
    ("head_array", "reaching"): 0.35,
    ("head_array", "pouring"): 0.22,
}
"""The paper's request-time skewness (Table "skewness", FACTS section 9)."""

PAPER_MANUAL_SWITCHES = {
    ("joystick", "reaching"): 2.38,
    ("joystick", "pouring"): 6.88,
    ("head_array", "reaching"): 14.30,
    ("head_array", "pouring"): 34.48,
}
"""Manual user-mode-switch means over the paper's 8 subjects (data README)."""

WITHIN = 0.5
"""``--compare`` flags a ratio outside ``[1 - WITHIN, 1 + WITHIN]`` (issue 13: within 50 %)."""


def load_study(folder: str | Path) -> list[TrialRecord]:
    """The records of ``folder/trials.jsonl``.

    Raises:
        RecordError: The folder or file is missing, empty, or has a bad line (file and line named).
    """
    folder = Path(folder)
    path = folder / "trials.jsonl"
    if not folder.is_dir():
        raise RecordError(f"{folder}: no such study folder")
    if not path.is_file():
        raise RecordError(f"{path}: no records (the study folder has no trials.jsonl)")
    records = read_records(path)
    if not records:
        raise RecordError(f"{path}: no records (the file is empty)")
    return records


@dataclass
class ReportFiles:
    """What :func:`write_report` wrote."""

    index: Path
    figures: list[Path]
    stats: Path
    summary: Path


# ----------------------------------------------------------------------------------------------
# Figures


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig: Any, path: Path) -> Path:
    plt = _plt()
    try:
        fig.savefig(path, dpi=100)
    finally:
        plt.close(fig)
    return path


def _select(trials: Sequence[TrialMetrics], interface: str = "all", task: str = "all") -> list[TrialMetrics]:
    return [
        m
        for m in trials
        if m.record.valid
        and (interface == "all" or m.record.interface == interface)
        and (task == "all" or m.record.task == task)
    ]


def _paradigms(trials: Sequence[TrialMetrics]) -> list[str]:
    present = {m.record.paradigm for m in trials}
    return [p for p in PARADIGMS if p in present]


def _find_test(
    tests: Sequence[dict[str, Any]], metric: str, interface: str, task: str, a: str, b: str, source: str
) -> dict[str, Any] | None:
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


def _box_panels(
    trials: Sequence[TrialMetrics],
    tests: Sequence[dict[str, Any]],
    metric: str,
    ylabel: str,
    source: str,
    title: str,
) -> Any:
    """Boxes of ``metric`` per paradigm, grouped by interface (left) and by task (right), with the
    rank-sum stars of every pair of paradigms (bracket over the pair)."""
    plt = _plt()
    paradigms = _paradigms(trials)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    width = 0.8 / max(1, len(paradigms))
    for ax, (kind, groups) in zip(
        axes, (("interface", ("joystick", "head_array")), ("task", ("reaching", "pouring"))), strict=True
    ):
        top = 0.0
        for gi, group in enumerate(groups):
            sel = _select(trials, **{kind: group})
            xs = {}
            for pi, paradigm in enumerate(paradigms):
                values = [m.value(metric) for m in sel if m.record.paradigm == paradigm]
                values = [v for v in values if v is not None]
                x = gi + (pi - (len(paradigms) - 1) / 2) * width
                xs[paradigm] = x
                if not values:
                    continue
                top = max(top, max(values))
                bp = ax.boxplot(values, positions=[x], widths=width * 0.8, patch_artist=True, whis=(0, 100))
                for box in bp["boxes"]:
                    box.set_facecolor(PARADIGM_COLORS[paradigm])
                    box.set_alpha(0.75)
                ax.plot(x, np.mean(values), marker="D", color="k", markersize=4)
            level = 0
            for a, b in (
                ("manual", "disambiguation"),
                ("manual", "automatic"),
                ("disambiguation", "automatic"),
            ):
                interface, task = (group, "all") if kind == "interface" else ("all", group)
                t = _find_test(tests, metric, interface, task, a, b, source)
                if t is None or a not in xs or b not in xs:
                    continue
                t_top = (
                    max((m.value(metric) or 0.0) for m in sel if m.record.paradigm in (a, b)) if sel else 0.0
                )
                y = t_top * (1.08 + 0.1 * level) + 0.5
                ax.plot([xs[a], xs[a], xs[b], xs[b]], [y * 0.98, y, y, y * 0.98], color="k", lw=1)
                ax.text((xs[a] + xs[b]) / 2, y, t["stars"], ha="center", va="bottom", fontsize=11)
                top = max(top, y * 1.1)
                level += 1
        ax.set_xticks(range(len(groups)))
        ax.set_xticklabels([INTERFACE_NAMES.get(g, TASK_NAMES.get(g, g)) for g in groups])
        ax.set_title(f"grouped by {kind}")
        ax.set_ylim(0, max(1.0, top * 1.08))
        ax.grid(axis="y", alpha=0.3)
    axes[0].set_ylabel(ylabel)
    handles = [plt.Rectangle((0, 0), 1, 1, color=PARADIGM_COLORS[p], alpha=0.75) for p in paradigms]
    axes[1].legend(handles, [p.capitalize() for p in paradigms], loc="upper left", fontsize=8)
    fig.suptitle(
        title + "  (boxes: full range and quartiles, diamond: mean; stars: rank-sum test)", fontsize=10
    )
    fig.tight_layout()
    return fig


def _stacked(trials: Sequence[TrialMetrics], source: str) -> Any:
    plt = _plt()
    paradigms = _paradigms(trials)
    groups = [(i, t) for i in ("joystick", "head_array") for t in ("reaching", "pouring")]
    fig, ax = plt.subplots(figsize=(11, 4.2))
    width = 0.8 / max(1, len(paradigms))
    for gi, (interface, task) in enumerate(groups):
        sel = _select(trials, interface, task)
        for pi, paradigm in enumerate(paradigms):
            ms = [m for m in sel if m.record.paradigm == paradigm]
            if not ms:
                continue
            x = gi + (pi - (len(paradigms) - 1) / 2) * width
            sw = float(np.mean([m.mode_switches for m in ms]))
            rq = float(np.mean([m.requests for m in ms]))
            au = float(np.mean([m.record.automatic_switches for m in ms]))
            color = PARADIGM_COLORS[paradigm]
            ax.bar(x, sw, width * 0.9, color=color, alpha=0.75, edgecolor="k")
            ax.bar(x, rq, width * 0.9, bottom=sw, color="#d62728", alpha=0.8, edgecolor="k")
            if au > 0:
                ax.bar(x, au, width * 0.9, bottom=sw + rq, color="white", hatch="//", edgecolor="k")
    ax.set_xticks(range(len(groups)))
    ax.set_xticklabels([f"{INTERFACE_NAMES[i]}\n{TASK_NAMES[t]}" for i, t in groups])
    ax.set_ylabel("mean per trial (after the authors' cleaning)")
    ax.margins(y=0.12)
    handles = [plt.Rectangle((0, 0), 1, 1, color=PARADIGM_COLORS[p], alpha=0.75) for p in paradigms]
    labels = [f"user mode switches ({p})" for p in paradigms]
    handles += [plt.Rectangle((0, 0), 1, 1, color="#d62728", alpha=0.8)]
    labels += ["disambiguation requests"]
    if any(m.record.automatic_switches for m in trials):
        handles += [plt.Rectangle((0, 0), 1, 1, facecolor="white", hatch="//", edgecolor="k")]
        labels += ["automatic switches (not button presses)"]
    ax.legend(handles, labels, fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    ax.set_title(f"Mode switches and requests stacked ({source})", fontsize=10)
    fig.tight_layout()
    return fig


def _raster(trials: Sequence[TrialMetrics], source: str) -> Any:
    plt = _plt()
    fig, axes = plt.subplots(2, 2, figsize=(12, 8), sharex=True)
    for row, interface in enumerate(("joystick", "head_array")):
        for col, task in enumerate(("reaching", "pouring")):
            ax = axes[row, col]
            sel = sorted(
                _select(trials, interface, task),
                key=lambda m: (m.record.subject, m.record.paradigm, m.record.repetition, m.record.trial_id),
            )
            y = 0
            ticks, labels, last = [], [], None
            for m in sel:
                r = m.record
                if r.subject != last:
                    if last is not None:
                        ax.axhline(y - 0.5, color="k", lw=0.6)
                    ticks.append(y)
                    labels.append(r.subject)
                    last = r.subject
                ax.axhline(y, color="#dddddd", lw=0.8, zorder=0)
                d = r.duration or 1.0
                sw = [t / d for t in r.mode_switch_times]
                rq = [t / d for t in r.request_times]
                ax.plot(sw, [y] * len(sw), "|", color="k", markersize=5)
                ax.plot(rq, [y] * len(rq), "o", color="#d62728", markersize=3)
                if r.paradigm != "manual":
                    ax.plot(-0.02, y, ">", color=PARADIGM_COLORS[r.paradigm], markersize=3)
                y += 1
            ax.set_yticks(ticks)
            ax.set_yticklabels(labels, fontsize=7)
            ax.set_xlim(-0.04, 1.02)
            ax.invert_yaxis()
            ax.set_title(f"{INTERFACE_NAMES[interface]}, {TASK_NAMES[task]}", fontsize=9)
    for ax in axes[1]:
        ax.set_xlabel("time / trial duration")
    fig.suptitle(
        f"Button presses per trial ({source}): black | user mode switch, red dot request; "
        "a triangle marks a Disambiguation / Automatic trial",
        fontsize=9,
    )
    fig.tight_layout()
    return fig


def _alpha(trials: Sequence[TrialMetrics], source: str) -> Any:
    plt = _plt()
    paradigms = _paradigms(trials)
    groups = [(i, t) for i in ("joystick", "head_array") for t in ("reaching", "pouring")]
    fig, ax = plt.subplots(figsize=(11, 4))
    width = 0.8 / max(1, len(paradigms))
    for gi, (interface, task) in enumerate(groups):
        sel = _select(trials, interface, task)
        for pi, paradigm in enumerate(paradigms):
            v = [m.mean_alpha for m in sel if m.record.paradigm == paradigm and m.mean_alpha is not None]
            if not v:
                continue
            x = gi + (pi - (len(paradigms) - 1) / 2) * width
            if len(set(v)) < 2:  # no spread for a density: the values as points
                ax.plot([x] * len(v), v, "o", color=PARADIGM_COLORS[paradigm])
                continue
            parts = ax.violinplot([v], positions=[x], widths=width * 0.9, showmeans=True)
            for body in parts["bodies"]:
                body.set_facecolor(PARADIGM_COLORS[paradigm])
                body.set_alpha(0.7)
            for name in ("cmeans", "cmins", "cmaxes", "cbars"):
                parts[name].set_color("k")
                parts[name].set_linewidth(0.8)
    ax.set_xticks(range(len(groups)))
    ax.set_xticklabels([f"{INTERFACE_NAMES[i]}\n{TASK_NAMES[t]}" for i, t in groups])
    ax.set_ylabel("mean alpha per trial")
    handles = [plt.Rectangle((0, 0), 1, 1, color=PARADIGM_COLORS[p], alpha=0.7) for p in paradigms]
    ax.legend(handles, [p.capitalize() for p in paradigms], fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    ax.set_title(
        f"Distribution of the per-trial mean blending factor alpha ({source}; bar: mean, whiskers: range)",
        fontsize=10,
    )
    fig.tight_layout()
    return fig


def _trace_figures(folder: Path, trials: Sequence[TrialMetrics], out: Path, suffix: str) -> list[Path]:
    """One goal-probability figure per condition: its first valid trial that has a trace."""
    from drake_disamb.plotting import goal_probability_figure

    written = []
    seen: set[tuple[str, str, str]] = set()
    for m in sorted(
        trials, key=lambda m: (m.record.interface, m.record.task, m.record.paradigm, m.record.trial_id)
    ):
        r = m.record
        key = (r.interface, r.task, r.paradigm)
        path = folder / "traces" / f"{r.trial_id}.npz"
        if key in seen or not r.valid or not path.is_file():
            continue
        try:
            with np.load(path) as z:
                t, belief = np.asarray(z["t"], dtype=float), np.asarray(z["belief"], dtype=float)
                u_h = np.asarray(z["u_h"], dtype=float) if "u_h" in z.files else None
        except (OSError, ValueError, KeyError):
            continue  # an unreadable trace is left out of the examples, not fatal
        if belief.ndim != 2 or len(t) != len(belief) or len(t) < 2:
            continue
        n = belief.shape[1]
        intended = r.intended_goals[0] if len(r.intended_goals) == 1 and r.intended_goals[0] < n else None
        fig = goal_probability_figure(
            t,
            belief,
            rho1=1.2 / n,
            request_times=r.request_times,
            mode_switch_times=r.mode_switch_times,
            intended_goal=intended,
            # The authors' u_h has no time stamps of its own (and another length): not drawn.
            command_times=t if u_h is not None and len(u_h) == len(t) else None,
            commands=u_h if u_h is not None and len(u_h) == len(t) else None,
            end_time=r.duration,
            title=f"{r.trial_id}: {INTERFACE_NAMES[r.interface]}, {r.task}, {r.paradigm} ({r.source})",
        )
        written.append(_save(fig, out / f"traces_{r.interface}_{r.task}_{r.paradigm}{suffix}.png"))
        seen.add(key)
    return written


# ----------------------------------------------------------------------------------------------
# The paper's findings


def _fmt(v: float | None, digits: int = 2) -> str:
    return "n/a" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.{digits}f}"


def _p(t: dict[str, Any] | None) -> str:
    if t is None or t["p_value"] is None:
        return "no test"
    return f"p = {t['p_value']:.3g} {t['stars']}"


def _verdict(ok: bool | None) -> str:
    return "n/a" if ok is None else ("yes" if ok else "no")


def findings(
    trials: Sequence[TrialMetrics], tests: Sequence[dict[str, Any]], source: str
) -> list[dict[str, str]]:
    """The table "the paper's finding / ours / agree?": one row per result of FACTS section 9 (and
    the data README's manual means), each computed from ``trials`` of ``source`` with the
    criterion used for "agree"."""
    rows: list[dict[str, str]] = []

    def add(paper: str, ours: str, ok: bool | None, criterion: str) -> None:
        rows.append({"paper": paper, "ours": ours, "agree": _verdict(ok), "criterion": criterion})

    def test(metric: str, interface: str, task: str) -> dict[str, Any] | None:
        return _find_test(tests, metric, interface, task, "manual", "disambiguation", source)

    def means(t: dict[str, Any] | None) -> str:
        return "no data" if t is None else f"Manual {_fmt(t['mean_a'])} vs Disambiguation {_fmt(t['mean_b'])}"

    t = test("button_presses", "head_array", "all")
    add(
        "Head array: significantly fewer button presses with Disambiguation than Manual",
        f"{means(t)}, {_p(t)}",
        None if t is None or t["p_value"] is None else t["mean_b"] < t["mean_a"] and t["p_value"] < 0.05,
        "fewer with Disambiguation and p < 0.05 (rank-sum, both tasks)",
    )
    t = test("mode_switches", "joystick", "all")
    add(
        "Joystick: significantly fewer user mode switches with Disambiguation (p < 0.05)",
        f"{means(t)}, {_p(t)}",
        None if t is None or t["p_value"] is None else t["mean_b"] < t["mean_a"] and t["p_value"] < 0.05,
        "fewer with Disambiguation and p < 0.05",
    )
    t = test("button_presses", "joystick", "all")
    add(
        "Joystick: the gain is offset by the requests (no significant decrease in button presses)",
        f"button presses {means(t)}, {_p(t)}",
        None
        if t is None or t["p_value"] is None
        else not (t["mean_b"] < t["mean_a"] and t["p_value"] < 0.05),
        "no significant decrease in button presses",
    )
    tr, tp = test("button_presses", "all", "reaching"), test("button_presses", "all", "pouring")
    if tr is not None and tp is not None:
        dr, dp = tr["mean_a"] - tr["mean_b"], tp["mean_a"] - tp["mean_b"]
        ours = (
            f"decrease Manual - Disambiguation: pouring {_fmt(dp)} ({_fmt(100 * dp / tp['mean_a'], 0)} %, "
            f"{_p(tp)}), reaching {_fmt(dr)} ({_fmt(100 * dr / tr['mean_a'], 0)} %, {_p(tr)})"
            if tp["mean_a"] and tr["mean_a"]
            else f"decrease pouring {_fmt(dp)}, reaching {_fmt(dr)}"
        )
        ok: bool | None = dp > dr
    else:
        ours, ok = "no data for both tasks", None
    add(
        "The decrease in button presses is larger for the multi-step task",
        ours,
        ok,
        "mean decrease (both interfaces) larger for pouring than for reaching",
    )
    parts, sig, seen = [], False, False
    for interface, task in (
        ("joystick", "all"),
        ("head_array", "all"),
        ("all", "reaching"),
        ("all", "pouring"),
    ):
        t = test("completion_time", interface, task)
        if t is None or t["p_value"] is None:
            continue
        seen = True
        sig = sig or t["p_value"] < 0.05
        name = INTERFACE_NAMES[interface] if task == "all" else TASK_NAMES[task]
        parts.append(f"{name}: {_fmt(t['mean_a'], 1)} s vs {_fmt(t['mean_b'], 1)} s, {_p(t)}")
    add(
        "No significant difference in completion time between Manual and Disambiguation",
        "; ".join(parts) or "no data",
        (not sig) if seen else None,
        "no rank-sum p < 0.05 by interface or by task",
    )
    rate = {}
    for paradigm in ("disambiguation", "manual"):
        known = [m.success for m in trials if m.record.paradigm == paradigm and m.success is not None]
        rate[paradigm] = (sum(known), len(known))
    if all(n for _, n in rate.values()):
        (sd, nd), (sm, nm) = rate["disambiguation"], rate["manual"]
        ours = f"Disambiguation {100 * sd / nd:.2f} % ({sd}/{nd}) vs Manual {100 * sm / nm:.2f} % ({sm}/{nm})"
        ok = sd / nd <= sm / nm
    else:
        ours, ok = "success not known for both paradigms", None
    add(
        "Success 92.50 % (148/160) with Disambiguation vs 97.92 % (94/96) Manual",
        ours,
        ok,
        "success rate not higher with Disambiguation",
    )
    failed = [m for m in trials if m.success is False]
    if [m for m in trials if m.success is not None]:
        n_pour = sum(1 for m in failed if m.record.task == "pouring")
        ours, ok = (
            f"{n_pour} of {len(failed)} unsuccessful trials in pouring",
            (n_pour > len(failed) / 2 if failed else None),
        )
    else:
        ours, ok = "success not known", None
    add("13 of the 14 unsuccessful trials were multi-step", ours, ok, "most failures in the multi-step task")
    t = test("mean_alpha", "all", "all")
    if t is not None:
        sa = np.std(
            [
                m.mean_alpha
                for m in _select(trials)
                if m.record.paradigm == "manual" and m.mean_alpha is not None
            ]
        )
        sb = np.std(
            [
                m.mean_alpha
                for m in _select(trials)
                if m.record.paradigm == "disambiguation" and m.mean_alpha is not None
            ]
        )
        ours = (
            f"Disambiguation {_fmt(t['mean_b'])} +/- {_fmt(float(sb))} vs "
            f"Manual {_fmt(t['mean_a'])} +/- {_fmt(float(sa))}, {_p(t)}"
        )
        ok = None if t["p_value"] is None else t["mean_b"] > t["mean_a"] and t["p_value"] >= 0.05
    else:
        ours, ok = "no data", None
    add(
        "alpha higher with Disambiguation (0.27 +/- 0.16 vs 0.25 +/- 0.16), not significant",
        ours,
        ok,
        "higher mean alpha with Disambiguation, p >= 0.05",
    )
    skew = {}
    for (interface, task), paper in PAPER_SKEWNESS.items():
        sel = [m for m in _select(trials, interface, task) if m.record.paradigm == "disambiguation"]
        skew[(interface, task)] = s = request_time_skewness(sel)
        add(
            f"Request-time skewness {INTERFACE_NAMES[interface]}, {TASK_NAMES[task]}: "
            f"{paper:.2f} (requests early)",
            _fmt(s),
            None if s is None else s > 0,
            "positive skewness (requests concentrated early)",
        )
    pairs = [(skew[("head_array", k)], skew[("joystick", k)]) for k in ("reaching", "pouring")]
    add(
        "Head-array requests less skewed than joystick requests (both tasks)",
        ", ".join(
            f"{k}: head array {_fmt(h)} vs joystick {_fmt(j)}"
            for k, (h, j) in zip(("reaching", "pouring"), pairs, strict=True)
        ),
        None if any(h is None or j is None for h, j in pairs) else all(h < j for h, j in pairs),
        "head-array skewness below joystick skewness for both tasks",
    )
    req = {}
    for key in ("joystick", "head_array", "reaching", "pouring"):
        sel = _select(trials, key, "all") if key in INTERFACE_NAMES else _select(trials, "all", key)
        v = [m.requests for m in sel if m.record.paradigm == "disambiguation"]
        req[key] = float(np.mean(v)) if v else None
    add(
        "More requests with the more limited interface and the more complex task",
        f"mean requests: head array {_fmt(req['head_array'])} vs joystick {_fmt(req['joystick'])}; "
        f"pouring {_fmt(req['pouring'])} vs reaching {_fmt(req['reaching'])}",
        None
        if None in req.values()
        else req["head_array"] > req["joystick"] and req["pouring"] > req["reaching"],
        "more requests with the head array and with pouring",
    )
    for (interface, task), paper in PAPER_MANUAL_SWITCHES.items():
        v = [m.mode_switches for m in _select(trials, interface, task) if m.record.paradigm == "manual"]
        if v:
            mean = float(np.mean(v))
            ours, ok = f"{mean:.2f} (ratio {mean / paper:.2f})", abs(mean / paper - 1) <= WITHIN
        else:
            ours, ok = "no Manual trials", None
        add(
            f"Manual user mode switches, {INTERFACE_NAMES[interface]}, {TASK_NAMES[task]}: {paper:.2f} "
            "(8 subjects, data README)",
            ours,
            ok,
            "within 50 %",
        )
    return rows


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


# ----------------------------------------------------------------------------------------------
# HTML

_CSS = """
body { font-family: sans-serif; max-width: 1200px; margin: 1em auto; padding: 0 1em; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.85em; }
th, td { border: 1px solid #bbb; padding: 3px 6px; text-align: left; vertical-align: top; }
th { background: #eee; }
td.yes { background: #dff0d8; } td.no { background: #f2dede; }
img { max-width: 100%; border: 1px solid #ddd; margin: 0.3em 0; }
.note { color: #555; font-size: 0.9em; }
div.wide { overflow-x: auto; }
"""


def _table(
    rows: Sequence[dict[str, Any]], columns: Sequence[str], headers: Sequence[str] | None = None
) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in (headers or columns))
    body = []
    for r in rows:
        cells = []
        for c in columns:
            v = r.get(c)
            text = _fmt(v, 3) if isinstance(v, float) else ("n/a" if v is None else str(v))
            cls = f' class="{v}"' if c == "agree" and v in ("yes", "no") else ""
            if isinstance(v, bool):
                cls = f' class="{"yes" if v else "no"}"'
            cells.append(f"<td{cls}>{html.escape(text)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f'<div class="wide"><table><tr>{head}</tr>{"".join(body)}</table></div>'


def _img(path: Path, alt: str) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f'<p><img src="data:image/png;base64,{data}" alt="{html.escape(alt)}"></p>'


def _page(title: str, sections: Sequence[str]) -> str:
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>"
        f"<h1>{html.escape(title)}</h1>" + "\n".join(sections) + "</body></html>\n"
    )


def _write_json(path: Path, data: Any) -> None:
    path.write_text(json.dumps(data, indent=1, allow_nan=False) + "\n", encoding="utf-8")


def _report_dir(folder: Path) -> Path:
    out = folder / "report"
    try:
        out.mkdir(exist_ok=True)
    except OSError as err:
        raise RecordError(f"{out}: cannot create the report folder: {err.strerror or err}") from None
    return out


SUMMARY_COLUMNS = (
    "source",
    "interface",
    "task",
    "paradigm",
    "n_trials",
    "n_valid",
    "n_subjects",
    "mean_mode_switches",
    "mean_requests",
    "mean_button_presses",
    "mean_completion_time",
    "success_rate",
    "request_time_skewness",
    "mean_alpha",
    "mean_assistance_onset",
    "mean_automatic_switches",
    "mean_mode_switches_raw",
    "mean_requests_raw",
    "mean_button_presses_raw",
)
TEST_COLUMNS = (
    "source",
    "metric",
    "interface",
    "task",
    "a",
    "b",
    "n_a",
    "n_b",
    "mean_a",
    "mean_b",
    "statistic",
    "p_value",
    "stars",
    "effect_size",
    "ci_low",
    "ci_high",
)
MAIN_METRICS = ("button_presses", "mode_switches", "requests", "completion_time", "mean_alpha")


def _json_clean(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """NaN / inf -> None, so the JSON is strict."""
    return [
        {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()}
        for r in rows
    ]


def write_report(
    folder: str | Path, compare: str | Path | None = None, mixed_model: bool = True
) -> ReportFiles:
    """Write the report of ``folder`` (or the combined ablation report) into ``folder/report/``.

    Args:
        folder: A study folder (``trials.jsonl``, ``traces/``) or an ablation folder
            (``ablation.json``).
        compare: Another study folder whose means are set beside this one's.
        mixed_model: Fit the per-subject mixed model (:data:`stats.MIXED_METRICS`; about half a
            second per test); the signed-rank check on subject means is always made.

    Raises:
        RecordError: No records, a bad line or an unreadable folder (file and line named).
    """
    folder = Path(folder)
    if (folder / "ablation.json").is_file():
        return _write_ablation_report(folder)
    records = load_study(folder)
    other = load_study(compare) if compare is not None else None
    out = _report_dir(folder)
    trials = [trial_metrics(r) for r in records]
    summary = _json_clean(summarize(records))
    tests = _json_clean(run_tests(records, mixed_metrics=MIXED_METRICS if mixed_model else ()))
    _write_json(out / "summary.json", summary)
    _write_json(out / "stats.json", tests)
    sources = sorted({r.source for r in records})
    figures: list[Path] = []
    sections = [
        f'<p class="note">{len(records)} trials from '
        f"<code>{html.escape(str(folder / 'trials.jsonl'))}</code>; "
        f"sources: {', '.join(sources)}"
        + (" (a mix: every table and figure is per source)" if len(sources) > 1 else "")
        + ". Means over valid trials, after the authors' cleaning (requests less than 3 s apart merged, "
        "repeated joystick presses into the same mode within 2 s dropped); raw means in the *_raw columns. "
        "Tests: two-sided Wilcoxon rank-sum over trials (scipy mannwhitneyu); "
        "*** p &lt; 0.001, ** p &lt; 0.01, "
        "* p &lt; 0.05.</p>",
        "<h2>Summary</h2>",
        _table(summary, SUMMARY_COLUMNS),
    ]
    for source in sources:
        mine = [m for m in trials if m.record.source == source]
        suffix = "" if len(sources) == 1 else f"_{source}"
        sections.append(f"<h2>The paper's findings: the paper / ours ({html.escape(source)}) / agree?</h2>")
        sections.append(
            _table(
                findings(mine, tests, source),
                ("paper", "ours", "agree", "criterion"),
                ("the paper's finding", "ours", "agree?", "criterion"),
            )
        )
        skew_rows = []
        for interface in ("joystick", "head_array"):
            for task in ("reaching", "pouring"):
                for paradigm in ("disambiguation", "automatic"):
                    sel = [m for m in _select(mine, interface, task) if m.record.paradigm == paradigm]
                    if not sel:
                        continue
                    skew_rows.append(
                        {
                            "interface": interface,
                            "task": task,
                            "paradigm": paradigm,
                            "requests": sum(len(m.normalized_request_times) for m in sel),
                            "skewness": request_time_skewness(sel),
                            "paper": PAPER_SKEWNESS[(interface, task)]
                            if paradigm == "disambiguation"
                            else None,
                        }
                    )
        sections.append(f"<h2>Skewness of request times ({html.escape(source)})</h2>")
        sections.append(
            '<p class="note">Cleaned request times divided by the trial\'s duration, pooled over the valid '
            "trials of a condition; biased sample skewness (MATLAB skewness, scipy.stats.skew).</p>"
        )
        sections.append(_table(skew_rows, ("interface", "task", "paradigm", "requests", "skewness", "paper")))
        for name, fig, caption in (
            (
                "button_presses",
                _box_panels(
                    mine,
                    tests,
                    "button_presses",
                    "button presses per trial",
                    source,
                    f"Button presses ({source})",
                ),
                "Button presses (the paper's figure)",
            ),
            ("switches_requests", _stacked(mine, source), "Mode switches and requests"),
            (
                "completion_times",
                _box_panels(
                    mine,
                    tests,
                    "completion_time",
                    "completion time (s)",
                    source,
                    f"Completion times ({source})",
                ),
                "Completion times",
            ),
            ("raster", _raster(mine, source), "Button-press times per subject"),
            ("alpha", _alpha(mine, source), "Alpha distributions"),
        ):
            path = _save(fig, out / f"{name}{suffix}.png")
            figures.append(path)
            sections.append(f"<h2>{html.escape(caption)} ({html.escape(source)})</h2>")
            sections.append(_img(path, caption))
        traces = _trace_figures(folder, mine, out, suffix)
        figures += traces
        sections.append(f"<h2>Example goal-probability traces ({html.escape(source)})</h2>")
        if not traces:
            sections.append('<p class="note">No traces in traces/ for these trials.</p>')
        for path in traces:
            sections.append(_img(path, path.stem))
    sections.append("<h2>Rank-sum tests (main metrics)</h2>")
    sections.append(
        '<p class="note">effect_size: rank-biserial correlation (positive: a larger), '
        "95 % bootstrap interval; every test, the raw counts and the per-subject checks "
        "(signed-rank on subject means, mixed model with a "
        "random intercept per subject) are in stats.json.</p>"
    )
    sections.append(
        _table([t for t in tests if t["test"] == "ranksum" and t["metric"] in MAIN_METRICS], TEST_COLUMNS)
    )
    per_subject = [
        t
        for t in tests
        if t["test"] != "ranksum"
        and t["metric"] in ("button_presses", "completion_time")
        and t["interface"] != "all"
        and t["task"] == "all"
    ]
    sections.append("<h2>Per-subject checks (button presses, completion time)</h2>")
    sections.append(
        _table(
            per_subject,
            (
                "source",
                "metric",
                "interface",
                "task",
                "a",
                "b",
                "test",
                "n_a",
                "n_b",
                "statistic",
                "p_value",
                "stars",
                "note",
            ),
        )
    )
    if other is not None:
        rows = _json_clean(compare_summaries(summary, _json_clean(summarize(other))))
        _write_json(out / "compare.json", rows)
        sections.append(f"<h2>Compared with {html.escape(str(compare))}</h2>")
        sections.append(
            '<p class="note">Ratio = this folder / the other; flagged (red) outside 50 % '
            "(issue 13's acceptance: "
            "the simulated population's means within 50 % of the people's).</p>"
        )
        cols = ["interface", "task", "paradigm", "source", "other_source"]
        for name in COMPARED:
            cols += [name, f"other_{name}", f"ratio_{name}", f"within_{name}"]
        sections.append(_table(rows, cols))
    index = out / "index.html"
    index.write_text(_page(f"Study report: {folder.name}", sections), encoding="utf-8")
    return ReportFiles(index=index, figures=figures, stats=out / "stats.json", summary=out / "summary.json")


# ----------------------------------------------------------------------------------------------
# Ablations


def _read_ablation(folder: Path) -> list[dict[str, Any]]:
    path = folder / "ablation.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise RecordError(f"{path}: not a readable ablation file: {err}") from None
    if not isinstance(data, dict) or data.get("format") != 1 or not isinstance(data.get("settings"), list):
        raise RecordError(f'{path}: expected {{"format": 1, "settings": [...]}}')
    for i, s in enumerate(data["settings"]):
        if not isinstance(s, dict) or not isinstance(s.get("name"), str) or not isinstance(s.get("dir"), str):
            raise RecordError(
                f"{path}: settings[{i}]: expected an object with string name and dir, got {s!r}"
            )
        if Path(s["dir"]).is_absolute() or ".." in Path(s["dir"]).parts:
            raise RecordError(
                f"{path}: settings[{i}].dir: expected a folder inside {folder}, got {s['dir']!r}"
            )
    return data["settings"]


def _write_ablation_report(folder: Path) -> ReportFiles:
    settings = _read_ablation(folder)
    loaded = [(s, load_study(folder / s["dir"])) for s in settings]
    out = _report_dir(folder)
    tests: list[dict[str, Any]] = []
    summary: list[dict[str, Any]] = []
    for s, records in loaded:
        tag = {"setting": s["name"], "overrides": s.get("overrides", {})}
        summary += [{**tag, **r} for r in _json_clean(summarize(records))]
        tests += [
            {**tag, **t}
            for t in _json_clean(run_tests(records, ("button_presses", "completion_time"), per_subject=False))
        ]
    _write_json(out / "summary.json", summary)
    _write_json(out / "stats.json", tests)
    effect = []
    for t in tests:
        if t["task"] != "all" and t["interface"] != "all":
            continue
        effect.append({**t, "difference": t["mean_b"] - t["mean_a"]})
    figures = [_save(_ablation_figure(effect), out / "ablation_effects.png")]
    sections = [
        f'<p class="note">{len(settings)} settings from '
        f"<code>{html.escape(str(folder / 'ablation.json'))}</code>. "
        "Per setting, the paradigm effect (b minus a, means over valid trials after the authors' "
        "cleaning) on "
        "button presses and completion time, with the two-sided rank-sum test.</p>",
        _img(figures[0], "paradigm effect per setting"),
        "<h2>Paradigm effect per setting</h2>",
        _table(
            effect,
            (
                "setting",
                "metric",
                "interface",
                "task",
                "a",
                "b",
                "n_a",
                "n_b",
                "mean_a",
                "mean_b",
                "difference",
                "p_value",
                "stars",
                "effect_size",
            ),
        ),
        "<h2>Summary per setting</h2>",
        _table(summary, ("setting", *SUMMARY_COLUMNS)),
    ]
    index = out / "index.html"
    index.write_text(_page(f"Ablation report: {folder.name}", sections), encoding="utf-8")
    return ReportFiles(index=index, figures=figures, stats=out / "stats.json", summary=out / "summary.json")


def _ablation_figure(effect: Sequence[dict[str, Any]]) -> Any:
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for ax, metric, unit in zip(axes, ("button_presses", "completion_time"), ("presses", "s"), strict=True):
        rows = [
            r
            for r in effect
            if r["metric"] == metric
            and r["task"] == "all"
            and r["interface"] != "all"
            and (r["a"], r["b"]) == ("manual", "disambiguation")
        ]
        settings = list(dict.fromkeys(r["setting"] for r in rows))
        for k, interface in enumerate(("joystick", "head_array")):
            ys = []
            for s in settings:
                r = next((r for r in rows if r["setting"] == s and r["interface"] == interface), None)
                ys.append((r["difference"], r["stars"]) if r else (math.nan, ""))
            xs = np.arange(len(settings)) + (k - 0.5) * 0.38
            ax.bar(xs, [y for y, _ in ys], 0.36, label=INTERFACE_NAMES[interface])
            for x, (y, st) in zip(xs, ys, strict=True):
                if math.isfinite(y):
                    ax.text(x, y, st, ha="center", va="bottom" if y >= 0 else "top", fontsize=9)
        ax.axhline(0, color="k", lw=0.8)
        ax.margins(y=0.12)
        ax.set_xticks(range(len(settings)))
        ax.set_xticklabels(settings, rotation=20, ha="right", fontsize=8)
        ax.set_ylabel(f"Disambiguation - Manual ({unit}), stars: rank-sum")
        ax.set_title(metric.replace("_", " "))
        ax.legend(fontsize=8)
        ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return fig
