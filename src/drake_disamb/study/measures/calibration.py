"""Behaviour estimates from the paper's human logs: what the simulated-user population is drawn from.

The logs (``../shared/data/tnsre2020_human_study/``, 4 of the paper's 8 subjects; their README gives
the format) are read with :func:`drake_disamb.study.data.authors.read_trials`. :func:`estimate_behaviour`
measures behaviour only, never the Manual-versus-Disambiguation outcome the study must predict:

- **Times.** ``user_vel`` (the user's command, about 100 Hz) has no timestamps: sample ``k`` is
  taken at ``k * total_time / M`` after ``start_time`` (``M`` samples), i.e. spread evenly over the
  trial. Event times (switches, requests) are ROS times minus ``start_time``.
- **Start delay**: from the start to the first mode switch or non-zero command.
- **Press interval**: between consecutive mode switches with no command between them (a mode
  change made of several presses) and less than 3 s apart.
- **Settle**: from the last switch of a mode change (user's or a request's) to the next non-zero
  command, when no other switch or request comes first, and at least :data:`MIN_SETTLE` (a command
  sooner was held through the press: its share is reported as ``held_through_switch``).
- **Pauses**: runs of zero command of at least :data:`MIN_PAUSE` seconds between the first and the
  last command that hold no switch or request; the rate is per second of commanding. Split by
  what the arm did when the pause began: a *carry* began while the belief was confident and the
  assistance moved the arm (``alpha > 0``: the study's system assists without input), an
  *unassisted* pause while it did not; each one's rate per second of commanding in that state and
  its durations (the user lets a confident autonomy carry the arm, or stops for other reasons).
- **Movement without command**: per trial, the seconds in which the arm moved (a non-zero blended
  command) while the user commanded nothing, and those of them with ``alpha > 0``, per interface
  and task (median over trials).
- **Deflection** (joystick): the command's size as a share of full deflection,
  ``max(|v| / 0.13, |w| / 0.4)`` (the study's speeds); **direction spread** (joystick): within each
  run of at least 10 non-zero samples in a 2-D mode, the angle of each sample to the run's mean
  direction, summarised as the von Mises concentration whose mean cosine it is.
- **Requests** (Disambiguation trials): per trial, the share of trials whose first request comes
  in the first 3 s, the request times normalised by the trial duration, and the share of mode
  changes made by a request (requests / (requests + user mode changes), a user mode change being a
  burst of switches as below: the choice is made once per change, however many presses it takes),
  and how that share falls during a trial: ``P(request | a change at t) = p0 * exp(-t / tau)``, per
  subject ``p0`` and one ``tau``, by maximum likelihood (:func:`fit_request_decay`).
- **Presses per mode change** (bursts of switches as above), and the share of head-array bursts
  of 7 or more presses (a full round: at least one overshoot), and the seconds of commanding per
  mode change (the user's and the requests') per interface: how long people drive in a mode.
- **Corrections per dwell**: a dwell is the time between two mode changes (switches or requests)
  in which the user commands; its corrections are its gaps of zero command shorter than
  :data:`MIN_PAUSE` between commands (a stop and a new, corrective submovement in the same mode;
  longer gaps are pauses). Per interface and per subject (pooled over paradigms), and as the
  probability ``c / (1 + c)`` of correcting at once after a movement that ended short (``c``
  corrections per dwell, a geometric count). Per interface and subject, the same probability
  from the stops of at least :data:`MIN_STOP` (shorter ones are mostly a stick passing through
  its centre): the estimate of ``correction_prob`` (head array) and ``stick_correction_prob``
  (joystick).
- **Reversals per dwell**: in the same dwells, how often the command turns back: consecutive
  commanded samples (above a tenth of the dwell's largest command, so that the stick's passage
  through its dead zone is not counted) whose directions point more than 90 degrees apart (a
  negative dot product), per interface. An overshoot and its correction, a wrong direction put
  right: what makes a commanded path longer than the way to the goal.
- **Acceptance**: after a request's mode switch, whether the user's next action is a command (kept
  the chosen mode) or a mode switch (cycled away); and how many user mode switches follow each
  request (merged) before the next one or the end of the trial, per interface (mean and median).
- **Confident by half of the trial**: per interface and task, the share of the first and of the
  second half of the trials' time with the belief's largest entry above ``rho1`` (where in a
  trial the assistance works).
- **Changes while the belief is confident**: mode changes (a request, or the first switch of a
  burst of user switches) per minute while the belief's largest entry is above the system's
  ``rho1`` (``1.2 / n``, the blending's threshold: the autonomy assists) and while it is not, and
  the share of the trial time it is, per interface over both paradigms. People let a confident
  autonomy carry them rather than change modes: how they use the assistance. The same in the
  reaching trials (one goal, known) with the belief's argmax the person's goal (the assistance
  helps them) against below ``rho1``: the share of the changes people forgo while helped,
  ``1 - rate helped / rate unsure``, is the population's ``carry_prob``; the same with the argmax
  on another goal above ``rho1`` (the arm heads for another object): ``counter_prob``.
- **How a trial starts and ends, and how far the arm is driven**: ending and starting in the
  gripper mode, and the commanded path (:mod:`drake_disamb.study.measures.course`, which defines them).
- **What the user commands by the belief's state, and rotation dwells**: in reaching, the shares
  of the time the assistance helps and of the time it cannot in which the user commands a
  translation or a rotation only; the user's changes into a rotation mode commanded in, and for
  how long (:mod:`drake_disamb.study.measures.commanding`, which defines them).

The trials measured are the analysed ones (:func:`~drake_disamb.study.measures.metrics.is_analysed`: valid,
not failed) of the paradigms people did (Manual and Disambiguation). The same function measures
a simulated study (:func:`drake_disamb.study.data.folder.StudyFolder.read_trials`, ``study calibrate
--simulated DIR``): the check that the population behaves as the estimates say, not only that it
was drawn from them.

The logs are read by :func:`drake_disamb.study.data.authors.read_trials` (the reader of ``study
import-authors``: the mode switch a request made is the one logged with the request's scores) and
the authors' metrics (user mode switches, merged requests, the joystick's cleaning) are those of
:mod:`drake_disamb.study.measures.metrics`.

The estimates that read only the mode and blended-command traces are in
:mod:`drake_disamb.study.measures.course`; the distributions fitted to the samples are those of
:mod:`drake_disamb.study.measures.fits`.

Each estimate is one function of the analysed trials (each a :class:`MeasuredTrial`: the trial with
what several measures read of it, computed once) and one row of :data:`MEASURES` (its name, its
function and its line of :func:`format_estimates`), which :func:`estimate_behaviour` and
:func:`format_estimates` loop over.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from drake_disamb.core.blending import RHO1_TIMES_N
from drake_disamb.interfaces import INTERFACES
from drake_disamb.study.data.authors import LOG_INTERFACES
from drake_disamb.study.data.folder import LoggedTrial
from drake_disamb.study.data.records import TrialRecord
from drake_disamb.study.measures.commanding import (
    CommandingByBelief,
    RotationDwells,
    commanding_by_belief,
    format_commanding,
    rotation_dwells,
    summarize_commanding,
    summarize_rotation_dwells,
    user_command,
)
from drake_disamb.study.measures.course import (
    CommandPath,
    GripperEnd,
    command_path,
    format_command_path,
    format_gripper,
    gripper_course,
    request_modes,
    starts_in_gripper,
    summarize_command_paths,
    summarize_gripper_end,
)
from drake_disamb.study.measures.fits import (
    LogNormalFit,
    RequestDecayFit,
    fit_lognormal,
    fit_request_decay,
    von_mises_kappa,
)
from drake_disamb.study.measures.metrics import clean_requests, is_analysed
from drake_disamb.study.measures.table import Measured, text_lines

__all__ = [
    "BURST_GAP",
    "EARLY_REQUEST",
    "MEASURES",
    "MIN_PAUSE",
    "MIN_SETTLE",
    "MIN_STOP",
    "PEOPLE_PARADIGMS",
    "BehaviourEstimates",
    "Measure",
    "MeasuredTrial",
    "estimate_behaviour",
    "format_condition_means",
    "format_estimates",
]

EARLY_REQUEST = 3.0
"""A first request before this time (s from the start) counts as early."""
BURST_GAP = 3.0
"""Switches less than this apart with no command between them are one mode change (s)."""
PEOPLE_PARADIGMS = ("manual", "disambiguation")
"""The paradigms of the paper's study (Automatic is ours): the trials the estimates measure."""
MIN_SETTLE = 0.1
"""A command sooner than this after a switch was held through it, not a settle (s)."""
MIN_PAUSE = 0.5
"""Shortest run of zero command that counts as a pause (s)."""
MIN_STOP = 0.1
"""Shortest run of zero command that counts as a corrective stop for the per-interface estimate
(s): a stick passing through its centre gives shorter ones."""

