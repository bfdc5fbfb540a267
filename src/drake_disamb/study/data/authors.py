"""Import the authors' human-study logs (4 of the paper's 8 subjects) as :class:`TrialRecord` s.

The logs (``../shared/data/tnsre2020_human_study/``, its README gives the format) are MATLAB files,
one per trial, ``H<s>/H<s>PH<b><TASK><IF>T<n>.mat``, and ``trial_order_testing_8.mat`` with each
trial's condition. :func:`read_trials` reads them all (the one reader: ``study calibrate`` uses it
too), and :func:`import_authors` turns every trial into a record with ``source="authors"``
appended to ``DIR/trials.jsonl`` and its time series in ``DIR/traces/<trial_id>.npz``. Nothing is
overwritten: trials whose ``trial_id`` (the file's stem, e.g. ``H2PH1POHAT1``) is already in
``DIR/trials.jsonl`` are skipped, so a second import (or one after an interruption) adds only the
missing ones.

How each field is made (times are seconds from the trial's ``start_time``):

- ``subject`` ``H2`` ... ``H9`` (the paper's subject 1 is H2); ``interface``, ``task``, ``paradigm``
  (``on`` -> ``disambiguation``, ``wo`` -> ``manual``), ``intended_goals`` (the 1-based target goal
  as a 0-based index into the task's goals: 5 for reaching, all 4 pouring goals, the belief the
  authors logged was over those 4), ``start_pose`` (home position - 1) from the trial-order file,
  with the corrections the authors' ``parse_data.m`` applies (:data:`ORDER_FIXES`).
- ``initial_mode``: the mode logged in ``current_mode``'s second row (the order file's 0-based
  initial mode agrees with it after the corrections), named as in
  :func:`study_modes` by its position in the study's cycle (joystick ids 12, 13, 45, 6, 7 ->
  ``vx_vy``, ``vx_vz``, ``wx_wz``, ``wy``, ``gripper``, docs/facts.md section 6; head array 1..7 ->
  ``vx``, ``vy``, ``vz``, ``wz``, ``wx``, ``wy``, ``gripper``: ``study identify`` reads ids 1-4 off
  the request scores, and 5, 6 are our choice, as in the ``tnsre2020_study`` preset). The
  authors' id is kept in ``extra["initial_mode_id"]``.
- ``request_times``: the rows of ``assistance_requested`` after the placeholder. Every request
  made one mode switch of its own (the disambiguation system's), logged in ``mode_switches`` at
  the time of the request's row in ``cmode_conf_disamb`` (the scores computed for it): that
  switch is the ``mode_switches`` row nearest in time to it (within 3 ms in every published
  trial). The authors' ``loadData.m`` instead takes the first switch at or after the request,
  which in one trial (H3PH1REHAT16: a button press 1.4 s after the request, 3.3 s before the
  system's switch) takes the user's press; the counts are the same either way.
- ``mode_switch_times``: the remaining rows of ``mode_switches`` after the placeholder and the
  initial-mode row (the README's "rows minus 2 minus requests"), ``mode_switch_modes`` the mode
  each entered (the ``current_mode`` row logged at that time). Raw: the authors' cleaning is
  applied by :mod:`drake_disamb.study.measures.metrics`.
- ``duration`` = ``completion_time`` = ``total_time``; ``reached_goals``, ``success`` and ``done``
  are null (not logged). ``valid`` is False for the 14 trials the authors excluded as failed
  (:data:`FAILED_TRIALS`, the paper's unsuccessful trials).
- ``mean_alpha``: the mean of ``alpha`` over its samples from ``start_time`` to ``end_time`` (all
  samples, commanded or not: the logs have no time stamps for ``user_vel`` to tell). The
  authors' ``loadData.m`` kept a different number, the share of those samples with alpha above
  0.6, which is in ``extra["alpha_share_above_0_6"]``.
- ``assistance_onset``: for reaching, the first time from which the belief's argmax is the
  target goal with alpha above 0 and stays so to the end
  (:func:`~drake_disamb.study.data.records.assistance_onset`);
  null for pouring, whose single logged target does not say which goal each stage meant.
- ``disambiguation_method``: ``algorithm1`` for disambiguation trials, null for manual ones;
  ``seed`` null, ``wall_time`` 0.

The trace has ``t`` (the ``alpha`` sample times, from the first logged sample, which may precede
the start), ``belief`` (``goal_probabilities``), ``alpha``, ``u`` (``blended_vel``) and ``mode``
(index into the interface's modes of the mode in force at each sample), all on ``t``; ``u_h``
(``user_vel``, about 100 Hz) was logged without times: it is stored as logged, with ``t_u_h``
spreading its samples evenly over ``t``'s span (an approximation); ``request_mode_scores`` and
``request_dim_scores`` are the scores computed at each request (``cmode_conf_disamb`` per score
column of the interface's modes, ``cdim_conf_disamb`` per dimension vx ... wz; one row per request,
without the time column), ``request_mode_ids`` the authors' id of the mode each request switched
to (the ``current_mode`` row nearest its switch). No ``ee_pose`` was logged.
Velocities are in the paper's order ``[vx, vy, vz, wx, wy, wz]``.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from drake_disamb.config import merge_layers, ordered_variant
from drake_disamb.config.system_presets import system_layer
from drake_disamb.interfaces import interface_modes, mode_name
from drake_disamb.study.data.folder import LoggedTrial, StudyFolder
from drake_disamb.study.data.records import TrialRecord, assistance_onset

__all__ = [
    "FAILED_TRIALS",
    "LOG_INTERFACES",
    "MODE_IDS",
    "ORDER_FIXES",
    "ImportSummary",
    "import_authors",
    "load_trial_order",
    "parse_trial_name",
    "read_trial",
    "read_trials",
    "study_modes",
]

FAILED_TRIALS: frozenset[tuple[str, int, int]] = frozenset(
    {
        ("H3", 2, 12),
        ("H4", 2, 9),
        ("H4", 2, 12),
        ("H5", 1, 3),
        ("H5", 1, 4),
        ("H5", 1, 11),
        ("H5", 1, 14),
        ("H5", 1, 16),
        ("H6", 1, 8),
        ("H6", 2, 6),
        ("H7", 1, 3),
        ("H7", 1, 13),
        ("H8", 1, 13),
        ("H8", 1, 15),
    }
)
"""(subject, block, trial) of the 14 trials the authors excluded as failed (data README)."""

ORDER_FIXES: dict[tuple[str, int, int], dict[str, int]] = {
    ("H9", 2, 12): {"goal": 4},
    ("H3", 1, 11): {"initial_mode": 2},
    ("H2", 1, 2): {"home": 3},
    ("H2", 1, 3): {"home": 1},
    ("H2", 2, 1): {"initial_mode": 3},
}
"""Corrections of the trial-order file that the authors' ``parse_data.m`` applies ("fix human
errors in trial conditions"), keyed by (subject, block, trial)."""

