"""The report's figures as PNG (matplotlib, Agg), one function per figure of ``study report``.

:func:`source_figures` draws and saves, for the trials of one source, ``button_presses.png`` (the
paper's figure: by interface and by task, with the rank-sum test's stars), ``switches_requests.png``
(mean user mode switches and requests stacked), ``completion_times.png``, ``raster.png`` (every
button press of every trial on normalised trial time, per subject) and ``alpha.png`` (per-trial
mean alpha); :func:`trace_figures` one goal-probability trace per condition from ``traces/``;
:func:`ablation_figure` the paradigm effect per setting of an ablation folder.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from drake_disamb.config.schema import PARADIGMS
from drake_disamb.interfaces import INTERFACES, interfaces_in
from drake_disamb.study.analysis.findings import INTERFACE_NAMES, TASK_NAMES, find_ranksum, select_trials
from drake_disamb.study.data.records import TrialRecord
from drake_disamb.study.measures.metrics import TrialMetrics

if TYPE_CHECKING:
    from drake_disamb.plotting import BeliefPlot

__all__ = ["ablation_figure", "save_figure", "source_figures", "trace_figures"]

PARADIGM_COLORS = {"manual": "#9e9e9e", "disambiguation": "#1f77b4", "automatic": "#2ca02c"}
TASKS = ("reaching", "pouring")


def _conditions(trials: Sequence[TrialMetrics]) -> list[tuple[str, str]]:
    """The (interface, task) groups of the figures: every registered interface with trials, each
    with both tasks."""
    return [(i, t) for i in _interfaces(trials) for t in TASKS]


def _interfaces(trials: Sequence[TrialMetrics]) -> list[str]:
    """The registered interfaces with trials, in the registry's order (all of them without trials)."""
    return interfaces_in(m.record.interface for m in trials) or list(INTERFACES)


def _plt() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, path: Path) -> Path:
    """Save ``fig`` as PNG at 100 dpi to ``path`` (replaced whole, never written through a
    symlink: :func:`~drake_disamb.study.data.folder.write_atomic`) and close it; returns ``path``."""
    from drake_disamb.study.data.folder import write_atomic

    plt = _plt()
    try:
        write_atomic(path, lambda f: fig.savefig(f, dpi=100, format="png"))
    finally:
        plt.close(fig)
    return path


def _side_by_side(trials: Sequence[TrialMetrics]) -> tuple[list[str], float]:
    """The paradigms of ``trials`` (in :data:`PARADIGMS` order) and the width of one's slot when
    they stand side by side in a group 0.8 wide."""
    present = {m.record.paradigm for m in trials}
    paradigms = [p for p in PARADIGMS if p in present]
    return paradigms, 0.8 / max(1, len(paradigms))


def _slot(group: int, k: int, paradigms: Sequence[str], width: float) -> float:
    """The x of the ``k``-th of ``paradigms`` in the group at x = ``group``."""
    return group + (k - (len(paradigms) - 1) / 2) * width


def _by_condition(
    trials: Sequence[TrialMetrics], paradigms: Sequence[str], width: float
) -> Iterator[tuple[float, str, list[TrialMetrics]]]:
    """(x, paradigm, its analysed trials: valid, not failed) for every condition of
    :func:`_conditions` (groups at x = 0, 1, ...) and every paradigm with trials in it."""
    for gi, (interface, task) in enumerate(_conditions(trials)):
        sel = select_trials(trials, interface, task)
        for pi, paradigm in enumerate(paradigms):
            ms = [m for m in sel if m.record.paradigm == paradigm]
            if ms:
                yield _slot(gi, pi, paradigms, width), paradigm, ms


def _condition_ticks(ax: Any, trials: Sequence[TrialMetrics]) -> None:
    """Label the groups of :func:`_by_condition` on ``ax``'s x axis."""
    conditions = _conditions(trials)
    ax.set_xticks(range(len(conditions)))
    ax.set_xticklabels([f"{INTERFACE_NAMES[i]}\n{TASK_NAMES[t]}" for i, t in conditions])