K = TypeVar("K", bound=Hashable)
V = TypeVar("V")


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """``[start, stop)`` index ranges of the True runs of ``mask``."""
    m = np.concatenate(([False], mask, [False])).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(), strict=True))


def _grouped(pairs: Iterable[tuple[K, V]]) -> dict[K, list[V]]:
    """``{key: [values...]}`` of ``(key, value)`` pairs, keys in the order they first come."""
    out: dict[K, list[V]] = {}
    for key, value in pairs:
        out.setdefault(key, []).append(value)
    return out


def _per_interface(pairs: Iterable[tuple[str, V]]) -> dict[str, list[V]]:
    """:func:`_grouped` over the interfaces of the logs (:data:`LOG_INTERFACES`, each listed)."""
    out: dict[str, list[V]] = {k: [] for k in LOG_INTERFACES}
    for key, value in pairs:
        out[key].append(value)
    return out


def _sums(pairs: Iterable[tuple[str, float]]) -> dict[str, float]:
    """``{key: sum of its values}`` of ``(key, value)`` pairs, keys in the order they first come."""
    out: dict[str, float] = {}
    for key, value in pairs:
        out[key] = out.get(key, 0.0) + value
    return out


def _mean(values: Sequence[float]) -> float:
    """The mean of ``values`` (NaN for none)."""
    return float(np.mean(values)) if values else math.nan


def _reversals(u: NDArray[np.float64]) -> int:
    """The reversals of one dwell's ``(6, M)`` command (module docstring): consecutive samples
    above a tenth of the largest whose dot product is negative."""
    norms = np.linalg.norm(u, axis=0)
    if norms.size == 0 or norms.max() == 0.0:
        return 0
    kept = u[:, norms > 0.1 * norms.max()]
    return int(np.count_nonzero(np.einsum("ij,ij->j", kept[:, :-1], kept[:, 1:]) < 0.0))


# -- one trial ----------------------------------------------------------------------------------


class MeasuredTrial:
    """One analysed trial with what several measures read of it, each computed once: the user's
    command ``user_vel`` (``(6, M)``, samples ``dt`` s apart, :func:`~drake_disamb.study.measures.
    commanding.user_command`), where it is non-zero, the trial's events, its mode changes, pauses
    and dwells (module docstring)."""

    def __init__(self, trial: LoggedTrial) -> None:
        self.trial = trial
        self.user_vel, self.dt = user_command(trial)

    @property
    def record(self) -> TrialRecord:
        return self.trial.record

    @property
    def subject(self) -> str:
        return self.trial.record.subject

    @property
    def interface(self) -> str:
        return self.trial.record.interface

    @property
    def condition(self) -> tuple[str, str]:
        """``(interface, task)``."""
        return self.trial.record.interface, self.trial.record.task

    @cached_property
    def cmd(self) -> NDArray[np.bool_]:
        """Per user-command sample, whether the user commanded."""
        return np.any(self.user_vel != 0.0, axis=0)

    @cached_property
    def on(self) -> NDArray[np.int64]:
        """The samples with a command."""
        return np.flatnonzero(self.cmd)

    @cached_property
    def times_cmd(self) -> NDArray[np.float64]:
        """The times of the samples with a command (s)."""
        return self.on * self.dt

    @cached_property
    def commanding(self) -> float:
        """The seconds commanded."""
        return self.cmd.sum() * self.dt

    @cached_property
    def request_times(self) -> NDArray[np.float64]:
        return np.asarray(self.record.request_times, dtype=float)

    @cached_property
    def user_switches(self) -> NDArray[np.float64]:
        """The user's mode switches (s), as recorded."""
        return np.asarray(self.record.mode_switch_times, dtype=float)

    @cached_property
    def switches(self) -> NDArray[np.float64]:
        """Every mode switch after the start, the user's and the requests' (s, in time order)."""
        switch_times = self.trial.switch_times
        return switch_times[switch_times > 0]

    @cached_property
    def events(self) -> NDArray[np.float64]:
        """Every mode switch and every request (s, in time order)."""
        return np.sort(np.concatenate((self.trial.switch_times, self.request_times)))

    @cached_property
    def merged(self) -> list[float]:
        """The requests, merged as the authors cleaned them."""
        return clean_requests(self.record.request_times)

    @cached_property
    def own_changes(self) -> list[float]:
        """The times of the user's mode changes (:func:`_user_changes`)."""
        return _user_changes(self.record.mode_switch_times, self.cmd, self.dt)

    @cached_property
    def carrying(self) -> NDArray[np.bool_]:
        """Per user-command sample, whether the assistance moved the arm (:func:`_assisting`)."""
        return _assisting(self.trial, self.cmd.size, self.dt)

    def commanding_while(self, carried: bool) -> float:
        """The seconds commanded while the assistance moved the arm (``carried``) or did not."""
        return (self.cmd & (self.carrying == carried)).sum() * self.dt

    @cached_property
    def bursts(self) -> tuple[list[float], list[int]]:
        """The press intervals within mode changes (bursts of switches with no command between
        them, less than :data:`BURST_GAP` apart) and the presses of each change."""
        sw, cmd, dt = self.switches, self.cmd, self.dt
        intervals: list[float] = []
        sizes: list[int] = []
        burst = 1
        for a, b in zip(sw, sw[1:], strict=False):
            between = np.any(cmd[int(a / dt) + 1 : int(b / dt) + 1])
            if not between and b - a < BURST_GAP:
                intervals.append(b - a)
                burst += 1
            else:
                sizes.append(burst)
                burst = 1
        if sw.size:
            sizes.append(burst)
        return intervals, sizes

    @cached_property
    def dwells(self) -> list[tuple[int, int, int]]:
        """Per dwell with a command (between mode changes): its corrections (gaps of zero command
        shorter than :data:`MIN_PAUSE` between commands), its stops of :data:`MIN_STOP` to
        :data:`MIN_PAUSE` and its reversals (:func:`_reversals`)."""
        cmd, dt, events = self.cmd, self.dt, self.events
        edges = [0.0, *events[events > 0].tolist(), self.record.duration]
        out = []
        for a, b in zip(edges, edges[1:], strict=False):
            seg = cmd[int(a / dt) : int(b / dt)]
            if seg.any():
                inside = np.flatnonzero(seg)
                gaps = [(g1 - g0) * dt for g0, g1 in _runs(~seg[inside[0] : inside[-1] + 1])]
                corrections = sum(g < MIN_PAUSE for g in gaps)
                stops = sum(MIN_STOP <= g < MIN_PAUSE for g in gaps)
                out.append((corrections, stops, _reversals(self.user_vel[:, int(a / dt) : int(b / dt)])))
        return out

    @cached_property
    def settles(self) -> list[float]:
        """Per switch that a command follows before any other switch or request: the seconds from
        the switch to that command."""
        out = []
        for x in self.switches:
            later_cmd = self.times_cmd[self.times_cmd > x]
            later_evt = self.events[self.events > x + 1e-9]
            if later_cmd.size and (not later_evt.size or later_evt[0] > later_cmd[0]):
                out.append(later_cmd[0] - x)
        return out

    @cached_property
    def pauses(self) -> list[tuple[float, bool]]:
        """The pauses between the first and the last command (runs of zero command of at least
        :data:`MIN_PAUSE` s holding no switch or request): their seconds and whether the
        assistance moved the arm when each began."""
        on, cmd, dt, events = self.on, self.cmd, self.dt, self.events
        if not on.size:
            return []
        out = []
        for a, b in _runs(~cmd[on[0] : on[-1] + 1]):
            t0, t1 = (on[0] + a) * dt, (on[0] + b) * dt
            if t1 - t0 >= MIN_PAUSE and not np.any((events >= t0) & (events <= t1)):
                out.append((t1 - t0, bool(self.carrying[on[0] + a])))
        return out

    @cached_property
    def deflections(self) -> list[float]:
        """A proportional interface's (the joystick's): per commanded sample, the command's share of
        full deflection (empty for another interface)."""
        kind = INTERFACES[self.interface]
        if not kind.proportional or not self.on.size:
            return []
        lin, ang = kind.default_speeds
        v = self.user_vel[:, self.on]
        size = np.maximum(np.linalg.norm(v[:3], axis=0) / lin, np.linalg.norm(v[3:], axis=0) / ang)
        return np.clip(size, 0, None).tolist()

    @cached_property
    def direction_cosines(self) -> list[float]:
        """A proportional interface's: within each run of at least 10 commanded samples in a 2-D
        mode, the cosine of each sample's angle to the run's mean direction."""
        if not INTERFACES[self.interface].proportional or not self.on.size:
            return []
        out: list[float] = []
        for a, b in _runs(self.cmd):
            if b - a < 10:
                continue
            run = self.user_vel[:, a:b]
            if np.count_nonzero(np.any(run != 0, axis=1)) != 2:
                continue  # a 2-D mode: the stick's direction is free
            unit = run / np.linalg.norm(run, axis=0, keepdims=True)
            mean = unit.mean(axis=1)
            norm = np.linalg.norm(mean)
            if norm > 0:
                out.extend((mean / norm @ unit).tolist())
        return out

    @cached_property
    def acceptance(self) -> tuple[int, int]:
        """After each request's mode switch: how many times the user's next action was a command
        (the mode kept) and how many times a switch (cycled away)."""
        accepted = rejected = 0
        for x in self.trial.request_switch_times:
            later_cmd = self.times_cmd[self.times_cmd > x]
            later_sw = self.user_switches[self.user_switches > x]
            later_req = self.request_times[self.request_times > x]
            nxt_cmd = later_cmd[0] if later_cmd.size else math.inf
            nxt_sw = later_sw.min() if later_sw.size else math.inf
            nxt_req = later_req.min() if later_req.size else math.inf
            if min(nxt_cmd, nxt_sw) < nxt_req and min(nxt_cmd, nxt_sw) < math.inf:
                accepted += nxt_cmd < nxt_sw
                rejected += nxt_sw < nxt_cmd
        return accepted, rejected