MODE_IDS: dict[str, tuple[int, ...]] = {
    "joystick": (12, 13, 45, 6, 7),
    "head_array": (1, 2, 3, 4, 5, 6, 7),
}
"""The authors' mode ids per interface, in the order of the interface's modes (the cycle order)."""

LOG_INTERFACES: tuple[str, ...] = tuple(MODE_IDS)
"""The interfaces of the authors' logs (the paper's study)."""

_INTERFACES = {"J2": "joystick", "HA": "head_array", "j": "joystick", "h": "head_array"}
_TASKS = {"RE": "reaching", "PO": "pouring", "r": "reaching", "p": "pouring"}
_PARADIGMS = {"on": "disambiguation", "wo": "manual"}
_NAME = re.compile(r"^(H\d)PH([12])(RE|PO)(J2|HA)T(\d{1,2})\.mat$")
_SWITCH_MATCH = 0.05
"""Largest gap (s) between a request's score row and the mode switch it made; wider is an error."""


@functools.cache
def study_modes(interface: str) -> tuple[tuple[int, ...], ...]:
    """The modes of the study's ``interface`` in the order of its mode ids (:data:`MODE_IDS`):
    the mode order of the ``tnsre2020_study`` preset (the study's head array steps vx, vy, vz,
    wz, ...), else the interface's registered order; the gripper mode last. (Read once: every
    trial file asks.)"""
    order = merge_layers([system_layer("tnsre2020_study")]).interface_mode_order.get(interface)
    if order is None:
        return interface_modes(interface)
    return ordered_variant(interface, order, f"tnsre2020_study.interface_mode_order.{interface}").modes


def parse_trial_name(name: str) -> tuple[str, int, str, str, int]:
    """``(subject, block, task, interface, trial)`` of a trial file name like ``H2PH1POHAT1.mat``.

    Raises:
        ValueError: The name does not follow the data README's pattern.
    """
    m = _NAME.match(name)
    if m is None:
        raise ValueError(f"trial file name: expected H<s>PH<b><RE|PO><J2|HA>T<n>.mat, got {name!r}")
    return m[1], int(m[2]), _TASKS[m[3]], _INTERFACES[m[4]], int(m[5])


