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
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from drake_disamb.core.blending import RHO1_TIMES_N
from drake_disamb.core.interfaces import INTERFACES
from drake_disamb.study.data.authors import LOG_INTERFACES
from drake_disamb.study.data.folder import LoggedTrial
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


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """``[start, stop)`` index ranges of the True runs of ``mask``."""
    m = np.concatenate(([False], mask, [False])).astype(np.int8)
    d = np.diff(m)
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(), strict=True))


@dataclass
class BehaviourEstimates:
    """What :func:`estimate_behaviour` measured (times in s). Per-subject lists feed the fits."""

    start_delay: LogNormalFit
    press_interval: LogNormalFit
    settle: LogNormalFit
    held_through_switch: float
    pause_duration: LogNormalFit
    pause_rate: dict[str, float]
    unassisted_pause_duration: LogNormalFit
    unassisted_pause_rate: dict[str, float]
    """Per subject, pauses begun while the assistance did not move the arm, per second of
    commanding while it did not."""
    carry_duration: LogNormalFit
    carry_rate: dict[str, float]
    """Per subject, pauses begun while the assistance moved the arm (``alpha > 0``), per second of
    commanding while it did."""
    uncommanded_motion: dict[str, dict[str, tuple[float, float, int]]]
    """Per interface and task: the median seconds per trial in which the arm moved while the user
    commanded nothing, the same with ``alpha > 0``, and the number of trials."""
    deflection: LogNormalFit
    full_deflection_share: float
    direction_mean_cos: float
    direction_kappa: float
    direction_kappa_by_subject: dict[str, float]
    presses_per_change: dict[str, float]
    commanding_per_change: dict[str, float]
    full_round_share: float
    corrections_per_dwell: dict[str, float]
    corrections_per_dwell_by_subject: dict[str, float]
    correction_prob_by_interface: dict[str, dict[str, float]]
    """Per interface, per subject: ``c / (1 + c)`` of the stops of :data:`MIN_STOP` to
    :data:`MIN_PAUSE` s per dwell."""
    reversals_per_dwell: dict[str, tuple[float, int]]
    """Per interface, the command's reversals per dwell (mean) and the number of dwells."""
    request_share: dict[str, float]
    request_share_by_subject: dict[str, float]
    early_request_share: float
    requests_per_trial: dict[str, float]
    request_time_mean: float
    request_decay: RequestDecayFit
    accept_share: float
    accept_n: int
    switches_after_request: dict[str, tuple[float, float, int]]
    """Per interface, the user mode switches after each request until the next request or the
    end of the trial: mean, median and the number of requests (Disambiguation trials)."""
    request_translation: dict[str, tuple[float, int]]
    """Per interface, the share of the requests' mode switches that chose a translation mode, and
    their number (:func:`~drake_disamb.study.measures.course.request_modes`)."""
    tail: LogNormalFit
    commanding_share: float
    n_trials: int
    changes_per_minute: dict[str, tuple[float, float]]
    changes_per_minute_helped: dict[str, tuple[float, float]]
    """Per interface, reaching trials: mode changes per minute while the belief's argmax is the
    person's goal above ``rho1`` (the assistance helps), and while the belief is below ``rho1``."""
    changes_per_minute_misled: dict[str, tuple[float, float]]
    """The same with the argmax on another goal above ``rho1`` (the assistance pulls elsewhere)."""
    confident_share: dict[str, float]
    confident_by_half: dict[str, dict[str, tuple[float, float]]]
    """Per interface and task, the share of the first and of the second half of the trials' time
    with the belief confident (its largest entry above ``rho1``)."""
    gripper_end: dict[str, dict[str, GripperEnd]]
    starts_in_gripper: dict[str, tuple[float, int]]
    """Per interface, the share of trials starting in the gripper mode and the number of trials."""
    command_path: dict[str, dict[str, CommandPath]]
    """Per interface and task, the commanded path (:class:`CommandPath`)."""
    commanding_by_belief: dict[str, CommandingByBelief]
    """Per interface, reaching: what the user commands while the belief helps and while it is unsure."""
    rotation_dwells: dict[str, RotationDwells]
    """Per interface: the user's changes into a rotation mode, commanded in or not, and how long."""