def _disambiguation(trials: Sequence[MeasuredTrial]) -> list[MeasuredTrial]:
    """The Disambiguation trials of ``trials``."""
    return [v for v in trials if v.record.paradigm == "disambiguation"]


# -- times and pauses ---------------------------------------------------------------------------


def _n_trials(trials: Sequence[MeasuredTrial]) -> int:
    """The trials measured."""
    return len(trials)


def _first_action(v: MeasuredTrial) -> float | None:
    """The time of the trial's first mode switch or command (``None``: neither after the start)."""
    user_switches = np.sort(v.user_switches[v.user_switches > 0])
    first = [x for x in (v.times_cmd[:1].tolist() + user_switches[:1].tolist()) if x > 0]
    return min(first) if first else None


def _start_delay(trials: Sequence[MeasuredTrial]) -> LogNormalFit:
    """From the start to the first mode switch or non-zero command, per subject."""
    return fit_lognormal(_grouped((v.subject, x) for v in trials if (x := _first_action(v)) is not None))


def _press_interval(trials: Sequence[MeasuredTrial]) -> LogNormalFit:
    """Between consecutive switches of one mode change, per subject."""
    return fit_lognormal(_grouped((v.subject, x) for v in trials for x in v.bursts[0]))


def _settle(trials: Sequence[MeasuredTrial]) -> LogNormalFit:
    """From the last switch of a change to the next command, at least :data:`MIN_SETTLE`."""
    return fit_lognormal(
        _grouped((v.subject, float(x)) for v in trials for x in v.settles if not x < MIN_SETTLE)
    )


def _held_through_switch(trials: Sequence[MeasuredTrial]) -> float:
    """The share of the switches a command follows in which it follows sooner than :data:`MIN_SETTLE`."""
    settles = [x for v in trials for x in v.settles]
    return sum(1 for x in settles if x < MIN_SETTLE) / len(settles) if settles else math.nan


def _pause_duration(trials: Sequence[MeasuredTrial]) -> LogNormalFit:
    """The pauses' seconds, per subject."""
    return fit_lognormal(_grouped((v.subject, d) for v in trials for d, _ in v.pauses))


def _pause_rate(trials: Sequence[MeasuredTrial]) -> dict[str, float]:
    """Per subject, pauses per second of commanding."""
    count = _sums((v.subject, 1) for v in trials for _ in v.pauses)
    time = _sums((v.subject, v.commanding) for v in trials if v.on.size)
    return {s: count.get(s, 0.0) / time[s] for s in sorted(time)}


def _split_duration(trials: Sequence[MeasuredTrial], carried: bool) -> LogNormalFit:
    """The seconds of the pauses begun while the assistance moved the arm (``carried``) or did not."""
    return fit_lognormal(
        _grouped((v.subject, d) for v in trials for d, state in v.pauses if state == carried)
    )


def _split_rate(trials: Sequence[MeasuredTrial], carried: bool) -> dict[str, float]:
    """Per subject, pauses begun while the assistance moved the arm (``carried``) or did not, per
    second of commanding in that state."""
    count = _sums((v.subject, 1) for v in trials for _, state in v.pauses if state == carried)
    time = _sums((v.subject, v.commanding_while(carried)) for v in trials if v.on.size)
    return {s: count.get(s, 0.0) / t for s, t in sorted(time.items()) if t > 0}


def _unassisted_pause_duration(trials: Sequence[MeasuredTrial]) -> LogNormalFit:
    """The seconds of the pauses begun while the assistance did not move the arm."""
    return _split_duration(trials, False)


def _unassisted_pause_rate(trials: Sequence[MeasuredTrial]) -> dict[str, float]:
    """Per subject, pauses begun while the assistance did not move the arm, per second of
    commanding while it did not."""
    return _split_rate(trials, False)