class _MatVariables(dict):
    """A MATLAB file's variables: reading one it lacks is a ``ValueError`` naming the file and the
    variable (not a ``KeyError``, which no command turns into its one-line error)."""

    def __init__(self, variables: dict[str, Any], path: Path) -> None:
        super().__init__(variables)
        self.path = path

    def __missing__(self, name: str) -> Any:
        raise ValueError(f"{self.path}: no variable {name!r}")


def load_mat(path: Path) -> dict[str, Any]:
    """The variables of a MATLAB file (scipy's loadmat); a damaged file, or reading a variable it
    lacks, is a ValueError naming it."""
    from scipy.io import loadmat

    try:
        return _MatVariables(loadmat(str(path)), path)
    except Exception as err:  # scipy raises several types for a damaged file
        raise ValueError(f"{path}: cannot read the MATLAB file: {err}") from None


def load_trial_order(path: str | Path) -> dict[tuple[str, int, int], dict[str, Any]]:
    """The condition of every trial in ``trial_order_testing_8.mat``, corrected by :data:`ORDER_FIXES`.

    Returns:
        ``{(subject, block, trial): {"task", "interface", "paradigm", "goal", "home",
        "initial_mode"}}`` with ``goal`` and ``home`` 1-based and ``initial_mode`` 0-based, as in
        the file.
    """
    path = Path(path)
    data = load_mat(path)
    order: dict[tuple[str, int, int], dict[str, Any]] = {}
    for block in (1, 2):
        key = f"ph{block}_trial_mat"
        if key not in data:
            raise ValueError(f"{path}: no variable {key!r}")
        mat = data[key]
        if mat.ndim != 3 or mat.shape[1] != 6:
            raise ValueError(f"{path}: {key} has shape {mat.shape}, expected (16, 6, subjects)")
        for s in range(mat.shape[2]):
            subject = f"H{s + 2}"
            for n in range(mat.shape[0]):
                cell = [np.asarray(mat[n, c, s]).ravel() for c in range(6)]
                entry = {
                    "task": _TASKS[str(cell[0][0])],
                    "interface": _INTERFACES[str(cell[1][0])],
                    "paradigm": _PARADIGMS[str(cell[2][0])],
                    "goal": int(cell[3][0]),
                    "home": int(cell[4][0]),
                    "initial_mode": int(cell[5][0]),
                }
                entry.update(ORDER_FIXES.get((subject, block, n + 1), {}))
                order[(subject, block, n + 1)] = entry
    return order


def _events(data: dict[str, Any], name: str, path: Path, width: int) -> NDArray[np.float64]:
    if name not in data:
        raise ValueError(f"{path}: no variable {name!r}")
    a = np.asarray(data[name], dtype=float)
    if a.ndim != 2 or a.shape[1] != width or a.shape[0] < 1:
        raise ValueError(f"{path}: {name} has shape {a.shape}, expected (k, {width}) with a placeholder row")
    return a[1:]  # row 1 is the zero placeholder


def _scalar(data: dict[str, Any], name: str, path: Path) -> float:
    if name not in data:
        raise ValueError(f"{path}: no variable {name!r}")
    value = float(np.asarray(data[name], dtype=float).ravel()[0])
    if not np.isfinite(value):
        raise ValueError(f"{path}: {name} is {value}")
    return value


@dataclass(frozen=True)
class _TrialFile:
    """One trial file: its path, what its name says and its entry of the trial order."""

    path: Path
    subject: str
    block: int
    task: str
    interface: str
    trial: int
    cond: dict[str, Any]


def _trial_file(path: Path, order: dict[tuple[str, int, int], dict[str, Any]]) -> _TrialFile:
    """``path``'s name parsed and matched to its trial-order entry (which must agree with it)."""
    subject, block, task, interface, trial = parse_trial_name(path.name)
    cond = order.get((subject, block, trial))
    if cond is None:
        raise ValueError(f"{path}: no entry for ({subject}, block {block}, trial {trial}) in the trial order")
    if (cond["task"], cond["interface"]) != (task, interface):
        raise ValueError(
            f"{path}: the trial order says {cond['task']} / {cond['interface']}, "
            f"the file name {task} / {interface}"
        )
    return _TrialFile(path, subject, block, task, interface, trial, cond)


