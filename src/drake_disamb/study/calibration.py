"""Behaviour estimates from the paper's human logs: what the simulated-user population is drawn from.

The logs (``../shared/data/tnsre2020_human_study/``, 4 of the paper's 8 subjects; their README gives
the format) are read with :func:`read_human_trials`. :func:`estimate_behaviour` measures behaviour
only, never the Manual-versus-Disambiguation outcome the study must predict:

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
  last command that hold no switch or request; the rate is per second of commanding.
- **Deflection** (joystick): the command's size as a share of full deflection,
  ``max(|v| / 0.13, |w| / 0.4)`` (the study's speeds); **direction spread** (joystick): within each
  run of at least 10 non-zero samples in a 2-D mode, the angle of each sample to the run's mean
  direction, summarised as the von Mises concentration whose mean cosine it is.
- **Requests** (Disambiguation trials): per trial, the share of trials whose first request comes
  in the first 3 s, the request times normalised by the trial duration, and the share of mode
  changes made by a request (requests / (requests + user mode changes)).
- **Presses per mode change** (bursts of switches as above), and the share of head-array bursts
  of 7 or more presses (a full round: at least one overshoot).
- **Acceptance**: after a request's mode switch, whether the user's next action is a command (kept
  the chosen mode) or a mode switch (cycled away).

The authors' metrics of a trial (:func:`authors_metrics`) follow their README: user mode switches =
rows of ``mode_switches`` minus 2 minus the requests; requests less than 3 s apart merged; for the
joystick, a switch into the same mode as the switch before it within 2 s is dropped (we implement
the stated rule; their script used a stale variable).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

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
"""The 14 failed trials the authors excluded, as (subject, block, trial)."""

MERGE_REQUESTS = 3.0
"""Requests less than this many seconds apart count as one (the authors' analysis)."""
JOYSTICK_REPEAT = 2.0
"""A joystick switch into the same mode as the one before it within this many seconds is dropped."""
BURST_GAP = 3.0
"""Switches less than this apart with no command between them are one mode change (s)."""
MIN_SETTLE = 0.1
"""A command sooner than this after a switch was held through it, not a settle (s)."""
MIN_PAUSE = 0.5
"""Shortest run of zero command that counts as a pause (s)."""
SPEEDS = {"joystick": (0.13, 0.4), "head_array": (0.1, 0.2)}
"""Full-deflection linear (m/s) and angular (rad/s) speeds of the study's interfaces."""

_NAME = re.compile(r"^H(\d)PH(\d)(RE|PO)(J2|HA)T(\d+)\.mat$")
_TASKS = {"RE": "reaching", "PO": "pouring"}
_INTERFACES = {"J2": "joystick", "HA": "head_array"}
_PARADIGMS = {"on": "disambiguation", "wo": "manual"}


@dataclass(frozen=True)
class HumanTrial:
    """One trial of the authors' logs (times in s after ``start_time``).

    Attributes:
        subject: ``"H2"`` ... ``"H5"``.
        block, trial: Testing block (1, 2) and trial number within it (1..16).
        task: ``"reaching"`` or ``"pouring"``; interface: ``"joystick"`` or ``"head_array"``;
        paradigm: ``"manual"`` or ``"disambiguation"`` (from the trial-order file).
        valid: Not one of the :data:`FAILED_TRIALS`.
        total_time: ``end_time - start_time`` (s).
        switch_times, switch_modes: Every mode switch after the initial mode (requests' included)
            and the mode it went to.
        request_times: Every request press (unmerged).
        user_vel: ``(6, M)`` user command, spread evenly over ``total_time``.
    """

    subject: str
    block: int
    trial: int
    task: str
    interface: str
    paradigm: str
    valid: bool
    total_time: float
    switch_times: NDArray[np.float64]
    switch_modes: NDArray[np.int64]
    request_times: NDArray[np.float64]
    user_vel: NDArray[np.float64] = field(repr=False)

    @property
    def dt(self) -> float:
        """Seconds per ``user_vel`` sample (``total_time / M``; the log has no times)."""
        return self.total_time / max(self.user_vel.shape[1], 1)

    @property
    def commanding(self) -> NDArray[np.bool_]:
        """Per ``user_vel`` sample, whether the user commanded anything."""
        return np.any(self.user_vel != 0.0, axis=0)


def _events(value: NDArray[np.float64]) -> NDArray[np.float64]:
    a = np.atleast_2d(np.asarray(value, dtype=float))
    return a[1:] if a.shape[0] > 1 else np.zeros((0, a.shape[1]))


def read_human_trials(data_dir: str | Path) -> list[HumanTrial]:
    """Every trial file under ``data_dir`` (``H<s>/H<s>PH<b><TASK><IF>T<n>.mat``), sorted by name.

    Raises:
        ValueError: ``data_dir`` (or its ``trial_order_testing_8.mat``) is missing or holds no trial.
    """
    import scipy.io

    root = Path(data_dir)
    order_file = root / "trial_order_testing_8.mat"
    if not order_file.is_file():
        raise ValueError(f"data_dir: expected the authors' logs with {order_file.name}, got {str(root)!r}")
    order = scipy.io.loadmat(order_file)
    trials = []
    for path in sorted(root.glob("H*/H*.mat")):
        m = _NAME.match(path.name)
        if m is None:
            continue
        s, b, task, itf, n = m.groups()
        table = order[f"ph{b}_trial_mat"]
        paradigm = _PARADIGMS[str(np.squeeze(table[int(n) - 1, 2, int(s) - 2]))]
        d = scipy.io.loadmat(path)
        start = float(np.squeeze(d["start_time"]))
        switches = _events(d["mode_switches"])[1:]  # the first row left is the initial mode
        modes = _events(d["current_mode"])
        # The mode a switch went to: the last current_mode entry logged at or before it.
        after = []
        for t in switches[:, 1]:
            k = np.searchsorted(modes[:, 1], t + 1e-6, side="right") - 1
            after.append(int(modes[k, 0]) if k >= 0 else -1)
        trials.append(
            HumanTrial(
                subject=f"H{s}",
                block=int(b),
                trial=int(n),
                task=_TASKS[task],
                interface=_INTERFACES[itf],
                paradigm=paradigm,
                valid=(f"H{s}", int(b), int(n)) not in FAILED_TRIALS,
                total_time=float(np.squeeze(d["total_time"])),
                switch_times=switches[:, 1] - start,
                switch_modes=np.array(after, dtype=np.int64),
                request_times=_events(d["assistance_requested"])[:, 1] - start,
                user_vel=np.asarray(d["user_vel"], dtype=float),
            )
        )
    if not trials:
        raise ValueError(f"data_dir: no trial files H<s>/H<s>PH<b>...mat under {str(root)!r}")
    return trials


def merge_times(times: Iterable[float], gap: float = MERGE_REQUESTS) -> list[float]:
    """Times with every time less than ``gap`` after the last kept one dropped."""
    kept: list[float] = []
    for t in sorted(times):
        if not kept or t - kept[-1] >= gap:
            kept.append(float(t))
    return kept


def request_switch_indices(trial: HumanTrial) -> set[int]:
    """Indices of the switches the requests caused: the first switch after each request."""
    out: set[int] = set()
    for r in trial.request_times:
        later = np.flatnonzero(
            (trial.switch_times > r) & ~np.isin(np.arange(len(trial.switch_times)), list(out))
        )
        if later.size:
            out.add(int(later[0]))
    return out


def authors_metrics(trial: HumanTrial) -> dict[str, float]:
    """The paper's metrics of one trial the authors' way: ``mode_switches`` (the user's),
    ``requests`` (merged), ``button_presses`` and ``completion_time`` (``total_time``)."""
    requests = merge_times(trial.request_times)
    switches = max(len(trial.switch_times) - len(trial.request_times), 0)
    if trial.interface == "joystick":
        caused = request_switch_indices(trial)
        user = [k for k in range(len(trial.switch_times)) if k not in caused]
        dropped = 0
        for a, b in zip(user, user[1:], strict=False):
            same = trial.switch_modes[a] == trial.switch_modes[b]
            if same and trial.switch_times[b] - trial.switch_times[a] < JOYSTICK_REPEAT:
                dropped += 1
        switches = max(switches - dropped, 0)
    return {
        "mode_switches": float(switches),
        "requests": float(len(requests)),
        "button_presses": float(switches + len(requests)),
        "completion_time": trial.total_time,
    }


def human_condition_means(trials: Iterable[HumanTrial]) -> dict[tuple[str, str, str], dict[str, float]]:
    """Mean :func:`authors_metrics` of the valid trials per ``(interface, task, paradigm)`` (with
    ``n``, the trial count)."""
    groups: dict[tuple[str, str, str], list[dict[str, float]]] = {}
    for t in trials:
        if t.valid:
            groups.setdefault((t.interface, t.task, t.paradigm), []).append(authors_metrics(t))
    return {
        key: {**{k: float(np.mean([m[k] for m in ms])) for k in ms[0]}, "n": float(len(ms))}
        for key, ms in sorted(groups.items())
    }


@dataclass(frozen=True)
class LogNormalFit:
    """A positive quantity summarised as a lognormal: ``median`` and ``log_sd``, from ``n`` values,
    with the between-subject log-sd of the per-subject medians (``subject_log_sd``)."""

    median: float
    log_sd: float
    n: int
    subject_medians: dict[str, float]

    @property
    def subject_log_sd(self) -> float:
        v = [math.log(x) for x in self.subject_medians.values() if x > 0]
        return float(np.std(v, ddof=1)) if len(v) > 1 else 0.0


def fit_lognormal(values_by_subject: dict[str, list[float]]) -> LogNormalFit:
    """Lognormal summary of positive values pooled over subjects (non-positive values left out)."""
    pooled = [v for vs in values_by_subject.values() for v in vs if v > 0]
    if not pooled:
        return LogNormalFit(float("nan"), float("nan"), 0, {})
    logs = np.log(pooled)
    return LogNormalFit(
        median=float(np.exp(np.median(logs))),
        log_sd=float(np.std(logs, ddof=1)) if len(logs) > 1 else 0.0,
        n=len(pooled),
        subject_medians={s: float(np.median(vs)) for s, vs in values_by_subject.items() if vs},
    )


def von_mises_kappa(mean_cos: float) -> float:
    """The 2-D von Mises concentration whose mean cosine ``I1(k) / I0(k)`` is ``mean_cos``."""
    from scipy.optimize import brentq
    from scipy.special import i0e, i1e

    if not 0 < mean_cos < 1:
        return float("inf") if mean_cos >= 1 else 0.0
    return float(brentq(lambda k: i1e(k) / i0e(k) - mean_cos, 1e-9, 1e6))


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
    deflection: LogNormalFit
    full_deflection_share: float
    direction_mean_cos: float
    direction_kappa: float
    direction_kappa_by_subject: dict[str, float]
    presses_per_change: dict[str, float]
    full_round_share: float
    request_share: dict[str, float]
    request_share_by_subject: dict[str, float]
    early_request_share: float
    requests_per_trial: dict[str, float]
    request_time_mean: float
    accept_share: float
    accept_n: int
    tail: LogNormalFit
    commanding_share: float
    n_trials: int


def estimate_behaviour(trials: Iterable[HumanTrial]) -> BehaviourEstimates:
    """The behaviour estimates of the valid trials (module docstring)."""
    valid = [t for t in trials if t.valid]
    if not valid:
        raise ValueError("trials: expected at least one valid trial, got none")
    start: dict[str, list[float]] = {}
    press: dict[str, list[float]] = {}
    settle: dict[str, list[float]] = {}
    held = n_settle = 0
    pause: dict[str, list[float]] = {}
    pause_count: dict[str, float] = {}
    command_time: dict[str, float] = {}
    deflect: dict[str, list[float]] = {}
    cos_by_subject: dict[str, list[float]] = {}
    tail: dict[str, list[float]] = {}
    bursts: dict[str, list[int]] = {"joystick": [], "head_array": []}
    req_share: dict[str, list[float]] = {"joystick": [], "head_array": []}
    req_share_subject: dict[str, list[float]] = {}
    req_count: dict[str, list[float]] = {"joystick": [], "head_array": []}
    early, req_norm = [], []
    accepted = rejected = 0
    commanding_total = time_total = 0.0
    for t in valid:
        s = t.subject
        cmd = t.commanding
        dt = t.dt
        on = np.flatnonzero(cmd)
        times_cmd = on * dt
        commanding_total += cmd.sum() * dt
        time_total += t.total_time
        caused = request_switch_indices(t)
        events = np.sort(np.concatenate((t.switch_times, t.request_times)))
        user_sw = np.array([x for k, x in enumerate(t.switch_times) if k not in caused and x > 0])
        first = [x for x in (times_cmd[:1].tolist() + user_sw[:1].tolist()) if x > 0]
        if first:
            start.setdefault(s, []).append(min(first))
        if on.size:
            tail.setdefault(s, []).append(t.total_time - times_cmd[-1])
        # Mode changes: bursts of switches with no command between them.
        sw = np.sort(t.switch_times[t.switch_times > 0])
        burst = 1
        for a, b in zip(sw, sw[1:], strict=False):
            between = np.any(cmd[int(a / dt) + 1 : int(b / dt) + 1])
            if not between and b - a < BURST_GAP:
                press.setdefault(s, []).append(b - a)
                burst += 1
            else:
                bursts[t.interface].append(burst)
                burst = 1
        if sw.size:
            bursts[t.interface].append(burst)
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
        if on.size:
            inner = ~cmd[on[0] : on[-1] + 1]
            for a, b in _runs(inner):
                t0, t1 = (on[0] + a) * dt, (on[0] + b) * dt
                if t1 - t0 >= MIN_PAUSE and not np.any((events >= t0) & (events <= t1)):
                    pause.setdefault(s, []).append(t1 - t0)
                    pause_count[s] = pause_count.get(s, 0.0) + 1
            command_time[s] = command_time.get(s, 0.0) + cmd.sum() * dt
        # Joystick: deflection and direction spread.
        if t.interface == "joystick" and on.size:
            lin, ang = SPEEDS["joystick"]
            v = t.user_vel[:, on]
            size = np.maximum(np.linalg.norm(v[:3], axis=0) / lin, np.linalg.norm(v[3:], axis=0) / ang)
            deflect.setdefault(s, []).extend(np.clip(size, 0, None).tolist())
            for a, b in _runs(cmd):
                if b - a < 10:
                    continue
                run = t.user_vel[:, a:b]
                if np.count_nonzero(np.any(run != 0, axis=1)) != 2:
                    continue  # a 2-D mode: the stick's direction is free
                unit = run / np.linalg.norm(run, axis=0, keepdims=True)
                mean = unit.mean(axis=1)
                norm = np.linalg.norm(mean)
                if norm > 0:
                    cos_by_subject.setdefault(s, []).extend((mean / norm @ unit).tolist())
        if t.paradigm == "disambiguation":
            merged = merge_times(t.request_times)
            req_count[t.interface].append(len(merged))
            n_user = authors_metrics(t)["mode_switches"]
            changes = len(merged) + n_user
            if changes:
                req_share[t.interface].append(len(merged) / changes)
                req_share_subject.setdefault(s, []).append(len(merged) / changes)
            early.append(float(bool(merged) and merged[0] < 3.0))
            req_norm.extend((np.asarray(merged) / t.total_time).tolist())
            for k in caused:
                x = t.switch_times[k]
                later_cmd = times_cmd[times_cmd > x]
                later_sw = np.array([y for j, y in enumerate(t.switch_times) if j not in caused and y > x])
                later_req = t.request_times[t.request_times > x]
                nxt_cmd = later_cmd[0] if later_cmd.size else math.inf
                nxt_sw = later_sw.min() if later_sw.size else math.inf
                nxt_req = later_req.min() if later_req.size else math.inf
                if min(nxt_cmd, nxt_sw) < nxt_req and min(nxt_cmd, nxt_sw) < math.inf:
                    accepted += nxt_cmd < nxt_sw
                    rejected += nxt_sw < nxt_cmd
    all_cos = [c for cs in cos_by_subject.values() for c in cs]
    mean_cos = float(np.mean(all_cos)) if all_cos else float("nan")
    deflections = [d for ds in deflect.values() for d in ds]
    ha = bursts["head_array"]
    return BehaviourEstimates(
        start_delay=fit_lognormal(start),
        press_interval=fit_lognormal(press),
        settle=fit_lognormal(settle),
        held_through_switch=held / n_settle if n_settle else math.nan,
        pause_duration=fit_lognormal(pause),
        pause_rate={s: pause_count.get(s, 0.0) / command_time[s] for s in sorted(command_time)},
        deflection=fit_lognormal(deflect),
        full_deflection_share=float(np.mean(np.asarray(deflections) >= 0.99)) if deflections else math.nan,
        direction_mean_cos=mean_cos,
        direction_kappa=von_mises_kappa(mean_cos) if all_cos else math.nan,
        direction_kappa_by_subject={s: von_mises_kappa(float(np.mean(c))) for s, c in cos_by_subject.items()},
        presses_per_change={k: float(np.mean(v)) if v else math.nan for k, v in bursts.items()},
        full_round_share=float(np.mean(np.asarray(ha) >= 7)) if ha else math.nan,
        request_share={k: float(np.mean(v)) if v else math.nan for k, v in req_share.items()},
        request_share_by_subject={s: float(np.mean(v)) for s, v in sorted(req_share_subject.items())},
        early_request_share=float(np.mean(early)) if early else math.nan,
        requests_per_trial={k: float(np.mean(v)) if v else math.nan for k, v in req_count.items()},
        request_time_mean=float(np.mean(req_norm)) if req_norm else math.nan,
        accept_share=accepted / (accepted + rejected) if accepted + rejected else math.nan,
        accept_n=int(accepted + rejected),
        tail=fit_lognormal(tail),
        commanding_share=commanding_total / time_total if time_total else math.nan,
        n_trials=len(valid),
    )


def _fmt_fit(name: str, fit: LogNormalFit, unit: str = "s") -> str:
    per = ", ".join(f"{s} {v:.3g}" for s, v in sorted(fit.subject_medians.items()))
    return (
        f"{name:<28} median {fit.median:.3g} {unit}, log-sd {fit.log_sd:.2f} (n={fit.n}); "
        f"per subject: {per}; between-subject log-sd {fit.subject_log_sd:.2f}"
    )


def format_estimates(est: BehaviourEstimates) -> str:
    """The estimates as text, one line each."""
    rates = ", ".join(f"{s} {v:.3g}" for s, v in est.pause_rate.items())
    kappas = ", ".join(f"{s} {v:.3g}" for s, v in sorted(est.direction_kappa_by_subject.items()))
    shares = ", ".join(f"{s} {v:.2f}" for s, v in est.request_share_by_subject.items())
    lines = [
        f"valid trials: {est.n_trials}",
        _fmt_fit("start delay", est.start_delay),
        _fmt_fit("press interval (in a change)", est.press_interval),
        _fmt_fit(f"settle (switch -> command >= {MIN_SETTLE} s)", est.settle),
        f"{'command held through switch':<28} {est.held_through_switch:.2f} of switches a command follows",
        _fmt_fit(f"pause duration (>= {MIN_PAUSE} s)", est.pause_duration),
        f"{'pause rate':<28} per second of commanding: {rates}",
        _fmt_fit("joystick deflection", est.deflection, "of full"),
        f"{'full deflection share':<28} {est.full_deflection_share:.2f}",
        f"{'joystick direction':<28} mean cos {est.direction_mean_cos:.4f} -> von Mises kappa "
        f"{est.direction_kappa:.3g}; per subject: {kappas}",
        f"{'presses per mode change':<28} joystick {est.presses_per_change['joystick']:.2f}, head array "
        f"{est.presses_per_change['head_array']:.2f}; head-array changes of >= 7 presses "
        f"{est.full_round_share:.2f}",
        f"{'requests per trial':<28} joystick {est.requests_per_trial['joystick']:.2f}, head array "
        f"{est.requests_per_trial['head_array']:.2f} (Disambiguation trials, merged)",
        f"{'request share of changes':<28} joystick {est.request_share['joystick']:.2f}, head array "
        f"{est.request_share['head_array']:.2f}; per subject: {shares}",
        f"{'first request in 3 s':<28} {est.early_request_share:.2f} of Disambiguation trials; mean "
        f"normalised request time {est.request_time_mean:.2f}",
        f"{'request mode kept':<28} {est.accept_share:.2f} (n={est.accept_n}: next action a command, "
        "not a switch)",
        _fmt_fit("tail (last command -> end)", est.tail),
        f"{'commanding share':<28} {est.commanding_share:.2f} of trial time",
    ]
    return "\n".join(lines)


def format_condition_means(means: dict[tuple[str, str, str], dict[str, float]]) -> str:
    """Per-condition means of the authors' metrics as a table."""
    lines = [
        f"{'interface':<11} {'task':<9} {'paradigm':<15} {'n':>3} {'switches':>9} {'requests':>9} {'time':>7}"
    ]
    for (itf, task, par), m in means.items():
        lines.append(
            f"{itf:<11} {task:<9} {par:<15} {int(m['n']):>3} {m['mode_switches']:>9.2f} "
            f"{m['requests']:>9.2f} {m['completion_time']:>7.1f}"
        )
    return "\n".join(lines)