def _carry_duration(trials: Sequence[MeasuredTrial]) -> LogNormalFit:
    """The seconds of the pauses begun while the assistance moved the arm (``alpha > 0``)."""
    return _split_duration(trials, True)


def _carry_rate(trials: Sequence[MeasuredTrial]) -> dict[str, float]:
    """Per subject, pauses begun while the assistance moved the arm (``alpha > 0``), per second of
    commanding while it did."""
    return _split_rate(trials, True)


def _uncommanded(trials: Sequence[MeasuredTrial]) -> dict[str, dict[str, tuple[float, float, int]]]:
    """Per interface and task: the median seconds per trial in which the arm moved while the user
    commanded nothing, the same with ``alpha > 0``, and the number of trials."""
    moved = _grouped(
        (v.condition, m) for v in trials if (m := _uncommanded_motion(v.trial, v.cmd, v.dt)) is not None
    )
    return _per_condition(
        moved,
        lambda rows: (
            float(np.median([m[0] for m in rows])),
            float(np.median([m[1] for m in rows])),
            len(rows),
        ),
    )


def _tail(trials: Sequence[MeasuredTrial]) -> LogNormalFit:
    """From the last command to the end, per subject."""
    return fit_lognormal(
        _grouped((v.subject, v.record.duration - v.times_cmd[-1]) for v in trials if v.on.size)
    )


def _commanding_share(trials: Sequence[MeasuredTrial]) -> float:
    """The share of the trials' time with a command."""
    commanding = sum((v.commanding for v in trials), 0.0)
    total = sum((v.record.duration for v in trials), 0.0)
    return commanding / total if total else math.nan


# -- the joystick -------------------------------------------------------------------------------


def _deflections_by_subject(trials: Sequence[MeasuredTrial]) -> dict[str, list[float]]:
    return _grouped((v.subject, d) for v in trials for d in v.deflections)


def _deflection(trials: Sequence[MeasuredTrial]) -> LogNormalFit:
    """The joystick's deflection: the command's size as a share of full deflection."""
    return fit_lognormal(_deflections_by_subject(trials))


def _full_deflection_share(trials: Sequence[MeasuredTrial]) -> float:
    """The share of the joystick's commanded samples at full deflection."""
    deflections = [d for ds in _deflections_by_subject(trials).values() for d in ds]
    return float(np.mean(np.asarray(deflections) >= 0.99)) if deflections else math.nan


def _cosines_by_subject(trials: Sequence[MeasuredTrial]) -> dict[str, list[float]]:
    return _grouped((v.subject, c) for v in trials for c in v.direction_cosines)


def _direction_mean_cos(trials: Sequence[MeasuredTrial]) -> float:
    """The mean cosine of the joystick's directions to their runs' mean direction."""
    cosines = [c for cs in _cosines_by_subject(trials).values() for c in cs]
    return float(np.mean(cosines)) if cosines else float("nan")


def _direction_kappa(trials: Sequence[MeasuredTrial]) -> float:
    """The von Mises concentration whose mean cosine is :func:`_direction_mean_cos`'s."""
    has_cosines = any(v.direction_cosines for v in trials)
    return von_mises_kappa(_direction_mean_cos(trials)) if has_cosines else math.nan


def _direction_kappa_by_subject(trials: Sequence[MeasuredTrial]) -> dict[str, float]:
    """The same per subject."""
    return {s: von_mises_kappa(float(np.mean(c))) for s, c in _cosines_by_subject(trials).items()}


# -- mode changes and dwells --------------------------------------------------------------------


def _bursts(trials: Sequence[MeasuredTrial]) -> dict[str, list[int]]:
    """Per interface, the presses of each mode change."""
    return _per_interface((v.interface, b) for v in trials for b in v.bursts[1])


def _presses_per_change(trials: Sequence[MeasuredTrial]) -> dict[str, float]:
    """Per interface, the mean presses per mode change."""
    return {k: _mean(v) for k, v in _bursts(trials).items()}


def _full_round_share(trials: Sequence[MeasuredTrial]) -> float:
    """The share of the cycling interfaces' (the head array's) mode changes of as many presses as
    the cycle has modes: a full round, at least one overshoot."""
    rounds = [
        b >= len(INTERFACES[k].modes)
        for k, v in _bursts(trials).items()
        if not INTERFACES[k].proportional
        for b in v
    ]
    return float(np.mean(rounds)) if rounds else math.nan


def _commanding_per_change(trials: Sequence[MeasuredTrial]) -> dict[str, float]:
    """Per interface, the seconds of commanding per mode change."""
    commanding = dict.fromkeys(LOG_INTERFACES, 0.0)
    for v in trials:
        commanding[v.interface] += v.commanding
    return {k: commanding[k] / len(v) if v else math.nan for k, v in _bursts(trials).items()}


def _corrections_per_dwell(trials: Sequence[MeasuredTrial]) -> dict[str, float]:
    """Per interface, the corrections per dwell."""
    corrections = _per_interface((v.interface, d[0]) for v in trials for d in v.dwells)
    return {k: _mean(v) for k, v in corrections.items()}


def _corrections_per_dwell_by_subject(trials: Sequence[MeasuredTrial]) -> dict[str, float]:
    """Per subject, the corrections per dwell."""
    corrections = _grouped((v.subject, d[0]) for v in trials for d in v.dwells)
    return {s: float(np.mean(v)) for s, v in sorted(corrections.items())}


def _correction_prob_by_interface(trials: Sequence[MeasuredTrial]) -> dict[str, dict[str, float]]:
    """Per interface, per subject: ``c / (1 + c)`` of the stops of :data:`MIN_STOP` to
    :data:`MIN_PAUSE` s per dwell."""
    stops: dict[str, dict[str, list[int]]] = {k: {} for k in LOG_INTERFACES}
    for v in trials:
        for d in v.dwells:
            stops[v.interface].setdefault(v.subject, []).append(d[1])
    return {
        k: {s: float(np.mean(v) / (1.0 + np.mean(v))) for s, v in sorted(by.items())}
        for k, by in stops.items()
    }


def _reversals_per_dwell(trials: Sequence[MeasuredTrial]) -> dict[str, tuple[float, int]]:
    """Per interface, the command's reversals per dwell (mean) and the number of dwells."""
    reversals = _per_interface((v.interface, d[2]) for v in trials for d in v.dwells)
    return {k: (_mean(v), len(v)) for k, v in reversals.items()}


# -- requests -----------------------------------------------------------------------------------


def _requests_per_trial(trials: Sequence[MeasuredTrial]) -> dict[str, float]:
    """Per interface, the merged requests per Disambiguation trial."""
    counts = _per_interface((v.interface, len(v.merged)) for v in _disambiguation(trials))
    return {k: _mean(v) for k, v in counts.items()}


def _request_shares(trials: Sequence[MeasuredTrial]) -> list[tuple[MeasuredTrial, float]]:
    """Per Disambiguation trial with a mode change: the share of its changes made by a request."""
    return [
        (v, len(v.merged) / (len(v.merged) + len(v.own_changes)))
        for v in _disambiguation(trials)
        if v.merged or v.own_changes
    ]


def _request_share(trials: Sequence[MeasuredTrial]) -> dict[str, float]:
    """Per interface, the share of the mode changes made by a request."""
    shares = _per_interface((v.interface, x) for v, x in _request_shares(trials))
    return {k: _mean(v) for k, v in shares.items()}