def _mode_name(f: _TrialFile, mode_id: float) -> str:
    """The study's name of the authors' ``mode_id`` of ``f``'s interface."""
    ids = MODE_IDS[f.interface]
    if int(mode_id) not in ids:
        raise ValueError(f"{f.path}: current_mode id {mode_id!r} is not one of {ids} ({f.interface})")
    return mode_name(study_modes(f.interface)[ids.index(int(mode_id))])


@dataclass(frozen=True)
class _Events:
    """A trial file's logged events (times in s from its start): every mode switch but the
    initial-mode row, the requests, the ``current_mode`` rows and their times, and the scores of
    each request (the time column last)."""

    switch_t: NDArray[np.float64]
    request_t: NDArray[np.float64]
    current: NDArray[np.float64]
    cm_t: NDArray[np.float64]
    scores: NDArray[np.float64]
    dim_scores: NDArray[np.float64]

    @property
    def initial_id(self) -> int:
        return int(self.current[0, 0])

    def mode_id_at(self, k: int) -> float:
        """The authors' id of the mode entered by switch ``k`` (the ``current_mode`` row nearest it)."""
        return self.current[int(np.argmin(np.abs(self.cm_t - self.switch_t[k]))), 0]


def _read_events(data: dict[str, Any], path: Path, start: float) -> _Events:
    """The events of the trial file ``path`` (variables ``data``, start time ``start``)."""
    switches = _events(data, "mode_switches", path, 2)
    current = _events(data, "current_mode", path, 2)
    requested = _events(data, "assistance_requested", path, 2)
    scores = np.asarray(data.get("cmode_conf_disamb", np.zeros((1, 7))), dtype=float)[1:]
    dim_scores = np.asarray(data.get("cdim_conf_disamb", np.zeros((1, 7))), dtype=float)[1:]
    if len(switches) < 1 or len(current) < 1:
        raise ValueError(f"{path}: mode_switches / current_mode lack the initial-mode row")
    if len(scores) != len(requested):
        raise ValueError(
            f"{path}: {len(requested)} requests but {len(scores)} rows of cmode_conf_disamb (one per request)"
        )
    return _Events(
        switch_t=switches[1:, 1] - start,
        request_t=requested[:, 1] - start,
        current=current,
        cm_t=current[:, 1] - start,
        scores=scores,
        dim_scores=dim_scores,
    )


def _request_switches(path: Path, events: _Events, start: float) -> list[int]:
    """Per request, the index of the mode switch it made: the one nearest its score row."""
    own: list[int] = []
    for score_t in events.scores[:, -1] - start:
        gaps = np.abs(events.switch_t - score_t)
        k = int(np.argmin(gaps)) if len(gaps) else -1
        if k < 0 or gaps[k] > _SWITCH_MATCH or k in own:
            raise ValueError(
                f"{path}: no mode switch of its own for the request scored at t = {score_t:.3f} s"
            )
        own.append(k)
    return own


@dataclass(frozen=True)
class _Modes:
    """A trial file's modes: the initial one's name, the index of each request's own mode switch
    among the events' switches, those of the user's switches and the name of the mode each entered."""

    initial: str
    own: list[int]
    user: list[int]
    user_modes: list[str]


def _modes(f: _TrialFile, events: _Events, start: float) -> _Modes:
    """The modes of ``f`` (module docstring: ``initial_mode``, ``request_times``, ``mode_switch_times``)."""
    initial = _mode_name(f, events.initial_id)
    own = _request_switches(f.path, events, start)
    user = [k for k in range(len(events.switch_t)) if k not in own]
    return _Modes(initial, own, user, [_mode_name(f, events.mode_id_at(k)) for k in user])


@dataclass(frozen=True)
class _Series:
    """A trial file's time series on the alpha samples' times ``t`` (cut to their common length),
    the user's command as logged, and alpha's mean and share above 0.6 within the trial."""

    t: NDArray[np.float64]
    alpha: NDArray[np.float64]
    belief: NDArray[np.float64]
    blended: NDArray[np.float64]
    user_vel: NDArray[np.float64]
    mean_alpha: float | None
    alpha_share: float | None


def _table(data: dict[str, Any], name: str, path: Path, rows: bool = True) -> NDArray[np.float64]:
    """The 2-D variable ``name`` of the trial file ``path``, one sample per row (``rows``) or per
    column (transposed); anything else is a ValueError naming the file and the variable."""
    a = np.asarray(data[name], dtype=float)
    if a.ndim != 2 or a.size == 0:
        raise ValueError(f"{path}: {name} has shape {a.shape}, expected a table of samples")
    return a if rows else a.T


