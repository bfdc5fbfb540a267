"""The study's metrics as the paper and the authors computed them, from :class:`TrialRecord` s.

Paper Section "Study Methods" (Metrics) and docs/facts.md section 10; the authors' analysis is
``loadData.m`` / ``parse_data.m`` of their repository. Per trial (:func:`trial_metrics`):

- **raw counts**: the record's ``mode_switches`` (the user's own presses), ``requests`` and
  ``button_presses`` (their sum);
- **cleaned counts** (the authors' cleaning, both interfaces unless said):
  * requests: a request less than :data:`REQUEST_MERGE` (3 s) after the previous request (the
    previous one in the raw list, as ``loadData.m`` drops ``find(diff(t) < 3) + 1``) is merged
    into it (dropped);
  * joystick mode switches: a user switch into the same mode as the previous user switch, less
    than :data:`REPEAT_WINDOW` (2 s) after it, is dropped (``loadData.m`` compares consecutive
    user switches of the joystick the same way; its count then subtracts a stale variable, the
    number of merged requests of the last trial that had some: we subtract the number of presses
    actually dropped). Head-array switches are not cleaned (the authors removed the head array's
    duplicated ``current_mode`` messages, which do not enter ``mode_switches``);
  * button presses = cleaned switches + cleaned requests;
- **request times normalised** by the trial's duration (cleaned requests), pooled over the analysed
  trials of a group for the skewness (:func:`request_time_skewness`, ``scipy.stats.skew`` with its
  default biased estimator = MATLAB's ``skewness``);
- **completion time** (``completion_time``; None when the task was not done);
- **success** (:func:`trial_success`): the record's ``success`` (every stage at the intended goal:
  reaching the wrong goal is a failure); the authors' logs do not say, and their failed trials are
  exactly the ones they excluded, so for ``source == "authors"`` success is ``valid``;
- **mean alpha** and **assistance onset** as in the record.

Failed trials are left out of every mean and test, as the authors left theirs out: a trial is
*analysed* (:attr:`TrialMetrics.analysed`) when it is valid and did not fail (``success`` False: a
simulated or live trial that ran out of time or ended at the wrong goal; the authors' failed trials
are their invalid ones). Failed and invalid trials count in the success rate (as failures where
the record says so).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_disamb.interfaces import INTERFACES
from drake_disamb.study.data.records import TrialRecord

__all__ = [
    "COUNT_METRICS",
    "METRICS",
    "REPEAT_WINDOW",
    "REQUEST_MERGE",
    "TrialMetrics",
    "clean_mode_switches",
    "clean_requests",
    "group_key",
    "is_analysed",
    "request_time_skewness",
    "summarize",
    "trial_metrics",
    "trial_success",
]

REQUEST_MERGE = 3.0
"""Requests less than this many seconds after the previous one are merged into it (authors)."""

REPEAT_WINDOW = 2.0
"""Joystick presses into the same mode as the previous press, within this many seconds, are dropped."""

COUNT_METRICS = ("mode_switches", "requests", "button_presses")
"""The counted metrics; each exists cleaned (this name) and raw (``<name>_raw``)."""

METRICS = (
    "button_presses",
    "mode_switches",
    "requests",
    "button_presses_raw",
    "mode_switches_raw",
    "requests_raw",
    "completion_time",
    "mean_alpha",
    "assistance_onset",
)
"""Per-trial numbers the statistics test (:class:`TrialMetrics` attributes)."""


def clean_requests(times: Sequence[float], window: float = REQUEST_MERGE) -> list[float]:
    """The request times left after merging: a request less than ``window`` s after the
    previous request (raw list, in time order) is dropped."""
    t = sorted(float(x) for x in times)
    return [x for i, x in enumerate(t) if i == 0 or x - t[i - 1] >= window]


def clean_mode_switches(
    times: Sequence[float], modes: Sequence[str], interface: str, window: float = REPEAT_WINDOW
) -> list[float]:
    """The user mode-switch times left after the authors' cleaning: for the joystick, a switch
    into the same mode as the previous switch (raw list), less than ``window`` s after it, is
    dropped; head-array switches are kept."""
    if len(times) != len(modes):
        raise ValueError(f"mode switches: {len(times)} times but {len(modes)} modes")
    if not INTERFACES[interface].clean_repeated_switches:
        return [float(x) for x in times]
    kept = []
    for i, (t, m) in enumerate(zip(times, modes, strict=True)):
        if i > 0 and m == modes[i - 1] and t - times[i - 1] < window:
            continue
        kept.append(float(t))
    return kept


def trial_success(record: TrialRecord) -> bool | None:
    """Whether the trial succeeded: ``record.success``; for the authors' logs (no success logged)
    ``record.valid`` (their failed trials are the excluded ones); None if unknown."""
    if record.success is not None:
        return bool(record.success)
    if record.source == "authors":
        return bool(record.valid)
    return None


def is_analysed(record: TrialRecord) -> bool:
    """Whether a trial enters the means and tests: valid and not failed (:func:`trial_success` not
    False; module docstring)."""
    return record.valid and trial_success(record) is not False


@dataclass(frozen=True)
class TrialMetrics:
    """The metrics of one trial (see the module docstring)."""

    record: TrialRecord
    mode_switches_raw: int
    requests_raw: int
    button_presses_raw: int
    mode_switches: int
    requests: int
    button_presses: int
    request_times: tuple[float, ...]
    normalized_request_times: tuple[float, ...]
    normalized_press_times: tuple[float, ...]
    completion_time: float | None
    success: bool | None
    mean_alpha: float | None
    assistance_onset: float | None

    @property
    def analysed(self) -> bool:
        """Whether the trial enters the means and tests (:func:`is_analysed`)."""
        return is_analysed(self.record)

    def value(self, metric: str) -> float | None:
        """The number of ``metric`` (one of :data:`METRICS`), None where undefined."""
        if metric not in METRICS:
            raise ValueError(f"metric: expected one of {METRICS}, got {metric!r}")
        v = getattr(self, metric)
        return None if v is None else float(v)


def trial_metrics(record: TrialRecord) -> TrialMetrics:
    """The metrics of one record."""
    requests = clean_requests(record.request_times)
    switches = clean_mode_switches(record.mode_switch_times, record.mode_switch_modes, record.interface)
    d = record.duration if record.duration > 0 else math.nan
    norm_req = tuple(t / d for t in requests) if d == d else ()
    norm_press = tuple(sorted(t / d for t in [*switches, *requests])) if d == d else ()
    return TrialMetrics(
        record=record,
        mode_switches_raw=record.mode_switches,
        requests_raw=record.requests,
        button_presses_raw=record.button_presses,
        mode_switches=len(switches),
        requests=len(requests),
        button_presses=len(switches) + len(requests),
        request_times=tuple(requests),
        normalized_request_times=norm_req,
        normalized_press_times=norm_press,
        completion_time=record.completion_time,
        success=trial_success(record),
        mean_alpha=record.mean_alpha,
        assistance_onset=record.assistance_onset,
    )


def request_time_skewness(trials: Iterable[TrialMetrics]) -> float | None:
    """Skewness (biased, MATLAB's ``skewness``) of the cleaned request times normalised by
    duration, pooled over the analysed trials; None where there are no requests (or all equal)."""
    from scipy.stats import skew

    pooled = [x for m in trials if m.analysed for x in m.normalized_request_times]
    if not pooled:
        return None
    value = float(skew(np.asarray(pooled)))
    return value if math.isfinite(value) else None


def group_key(record: TrialRecord) -> tuple[str, str, str, str]:
    """``(source, interface, task, paradigm)``: the group a record belongs to in the summary."""
    return record.source, record.interface, record.task, record.paradigm


def _mean(values: Iterable[float | None]) -> float | None:
    v = [x for x in values if x is not None]
    return float(np.mean(v)) if v else None


def _sd(values: Iterable[float | None]) -> float | None:
    v = [x for x in values if x is not None]
    return float(np.std(v, ddof=1)) if len(v) > 1 else None


def summarize(records: Sequence[TrialRecord]) -> list[dict[str, Any]]:
    """One row per source, interface, task and paradigm (sorted): counts (``n_valid`` valid trials,
    ``n_analysed`` of them not failed) and means (analysed trials only) after the authors'
    cleaning, the raw means (``*_raw``), the success rate (all trials whose success is known), the
    request-time skewness, ``end_reasons``: how many trials ended how (``done``, ``time
    limit``, ``given up``, ...: a simulated record's ``extra["end_reason"]``; empty for people),
    and ``time_limit_progress_ages``: for the trials that ran to the time limit, how long before
    the end the arm last came closer to the intended goal (``extra["progress_age"]``, s; a trial
    whose arm is stuck is ended earlier by the experimenter's rule, ``give_up_after``), and
    ``failed_ik_held``: for the failed trials that logged it, the share of their last minute of
    commanding at which the IK held the arm (``extra["ik_held"]``, sorted;
    :func:`~drake_disamb.study.run.outcome.ik_held_share`)."""
    groups: dict[tuple[str, str, str, str], list[TrialMetrics]] = {}
    for r in records:
        groups.setdefault(group_key(r), []).append(trial_metrics(r))
    rows = []
    for (source, interface, task, paradigm), ms in sorted(groups.items()):
        analysed = [m for m in ms if m.analysed]  # the means' trials
        known = [m.success for m in ms if m.success is not None]
        row: dict[str, Any] = {
            "source": source,
            "interface": interface,
            "task": task,
            "paradigm": paradigm,
            "n_trials": len(ms),
            "n_valid": sum(m.record.valid for m in ms),
            "n_analysed": len(analysed),
            "n_subjects": len({m.record.subject for m in ms}),
        }
        for name in COUNT_METRICS:
            row[f"mean_{name}"] = _mean(getattr(m, name) for m in analysed)
        row["mean_completion_time"] = _mean(m.completion_time for m in analysed)
        row["sd_completion_time"] = _sd(m.completion_time for m in analysed)
        row["success_rate"] = float(np.mean(known)) if known else None
        row["n_success_known"] = len(known)
        reasons = [m.record.extra.get("end_reason") for m in ms]
        row["end_reasons"] = {k: reasons.count(k) for k in sorted({r for r in reasons if r})}
        row["time_limit_progress_ages"] = sorted(
            float(m.record.extra["progress_age"])
            for m in ms
            if m.record.extra.get("end_reason") == "time limit"
            and isinstance(m.record.extra.get("progress_age"), int | float)
        )
        row["failed_ik_held"] = sorted(
            float(m.record.extra["ik_held"])
            for m in ms
            if m.success is False and isinstance(m.record.extra.get("ik_held"), int | float)
        )
        row["request_time_skewness"] = request_time_skewness(analysed)
        row["mean_alpha"] = _mean(m.mean_alpha for m in analysed)
        row["sd_alpha"] = _sd(m.mean_alpha for m in analysed)
        row["mean_assistance_onset"] = _mean(m.assistance_onset for m in analysed)
        row["mean_automatic_switches"] = _mean(float(m.record.automatic_switches) for m in analysed)
        for name in COUNT_METRICS:
            row[f"mean_{name}_raw"] = _mean(getattr(m, f"{name}_raw") for m in analysed)
        rows.append(row)
    return rows