def _request_share_by_subject(trials: Sequence[MeasuredTrial]) -> dict[str, float]:
    """The same per subject."""
    shares = _grouped((v.subject, x) for v, x in _request_shares(trials))
    return {s: float(np.mean(v)) for s, v in sorted(shares.items())}


def _request_decay(trials: Sequence[MeasuredTrial]) -> RequestDecayFit:
    """How the share of changes made by a request falls during a trial (:func:`fit_request_decay`)."""
    events: list[tuple[str, float, bool]] = []
    for v in _disambiguation(trials):
        events.extend((v.subject, x, True) for x in v.merged)
        events.extend((v.subject, x, False) for x in v.own_changes)
    return fit_request_decay(events)


def _early_request_share(trials: Sequence[MeasuredTrial]) -> float:
    """The share of Disambiguation trials whose first request comes before :data:`EARLY_REQUEST`."""
    return _mean([float(bool(v.merged) and v.merged[0] < EARLY_REQUEST) for v in _disambiguation(trials)])


def _request_time_mean(trials: Sequence[MeasuredTrial]) -> float:
    """The mean request time normalised by the trial's duration."""
    return _mean(
        [x for v in _disambiguation(trials) for x in (np.asarray(v.merged) / v.record.duration).tolist()]
    )


def _accept_share(trials: Sequence[MeasuredTrial]) -> float:
    """After a request's mode switch, the share of next actions that are a command (the mode kept)."""
    accepted = sum(v.acceptance[0] for v in _disambiguation(trials))
    rejected = sum(v.acceptance[1] for v in _disambiguation(trials))
    return accepted / (accepted + rejected) if accepted + rejected else math.nan


def _accept_n(trials: Sequence[MeasuredTrial]) -> int:
    """The requests' mode switches followed by a command or a switch."""
    return int(sum(sum(v.acceptance) for v in _disambiguation(trials)))


def _switches_after_request(trials: Sequence[MeasuredTrial]) -> dict[str, tuple[float, float, int]]:
    """Per interface, the user mode switches after each request until the next request or the end
    of the trial: mean, median and the number of requests (Disambiguation trials)."""
    after: dict[str, list[int]] = {k: [] for k in LOG_INTERFACES}
    for v in _disambiguation(trials):
        edges = [*v.merged, math.inf]
        after[v.interface].extend(
            int(np.count_nonzero((v.user_switches > a) & (v.user_switches < b)))
            for a, b in zip(edges[:-1], edges[1:], strict=True)
        )
    return {
        k: (float(np.mean(v)), float(np.median(v)), len(v)) if v else (math.nan, math.nan, 0)
        for k, v in after.items()
    }


def _request_translation(trials: Sequence[MeasuredTrial]) -> dict[str, tuple[float, int]]:
    """Per interface, the share of the requests' mode switches that chose a translation mode, and
    their number (:func:`~drake_disamb.study.measures.course.request_modes`)."""
    chosen = _per_interface((v.interface, x) for v in _disambiguation(trials) for x in request_modes(v.trial))
    return {k: (_mean(v), len(v)) for k, v in chosen.items()}


# -- the belief ---------------------------------------------------------------------------------


def _confident_counts(trials: Sequence[MeasuredTrial]) -> dict[str, NDArray[np.float64]]:
    """Per interface, ``[confident s, not confident s, changes while confident, changes while not]``
    (:func:`_count_confident_changes`)."""
    acc = {k: np.zeros(4) for k in LOG_INTERFACES}
    for v in trials:
        _count_confident_changes(v.trial, [*v.merged, *v.own_changes], acc[v.interface])
    return acc


def _goal_counts(trials: Sequence[MeasuredTrial], elsewhere: bool) -> dict[str, NDArray[np.float64]]:
    """The same in the reaching trials with one intended goal, confident meaning the belief's
    argmax is that goal (``elsewhere``: another goal)."""
    acc = {k: np.zeros(4) for k in LOG_INTERFACES}
    for v in trials:
        r = v.record
        if r.task == "reaching" and len(r.intended_goals) == 1:
            changes = [*v.merged, *v.own_changes]
            _count_confident_changes(
                v.trial, changes, acc[v.interface], r.intended_goals[0], elsewhere=elsewhere
            )
    return acc


def _changes_per_minute(trials: Sequence[MeasuredTrial]) -> dict[str, tuple[float, float]]:
    """Per interface, mode changes per minute while the belief is confident and while it is not."""
    return _per_minute(_confident_counts(trials))


def _confident_share(trials: Sequence[MeasuredTrial]) -> dict[str, float]:
    """Per interface, the share of the time with the belief confident."""
    return {
        k: v[0] / (v[0] + v[1]) if v[0] + v[1] > 0 else math.nan for k, v in _confident_counts(trials).items()
    }


def _changes_per_minute_helped(trials: Sequence[MeasuredTrial]) -> dict[str, tuple[float, float]]:
    """Per interface, reaching trials: mode changes per minute while the belief's argmax is the
    person's goal above ``rho1`` (the assistance helps), and while the belief is below ``rho1``."""
    return _per_minute(_goal_counts(trials, elsewhere=False))


def _changes_per_minute_misled(trials: Sequence[MeasuredTrial]) -> dict[str, tuple[float, float]]:
    """The same with the argmax on another goal above ``rho1`` (the assistance pulls elsewhere)."""
    return _per_minute(_goal_counts(trials, elsewhere=True))


def _confident_by_half(trials: Sequence[MeasuredTrial]) -> dict[str, dict[str, tuple[float, float]]]:
    """Per interface and task, the share of the first and of the second half of the trials' time
    with the belief confident (its largest entry above ``rho1``)."""
    return _per_condition(_grouped((v.condition, _confident_halves(v.trial)) for v in trials), _half_shares)


# -- how a trial starts and ends, what the user commands -----------------------------------------


def _gripper_end(trials: Sequence[MeasuredTrial]) -> dict[str, dict[str, GripperEnd]]:
    """Per interface and task, the trials ending in the gripper mode (:class:`GripperEnd`)."""
    return _per_condition(
        _grouped((v.condition, gripper_course(v.trial)) for v in trials), summarize_gripper_end
    )


def _starts_in_gripper(trials: Sequence[MeasuredTrial]) -> dict[str, tuple[float, int]]:
    """Per interface, the share of trials starting in the gripper mode and the number of trials."""
    starts = _grouped((v.interface, starts_in_gripper(v.trial)) for v in trials)
    return {i: (float(np.mean(starts[i])), len(starts[i])) for i in INTERFACES if i in starts}


def _command_path(trials: Sequence[MeasuredTrial]) -> dict[str, dict[str, CommandPath]]:
    """Per interface and task, the commanded path (:class:`CommandPath`)."""
    paths = _grouped((v.condition, p) for v in trials if (p := command_path(v.trial)) is not None)
    return _per_condition(paths, summarize_command_paths)


def _commanding_by_belief(trials: Sequence[MeasuredTrial]) -> dict[str, CommandingByBelief]:
    """Per interface, reaching: what the user commands while the belief helps and while it is unsure."""
    rows = _grouped(
        (v.interface, row)
        for v in trials
        if v.record.task == "reaching" and (row := commanding_by_belief(v.trial)) is not None
    )
    return {i: summarize_commanding(rows[i]) for i in INTERFACES if i in rows}


def _rotation_dwells(trials: Sequence[MeasuredTrial]) -> dict[str, RotationDwells]:
    """Per interface: the user's changes into a rotation mode, commanded in or not, and how long."""
    rows = _grouped((v.interface, rotation_dwells(v.trial)) for v in trials)
    return {i: summarize_rotation_dwells(rows[i]) for i in INTERFACES if i in rows}