def _read_series(data: dict[str, Any], path: Path, start: float, total: float) -> _Series:
    """The time series of the trial file ``path`` (variables ``data``), times in s from ``start``."""
    alpha_log = _events(data, "alpha", path, 2)
    belief = _table(data, "goal_probabilities", path)[1:]
    blended = _table(data, "blended_vel", path, rows=False)[1:]
    user_vel = _table(data, "user_vel", path, rows=False)
    t_alpha = alpha_log[:, 1] - start
    in_trial = (t_alpha >= 0.0) & (t_alpha <= total)
    mean_alpha = float(np.mean(alpha_log[in_trial, 0])) if np.any(in_trial) else None
    share = float(np.mean(alpha_log[in_trial, 0] > 0.6)) if np.any(in_trial) else None
    # A few files log one sample more of one of these arrays: the trace keeps the common length.
    n = min(len(t_alpha), len(belief), len(blended))
    return _Series(t_alpha[:n], alpha_log[:n, 0], belief[:n], blended[:n], user_vel, mean_alpha, share)


def _mode_index(f: _TrialFile, events: _Events, t: NDArray[np.float64]) -> NDArray[np.int64]:
    """Per sample time ``t``, the index into the interface's modes of the mode in force."""
    ids = MODE_IDS[f.interface]
    mode_index = np.zeros(len(t), dtype=np.int64)
    order_idx = np.searchsorted(events.cm_t, t, side="right") - 1
    cm_index = np.array([ids.index(int(v)) if int(v) in ids else -1 for v in events.current[:, 0]])
    mode_index[:] = np.where(order_idx >= 0, cm_index[np.clip(order_idx, 0, None)], cm_index[0])
    return mode_index


def _extra(f: _TrialFile, events: _Events, series: _Series) -> dict[str, Any]:
    """The record's ``extra``: where it came from and what the authors kept that the record does not."""
    extra: dict[str, Any] = {
        "file": f"{f.subject}/{f.path.name}",
        "block": f.block,
        "trial": f.trial,
        "target_goal": f.cond["goal"],
        "initial_mode_id": events.initial_id,
        "alpha_share_above_0_6": series.alpha_share,
    }
    if f.cond["initial_mode"] != MODE_IDS[f.interface].index(events.initial_id):
        extra["order_initial_mode"] = f.cond["initial_mode"]
    return extra


def _record(f: _TrialFile, events: _Events, modes: _Modes, series: _Series, total: float) -> TrialRecord:
    """The trial's record (module docstring)."""
    t, goal = series.t, f.cond["goal"] - 1
    during = (t >= 0.0) & (t <= total)
    onset = None
    if f.task == "reaching" and np.any(during):
        onset = assistance_onset(t[during], series.belief[during], series.alpha[during], goal)
    paradigm = f.cond["paradigm"]
    return TrialRecord(
        trial_id=f.path.stem,
        subject=f.subject,
        interface=f.interface,
        task=f.task,
        paradigm=paradigm,
        disambiguation_method="algorithm1" if paradigm == "disambiguation" else None,
        repetition=0,
        seed=None,
        start_pose=f.cond["home"] - 1,
        initial_mode=modes.initial,
        intended_goals=[goal],
        reached_goals=None,
        success=None,
        done=None,
        duration=total,
        completion_time=total,
        mode_switches=len(modes.user),
        requests=len(events.request_t),
        automatic_switches=0,
        button_presses=len(modes.user) + len(events.request_t),
        request_times=[float(x) for x in events.request_t],
        mode_switch_times=[float(events.switch_t[k]) for k in modes.user],
        mode_switch_modes=modes.user_modes,
        automatic_switch_times=[],
        mean_alpha=series.mean_alpha,
        assistance_onset=onset,
        wall_time=0.0,
        valid=(f.subject, f.block, f.trial) not in FAILED_TRIALS,
        source="authors",
        extra=_extra(f, events, series),
    )


def _trace(f: _TrialFile, events: _Events, modes: _Modes, series: _Series) -> dict[str, NDArray[Any]]:
    """The trial's trace (module docstring)."""
    t = series.t
    m = len(series.user_vel)
    return {
        "t": t,
        "belief": series.belief,
        "alpha": series.alpha,
        "u": series.blended,
        "mode": _mode_index(f, events, t),
        "u_h": series.user_vel,
        "t_u_h": np.linspace(t[0], t[-1], m) if len(t) and m else np.zeros(m),
        "request_mode_scores": events.scores[:, :-1],
        "request_dim_scores": events.dim_scores[:, :-1],
        "request_mode_ids": np.array([events.mode_id_at(k) for k in modes.own], dtype=np.int64),
    }


