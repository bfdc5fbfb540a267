"""How a trial starts and ends and how far the arm is driven, from its mode and command traces.

Behaviour estimates of :mod:`drake_disamb.study.measures.calibration` that read only a trial's traces (the
people's logs through :func:`drake_disamb.study.data.authors.read_trials`, a simulated study through
:func:`~drake_disamb.study.data.folder.StudyFolder.read_trials`; the trace ``mode`` is an index into the
interface's modes on ``t``, ``u`` the blended command ``[vx, vy, vz, wx, wy, wz]``):

- **Ending in the gripper mode** (letting go of the object), per interface and task: the share of
  trials whose mode at the end (the trace's ``mode`` at its last sample up to ``duration``) is the
  gripper mode (the interface's last mode, ``Interface.gripper_mode``: the
  logs' joystick id 7 and head-array id 7), and among those the median seconds from the last
  change into it (the last switch of the burst that reached it, to the trace's sample period:
  50 ms in the logs) to the end, and the median number of changes into it (from another mode; a
  switch the log shows re-selecting the current mode is no change) per trial (:class:`GripperEnd`).
- **Starting in the gripper mode**: per interface, the share of trials whose ``initial_mode`` is
  the gripper mode (the study's trial order drew it uniformly over all of an interface's modes,
  gripper included: 1/5 joystick, 1/7 head array).
- **Commanded path** (:class:`CommandPath`), per interface and task: the blended command ``u``
  (``blended_vel`` in the logs; the same signal in a simulated trace) integrated over the trial
  (from 0 to its completion time): the median translational path (m, the sum of ``|u[:3]| dt``),
  rotational path (rad, ``|u[3:]| dt``) and seconds with the arm commanded (``|u[:3]|`` above
  5 mm/s), and the median speed while it is. How far people actually drive the arm for a task, not
  only how they change modes.
- **The mode a request chose** (:func:`request_modes`): per request that changed the mode, whether
  the new mode is a translation mode (its dimensions all among vx, vy, vz). A check of the system
  more than of its user: which modes the disambiguation picks on the task (the study's orders of
  the interfaces' modes differ from the registered ones only among the rotation modes, so the
  registered modes tell a translation mode by its index in either).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from drake_disamb.core.layout import is_translation_mode
from drake_disamb.interfaces import INTERFACES, gripper_mode
from drake_disamb.study.data.folder import LoggedTrial

__all__ = [
    "MOVING_SPEED",
    "CommandPath",
    "GripperEnd",
    "command_path",
    "format_command_path",
    "format_gripper",
    "gripper_course",
    "mode_after",
    "request_modes",
    "starts_in_gripper",
    "summarize_command_paths",
    "summarize_gripper_end",
]


@dataclass(frozen=True)
class GripperEnd:
    """The trials of one interface and task that end in the gripper mode (module docstring): their
    ``share`` of the ``n`` trials, and among them the median seconds from the last change into the
    gripper mode to the end (``time_to_end``) and the median number of changes into it per trial
    (``entries``); both NaN when no trial ends there."""

    share: float
    n: int
    time_to_end: float
    entries: float


@dataclass(frozen=True)
class CommandPath:
    """Medians over the ``n`` trials of one interface and task (module docstring): translational
    path ``path`` (m), rotational path ``rotation`` (rad), seconds moving ``moving`` and the speed
    while moving ``speed`` (m/s)."""

    path: float
    rotation: float
    moving: float
    speed: float
    n: int


MOVING_SPEED = 0.005
"""The arm counts as commanded while the blended command's translation is above this (m/s)."""


def command_path(trial: LoggedTrial) -> tuple[float, float, float] | None:
    """Translational path (m), rotational path (rad) and seconds moving of the trace's ``u``
    (``None`` for a trace without one)."""
    if "u" not in trial.trace:
        return None
    t = np.asarray(trial.trace["t"], dtype=float)
    u = np.asarray(trial.trace["u"], dtype=float)
    end = trial.record.completion_time
    inside = (t >= 0.0) & (t <= (end if end is not None else t[-1]))
    t, u = t[inside], u[inside]
    if t.size < 2:
        return 0.0, 0.0, 0.0
    dt = np.diff(t, append=t[-1])  # each sample held until the next
    speed = np.linalg.norm(u[:, :3], axis=1)
    return (
        float(speed @ dt),
        float(np.linalg.norm(u[:, 3:6], axis=1) @ dt),
        float(dt[speed > MOVING_SPEED].sum()),
    )


def summarize_command_paths(rows: Sequence[tuple[float, float, float]]) -> CommandPath:
    """:class:`CommandPath` of one interface and task's :func:`command_path` results."""
    a = np.asarray(rows, dtype=float).reshape(-1, 3)
    speeds = a[:, 0] / np.where(a[:, 2] > 0, a[:, 2], np.nan)
    return CommandPath(
        *(float(np.median(a[:, k])) for k in range(3)),
        float(np.nanmedian(speeds)) if np.any(np.isfinite(speeds)) else math.nan,
        len(a),
    )