# -- the helpers of the measures ----------------------------------------------------------------


def _per_condition(rows: dict[tuple[str, str], list[Any]], summarize: Callable[[Any], Any]) -> dict[str, Any]:
    """``{interface: {task: summarize(rows[interface, task])}}`` over the conditions with rows."""
    out: dict[str, Any] = {}
    for i in INTERFACES:
        tasks = {k: summarize(rows[i, k]) for k in ("reaching", "pouring") if (i, k) in rows}
        if tasks:
            out[i] = tasks
    return out


def _assisting(trial: LoggedTrial, m: int, dt: float) -> NDArray[np.bool_]:
    """Per user-command sample (``m`` of them, ``dt`` s apart), whether the assistance moved the
    arm then (the blending's ``alpha > 0`` at that time in the trace; False where unknown)."""
    t = np.asarray(trial.trace["t"], dtype=float)
    alpha = np.asarray(trial.trace.get("alpha", ()), dtype=float).reshape(-1)
    if t.size == 0 or alpha.size != t.size:
        return np.zeros(m, dtype=bool)
    i = np.clip(np.searchsorted(t, np.arange(m) * dt, side="right") - 1, 0, t.size - 1)
    return alpha[i] > 0.0


def _uncommanded_motion(trial: LoggedTrial, cmd: NDArray[np.bool_], dt: float) -> tuple[float, float] | None:
    """The seconds of the trial in which the arm moved (non-zero blended command) while the user
    commanded nothing (``cmd``: per user-command sample, ``dt`` s apart), and those with
    ``alpha > 0``; ``None`` without a usable trace."""
    if "u" not in trial.trace or "alpha" not in trial.trace:
        return None
    t = np.asarray(trial.trace["t"], dtype=float)
    u = np.asarray(trial.trace["u"], dtype=float)
    alpha = np.asarray(trial.trace["alpha"], dtype=float).reshape(-1)
    if t.size < 2 or u.ndim != 2 or u.shape[0] != t.size or alpha.size != t.size or cmd.size == 0:
        return None
    duration = trial.record.duration
    span = np.clip(np.append(t[1:], t[-1]), 0.0, duration) - np.clip(t, 0.0, duration)
    idle = ~cmd[np.clip((t / dt).astype(int), 0, cmd.size - 1)]
    moving = np.any(u[:, :6] != 0.0, axis=1) & idle
    return float(span[moving].sum()), float(span[moving & (alpha > 0.0)].sum())


def _user_changes(switch_times: Sequence[float], cmd: NDArray[np.bool_], dt: float) -> list[float]:
    """The times of the user's mode changes: the first switch of each burst of user switches (less
    than :data:`BURST_GAP` apart with no command between; ``cmd`` as in :func:`estimate_behaviour`)."""
    starts: list[float] = []
    last = -math.inf
    for x in sorted(x for x in switch_times if x > 0):
        if last == -math.inf or x - last >= BURST_GAP or np.any(cmd[int(last / dt) + 1 : int(x / dt) + 1]):
            starts.append(x)
        last = x
    return starts


def _per_minute(acc: dict[str, NDArray[np.float64]]) -> dict[str, tuple[float, float]]:
    """Per interface, changes per minute in the two states of ``acc`` (as :func:`_count_confident_changes`
    fills it)."""
    return {
        k: (
            60.0 * v[2] / v[0] if v[0] > 0 else math.nan,
            60.0 * v[3] / v[1] if v[1] > 0 else math.nan,
        )
        for k, v in acc.items()
    }


def _count_confident_changes(
    trial: LoggedTrial,
    changes: Sequence[float],
    acc: NDArray[np.float64],
    goal: int | None = None,
    elsewhere: bool = False,
) -> None:
    """Add the trial's confident / not-confident seconds and its mode ``changes`` (times: merged
    requests and the user's own changes) to ``acc`` (module docstring). With ``goal``: confident
    means the argmax is ``goal`` (above ``rho1``; ``elsewhere``: another goal), and the time
    confident in the other case counts in neither."""
    r = trial.record
    t = np.asarray(trial.trace["t"], dtype=float)
    belief = np.asarray(trial.trace["belief"], dtype=float)
    if t.size < 2 or belief.ndim != 2 or belief.shape[0] != t.size:
        return
    above = np.max(belief, axis=1) > RHO1_TIMES_N / belief.shape[1]
    sure = above if goal is None else above & ((np.argmax(belief, axis=1) == goal) != elsewhere)
    unsure = ~above
    span = np.clip(np.append(t[1:], t[-1]), 0.0, r.duration) - np.clip(t, 0.0, r.duration)
    acc[0] += float(span[sure].sum())
    acc[1] += float(span[unsure].sum())
    for x in changes:
        i = int(np.clip(np.searchsorted(t, x, side="right") - 1, 0, t.size - 1))
        if sure[i] or unsure[i]:
            acc[2 if sure[i] else 3] += 1


def _confident_halves(trial: LoggedTrial) -> NDArray[np.float64]:
    """The trial's seconds with the belief confident (above ``rho1``) and its seconds, in its first
    and in its second half: ``[confident, all, confident, all]`` (zeros for an unusable trace)."""
    r = trial.record
    t = np.asarray(trial.trace["t"], dtype=float)
    belief = np.asarray(trial.trace["belief"], dtype=float)
    out = np.zeros(4)
    if t.size < 2 or belief.ndim != 2 or belief.shape[0] != t.size or not r.duration > 0:
        return out
    above = np.max(belief, axis=1) > RHO1_TIMES_N / belief.shape[1]
    start = np.clip(t, 0.0, r.duration)
    span = np.clip(np.append(t[1:], t[-1]), 0.0, r.duration) - start
    second = start >= 0.5 * r.duration
    for k, half in enumerate((~second, second)):
        out[2 * k : 2 * k + 2] = span[half & above].sum(), span[half].sum()
    return out


def _half_shares(rows: Sequence[NDArray[np.float64]]) -> tuple[float, float]:
    """The confident share of the first and of the second half over the trials' ``rows``
    (:func:`_confident_halves`)."""
    c1, n1, c2, n2 = np.sum(rows, axis=0)
    return (c1 / n1 if n1 > 0 else math.nan, c2 / n2 if n2 > 0 else math.nan)


# -- the text of each estimate ------------------------------------------------------------------


def _per_subject(values: Mapping[str, float], digits: str = ".3g") -> str:
    return ", ".join(f"{s} {v:{digits}}" for s, v in values.items())


def _two_interfaces(values: Mapping[str, float]) -> str:
    return f"joystick {values['joystick']:.2f}, head array {values['head_array']:.2f}"


def _label(interface: str) -> str:
    return interface.replace("_", " ")


def _fmt_fit(name: str, fit: LogNormalFit, unit: str = "s") -> str:
    per = ", ".join(f"{s} {v:.3g}" for s, v in sorted(fit.subject_medians.items()))
    return (
        f"{name:<28} median {fit.median:.3g} {unit}, log-sd {fit.log_sd:.2f}, "
        f"max {fit.maximum:.3g} {unit} (n={fit.n}); "
        f"per subject: {per}; between-subject log-sd {fit.subject_log_sd:.2f}"
    )