def read_trial(path: str | Path, order: dict[tuple[str, int, int], dict[str, Any]]) -> LoggedTrial:
    """Read one trial file into its record and trace (see the module docstring).

    Args:
        path: ``H<s>/H<s>PH<b><TASK><IF>T<n>.mat``.
        order: :func:`load_trial_order`'s result.

    Raises:
        ValueError: The name, a variable or the trial's condition is missing or inconsistent; the
            message names the file.
    """
    path = Path(path)
    f = _trial_file(path, order)
    data = load_mat(path)
    start = _scalar(data, "start_time", path)
    total = _scalar(data, "total_time", path)
    events = _read_events(data, path, start)
    modes = _modes(f, events, start)
    series = _read_series(data, path, start, total)
    return LoggedTrial(
        _record(f, events, modes, series, total),
        _trace(f, events, modes, series),
        request_switch_times=events.switch_t[modes.own],
    )


@dataclass
class ImportSummary:
    """What :func:`import_authors` did."""

    imported: int
    skipped: int
    records: Path


def _trial_files(data_dir: Path) -> list[Path]:
    files = [p for p in data_dir.glob("H*/H*.mat") if _NAME.match(p.name)]

    def key(p: Path) -> tuple[str, int, str, int]:
        subject, block, task, interface, trial = parse_trial_name(p.name)
        return subject, block, interface, trial

    return sorted(files, key=key)


def _repetitions(records: list[TrialRecord]) -> None:
    """Number the trials of each (subject, interface, task, paradigm) 0, 1, ... in trial order."""
    groups: dict[tuple[str, str, str, str], list[TrialRecord]] = {}
    for r in records:
        groups.setdefault((r.subject, r.interface, r.task, r.paradigm), []).append(r)
    for group in groups.values():
        group.sort(key=lambda r: (r.extra["block"], r.extra["trial"]))
        for i, r in enumerate(group):
            r.repetition = i


def read_trials(data_dir: str | Path) -> list[LoggedTrial]:
    """Every trial file of ``data_dir`` read with :func:`read_trial`, in trial order (subject,
    block, interface, trial), with ``repetition`` numbered within each condition.

    Raises:
        ValueError: ``data_dir`` has no trial files or no trial order, or a file is malformed.
    """
    data_dir = Path(data_dir)
    order_path = data_dir / "trial_order_testing_8.mat"
    if not order_path.is_file():
        raise ValueError(f"{order_path}: the trial-order file is missing (is {data_dir} the data folder?)")
    files = _trial_files(data_dir)
    if not files:
        raise ValueError(f"{data_dir}: no trial files H<s>/H<s>PH<b><TASK><IF>T<n>.mat")
    order = load_trial_order(order_path)
    trials = [read_trial(p, order) for p in files]
    _repetitions([t.record for t in trials])
    return trials


def import_authors(
    data_dir: str | Path, out_dir: str | Path, progress: Callable[[str], None] | None = None
) -> ImportSummary:
    """Import every trial file of ``data_dir`` into the study folder ``out_dir`` (records and
    traces, :meth:`StudyFolder.append`, under the folder's writer lock).

    Trials already in ``out_dir/trials.jsonl`` (same ``trial_id``) are skipped; nothing existing is
    overwritten. Each record is appended only after its trace is written.

    Raises:
        ValueError: ``data_dir`` has no trial files or no trial order, or a file is malformed, or
            ``out_dir`` cannot be written or is a simulated study's folder (nothing is written).
        RecordError: ``out_dir/trials.jsonl`` exists but cannot be read (names file and line).
        FolderBusy: Another process writes ``out_dir``.
        FolderWriteError: A write failed (names the file); a rerun imports the rest.
    """
    # Read everything first: repetitions are numbered within each condition, and a malformed file
    # stops the import before anything is written.
    trials = read_trials(data_dir)
    folder = StudyFolder(out_dir).prepare()
    folder.check_source("authors")
    done = {r.trial_id for r in folder.read_records(repair=True)}
    imported = 0
    for trial in trials:
        rid = trial.record.trial_id
        if rid in done:
            continue
        folder.append(trial.record, trial.trace)
        imported += 1
        if progress is not None:
            progress(rid)
    return ImportSummary(imported=imported, skipped=len(trials) - imported, records=folder.records_path)
