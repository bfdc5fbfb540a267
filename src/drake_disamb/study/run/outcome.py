"""From a finished trial to its record and trace: the one function every producer of records uses.

:func:`record_from_result` turns a :class:`~drake_disamb.trial.TrialResult` into a
:class:`~drake_disamb.study.data.records.TrialRecord` (the study runner for simulated subjects,
``demo --live --record`` for a person); :func:`trace_arrays` gives the trial's time series in the
layout of ``DIR/traces/<trial_id>.npz`` (:mod:`drake_disamb.study.data.folder` writes them). Every
record keeps the scenario its trial ran (``extra.scenario``, :func:`record_scenario` reads it back),
so a simulated trial runs again from its record alone (``study rerun``).

Trace arrays (one row per control tick, all on the same sample times): ``t`` (T,) s; ``belief``
(T, n_goals); ``u_h`` and ``u`` (T, 6): spatial velocities in the paper's order
``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s, world frame W); ``alpha`` (T,); ``mode`` (T,) mode
index; ``ee_pose`` (T, 7) ``[x, y, z, qw, qx, qy, qz]`` of the end effector in W; ``stage`` (T,)
the task's stage index; from a simulated trial also ``ik_status`` (T,), the differential IK's
:class:`~drake_disamb.ik.IkStatus` code (logged whatever the station's backend).

**Held by the IK** (:func:`ik_held_share`, the record's ``extra["ik_held"]``): of the samples in
the trial's last :data:`IK_HELD_WINDOW` seconds where the user commands, the share at which the
IK stopped the arm or slowed it at a singularity (``STOPPED`` or ``SINGULAR``): an arm the user
keeps pushing into a singularity or a limit, the usual way a simulated trial gets stuck.

**Assistance onset** (:func:`stage_onsets`, by :func:`drake_disamb.study.data.records.assistance_onset`):
the blender assists only while the user commands
(``alpha`` is 0 with no input, by design), so the onset looks at the samples where the user
commands (``u_h != 0``): it is the time of the first such sample from which, on every commanding
sample to the end of its stage, the belief's argmax is the intended goal and ``alpha > 0``. Per
stage (``extra.assistance_onsets``, s from the trial start); the record's ``assistance_onset`` is
the first stage's.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from drake_disamb.config import dump_scenario, interface_variant, scenario_from_yaml
from drake_disamb.ik import IkStatus
from drake_disamb.study.data.records import TrialRecord, assistance_onset

__all__ = [
    "IK_HELD_WINDOW",
    "TRACE_ARRAYS",
    "ik_held_share",
    "record_condition",
    "record_from_result",
    "record_scenario",
    "stage_onsets",
    "trace_arrays",
]

TRACE_ARRAYS: tuple[str, ...] = ("t", "belief", "u_h", "u", "alpha", "mode", "ee_pose", "stage")
"""Arrays of a trace file (module docstring); ``ik_status`` is added when the trial logged it."""

IK_HELD_WINDOW = 60.0
"""Seconds at the end of a trial over which :func:`ik_held_share` looks (the experimenter's
``give_up_after`` of the paper's protocol: the window that ends a stuck trial)."""

_HELD = (int(IkStatus.STOPPED), int(IkStatus.SINGULAR))


def trace_arrays(result: Any) -> dict[str, NDArray[np.float64]]:
    """The trace of a :class:`~drake_disamb.trial.TrialResult` (module docstring for the layout)."""
    logs = result.logs
    t, belief = logs["belief"]
    out = {
        "t": np.asarray(t, dtype=float),
        "belief": np.asarray(belief, dtype=float),
        "u_h": np.asarray(logs["u_h"][1], dtype=float),
        "u": np.asarray(logs["u"][1], dtype=float),
        "alpha": np.asarray(logs["alpha"][1], dtype=float)[:, 0],
        "mode": np.asarray(logs["mode"][1], dtype=float)[:, 0],
        "ee_pose": np.asarray(logs["ee_pose"][1], dtype=float),
        "stage": np.asarray(logs["stage"][1], dtype=float)[:, 0],
    }
    if "ik_status" in logs:
        out["ik_status"] = np.asarray(logs["ik_status"][1], dtype=float)[:, 0]
    n = len(out["t"])
    for name, arr in out.items():
        if len(arr) != n:  # the loggers share one period: a mismatch is a wiring error
            raise RuntimeError(f"trace: {name} has {len(arr)} samples, t has {n}")
    return out


def ik_held_share(trace: dict[str, NDArray[np.float64]], window: float = IK_HELD_WINDOW) -> float | None:
    """Of the samples in the trace's last ``window`` seconds where the user commands (``u_h`` not
    zero), the share whose ``ik_status`` is ``STOPPED`` or ``SINGULAR``; ``None`` without an
    ``ik_status`` array or without commanding samples there."""
    status = trace.get("ik_status")
    if status is None or len(status) == 0:
        return None
    t = np.asarray(trace["t"], dtype=float)
    commanding = np.any(np.abs(np.asarray(trace["u_h"], dtype=float)) > 1e-9, axis=1)
    recent = commanding & (t >= t[-1] - window)
    if not np.any(recent):
        return None
    return float(np.mean(np.isin(np.rint(status[recent]).astype(int), _HELD)))


def _intended_index(n_belief: int, stage_sizes: list[int], stage: int, goal: int) -> int:
    """Belief index of the intended goal: within the stage, or among all goals (a task-wide belief)."""
    if n_belief == stage_sizes[stage]:
        return goal
    return sum(stage_sizes[:stage]) + goal


def stage_onsets(
    trace: dict[str, NDArray[np.float64]], intended_goals: list[int], stage_sizes: list[int]
) -> list[float | None]:
    """Per stage, the assistance onset (module docstring) in s from the trial start, or None: the
    one :func:`~drake_disamb.study.data.records.assistance_onset` on the stage's commanding samples."""
    t, belief, alpha, stage = trace["t"], trace["belief"], trace["alpha"], trace["stage"]
    commanding = np.any(np.abs(trace["u_h"]) > 1e-9, axis=1)
    onsets: list[float | None] = []
    for k, goal in enumerate(intended_goals):
        idx = np.flatnonzero((stage.astype(int) == k) & commanding)
        target = _intended_index(belief.shape[1], stage_sizes, k, goal)
        onsets.append(assistance_onset(t[idx], belief[idx], alpha[idx], target))
    return onsets


def _finite(value: float) -> float | None:
    value = float(value)
    return value if math.isfinite(value) else None


def record_condition(scenario: Any) -> dict[str, str | None]:
    """The names of a trial's condition in its record, from its scenario: ``interface``, ``task``,
    ``paradigm`` and ``disambiguation_method`` (None in the Manual paradigm, which has no requests)."""
    paradigm = scenario.paradigm
    method = None if paradigm == "manual" else getattr(scenario.disambiguation, "method", "algorithm1")
    return {
        "interface": scenario.interface,
        "task": scenario.task,
        "paradigm": paradigm,
        "disambiguation_method": method,
    }


def record_from_result(
    result: Any,
    *,
    trial_id: str,
    subject: str,
    repetition: int = 0,
    seed: int | None = None,
    start_pose: int | None = None,
    source: str = "simulated",
    trace: dict[str, NDArray[np.float64]] | None = None,
    wall_time: float | None = None,
    extra: dict[str, Any] | None = None,
) -> TrialRecord:
    """The :class:`TrialRecord` of a finished trial (``result``: a ``TrialResult``).

    Args:
        result: The trial.
        trial_id, subject, repetition, seed, start_pose, source: As in the record.
        trace: Its :func:`trace_arrays` if already computed.
        wall_time: The record's ``wall_time`` (default the simulation's; 0 for a person's trial).
        extra: Merged into the record's ``extra`` (after ``stage_times``, ``intended_goal_names``,
            ``reached_goal_names``, ``assistance_onsets``, ``disambiguation_switch_times``,
            ``interrupted``, ``end_reason``, ``progress_age`` and ``ik_held``); the trial's scenario
            comes last, ``scenario``: its YAML as ``demo --dump-scenario`` writes it, which
            loads back, alone, to the scenario that ran (:func:`record_scenario`).
    """
    sc = result.scenario
    trace = trace_arrays(result) if trace is None else trace
    stage_sizes = [len(sc.stage_goals(k)) for k in range(sc.n_stages)]
    onsets = stage_onsets(trace, list(result.intended_goals), stage_sizes)
    events = result.events
    switches = [e for e in events if e.kind == "mode_switch"]
    automatic = [float(e.time) for e in events if e.kind == "automatic_switch"]
    commanding = np.any(np.abs(trace["u_h"]) > 1e-9, axis=1)
    variant = interface_variant(sc)  # the trial's mode order names its modes
    info: dict[str, Any] = {
        "stage_times": [_finite(t) for t in result.stage_times],
        "intended_goal_names": list(result.intended_goal_names),
        "reached_goal_names": list(result.reached_goal_names),
        "assistance_onsets": onsets,
        "disambiguation_switch_times": [float(t) for t in result.disambiguation_switch_times],
        "interrupted": bool(result.interrupted),
        "end_reason": result.end_reason,
        "progress_age": _finite(result.progress_age),
        "ik_held": ik_held_share(trace),
    }
    info.update(extra or {})
    info["scenario"] = dump_scenario(sc)
    return TrialRecord(
        trial_id=trial_id,
        subject=subject,
        **record_condition(sc),
        repetition=int(repetition),
        seed=seed,
        start_pose=start_pose,
        initial_mode=variant.mode_name(sc.initial_mode),
        intended_goals=[int(g) for g in result.intended_goals],
        reached_goals=[int(g) for g in result.reached_goals],
        success=bool(result.success),
        done=bool(result.done),
        duration=float(result.time),
        completion_time=float(result.time) if result.done else None,
        mode_switches=len(switches),
        requests=int(result.requests),
        automatic_switches=len(automatic),
        button_presses=len(switches) + int(result.requests),
        request_times=[float(t) for t in result.request_times],
        mode_switch_times=[float(e.time) for e in switches],
        mode_switch_modes=[variant.mode_name(e.to_mode) for e in switches],
        automatic_switch_times=automatic,
        mean_alpha=float(result.mean_alpha) if np.any(commanding) else None,
        assistance_onset=onsets[0] if onsets else None,
        wall_time=float(result.wall_time if wall_time is None else wall_time),
        source=source,
        extra=info,
    )


def record_scenario(record: TrialRecord, source: str = "the record") -> Any:
    """The scenario a record keeps (``extra.scenario``), loaded by the one scenario loader.

    Raises:
        ValueError: the record keeps no scenario (a record of an older drake-disamb, or of the
            authors' logs), or it does not load, naming ``source``.
    """
    text = record.extra.get("scenario")
    if not isinstance(text, str):
        raise ValueError(
            f"{source}: keeps no scenario (extra.scenario; a record of an older drake-disamb, or of "
            "the authors' logs)"
        )
    return scenario_from_yaml(text, f"{source}: extra.scenario")