def _fmt_forgone(state: str, argmax: str, rates: dict[str, tuple[float, float]]) -> str:
    """One line of changes per minute in ``state`` against while unsure, per interface."""
    return f"... in reaching, {state:<11}" + "; ".join(
        f"{k.replace('_', ' ')} {v[0]:.1f} while the argmax is {argmax}, {v[1]:.1f} while unsure "
        f"(forgone while {state}: {1 - v[0] / v[1]:.2f})"
        for k, v in rates.items()
        if v[1] > 0 and math.isfinite(v[0])
    )


def _text_n_trials(n: int, _: BehaviourEstimates) -> str:
    return f"valid trials: {n}"


def _text_start_delay(fit: LogNormalFit, _: BehaviourEstimates) -> str:
    return _fmt_fit("start delay", fit)


def _text_press_interval(fit: LogNormalFit, _: BehaviourEstimates) -> str:
    return _fmt_fit("press interval (in a change)", fit)


def _text_settle(fit: LogNormalFit, _: BehaviourEstimates) -> str:
    return _fmt_fit(f"settle (switch -> command >= {MIN_SETTLE} s)", fit)


def _text_held(share: float, _: BehaviourEstimates) -> str:
    return f"{'command held through switch':<28} {share:.2f} of switches a command follows"


def _text_pause_duration(fit: LogNormalFit, _: BehaviourEstimates) -> str:
    return _fmt_fit(f"pause duration (>= {MIN_PAUSE} s)", fit)


def _text_pause_rate(rates: dict[str, float], _: BehaviourEstimates) -> str:
    return f"{'pause rate':<28} per second of commanding: {_per_subject(rates)}"


def _text_carry_duration(fit: LogNormalFit, _: BehaviourEstimates) -> str:
    return _fmt_fit("carry (pause, arm assisted)", fit)


def _text_carry_rate(rates: dict[str, float], _: BehaviourEstimates) -> str:
    per_subject = _per_subject(rates)
    return f"{'carry rate':<28} per second of commanding while the assistance moves the arm: {per_subject}"


def _text_unassisted_pause_duration(fit: LogNormalFit, _: BehaviourEstimates) -> str:
    return _fmt_fit("pause, arm not assisted", fit)


def _text_unassisted_rate(rates: dict[str, float], _: BehaviourEstimates) -> str:
    per_subject = _per_subject(rates)
    return f"{'unassisted pause rate':<28} per second of commanding while it does not: {per_subject}"


def _text_uncommanded(moved: dict[str, dict[str, tuple[float, float, int]]], _: BehaviourEstimates) -> str:
    return (
        "arm moving, no command       "
        + "; ".join(
            f"{_label(i)} {k} {m:.1f} s ({ma:.1f} s with alpha > 0, median of {n})"
            for i, tasks in moved.items()
            for k, (m, ma, n) in tasks.items()
        )
        + " per trial"
    )


def _text_deflection(fit: LogNormalFit, _: BehaviourEstimates) -> str:
    return _fmt_fit("joystick deflection", fit, "of full")


def _text_full_deflection(share: float, _: BehaviourEstimates) -> str:
    return f"{'full deflection share':<28} {share:.2f}"


def _text_direction(kappa: float, est: BehaviourEstimates) -> str:
    kappas = _per_subject(dict(sorted(est.direction_kappa_by_subject.items())))
    return (
        f"{'joystick direction':<28} mean cos {est.direction_mean_cos:.4f} -> von Mises kappa "
        f"{kappa:.3g}; per subject: {kappas}"
    )


def _text_presses(presses: dict[str, float], est: BehaviourEstimates) -> str:
    return (
        f"{'presses per mode change':<28} {_two_interfaces(presses)}; head-array changes of >= 7 "
        f"presses {est.full_round_share:.2f}"
    )


def _text_commanding_per_change(seconds: dict[str, float], _: BehaviourEstimates) -> str:
    return f"{'commanding s per change':<28} {_two_interfaces(seconds)}"


def _text_corrections(corrections: dict[str, float], est: BehaviourEstimates) -> str:
    by_subject = est.corrections_per_dwell_by_subject
    probs = ", ".join(f"{s} {v / (1 + v):.2f}" for s, v in by_subject.items())
    return (
        f"{'corrections per dwell':<28} {_two_interfaces(corrections)}; per subject: "
        f"{_per_subject(by_subject, '.2f')} (as a probability c / (1 + c): {probs})"
    )


def _text_correction_prob(probs: dict[str, dict[str, float]], _: BehaviourEstimates) -> str:
    return (
        f"{'correction probability':<28} "
        + "; ".join(f"{_label(k)} " + _per_subject(by, ".2f") for k, by in probs.items())
        + f" (stops of {MIN_STOP:g} to {MIN_PAUSE:g} s per dwell c, as c / (1 + c), per subject)"
    )


def _text_reversals(reversals: dict[str, tuple[float, int]], _: BehaviourEstimates) -> str:
    return (
        f"{'reversals per dwell':<28} "
        + ", ".join(f"{_label(k)} {m:.2f} (n={n})" for k, (m, n) in reversals.items())
        + " (the command turning back within a mode dwell)"
    )


def _text_requests_per_trial(requests: dict[str, float], _: BehaviourEstimates) -> str:
    return f"{'requests per trial':<28} {_two_interfaces(requests)} (Disambiguation trials, merged)"


def _text_request_share(shares: dict[str, float], est: BehaviourEstimates) -> str:
    return f"{'request share of changes':<28} {_two_interfaces(shares)}; per subject: " + _per_subject(
        est.request_share_by_subject, ".2f"
    )


def _text_request_decay(decay: RequestDecayFit, _: BehaviourEstimates) -> str:
    return (
        f"{'request share over time':<28} p0 * exp(-t / tau): tau {decay.tau:.0f} s, p0 per subject "
        + _per_subject(decay.p0, ".2f")
        + f" (maximum likelihood, n={decay.n} changes)"
    )


def _text_early_request(share: float, est: BehaviourEstimates) -> str:
    return (
        f"{'first request in 3 s':<28} {share:.2f} of Disambiguation trials; mean normalised "
        f"request time {est.request_time_mean:.2f}"
    )


def _text_accept(share: float, est: BehaviourEstimates) -> str:
    return f"{'request mode kept':<28} {share:.2f} (n={est.accept_n}: next action a command, not a switch)"


def _text_switches_after(after: dict[str, tuple[float, float, int]], _: BehaviourEstimates) -> str:
    return (
        f"{'switches after a request':<28} "
        + ", ".join(f"{_label(k)} mean {m:.2f}, median {med:.0f} (n={n})" for k, (m, med, n) in after.items())
        + " (user switches until the next request or the end)"
    )


def _text_request_translation(chosen: dict[str, tuple[float, int]], _: BehaviourEstimates) -> str:
    return (
        f"{'request chose translation':<28} "
        + ", ".join(f"{_label(k)} {share:.2f} (n={n})" for k, (share, n) in chosen.items())
        + " (of the requests' mode switches: the system's choice)"
    )


def _text_tail(fit: LogNormalFit, _: BehaviourEstimates) -> str:
    return _fmt_fit("tail (last command -> end)", fit)


def _text_commanding_share(share: float, _: BehaviourEstimates) -> str:
    return f"{'commanding share':<28} {share:.2f} of trial time"


def _text_changes_per_minute(rates: dict[str, tuple[float, float]], est: BehaviourEstimates) -> str:
    return "mode changes per minute      " + "; ".join(
        f"{_label(k)} {v[0]:.1f} while the belief is confident, {v[1]:.1f} while not "
        f"(confident {est.confident_share[k]:.2f} of the time)"
        for k, v in rates.items()
    )