def _paradigm_handles(plt: Any, paradigms: Sequence[str], alpha: float) -> list[Any]:
    """Legend patches in the colours of ``paradigms``."""
    return [plt.Rectangle((0, 0), 1, 1, color=PARADIGM_COLORS[p], alpha=alpha) for p in paradigms]


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
    paradigms, width = _side_by_side(trials)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True)
    for ax, (kind, groups) in zip(
        axes, (("interface", tuple(_interfaces(trials))), ("task", TASKS)), strict=True
    ):
        top = 0.0
        for gi, group in enumerate(groups):
            sel = select_trials(trials, **{kind: group})
            xs = {}
            for pi, paradigm in enumerate(paradigms):
                values = [m.value(metric) for m in sel if m.record.paradigm == paradigm]
                values = [v for v in values if v is not None]
                x = xs[paradigm] = _slot(gi, pi, paradigms, width)
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
                t = find_ranksum(tests, metric, interface, task, a, b, source)
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
    handles = _paradigm_handles(plt, paradigms, 0.75)
    axes[1].legend(handles, [p.capitalize() for p in paradigms], loc="upper left", fontsize=8)
    fig.suptitle(
        title + "  (boxes: full range and quartiles, diamond: mean; stars: rank-sum test)", fontsize=10
    )
    fig.tight_layout()
    return fig