def _reversals(u: NDArray[np.float64]) -> int:
    """The reversals of one dwell's ``(6, M)`` command (module docstring): consecutive samples
    above a tenth of the largest whose dot product is negative."""
    norms = np.linalg.norm(u, axis=0)
    if norms.size == 0 or norms.max() == 0.0:
        return 0
    kept = u[:, norms > 0.1 * norms.max()]
    return int(np.count_nonzero(np.einsum("ij,ij->j", kept[:, :-1], kept[:, 1:]) < 0.0))


def estimate_behaviour(trials: Iterable[LoggedTrial]) -> BehaviourEstimates:
    """The behaviour estimates of the valid trials (module docstring), from
    :func:`drake_disamb.study.data.authors.read_trials`."""
    valid = [t for t in trials if is_analysed(t.record) and t.record.paradigm in PEOPLE_PARADIGMS]
    if not valid:
        raise ValueError("trials: expected at least one valid Manual or Disambiguation trial, got none")
    start: dict[str, list[float]] = {}
    press: dict[str, list[float]] = {}
    settle: dict[str, list[float]] = {}
    held = n_settle = 0
    pause: dict[str, list[float]] = {}
    pause_count: dict[str, float] = {}
    command_time: dict[str, float] = {}
    # per state (True: the assistance moved the arm when the pause began): durations, counts, commanding s
    split_pause: dict[bool, dict[str, list[float]]] = {True: {}, False: {}}
    split_count: dict[bool, dict[str, float]] = {True: {}, False: {}}
    split_time: dict[bool, dict[str, float]] = {True: {}, False: {}}
    uncommanded: dict[tuple[str, str], list[tuple[float, float]]] = {}
    deflect: dict[str, list[float]] = {}
    cos_by_subject: dict[str, list[float]] = {}
    tail: dict[str, list[float]] = {}
    kinds = LOG_INTERFACES
    bursts: dict[str, list[int]] = {k: [] for k in kinds}
    req_share: dict[str, list[float]] = {k: [] for k in kinds}
    req_share_subject: dict[str, list[float]] = {}
    req_count: dict[str, list[float]] = {k: [] for k in kinds}
    early, req_norm = [], []
    change_events: list[tuple[str, float, bool]] = []  # Disambiguation: (subject, time, a request?)
    accepted = rejected = 0
    after_request: dict[str, list[int]] = {k: [] for k in kinds}  # user switches until the next request
    chosen_translation: dict[str, list[bool]] = {k: [] for k in kinds}  # per request switch
    corrections: dict[str, list[int]] = {k: [] for k in kinds}
    corrections_subject: dict[str, list[int]] = {}
    stops: dict[str, dict[str, list[int]]] = {k: {} for k in kinds}  # interface -> subject -> per dwell
    reversals: dict[str, list[int]] = {k: [] for k in kinds}
    commanding_total = time_total = 0.0
    commanding_by_interface = dict.fromkeys(kinds, 0.0)
    # interface -> [confident s, not confident s, changes while confident, changes while not]
    confident = {k: np.zeros(4) for k in kinds}
    helped = {k: np.zeros(4) for k in kinds}  # the same, reaching: helped (argmax the goal) / unsure
    misled = {k: np.zeros(4) for k in kinds}  # ... and the argmax on another goal / unsure
    halves: dict[tuple[str, str], list[NDArray[np.float64]]] = {}  # per trial: [confident s, s] per half
    gripper_paths: dict[tuple[str, str], list[tuple[bool, float, int]]] = {}
    gripper_starts: dict[str, list[bool]] = {}
    command_paths: dict[tuple[str, str], list[tuple[float, float, float]]] = {}
    by_belief: dict[str, list[NDArray[np.float64]]] = {}
    rotations: dict[str, list[list[float]]] = {}
    for trial in valid:
        r = trial.record
        s = r.subject
        gripper_paths.setdefault((r.interface, r.task), []).append(gripper_course(trial))
        path = command_path(trial)
        if path is not None:
            command_paths.setdefault((r.interface, r.task), []).append(path)
        gripper_starts.setdefault(r.interface, []).append(starts_in_gripper(trial))
        rotations.setdefault(r.interface, []).append(rotation_dwells(trial))
        if r.task == "reaching":
            row = commanding_by_belief(trial)
            if row is not None:
                by_belief.setdefault(r.interface, []).append(row)
        user_vel, dt = user_command(trial)
        cmd = np.any(user_vel != 0.0, axis=0)
        on = np.flatnonzero(cmd)
        times_cmd = on * dt
        commanding_total += cmd.sum() * dt
        commanding_by_interface[r.interface] += cmd.sum() * dt
        time_total += r.duration
        request_times = np.asarray(r.request_times, dtype=float)
        switch_times = trial.switch_times
        events = np.sort(np.concatenate((switch_times, request_times)))
        user_switches = np.asarray(r.mode_switch_times, dtype=float)
        user_sw = np.sort(user_switches[user_switches > 0])
        first = [x for x in (times_cmd[:1].tolist() + user_sw[:1].tolist()) if x > 0]
        if first:
            start.setdefault(s, []).append(min(first))
        if on.size:
            tail.setdefault(s, []).append(r.duration - times_cmd[-1])
        # Mode changes: bursts of switches with no command between them.
        sw = switch_times[switch_times > 0]
        burst = 1
        for a, b in zip(sw, sw[1:], strict=False):
            between = np.any(cmd[int(a / dt) + 1 : int(b / dt) + 1])
            if not between and b - a < BURST_GAP:
                press.setdefault(s, []).append(b - a)
                burst += 1
            else:
                bursts[r.interface].append(burst)
                burst = 1
        if sw.size:
            bursts[r.interface].append(burst)
        # Corrections: short stops between commands within a dwell (between mode changes).
        edges = [0.0, *events[events > 0].tolist(), r.duration]
        for a, b in zip(edges, edges[1:], strict=False):
            seg = cmd[int(a / dt) : int(b / dt)]
            if seg.any():
                inside = np.flatnonzero(seg)
                gaps = [(g1 - g0) * dt for g0, g1 in _runs(~seg[inside[0] : inside[-1] + 1])]
                n = sum(g < MIN_PAUSE for g in gaps)
                corrections[r.interface].append(n)
                corrections_subject.setdefault(s, []).append(n)
                stops[r.interface].setdefault(s, []).append(sum(MIN_STOP <= g < MIN_PAUSE for g in gaps))
                reversals[r.interface].append(_reversals(user_vel[:, int(a / dt) : int(b / dt)]))
        # Settle: last switch of a change -> next command, nothing else first.
        for x in sw:
            later_cmd = times_cmd[times_cmd > x]
            later_evt = events[events > x + 1e-9]
            if later_cmd.size and (not later_evt.size or later_evt[0] > later_cmd[0]):
                n_settle += 1
                if later_cmd[0] - x < MIN_SETTLE:
                    held += 1
                else:
                    settle.setdefault(s, []).append(float(later_cmd[0] - x))
        # Pauses between the first and the last command, with no event inside.
        carrying = _assisting(trial, cmd.size, dt)
        if on.size:
            inner = ~cmd[on[0] : on[-1] + 1]
            for a, b in _runs(inner):
                t0, t1 = (on[0] + a) * dt, (on[0] + b) * dt
                if t1 - t0 >= MIN_PAUSE and not np.any((events >= t0) & (events <= t1)):
                    pause.setdefault(s, []).append(t1 - t0)
                    pause_count[s] = pause_count.get(s, 0.0) + 1
                    state = bool(carrying[on[0] + a])
                    split_pause[state].setdefault(s, []).append(t1 - t0)
                    split_count[state][s] = split_count[state].get(s, 0.0) + 1
            command_time[s] = command_time.get(s, 0.0) + cmd.sum() * dt
            for state in (True, False):
                split_time[state][s] = split_time[state].get(s, 0.0) + (cmd & (carrying == state)).sum() * dt
        moved = _uncommanded_motion(trial, cmd, dt)
        if moved is not None:
            uncommanded.setdefault((r.interface, r.task), []).append(moved)
        # A proportional interface (the joystick): deflection and direction spread.
        if INTERFACES[r.interface].proportional and on.size:
            lin, ang = INTERFACES[r.interface].default_speeds
            v = user_vel[:, on]
            size = np.maximum(np.linalg.norm(v[:3], axis=0) / lin, np.linalg.norm(v[3:], axis=0) / ang)
            deflect.setdefault(s, []).extend(np.clip(size, 0, None).tolist())
            for a, b in _runs(cmd):
                if b - a < 10:
                    continue
                run = user_vel[:, a:b]
                if np.count_nonzero(np.any(run != 0, axis=1)) != 2:
                    continue  # a 2-D mode: the stick's direction is free
                unit = run / np.linalg.norm(run, axis=0, keepdims=True)
                mean = unit.mean(axis=1)
                norm = np.linalg.norm(mean)
                if norm > 0:
                    cos_by_subject.setdefault(s, []).extend((mean / norm @ unit).tolist())
        merged = clean_requests(r.request_times)
        own_changes = _user_changes(r.mode_switch_times, cmd, dt)
        _count_confident_changes(trial, [*merged, *own_changes], confident[r.interface])
        halves.setdefault((r.interface, r.task), []).append(_confident_halves(trial))
        if r.task == "reaching" and len(r.intended_goals) == 1:
            goal, changes_at = r.intended_goals[0], [*merged, *own_changes]
            _count_confident_changes(trial, changes_at, helped[r.interface], goal)
            _count_confident_changes(trial, changes_at, misled[r.interface], goal, elsewhere=True)
        if r.paradigm == "disambiguation":
            req_count[r.interface].append(len(merged))
            change_events.extend((s, x, True) for x in merged)
            change_events.extend((s, x, False) for x in own_changes)
            changes = len(merged) + len(own_changes)
            if changes:
                req_share[r.interface].append(len(merged) / changes)
                req_share_subject.setdefault(s, []).append(len(merged) / changes)
            edges = [*merged, math.inf]
            after_request[r.interface].extend(
                int(np.count_nonzero((user_switches > a) & (user_switches < b)))
                for a, b in zip(edges[:-1], edges[1:], strict=True)
            )
            early.append(float(bool(merged) and merged[0] < EARLY_REQUEST))
            chosen_translation[r.interface].extend(request_modes(trial))
            req_norm.extend((np.asarray(merged) / r.duration).tolist())
            for x in trial.request_switch_times:
                later_cmd = times_cmd[times_cmd > x]
                later_sw = user_switches[user_switches > x]
                later_req = request_times[request_times > x]
                nxt_cmd = later_cmd[0] if later_cmd.size else math.inf
                nxt_sw = later_sw.min() if later_sw.size else math.inf
                nxt_req = later_req.min() if later_req.size else math.inf
                if min(nxt_cmd, nxt_sw) < nxt_req and min(nxt_cmd, nxt_sw) < math.inf:
                    accepted += nxt_cmd < nxt_sw
                    rejected += nxt_sw < nxt_cmd
    all_cos = [c for cs in cos_by_subject.values() for c in cs]
    mean_cos = float(np.mean(all_cos)) if all_cos else float("nan")
    deflections = [d for ds in deflect.values() for d in ds]
    # A full round: as many presses as the cycle has modes (the switched, cycling kinds: the head array).
    rounds = [
        b >= len(INTERFACES[k].modes) for k, v in bursts.items() if not INTERFACES[k].proportional for b in v
    ]
    return BehaviourEstimates(
        start_delay=fit_lognormal(start),
        press_interval=fit_lognormal(press),
        settle=fit_lognormal(settle),
        held_through_switch=held / n_settle if n_settle else math.nan,
        pause_duration=fit_lognormal(pause),
        pause_rate={s: pause_count.get(s, 0.0) / command_time[s] for s in sorted(command_time)},
        unassisted_pause_duration=fit_lognormal(split_pause[False]),
        unassisted_pause_rate={
            s: split_count[False].get(s, 0.0) / v for s, v in sorted(split_time[False].items()) if v > 0
        },
        carry_duration=fit_lognormal(split_pause[True]),
        carry_rate={
            s: split_count[True].get(s, 0.0) / v for s, v in sorted(split_time[True].items()) if v > 0
        },
        uncommanded_motion={
            i: {
                k: (
                    float(np.median([m[0] for m in uncommanded[i, k]])),
                    float(np.median([m[1] for m in uncommanded[i, k]])),
                    len(uncommanded[i, k]),
                )
                for k in ("reaching", "pouring")
                if (i, k) in uncommanded
            }
            for i in INTERFACES
            if any((i, k) in uncommanded for k in ("reaching", "pouring"))
        },
        deflection=fit_lognormal(deflect),
        full_deflection_share=float(np.mean(np.asarray(deflections) >= 0.99)) if deflections else math.nan,
        direction_mean_cos=mean_cos,
        direction_kappa=von_mises_kappa(mean_cos) if all_cos else math.nan,
        direction_kappa_by_subject={s: von_mises_kappa(float(np.mean(c))) for s, c in cos_by_subject.items()},
        presses_per_change={k: float(np.mean(v)) if v else math.nan for k, v in bursts.items()},
        commanding_per_change={
            k: commanding_by_interface[k] / len(v) if v else math.nan for k, v in bursts.items()
        },
        full_round_share=float(np.mean(rounds)) if rounds else math.nan,
        corrections_per_dwell={k: float(np.mean(v)) if v else math.nan for k, v in corrections.items()},
        reversals_per_dwell={k: (float(np.mean(v)) if v else math.nan, len(v)) for k, v in reversals.items()},
        corrections_per_dwell_by_subject={
            s: float(np.mean(v)) for s, v in sorted(corrections_subject.items())
        },
        correction_prob_by_interface={
            k: {s: float(np.mean(v) / (1.0 + np.mean(v))) for s, v in sorted(by.items())}
            for k, by in stops.items()
        },
        request_share={k: float(np.mean(v)) if v else math.nan for k, v in req_share.items()},
        request_share_by_subject={s: float(np.mean(v)) for s, v in sorted(req_share_subject.items())},
        early_request_share=float(np.mean(early)) if early else math.nan,
        requests_per_trial={k: float(np.mean(v)) if v else math.nan for k, v in req_count.items()},
        request_time_mean=float(np.mean(req_norm)) if req_norm else math.nan,
        request_decay=fit_request_decay(change_events),
        accept_share=accepted / (accepted + rejected) if accepted + rejected else math.nan,
        accept_n=int(accepted + rejected),
        switches_after_request={
            k: (float(np.mean(v)), float(np.median(v)), len(v)) if v else (math.nan, math.nan, 0)
            for k, v in after_request.items()
        },
        request_translation={
            k: (float(np.mean(v)) if v else math.nan, len(v)) for k, v in chosen_translation.items()
        },
        tail=fit_lognormal(tail),
        commanding_share=commanding_total / time_total if time_total else math.nan,
        n_trials=len(valid),
        changes_per_minute={
            k: (
                60.0 * v[2] / v[0] if v[0] > 0 else math.nan,
                60.0 * v[3] / v[1] if v[1] > 0 else math.nan,
            )
            for k, v in confident.items()
        },
        changes_per_minute_helped=_per_minute(helped),
        changes_per_minute_misled=_per_minute(misled),
        confident_share={
            k: v[0] / (v[0] + v[1]) if v[0] + v[1] > 0 else math.nan for k, v in confident.items()
        },
        confident_by_half=_per_condition(halves, _half_shares),
        gripper_end=_per_condition(gripper_paths, summarize_gripper_end),
        starts_in_gripper={
            i: (float(np.mean(gripper_starts[i])), len(gripper_starts[i]))
            for i in INTERFACES
            if i in gripper_starts
        },
        command_path=_per_condition(command_paths, summarize_command_paths),
        commanding_by_belief={i: summarize_commanding(by_belief[i]) for i in INTERFACES if i in by_belief},
        rotation_dwells={i: summarize_rotation_dwells(rotations[i]) for i in INTERFACES if i in rotations},
    )


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