def _text_confident_by_half(halves: dict[str, dict[str, tuple[float, float]]], _: BehaviourEstimates) -> str:
    return (
        "confident by half of trial   "
        + "; ".join(
            f"{_label(i)} {task} {first:.2f} / {second:.2f}"
            for i, tasks in halves.items()
            for task, (first, second) in tasks.items()
        )
        + " (share of the first / second half with the belief above rho1)"
    )


def _text_helped(rates: dict[str, tuple[float, float]], _: BehaviourEstimates) -> str:
    return _fmt_forgone("helped", "the goal", rates)


def _text_misled(rates: dict[str, tuple[float, float]], _: BehaviourEstimates) -> str:
    return _fmt_forgone("misled", "another goal", rates)


def _text_gripper(ends: dict[str, dict[str, GripperEnd]], est: BehaviourEstimates) -> list[str]:
    return format_gripper(ends, est.starts_in_gripper)


def _text_command_path(paths: dict[str, dict[str, CommandPath]], _: BehaviourEstimates) -> str:
    return format_command_path(paths)


def _text_commanding(by_belief: dict[str, CommandingByBelief], est: BehaviourEstimates) -> list[str]:
    return format_commanding(by_belief, est.rotation_dwells)


class BehaviourEstimates(Measured):
    """What :func:`estimate_behaviour` measured: the value of each of :data:`MEASURES` (times in s;
    the per-subject values feed the fits), by its name as a key (``est["tail"]``) or an attribute
    (``est.tail``); each measure's function documents its value."""


Text = Callable[[Any, BehaviourEstimates], str | list[str]]
"""The line (or lines) of an estimate in :func:`format_estimates`: of its value and of all the
estimates (for a line that shows several)."""


@dataclass(frozen=True)
class Measure:
    """One behaviour estimate: its ``name`` (its key and attribute in :class:`BehaviourEstimates`),
    the function that measures it on the analysed trials, and its text (``None``: shown on the
    line of another estimate, which comes after it in :data:`MEASURES`)."""

    name: str
    measure: Callable[[Sequence[MeasuredTrial]], Any]
    text: Text | None = None


MEASURES: tuple[Measure, ...] = (
    Measure("n_trials", _n_trials, _text_n_trials),
    Measure("start_delay", _start_delay, _text_start_delay),
    Measure("press_interval", _press_interval, _text_press_interval),
    Measure("settle", _settle, _text_settle),
    Measure("held_through_switch", _held_through_switch, _text_held),
    Measure("pause_duration", _pause_duration, _text_pause_duration),
    Measure("pause_rate", _pause_rate, _text_pause_rate),
    Measure("carry_duration", _carry_duration, _text_carry_duration),
    Measure("carry_rate", _carry_rate, _text_carry_rate),
    Measure("unassisted_pause_duration", _unassisted_pause_duration, _text_unassisted_pause_duration),
    Measure("unassisted_pause_rate", _unassisted_pause_rate, _text_unassisted_rate),
    Measure("uncommanded_motion", _uncommanded, _text_uncommanded),
    Measure("deflection", _deflection, _text_deflection),
    Measure("full_deflection_share", _full_deflection_share, _text_full_deflection),
    Measure("direction_mean_cos", _direction_mean_cos, None),
    Measure("direction_kappa_by_subject", _direction_kappa_by_subject, None),
    Measure("direction_kappa", _direction_kappa, _text_direction),
    Measure("full_round_share", _full_round_share, None),
    Measure("presses_per_change", _presses_per_change, _text_presses),
    Measure("commanding_per_change", _commanding_per_change, _text_commanding_per_change),
    Measure("corrections_per_dwell_by_subject", _corrections_per_dwell_by_subject, None),
    Measure("corrections_per_dwell", _corrections_per_dwell, _text_corrections),
    Measure("correction_prob_by_interface", _correction_prob_by_interface, _text_correction_prob),
    Measure("reversals_per_dwell", _reversals_per_dwell, _text_reversals),
    Measure("requests_per_trial", _requests_per_trial, _text_requests_per_trial),
    Measure("request_share_by_subject", _request_share_by_subject, None),
    Measure("request_share", _request_share, _text_request_share),
    Measure("request_decay", _request_decay, _text_request_decay),
    Measure("request_time_mean", _request_time_mean, None),
    Measure("early_request_share", _early_request_share, _text_early_request),
    Measure("accept_n", _accept_n, None),
    Measure("accept_share", _accept_share, _text_accept),
    Measure("switches_after_request", _switches_after_request, _text_switches_after),
    Measure("request_translation", _request_translation, _text_request_translation),
    Measure("tail", _tail, _text_tail),
    Measure("commanding_share", _commanding_share, _text_commanding_share),
    Measure("confident_share", _confident_share, None),
    Measure("changes_per_minute", _changes_per_minute, _text_changes_per_minute),
    Measure("confident_by_half", _confident_by_half, _text_confident_by_half),
    Measure("changes_per_minute_helped", _changes_per_minute_helped, _text_helped),
    Measure("changes_per_minute_misled", _changes_per_minute_misled, _text_misled),
    Measure("starts_in_gripper", _starts_in_gripper, None),
    Measure("gripper_end", _gripper_end, _text_gripper),
    Measure("command_path", _command_path, _text_command_path),
    Measure("rotation_dwells", _rotation_dwells, None),
    Measure("commanding_by_belief", _commanding_by_belief, _text_commanding),
)
"""The behaviour estimates (module docstring) in the order of :func:`format_estimates`'s lines:
adding one is a function of the analysed trials and a row here."""


def measured_here(trial: LoggedTrial) -> bool:
    """Whether :func:`estimate_behaviour` measures ``trial``: a valid Manual or Disambiguation trial
    of an interface the people's logs have (:data:`LOG_INTERFACES`: the estimates are compared
    with theirs, interface by interface)."""
    r = trial.record
    return is_analysed(r) and r.paradigm in PEOPLE_PARADIGMS and r.interface in LOG_INTERFACES


def estimate_behaviour(trials: Iterable[LoggedTrial]) -> BehaviourEstimates:
    """The behaviour estimates (:data:`MEASURES`) of the trials :func:`measured_here` keeps (module
    docstring), from :func:`drake_disamb.study.data.authors.read_trials`."""
    valid = [MeasuredTrial(t) for t in trials if measured_here(t)]
    if not valid:
        raise ValueError(
            "trials: expected at least one valid Manual or Disambiguation trial of the "
            f"{' or '.join(LOG_INTERFACES)}, got none"
        )
    return BehaviourEstimates({m.name: m.measure(valid) for m in MEASURES})


def format_estimates(est: BehaviourEstimates) -> str:
    """The estimates as text, one line each (the text of each of :data:`MEASURES` that has one)."""
    return "\n".join(text_lines(MEASURES, est))


def format_condition_means(rows: Sequence[dict[str, Any]]) -> str:
    """The authors' metrics per condition as a table: the rows of
    :func:`drake_disamb.study.measures.metrics.summarize` (means of the analysed trials)."""
    lines = [
        f"{'interface':<11} {'task':<9} {'paradigm':<15} {'n':>3} {'switches':>9} {'requests':>9} {'time':>7}"
    ]
    for row in rows:
        lines.append(
            f"{row['interface']:<11} {row['task']:<9} {row['paradigm']:<15} {row['n_valid']:>3} "
            f"{row['mean_mode_switches']:>9.2f} {row['mean_requests']:>9.2f} "
            f"{row['mean_completion_time']:>7.1f}"
        )
    return "\n".join(lines)