def _stacked(trials: Sequence[TrialMetrics], source: str) -> Any:
    plt = _plt()
    paradigms, width = _side_by_side(trials)
    fig, ax = plt.subplots(figsize=(11, 4.2))
    for x, paradigm, ms in _by_condition(trials, paradigms, width):
        sw = float(np.mean([m.mode_switches for m in ms]))
        rq = float(np.mean([m.requests for m in ms]))
        au = float(np.mean([m.record.automatic_switches for m in ms]))
        color = PARADIGM_COLORS[paradigm]
        ax.bar(x, sw, width * 0.9, color=color, alpha=0.75, edgecolor="k")
        ax.bar(x, rq, width * 0.9, bottom=sw, color="#d62728", alpha=0.8, edgecolor="k")
        if au > 0:
            ax.bar(x, au, width * 0.9, bottom=sw + rq, color="white", hatch="//", edgecolor="k")
    _condition_ticks(ax, trials)
    ax.set_ylabel("mean per trial (after the authors' cleaning)")
    ax.margins(y=0.12)
    handles = _paradigm_handles(plt, paradigms, 0.75)
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
    interfaces = _interfaces(trials)
    fig, axes = plt.subplots(
        len(interfaces), 2, figsize=(12, 4 * len(interfaces)), sharex=True, squeeze=False
    )
    for row, interface in enumerate(interfaces):
        for col, task in enumerate(TASKS):
            ax = axes[row, col]
            sel = sorted(
                select_trials(trials, interface, task),
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
    for ax in axes[-1]:
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
    paradigms, width = _side_by_side(trials)
    fig, ax = plt.subplots(figsize=(11, 4))
    for x, paradigm, ms in _by_condition(trials, paradigms, width):
        v = [m.mean_alpha for m in ms if m.mean_alpha is not None]
        if not v:
            continue
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
    _condition_ticks(ax, trials)
    ax.set_ylabel("mean alpha per trial")
    handles = _paradigm_handles(plt, paradigms, 0.7)
    ax.legend(handles, [p.capitalize() for p in paradigms], fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    ax.set_title(
        f"Distribution of the per-trial mean blending factor alpha ({source}; bar: mean, whiskers: range)",
        fontsize=10,
    )
    fig.tight_layout()
    return fig


def source_figures(
    trials: Sequence[TrialMetrics], tests: Sequence[dict[str, Any]], source: str, out: Path, suffix: str
) -> list[tuple[Path, str]]:
    """Draw the five figures of ``source`` (its ``trials`` and the rank-sum ``tests``) and save them
    as ``out/<name><suffix>.png``; returns (path, caption) per figure, in the report's order."""
    written = []
    for name, fig, caption in (
        (
            "button_presses",
            _box_panels(
                trials,
                tests,
                "button_presses",
                "button presses per trial",
                source,
                f"Button presses ({source})",
            ),
            "Button presses (the paper's figure)",
        ),
        ("switches_requests", _stacked(trials, source), "Mode switches and requests"),
        (
            "completion_times",
            _box_panels(
                trials,
                tests,
                "completion_time",
                "completion time (s)",
                source,
                f"Completion times ({source})",
            ),
            "Completion times",
        ),
        ("raster", _raster(trials, source), "Button-press times per subject"),
        ("alpha", _alpha(trials, source), "Alpha distributions"),
    ):
        written.append((save_figure(fig, out / f"{name}{suffix}.png"), caption))
    return written


def _trace_plot(record: TrialRecord, trace: dict[str, Any]) -> BeliefPlot | None:
    """The goal-probability plot of a record's trace (``None``: fewer than two samples)."""
    from drake_disamb.plotting import BeliefPlot

    r = record
    t, belief = np.asarray(trace["t"], dtype=float), np.asarray(trace["belief"], dtype=float)
    u_h = np.asarray(trace["u_h"], dtype=float)
    if len(t) < 2:
        return None
    n = belief.shape[1]
    intended = r.intended_goals[0] if len(r.intended_goals) == 1 and r.intended_goals[0] < n else None
    return BeliefPlot(
        t,
        belief,
        rho1=1.2 / n,
        request_times=r.request_times,
        mode_switch_times=r.mode_switch_times,
        intended_goal=intended,
        # The authors' u_h has no time stamps of its own (and another length): not drawn.
        command_times=t if len(u_h) == len(t) else None,
        commands=u_h if len(u_h) == len(t) else None,
        end_time=r.duration,
        title=f"{r.trial_id}: {INTERFACE_NAMES[r.interface]}, {r.task}, {r.paradigm} ({r.source})",
    )


def trace_figures(
    folder: Path,
    trials: Sequence[TrialMetrics],
    out: Path,
    suffix: str,
    warn: Callable[[str], None] | None = None,
) -> list[Path]:
    """One goal-probability figure per condition: its first valid trial that has a usable trace
    (:meth:`~drake_disamb.study.data.folder.StudyFolder.read_trace`). Every record whose trace is
    missing, and a trace read for a figure that is bad, is left out with one ``warn`` naming the
    file."""
    from drake_disamb.plotting import goal_probability_figure
    from drake_disamb.study.data.folder import StudyFolder, TraceError

    study = StudyFolder(folder)

    written = []
    seen: set[tuple[str, str, str]] = set()
    for m in sorted(
        trials, key=lambda m: (m.record.interface, m.record.task, m.record.paradigm, m.record.trial_id)
    ):
        r = m.record
        key = (r.interface, r.task, r.paradigm)
        missing = not study.trace_path(r.trial_id).is_file()  # each one warned (read_trace says so)
        if not missing and (key in seen or not r.valid):
            continue
        try:
            trace = study.read_trace(r.trial_id)
        except TraceError as exc:  # left out of the examples, not fatal
            if warn is not None:
                warn(f"{exc}; left out of the figures")
            continue
        plot = _trace_plot(r, trace)
        if plot is None:
            continue
        fig = goal_probability_figure(plot)
        written.append(save_figure(fig, out / f"traces_{r.interface}_{r.task}_{r.paradigm}{suffix}.png"))
        seen.add(key)
    return written


def ablation_figure(effect: Sequence[dict[str, Any]]) -> Any:
    """Bars of the Disambiguation - Manual difference per setting and interface (button presses,
    completion time), with the rank-sum stars; ``effect``: the ablation report's rows."""
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
        interfaces = interfaces_in(r["interface"] for r in rows)
        for k, interface in enumerate(interfaces):
            ys = []
            for s in settings:
                r = next((r for r in rows if r["setting"] == s and r["interface"] == interface), None)
                ys.append((r["difference"], r["stars"]) if r else (math.nan, ""))
            xs = np.arange(len(settings)) + (k - (len(interfaces) - 1) / 2) * 0.76 / len(interfaces)
            ax.bar(xs, [y for y, _ in ys], 0.72 / len(interfaces), label=INTERFACE_NAMES[interface])
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
