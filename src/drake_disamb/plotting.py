"""Plots of a trial, in the style of the paper's goal-probability figure (fig. gp_evolution).

The paper's figure shows the time evolution of the goal probabilities with the minimum threshold
for robot assistance (grey dashed line, ``rho1``), disambiguation requests and manual mode
switches (red dots) and indications of non-zero human control commands (black segments below the
plotted data). :func:`goal_probability_figure` draws the same in two panels on one time axis: the
probabilities on top (each goal in its own colour, the intended goal thicker and named so in the
legend), and below them a strip with the requests, the mode switches and the stretches of
non-zero command. Vertical lines mark the stage changes of a multi-step task and the end of the
trial (goal reached, time limit or interruption); an optional caption explains the picture. What it
draws is a :class:`BeliefPlot` (:func:`trial_plot` makes one of a trial's result).
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

GOAL_COLORS = (
    "#1f77b4",
    "#ff7f0e",
    "#2ca02c",
    "#d62728",
    "#9467bd",
    "#8c564b",
    "#e377c2",
    "#7f7f7f",
)
"""Default line colours of goals 0, 1, ... (matplotlib's tab10) when no colours are given (the
published trials' goals have no objects); a trial's figure uses its objects' colours
(:func:`drake_disamb.display.goal_colors`)."""


def nonzero_segments(
    times: ArrayLike, values: ArrayLike, tolerance: float = 1e-9
) -> list[tuple[float, float]]:
    """Maximal time intervals ``[(t_start, t_end), ...]`` over which ``values`` is non-zero.

    Args:
        times: ``(T,)`` sample times (s), increasing.
        values: ``(T, d)`` (or ``(T,)``) samples; a sample is non-zero when any entry exceeds
            ``tolerance`` in magnitude (non-finite entries count as zero).
        tolerance: Magnitude below which an entry counts as zero.

    A run of non-zero samples ``i .. j`` gives the interval ``[t_i, t_{j+1}]`` (a command holds
    until the next sample), or ``[t_i, t_j]`` at the end of the data.
    """
    t = np.asarray(times, dtype=float)
    v = np.asarray(values, dtype=float).reshape(len(t), -1)
    active = np.any(np.where(np.isfinite(v), np.abs(v), 0.0) > tolerance, axis=1)
    segments = []
    i = 0
    while i < len(t):
        if not active[i]:
            i += 1
            continue
        j = i
        while j + 1 < len(t) and active[j + 1]:
            j += 1
        segments.append((float(t[i]), float(t[j + 1] if j + 1 < len(t) else t[j])))
        i = j + 1
    return segments


def _per_stage(items: Sequence[Any], nested: bool, n_stages: int, n: int, what: str) -> list[list[Any]]:
    """``items`` (``n`` entries, or when ``nested`` one list of ``n`` per stage) as per-stage lists."""
    if nested:
        if len(items) != n_stages or any(len(v) != n for v in items):
            raise ValueError(f"{what}: expected {n_stages} lists (one per stage) of {n}, got {list(items)!r}")
        return [list(v) for v in items]
    if len(items) != n:
        raise ValueError(f"{what}: expected {n} entries, got {len(items)}")
    return [list(items)] * n_stages


RESET_WINDOW = 10
"""Samples after a stage change searched for the belief's reset (see :func:`_reset_index`)."""


def _reset_index(t: NDArray[np.float64], p: NDArray[np.float64], change: float) -> int:
    """Index of the first sample of the belief after its reset at a stage change at ``change`` (s):
    the sample after the largest jump among the :data:`RESET_WINDOW` samples from ``change`` on."""
    i0 = int(np.searchsorted(t, change))
    i1 = min(i0 + RESET_WINDOW, len(t))
    if i1 - i0 < 2:
        return min(i0, len(t))
    jumps = np.nan_to_num(np.abs(np.diff(p[i0:i1], axis=0)).sum(axis=1))
    return i0 + 1 + int(np.argmax(jumps))


def _is_color(c: Any) -> bool:
    return isinstance(c, str) or (np.ndim(c) == 1 and len(c) in (3, 4))


@dataclass(frozen=True, eq=False)
class BeliefPlot:
    """What :func:`goal_probability_figure` draws of one trial.

    Attributes:
        times: ``(T,)`` sample times (s) of the belief.
        belief: ``(T, n)`` goal probabilities; slot ``i`` is goal ``i`` of the current stage.
        rho1: The assistance threshold drawn as a grey dashed line (omitted when ``None``).
        goal_names: Legend labels: ``n`` names, or one list of ``n`` per stage (default
            ``g0, g1, ...``).
        goal_colors: Line colours ``(r, g, b[, a])`` in [0, 1] (or matplotlib colours): ``n``, or
            one list of ``n`` per stage (default :data:`GOAL_COLORS`). Slot ``i`` is drawn in
            stage ``k``'s colour ``i`` while stage ``k`` runs.
        intended_goal: The user's goal index (every stage) or one per stage: its line is thicker and
            its legend entry says "intended".
        request_times: Times (s) of disambiguation requests (red dots in the bottom strip).
        mode_switch_times: Times (s) of manual mode switches (red open circles in the strip).
        command_times, commands: ``(T_u,)`` and ``(T_u, d)`` human commands: their non-zero
            stretches are black bars in the strip.
        stage_times: Completion time (s) of each stage of a multi-step task (NaN if not
            completed); the number of stages is ``len(stage_times)`` (at least 1). The changes
            between stages are dotted vertical lines.
        stage_names: Names of the stages, written at the top of each stage's stretch.
        end_time, end_label: A solid vertical line at ``end_time`` (s), labelled ``end_label``
            (e.g. "goal reached"); none when ``end_time`` is ``None``.
        title: Figure title.
        caption: Text under the figure (wrapped; newlines start new paragraphs).
    """

    times: ArrayLike
    belief: ArrayLike
    rho1: float | None = None
    goal_names: Sequence[str] | Sequence[Sequence[str]] | None = None
    goal_colors: Sequence[Any] | None = None
    intended_goal: int | Sequence[int] | None = None
    request_times: Sequence[float] = ()
    mode_switch_times: Sequence[float] = ()
    command_times: ArrayLike | None = None
    commands: ArrayLike | None = None
    stage_times: Sequence[float] = ()
    stage_names: Sequence[str] = ()
    end_time: float | None = None
    end_label: str = "end of trial"
    title: str = ""
    caption: str = ""


@dataclass(frozen=True)
class _Stages:
    """A :class:`BeliefPlot` checked and laid out per stage: the samples, each stage's goal names,
    colours and intended goal, and the times the data spans and each stage starts."""

    t: NDArray[np.float64]
    p: NDArray[np.float64]
    names: list[list[str]]
    colors: list[list[Any]]
    intended: list[int | None]
    t0: float
    t1: float
    starts: list[float]

    @property
    def count(self) -> int:
        return len(self.names)

    @property
    def ran(self) -> list[bool]:
        """Per stage, whether it started before the data ends (the first always counts)."""
        return [k == 0 or s < self.t1 for k, s in enumerate(self.starts)]


def _intended_per_stage(intended_goal: int | Sequence[int] | None, n_stages: int) -> list[int | None]:
    """The intended goal of each stage (``None``: not drawn as intended)."""
    if intended_goal is None:
        return [None] * n_stages
    if isinstance(intended_goal, int | np.integer):
        return [int(intended_goal)] * n_stages
    intended: list[int | None] = [int(g) for g in intended_goal]
    if len(intended) != n_stages:
        raise ValueError(f"intended_goal: expected {n_stages} indices (one per stage), got {intended}")
    return intended


def _stages(plot: BeliefPlot) -> _Stages:
    """``plot`` checked (shapes and counts) and laid out per stage.

    Raises:
        ValueError: shapes or counts that do not match.
    """
    t = np.asarray(plot.times, dtype=float)
    p = np.asarray(plot.belief, dtype=float)
    if p.ndim != 2 or p.shape[0] != t.shape[0]:
        raise ValueError(f"belief: expected shape ({t.shape[0]}, n) matching times, got {p.shape}")
    n = p.shape[1]
    n_stages = max(1, len(plot.stage_times))
    names_in = [f"g{i}" for i in range(n)] if plot.goal_names is None else list(plot.goal_names)
    names = _per_stage(
        names_in, bool(names_in) and not isinstance(names_in[0], str), n_stages, n, "goal_names"
    )
    colors_in = (
        [GOAL_COLORS[i % len(GOAL_COLORS)] for i in range(n)]
        if plot.goal_colors is None
        else list(plot.goal_colors)
    )
    colors = _per_stage(
        colors_in, bool(colors_in) and not _is_color(colors_in[0]), n_stages, n, "goal_colors"
    )
    colors = [
        [c if isinstance(c, str) else tuple(float(x) for x in c[:3]) for c in stage] for stage in colors
    ]
    intended = _intended_per_stage(plot.intended_goal, n_stages)
    t0 = float(t[0]) if len(t) else 0.0
    t1 = float(t[-1]) if len(t) else 1.0
    # Stage k runs from the end of stage k - 1 to its own end (or the end of the data).
    ends = [float(x) if np.isfinite(x) else np.inf for x in plot.stage_times] or [np.inf]
    starts = [t0] + [min(e, t1) for e in ends[:-1]]
    return _Stages(t, p, names, colors, intended, t0, t1, starts)


def _draw_goals(ax: Any, st: _Stages, stage_names: Sequence[str]) -> None:
    """Each stage's goal lines, from the belief's reset after the stage began.

    The belief refers to a stage's goals from its reset on (a tick or two after the stage
    changed): each stage's lines start at the sample after the largest jump of the belief within
    RESET_WINDOW samples of the change, so no line joins two goal sets."""
    t, p = st.t, st.p
    first = [0] + [_reset_index(t, p, st.starts[k]) for k in range(1, st.count)]
    for k in range(st.count):
        if not st.ran[k]:
            break  # the trial ended before this stage
        stop = first[k + 1] if k + 1 < st.count and st.ran[k + 1] else len(t)
        seg = slice(first[k], stop)
        for i in range(p.shape[1]):
            mine = st.intended[k] == i
            label = st.names[k][i] + (" (intended)" if mine else "")
            if st.count > 1 and stage_names:
                label = f"{stage_names[k]}: {label}"
            ax.plot(t[seg], p[seg, i], color=st.colors[k][i], lw=2.8 if mine else 1.4, label=label)


def _draw_marks(ax: Any, strip: Any, st: _Stages, plot: BeliefPlot) -> None:
    """The threshold, the stage changes and names, and the end of the trial."""
    if plot.rho1 is not None:
        ax.axhline(plot.rho1, color="0.5", ls="--", lw=1.2, label=r"$\rho_1$ (assistance threshold)")
    for k in range(1, st.count):
        if st.ran[k]:
            for a in (ax, strip):
                a.axvline(
                    st.starts[k],
                    color="k",
                    ls=":",
                    lw=1.1,
                    label="stage change" if a is ax and k == 1 else None,
                )
    if st.count > 1 and plot.stage_names:
        for k in range(st.count):
            if st.ran[k]:
                ax.text(
                    st.starts[k],
                    1.045,
                    f" {k + 1}: {plot.stage_names[k]}",
                    fontsize=8,
                    va="bottom",
                    ha="left",
                )
    if _has_end(plot):
        for a in (ax, strip):
            a.axvline(plot.end_time, color="0.15", lw=1.6, label=plot.end_label if a is ax else None)


def _has_end(plot: BeliefPlot) -> bool:
    return plot.end_time is not None and bool(np.isfinite(plot.end_time))


def _draw_strip(strip: Any, plot: BeliefPlot) -> None:
    """The bottom strip: one row per kind of event, on the same time axis."""
    rows = ("$u_h \\neq 0$", "mode switch", "request")
    if plot.command_times is not None and plot.commands is not None:
        for a, b in nonzero_segments(plot.command_times, plot.commands):
            strip.plot([a, b], [0, 0], color="k", lw=5, solid_capstyle="butt")
    switches, requests = plot.mode_switch_times, plot.request_times
    if len(switches):
        strip.plot(switches, np.ones(len(switches)), "o", mfc="none", mec="red", ms=6)
    if len(requests):
        strip.plot(requests, np.full(len(requests), 2.0), "o", color="red", ms=6)
    strip.set_yticks(range(len(rows)), rows, fontsize=8)
    strip.set_ylim(-0.7, 2.7)
    strip.grid(axis="x", alpha=0.25)
    strip.set_xlabel("time (s)")


def _frame(fig: Any, ax: Any, st: _Stages, plot: BeliefPlot) -> None:
    """Axes limits and labels, the title, the legend, the caption and the margins."""
    ax.set_ylim(-0.02, 1.02)
    # A little room on both sides, so that an event at t = 0 and the end line show in full.
    end = plot.end_time
    t_last = max(st.t1, float(end)) if end is not None and np.isfinite(end) else st.t1
    pad = 0.015 * max(t_last - st.t0, 1e-3)
    ax.set_xlim(st.t0 - pad, t_last + pad)
    ax.set_ylabel("goal probability")
    named_stages = st.count > 1 and bool(plot.stage_names)
    if plot.title:
        ax.set_title(plot.title, pad=16 if named_stages else 6)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    ax.grid(alpha=0.25)
    bottom = 0.12
    if plot.caption:
        wrapped = "\n".join(textwrap.fill(par, 140) for par in plot.caption.split("\n"))
        lines = wrapped.count("\n") + 1
        bottom = 0.11 + 0.035 * lines
        fig.text(0.02, 0.015, wrapped, fontsize=7.5, va="bottom", ha="left", color="0.2")
    fig.subplots_adjust(left=0.11, right=0.72, top=0.88 if named_stages else 0.92, bottom=bottom)


def goal_probability_figure(plot: BeliefPlot) -> Any:
    """The goal-probability figure of one trial (a matplotlib ``Figure``; the caller closes it).

    Raises:
        ValueError: shapes or counts of ``plot`` that do not match.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    st = _stages(plot)
    fig, (ax, strip) = plt.subplots(
        2,
        1,
        sharex=True,
        figsize=(9.0, 4.9 if plot.caption else 4.4),
        dpi=120,
        gridspec_kw={"height_ratios": [4.0, 1.25], "hspace": 0.08},
    )
    _draw_goals(ax, st, plot.stage_names)
    _draw_marks(ax, strip, st, plot)
    _draw_strip(strip, plot)
    _frame(fig, ax, st, plot)
    return fig


def trial_outcome(result: Any) -> str:
    """How a trial ended, for labels: "interrupted", "goal reached", "other goal reached" or
    "time limit" (``result`` is a :class:`~drake_disamb.trial.TrialResult`)."""
    if getattr(result, "interrupted", False):
        return "interrupted"
    if result.done:
        return "goal reached" if result.success else "other goal reached"
    return "time limit"


def trial_plot(result: Any) -> BeliefPlot:
    """The :class:`BeliefPlot` of a :class:`~drake_disamb.trial.TrialResult`: its goals in their
    objects' colours, the intended goal(s), stage changes, the end of the trial and the caption of
    :func:`drake_disamb.display.belief_caption`."""
    from drake_disamb.display import belief_caption, goal_colors

    sc = result.scenario
    t, belief = result.logs["belief"]
    _, uh = result.logs["u_h"]
    names = [[g.name for g in sc.belief_goals(k)] for k in range(sc.n_stages)]
    colors = goal_colors(sc)
    multi = sc.n_stages > 1
    outcome = trial_outcome(result)
    return BeliefPlot(
        t,
        belief,
        rho1=result.rho1,
        goal_names=names if multi else names[0],
        goal_colors=colors if multi else colors[0],
        request_times=result.request_times,
        mode_switch_times=result.mode_switch_times,
        command_times=t,
        commands=uh,
        stage_times=result.stage_times if multi else (),
        stage_names=[s.name for s in sc.stages] if multi else (),
        intended_goal=[sc.belief_slot(k, g) for k, g in enumerate(sc.user.goals)]
        if multi
        else sc.user.goals[0],
        end_time=result.time,
        end_label=f"{outcome} ({result.time:.1f} s)",
        title=f"{sc.task}, {sc.interface.replace('_', ' ')}, {sc.paradigm} paradigm: "
        f"{outcome} at {result.time:.1f} s",
        caption=belief_caption(sc),
    )


def trial_figure(result: Any) -> Any:
    """:func:`goal_probability_figure` of a :class:`~drake_disamb.trial.TrialResult` (:func:`trial_plot`)."""
    return goal_probability_figure(trial_plot(result))


def write_trial_figure(result: Any, path: str | Path) -> Path:
    """Write :func:`trial_figure` to ``path`` (its parent directory is created)."""
    return _save(trial_figure(result), path)


def _save(fig: Any, path: str | Path) -> Path:
    """Write ``fig`` to ``path`` (parent directory created) and close it."""
    import matplotlib.pyplot as plt

    out = Path(path)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(out)
    finally:
        plt.close(fig)
    return out


def save_recording(
    meshcat: Any, path: str | Path, legend: Any = None, title: str = "", panel_log: Any = None
) -> Path:
    """Write Meshcat's current scene and published recording as a self-contained HTML file.

    ``legend`` (rows of :func:`drake_disamb.display.legend_rows`) is laid over the page, headed by
    ``title``: Meshcat's HTML leaves out the control panel where a live page shows it. With
    ``panel_log`` (the operator panel's states) the panel is replayed beside the scene
    (:func:`drake_disamb.operator_page.replay.add_panel_replay`)."""
    from drake_disamb.display import add_legend_to_html
    from drake_disamb.operator_page.replay import add_panel_replay

    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    page = meshcat.StaticHtml()
    if legend:
        page = add_legend_to_html(page, legend, title)
    if panel_log:
        page = add_panel_replay(page, panel_log)
    out.write_text(page, encoding="utf-8")
    return out


def write_trial_figures(result: Any, handles: Any, out_dir: str | Path) -> list[Path]:
    """Write the goal-probability figure, the Meshcat recording (if any, with the operator panel
    replayed beside the scene) and the diagram picture of a
    :class:`~drake_disamb.trial.TrialResult` run on ``handles``
    (:class:`~drake_disamb.builder.SharedControlDiagram`)."""
    from drake_disamb.diagram_io import write_diagram_graph
    from drake_disamb.display import legend_rows

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    sc = result.scenario
    written = [write_trial_figure(result, out / "goal_probabilities.png")]
    if handles.meshcat is not None:
        title = f"{sc.task}, {sc.interface.replace('_', ' ')}, {sc.paradigm} paradigm"
        panel = handles.systems.get("panel")
        log = panel.recorder.log if panel is not None and panel.recorder is not None else None
        written.append(save_recording(handles.meshcat, out / "recording.html", legend_rows(sc), title, log))
    written.extend(Path(p) for p in _as_list(write_diagram_graph(handles.diagram, out / "diagram")))
    return written


def _as_list(value: Any) -> list[Any]:
    if value is None:
        return []
    if isinstance(value, list | tuple):
        return list(value)
    return [value]