def _mode_trace(trial: LoggedTrial) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The trace's sample times ``t`` (s) and ``mode`` (indices into the interface's modes)."""
    t = np.asarray(trial.trace["t"], dtype=float)
    return t, np.rint(np.asarray(trial.trace["mode"], dtype=float)).astype(int)


def gripper_course(trial: LoggedTrial) -> tuple[bool, float, int]:
    """Whether the trial ends in the gripper mode, the seconds from its last change into the
    gripper mode to the end (NaN without one) and its number of changes into it (trace ``mode``:
    indices into the interface's modes, on ``t``)."""
    r = trial.record
    gripper = gripper_mode(r.interface)
    t, mode = _mode_trace(trial)
    inside = t <= r.duration + 1e-9
    last = mode[inside][-1] if np.any(inside) else mode[0]
    changed = np.flatnonzero(np.diff(mode) != 0) + 1
    entries = changed[(mode[changed] == gripper) & (t[changed] > 0.0) & inside[changed]]
    return (
        bool(last == gripper),
        r.duration - float(t[entries[-1]]) if entries.size else math.nan,
        len(entries),
    )


def mode_after(trial: LoggedTrial, times: Sequence[float]) -> list[tuple[int, ...] | None]:
    """The dimensions of the mode in force just after each switch at ``times`` (the trace's
    ``mode`` at the first sample at least one and a half sample periods later, or the last; ``None``
    for an index that is none of the interface's modes)."""
    t, mode = _mode_trace(trial)
    if t.size == 0:
        return []
    modes = INTERFACES[trial.record.interface].modes
    step = 1.5 * float(np.median(np.diff(t))) if t.size > 1 else 0.0
    out: list[tuple[int, ...] | None] = []
    for x in times:
        m = int(mode[min(int(np.searchsorted(t, float(x) + step)), t.size - 1)])
        out.append(tuple(modes[m]) if 0 <= m < len(modes) else None)
    return out


def request_modes(trial: LoggedTrial) -> list[bool]:
    """Per request switch of the trial (``LoggedTrial.request_switch_times``), whether the mode it
    switched to (:func:`mode_after`) is a translation mode."""
    after = mode_after(trial, np.asarray(trial.request_switch_times, dtype=float).tolist())
    return [dims is not None and is_translation_mode(dims) for dims in after]


def starts_in_gripper(trial: LoggedTrial) -> bool:
    """Whether the trial's ``initial_mode`` (a mode name) is its interface's gripper mode."""
    r = trial.record
    kind = INTERFACES[r.interface]
    return r.initial_mode == kind.mode_name(kind.gripper_mode)


def summarize_gripper_end(rows: Sequence[tuple[bool, float, int]]) -> GripperEnd:
    """:class:`GripperEnd` of one interface and task's :func:`gripper_course` results."""
    ends = [(dt, k) for end, dt, k in rows if end]
    times = [dt for dt, _ in ends if math.isfinite(dt)]
    return GripperEnd(
        share=len(ends) / len(rows),
        n=len(rows),
        time_to_end=float(np.median(times)) if times else math.nan,
        entries=float(np.median([k for _, k in ends])) if ends else math.nan,
    )


def _format_gripper_end(task: str, g: GripperEnd) -> str:
    if g.share == 0.0:
        return f"{task} 0.00 of {g.n}"
    return (
        f"{task} {g.share:.2f} of {g.n} (median {g.time_to_end:.1f} s from the change to the end, "
        f"{g.entries:g} change{'s' if g.entries != 1 else ''} into it)"
    )


def format_gripper(
    ends: Mapping[str, Mapping[str, GripperEnd]], starts: Mapping[str, tuple[float, int]]
) -> list[str]:
    """The two gripper-mode lines of ``study calibrate``: trials ending in it per interface and task
    (``ends``), trials starting in it per interface (``starts``: share and trial count)."""
    return [
        f"{'ends in gripper mode':<28} "
        + "; ".join(
            f"{k.replace('_', ' ')} " + ", ".join(_format_gripper_end(task, g) for task, g in tasks.items())
            for k, tasks in ends.items()
        ),
        f"{'starts in gripper mode':<28} "
        + ", ".join(
            f"{k.replace('_', ' ')} {share:.2f} of {n} (1/{len(INTERFACES[k].modes)} = "
            f"{1 / len(INTERFACES[k].modes):.2f} "
            "if uniform over all modes)"
            for k, (share, n) in starts.items()
        ),
    ]


def format_command_path(paths: Mapping[str, Mapping[str, CommandPath]]) -> str:
    """The commanded paths per interface and task as one line of ``study calibrate``."""
    return (
        f"{'commanded path per trial':<28} "
        + "; ".join(
            f"{k.replace('_', ' ')} "
            + ", ".join(
                f"{task} {c.path:.2f} m, {c.rotation:.2f} rad, moving {c.moving:.1f} s at {c.speed:.3f} m/s"
                for task, c in tasks.items()
            )
            for k, tasks in paths.items()
        )
        + " (medians; the blended command integrated over the trial)"
    )
