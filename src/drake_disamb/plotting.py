"""Plots of a trial, in the style of the paper's goal-probability figure (fig. gp_evolution).

The paper's figure shows the time evolution of the goal probabilities with the minimum threshold
for robot assistance (grey dashed line, ``rho1``), disambiguation requests and manual mode
switches (red dots) and indications of non-zero human control commands (black segments below the
plotted data). :func:`plot_goal_probabilities` draws the same, and marks stage changes of a
multi-step task with vertical dotted lines.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

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
"""Line colours of goals 0, 1, ... (matplotlib's tab10, as in the Meshcat display)."""


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


def plot_goal_probabilities(
    times: ArrayLike,
    belief: ArrayLike,
    path: str | Path,
    *,
    rho1: float | None = None,
    goal_names: Sequence[str] | None = None,
    request_times: Sequence[float] = (),
    mode_switch_times: Sequence[float] = (),
    command_times: ArrayLike | None = None,
    commands: ArrayLike | None = None,
    stage_times: Sequence[float] = (),
    intended_goal: int | None = None,
    title: str = "",
) -> Path:
    """Write the goal-probability figure of one trial to ``path`` (PNG, PDF, SVG ...).

    Args:
        times: ``(T,)`` sample times (s) of the belief.
        belief: ``(T, n)`` goal probabilities.
        path: Output file; its parent directory is created.
        rho1: The assistance threshold drawn as a grey dashed line (omitted when ``None``).
        goal_names: Legend labels, one per goal (default ``g0, g1, ...``).
        request_times: Times (s) of disambiguation requests (red dots).
        mode_switch_times: Times (s) of manual mode switches (red open circles).
        command_times, commands: ``(T_u,)`` and ``(T_u, d)`` human commands: their non-zero
            stretches are drawn as black segments below the data.
        stage_times: Times (s) at which a stage of a multi-step task completed (dotted lines).
        intended_goal: Index of the user's goal: its line is drawn thicker.
        title: Figure title.

    Returns:
        The path written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.asarray(times, dtype=float)
    p = np.asarray(belief, dtype=float)
    if p.ndim != 2 or p.shape[0] != t.shape[0]:
        raise ValueError(f"belief: expected shape ({t.shape[0]}, n) matching times, got {p.shape}")
    n = p.shape[1]
    names = [f"g{i}" for i in range(n)] if goal_names is None else list(goal_names)
    if len(names) != n:
        raise ValueError(f"goal_names: expected {n} names, got {len(names)}")
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)

    fig, ax = plt.subplots(figsize=(8.0, 3.6), dpi=120)
    for i in range(n):
        lw = 2.6 if intended_goal == i else 1.5
        ax.plot(t, p[:, i], color=GOAL_COLORS[i % len(GOAL_COLORS)], lw=lw, label=names[i])
    if rho1 is not None:
        ax.axhline(rho1, color="0.5", ls="--", lw=1.2, label=r"$\rho_1$ (assistance threshold)")
    event_y = 1.04
    if len(request_times):
        ax.plot(
            request_times,
            np.full(len(request_times), event_y),
            "o",
            color="red",
            ms=6,
            label="disambiguation request",
            clip_on=False,
        )
    if len(mode_switch_times):
        ax.plot(
            mode_switch_times,
            np.full(len(mode_switch_times), event_y),
            "o",
            mfc="none",
            mec="red",
            ms=6,
            label="manual mode switch",
            clip_on=False,
        )
    for k, ts in enumerate(stage_times):
        if np.isfinite(ts):
            ax.axvline(ts, color="k", ls=":", lw=1.0, label="stage complete" if k == 0 else None)
    seg_y = -0.06
    if command_times is not None and commands is not None:
        for j, (a, b) in enumerate(nonzero_segments(command_times, commands)):
            ax.plot(
                [a, b],
                [seg_y, seg_y],
                color="k",
                lw=4,
                solid_capstyle="butt",
                label="non-zero $u_h$" if j == 0 else None,
                clip_on=False,
            )
    ax.set_ylim(-0.1, 1.08)
    ax.set_xlim(float(t[0]) if len(t) else 0.0, float(t[-1]) if len(t) else 1.0)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("goal probability")
    if title:
        ax.set_title(title)
    ax.legend(loc="center left", bbox_to_anchor=(1.01, 0.5), fontsize=8, frameon=False)
    ax.grid(alpha=0.25)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)
    return out