def _fmt_forgone(state: str, argmax: str, rates: dict[str, tuple[float, float]]) -> str:
    """One line of changes per minute in ``state`` against while unsure, per interface."""
    return f"... in reaching, {state:<11}" + "; ".join(
        f"{k.replace('_', ' ')} {v[0]:.1f} while the argmax is {argmax}, {v[1]:.1f} while unsure "
        f"(forgone while {state}: {1 - v[0] / v[1]:.2f})"
        for k, v in rates.items()
        if v[1] > 0 and math.isfinite(v[0])
    )


def _fmt_fit(name: str, fit: LogNormalFit, unit: str = "s") -> str:
    per = ", ".join(f"{s} {v:.3g}" for s, v in sorted(fit.subject_medians.items()))
    return (
        f"{name:<28} median {fit.median:.3g} {unit}, log-sd {fit.log_sd:.2f}, "
        f"max {fit.maximum:.3g} {unit} (n={fit.n}); "
        f"per subject: {per}; between-subject log-sd {fit.subject_log_sd:.2f}"
    )


def format_estimates(est: BehaviourEstimates) -> str:
    """The estimates as text, one line each."""
    rates = ", ".join(f"{s} {v:.3g}" for s, v in est.pause_rate.items())
    kappas = ", ".join(f"{s} {v:.3g}" for s, v in sorted(est.direction_kappa_by_subject.items()))
    shares = ", ".join(f"{s} {v:.2f}" for s, v in est.request_share_by_subject.items())
    corr = ", ".join(f"{s} {v:.2f}" for s, v in est.corrections_per_dwell_by_subject.items())
    probs = ", ".join(f"{s} {v / (1 + v):.2f}" for s, v in est.corrections_per_dwell_by_subject.items())
    lines = [
        f"valid trials: {est.n_trials}",
        _fmt_fit("start delay", est.start_delay),
        _fmt_fit("press interval (in a change)", est.press_interval),
        _fmt_fit(f"settle (switch -> command >= {MIN_SETTLE} s)", est.settle),
        f"{'command held through switch':<28} {est.held_through_switch:.2f} of switches a command follows",
        _fmt_fit(f"pause duration (>= {MIN_PAUSE} s)", est.pause_duration),
        f"{'pause rate':<28} per second of commanding: {rates}",
        _fmt_fit("carry (pause, arm assisted)", est.carry_duration),
        f"{'carry rate':<28} per second of commanding while the assistance moves the arm: "
        + ", ".join(f"{s} {v:.3g}" for s, v in est.carry_rate.items()),
        _fmt_fit("pause, arm not assisted", est.unassisted_pause_duration),
        f"{'unassisted pause rate':<28} per second of commanding while it does not: "
        + ", ".join(f"{s} {v:.3g}" for s, v in est.unassisted_pause_rate.items()),
        "arm moving, no command       "
        + "; ".join(
            f"{i.replace('_', ' ')} {k} {m:.1f} s ({ma:.1f} s with alpha > 0, median of {n})"
            for i, tasks in est.uncommanded_motion.items()
            for k, (m, ma, n) in tasks.items()
        )
        + " per trial",
        _fmt_fit("joystick deflection", est.deflection, "of full"),
        f"{'full deflection share':<28} {est.full_deflection_share:.2f}",
        f"{'joystick direction':<28} mean cos {est.direction_mean_cos:.4f} -> von Mises kappa "
        f"{est.direction_kappa:.3g}; per subject: {kappas}",
        f"{'presses per mode change':<28} joystick {est.presses_per_change['joystick']:.2f}, head array "
        f"{est.presses_per_change['head_array']:.2f}; head-array changes of >= 7 presses "
        f"{est.full_round_share:.2f}",
        f"{'commanding s per change':<28} joystick {est.commanding_per_change['joystick']:.2f}, head array "
        f"{est.commanding_per_change['head_array']:.2f}",
        f"{'corrections per dwell':<28} joystick {est.corrections_per_dwell['joystick']:.2f}, head array "
        f"{est.corrections_per_dwell['head_array']:.2f}; per subject: {corr} (as a probability "
        f"c / (1 + c): {probs})",
        f"{'correction probability':<28} "
        + "; ".join(
            f"{k.replace('_', ' ')} " + ", ".join(f"{s} {v:.2f}" for s, v in by.items())
            for k, by in est.correction_prob_by_interface.items()
        )
        + f" (stops of {MIN_STOP:g} to {MIN_PAUSE:g} s per dwell c, as c / (1 + c), per subject)",
        f"{'reversals per dwell':<28} "
        + ", ".join(f"{k.replace('_', ' ')} {m:.2f} (n={n})" for k, (m, n) in est.reversals_per_dwell.items())
        + " (the command turning back within a mode dwell)",
        f"{'requests per trial':<28} joystick {est.requests_per_trial['joystick']:.2f}, head array "
        f"{est.requests_per_trial['head_array']:.2f} (Disambiguation trials, merged)",
        f"{'request share of changes':<28} joystick {est.request_share['joystick']:.2f}, head array "
        f"{est.request_share['head_array']:.2f}; per subject: {shares}",
        f"{'request share over time':<28} p0 * exp(-t / tau): tau {est.request_decay.tau:.0f} s, "
        "p0 per subject "
        + ", ".join(f"{k} {v:.2f}" for k, v in est.request_decay.p0.items())
        + f" (maximum likelihood, n={est.request_decay.n} changes)",
        f"{'first request in 3 s':<28} {est.early_request_share:.2f} of Disambiguation trials; mean "
        f"normalised request time {est.request_time_mean:.2f}",
        f"{'request mode kept':<28} {est.accept_share:.2f} (n={est.accept_n}: next action a command, "
        "not a switch)",
        f"{'switches after a request':<28} "
        + ", ".join(
            f"{k.replace('_', ' ')} mean {m:.2f}, median {med:.0f} (n={n})"
            for k, (m, med, n) in est.switches_after_request.items()
        )
        + " (user switches until the next request or the end)",
        f"{'request chose translation':<28} "
        + ", ".join(
            f"{k.replace('_', ' ')} {share:.2f} (n={n})" for k, (share, n) in est.request_translation.items()
        )
        + " (of the requests' mode switches: the system's choice)",
        _fmt_fit("tail (last command -> end)", est.tail),
        f"{'commanding share':<28} {est.commanding_share:.2f} of trial time",
        "mode changes per minute      "
        + "; ".join(
            f"{k.replace('_', ' ')} {v[0]:.1f} while the belief is confident, {v[1]:.1f} while not "
            f"(confident {est.confident_share[k]:.2f} of the time)"
            for k, v in est.changes_per_minute.items()
        ),
        "confident by half of trial   "
        + "; ".join(
            f"{i.replace('_', ' ')} {task} {first:.2f} / {second:.2f}"
            for i, tasks in est.confident_by_half.items()
            for task, (first, second) in tasks.items()
        )
        + " (share of the first / second half with the belief above rho1)",
        _fmt_forgone("helped", "the goal", est.changes_per_minute_helped),
        _fmt_forgone("misled", "another goal", est.changes_per_minute_misled),
        *format_gripper(est.gripper_end, est.starts_in_gripper),
        format_command_path(est.command_path),
        *format_commanding(est.commanding_by_belief, est.rotation_dwells),
    ]
    return "\n".join(lines)


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
