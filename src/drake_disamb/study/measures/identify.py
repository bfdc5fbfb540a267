"""The system the study's people used, identified from its logs (``drake-disamb study identify``).

The paper does not publish its robot's inference and blending settings; the logs of its study
(``../shared/data/tnsre2020_human_study/``, read by :func:`drake_disamb.study.data.authors.read_trials`)
show them. Everything here is measured from the trials given (any subset of subjects) and checked
by replaying the logs through the core's own functions (:func:`~drake_disamb.core.inference.
dft_euler_step`, :func:`~drake_disamb.core.inference.dft_euler_rollout`,
:func:`~drake_disamb.core.blending.blending_alpha`, :func:`~drake_disamb.core.blending.blend`,
:func:`~drake_disamb.core.autonomy.potential_field_commands`). Times are seconds from the trial's
``start_time``; ``u_h`` (logged without times) is placed as the reader spreads it.

- **Belief updates** (:func:`update_period`): the rows of ``goal_probabilities`` whose belief
  differs from the row before are the updates; the period is the median time between consecutive
  updates (rounded to the millisecond: the log's stamps jitter by a few ms).
- **Idle decay** (:func:`fit_idle_decay`): an update with no user command from three periods before
  it to one after (in ``u_h``, and in the blended command of the rows
  without assistance) is idle. Per goal count ``n``, the least-squares factor
  ``f`` by which it shrinks the deviation from uniform, and the rest state ``c`` of
  ``p' = f p + (1 - f) c``. An explicit Euler step of ``dt`` (the period) with ``tau1 = tau2 =
  tau`` and no excitation has ``f = 1 - dt / tau``. A zero command that excited every goal by
  ``e`` (1/s) would divide by ``1 + n dt e`` after the renormalisation, so ``f`` would depend on
  ``n``: from two goal counts, ``dt e = (f_a - f_b) / (n_b f_b - n_a f_a)``; below
  :data:`EXCITATION_TOLERANCE` the zero command excites nothing. The replay
  (:func:`idle_replay_error`) runs :func:`~drake_disamb.core.inference.dft_euler_step` with the
  identified values from each logged belief before an idle update.
- **Alpha** (:func:`fit_alpha_law`): ``alpha_max`` is the largest logged alpha; on the rows with
  ``0 < alpha < alpha_max`` alpha is a straight line in the belief's maximum (rounded to the
  decimals, of :data:`ALPHA_DECIMALS`, whose law matches the most rows), whose zero and top are
  the thresholds ``rho1``, ``rho2`` per goal count (rounded to the same decimals). Alpha is taken as 0 from a
  request's press to its mode switch. :func:`alpha_matches` says which rows the law reproduces
  (within :data:`ALPHA_TOLERANCE`) with :func:`~drake_disamb.core.blending.blending_alpha`.
- **Request time** (:func:`request_timing`): from each press (``assistance_requested``) to the
  mode switch the request made; the share of rows in between with alpha and the blended
  command 0; and the share of them at which the belief changed (against the rest of the trials:
  a belief that updates at 10 Hz changes at about every other 20 Hz row, also when idle).
- **Mode map** (:func:`identify_mode_map`): which dimensions each score column of
  ``cmode_conf_disamb`` sums (the subset of ``cdim_conf_disamb`` columns whose sum it equals over
  every request), which mode id the system switched to when a column scored highest (the
  mode-id-to-column map), hence the interface's mode ids as dimension tuples; and the share of
  requests whose new mode is the argmax of the logged scores.
- **Known path** (:func:`identify_known_path`): on the trial with the autonomy's commands
  (``known_path/test_data.mat``: per goal, at 20 Hz), the end-effector position solved sample by
  sample from the commands as a saturated unit attractor towards each goal plus a common repeller
  offset on every goal's command but the nearest goal's (:func:`solve_positions`); the blend law
  ``(1 - alpha) u_h + alpha u_a(argmax p)`` there; and the DFT gain ``lambda`` (directedness term
  only, the identified ``tau``) that replays the logged belief best, with its per-goal correlation
  and argmax agreement, beside the same with the proximity term and another setting's (the
  ``mico`` preset's).

What the logs cannot show: orientations were not logged, so neither the agreement term nor the
rotational part of the autonomy can be identified, and the system's ``D_k`` cannot be recomputed.

Each identification is a function of the logs (:class:`Logs`) and of the identifications before it,
with its text and its JSON keys, and one row of :data:`IDENTIFICATIONS`, which :func:`identify`,
:func:`format_identification` and :meth:`Identification.to_json` loop over.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from drake_disamb.config import load_scenario
from drake_disamb.core.autonomy import PotentialFieldConfig, potential_field_commands
from drake_disamb.core.blending import blend, blending_alpha
from drake_disamb.core.inference import DFTParams, dft_drive, dft_euler_rollout, dft_euler_step
from drake_disamb.core.layout import DIM_NAMES
from drake_disamb.study.data.authors import MODE_IDS, load_mat, read_trials
from drake_disamb.study.data.folder import LoggedTrial
from drake_disamb.study.measures.table import Measured, text_lines

__all__ = [
    "ALPHA_DECIMALS",
    "ALPHA_TOLERANCE",
    "EXCITATION_TOLERANCE",
    "IDENTIFICATIONS",
    "KNOWN_PATH_TRIAL",
    "AlphaLaw",
    "BeliefReplay",
    "Identification",
    "Identifying",
    "IdleDecay",
    "KnownPath",
    "Logs",
    "ModeMap",
    "RequestTiming",
    "UpdatePeriod",
    "alpha_matches",
    "belief_replay",
    "fit_alpha_law",
    "fit_idle_decay",
    "format_identification",
    "identify",
    "identify_known_path",
    "identify_mode_map",
    "idle_replay_error",
    "idle_steps",
    "request_timing",
    "solve_positions",
    "update_period",
    "update_rows",
]

ALPHA_DECIMALS: tuple[int | None, ...] = (None, 2, 3, 4)
"""Roundings of the belief's maximum tried for the alpha law (``None``: not rounded)."""
ALPHA_TOLERANCE = 1e-3
"""A row's alpha matches the law within this."""
EXCITATION_TOLERANCE = 1e-3
"""Below this uniform excitation (1/s) a zero command excites nothing."""
IDLE_MIN_DEVIATION = 1e-6
"""An idle update counts in the decay fit when its belief is at least this far from uniform."""
SCORE_TOLERANCE = 1e-5
"""A score column is the sum of a dimension subset when it is within this of it at every request."""
KNOWN_PATH_TRIAL = "H3PH1REHAT10"
"""The trial whose autonomy commands were published (``known_path/test_data.mat``)."""
KNOWN_PATH_FILE = Path("known_path") / "test_data.mat"
LAMBDA_GRID: tuple[float, ...] = tuple(float(x) for x in np.round(np.geomspace(0.1, 30.0, 49), 4))
"""The DFT gains (1/s) tried for the belief replay of the known-path trial."""
PROXIMITY_RADII: tuple[float, ...] = (0.1, 0.2, 0.3)
"""Radii (m) of the proximity term tried beside the best directedness-only replay."""
_REPELLER_FLOOR = 1e-3
"""A repeller offset (m/s) above this counts as felt (the radius's evidence)."""


# -- belief updates ---------------------------------------------------------------------------------


def update_rows(belief: NDArray[np.float64]) -> NDArray[np.bool_]:
    """True at the rows (from the second) whose belief differs from the row before."""
    b = np.asarray(belief, dtype=float)
    out = np.zeros(len(b), dtype=bool)
    if len(b) > 1:
        out[1:] = np.any(b[1:] != b[:-1], axis=1)
    return out


@dataclass(frozen=True)
class UpdatePeriod:
    """The belief's update period (s), from ``n`` intervals between consecutive updates; ``share`` of
    the logged rows that are updates."""

    period: float
    n: int
    share: float


def update_period(trials: Sequence[LoggedTrial]) -> UpdatePeriod:
    """The median interval between consecutive belief updates over ``trials`` (ms resolution)."""
    gaps, updates, rows = [], 0, 0
    for trial in trials:
        t, belief = trial.trace["t"], trial.trace["belief"]
        changed = update_rows(belief)
        gaps.append(np.diff(t[changed]))
        updates += int(changed.sum())
        rows += len(t)
    g = np.concatenate(gaps) if gaps else np.zeros(0)
    if not len(g):
        raise ValueError("trials: no belief updates in the logs")
    return UpdatePeriod(round(float(np.median(g)), 3), len(g), updates / max(rows, 1))


# -- idle decay -------------------------------------------------------------------------------------


def _command_at(trial: LoggedTrial) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The user command's times and samples ``(M,)``, ``(M, 6)``."""
    return np.asarray(trial.trace["t_u_h"], dtype=float), np.asarray(trial.trace["u_h"], dtype=float)


def _none_within(
    t: NDArray[np.float64], moving: NDArray[np.bool_], times: NDArray[np.float64], period: float
) -> NDArray[np.bool_]:
    """True at ``times`` with no ``moving`` sample from three periods before to one after."""
    cum = np.concatenate(([0], np.cumsum(moving.astype(np.int64))))
    lo = np.searchsorted(t, times - 3.0 * period, side="left")
    hi = np.searchsorted(t, times + 1.0 * period, side="right")
    return (cum[hi] - cum[lo]) == 0


def _idle_mask(trial: LoggedTrial, times: NDArray[np.float64], period: float) -> NDArray[np.bool_]:
    """True at ``times`` with no user command around them (:func:`_none_within`): none in ``u_h``
    (whose times are the reader's spread), and no blended command on the rows without assistance
    (``alpha = 0``: the blended command is the user's, with the rows' own times)."""
    t_u, u = _command_at(trial)
    t = np.asarray(trial.trace["t"], dtype=float)
    blended = np.any(np.asarray(trial.trace["u"], dtype=float) != 0.0, axis=1)
    unassisted = np.asarray(trial.trace["alpha"], dtype=float) == 0.0
    return _none_within(t_u, np.any(u != 0.0, axis=1), times, period) & _none_within(
        t, blended & unassisted, times, period
    )


def idle_steps(trial: LoggedTrial, period: float) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """The idle updates of a trial: beliefs before and after ``(k, n)`` and the number of idle
    stretches (runs of consecutive idle updates) they come from."""
    belief = np.asarray(trial.trace["belief"], dtype=float)
    t = np.asarray(trial.trace["t"], dtype=float)
    rows = np.flatnonzero(update_rows(belief))
    n = belief.shape[1]
    if not len(rows):
        return np.zeros((0, n)), np.zeros((0, n)), 0
    idle = _idle_mask(trial, t[rows], period)
    informative = np.max(np.abs(belief[rows - 1] - 1.0 / n), axis=1) > IDLE_MIN_DEVIATION
    keep = idle & informative
    starts = np.count_nonzero(keep & ~np.concatenate(([False], keep[:-1])))
    return belief[rows[keep] - 1], belief[rows[keep]], int(starts)


@dataclass(frozen=True)
class IdleDecay:
    """The belief's decay with no command (module docstring).

    ``factor`` and ``rest_deviation`` (the largest ``|c_i - 1/n|``) per goal count; ``tau`` (s)
    from the pooled factor and ``dt``; ``excitation`` the uniform excitation of a zero command
    (1/s; ``None`` with a single goal count); ``updates`` and ``stretches`` counted."""

    dt: float
    factor: dict[int, float]
    tau: float
    rest_deviation: dict[int, float]
    excitation: float | None
    updates: dict[int, int]
    stretches: int

    @property
    def zero_command_excitation(self) -> bool | None:
        """Whether a zero command excites the goals (``None``: one goal count cannot tell)."""
        return None if self.excitation is None else abs(self.excitation) > EXCITATION_TOLERANCE

    def params(self, **overrides: Any) -> DFTParams:
        """The identified update as :class:`DFTParams` (``tau1 = tau2 = tau``, uniform rest state)."""
        base = DFTParams(
            tau1=self.tau,
            tau2=self.tau,
            lam=1.0,
            agreement=False,
            proximity=False,
            zero_command_excitation=bool(self.zero_command_excitation),
        )
        return dataclasses.replace(base, **overrides)


def fit_idle_decay(
    steps: Iterable[tuple[NDArray[np.float64], NDArray[np.float64]]], dt: float, stretches: int = 0
) -> IdleDecay:
    """:class:`IdleDecay` from ``(before, after)`` belief pairs ``(k, n)`` of idle updates of ``dt`` s."""
    by_n: dict[int, list[tuple[NDArray[np.float64], NDArray[np.float64]]]] = {}
    for before, after in steps:
        if len(before):
            by_n.setdefault(before.shape[1], []).append((before, after))
    if not by_n:
        raise ValueError("trials: no idle belief updates (no stretch without a user command)")
    factor, rest, counts = {}, {}, {}
    num = den = 0.0
    for n, pairs in sorted(by_n.items()):
        x = np.concatenate([p for p, _ in pairs]) - 1.0 / n
        y = np.concatenate([q for _, q in pairs]) - 1.0 / n
        f = float(np.sum(x * y) / np.sum(x * x))
        factor[n], counts[n] = f, len(x)
        num, den = num + float(np.sum(x * y)), den + float(np.sum(x * x))
        # p' = f p + (1 - f) c, per goal: c = mean((p' - f p) / (1 - f))
        c = np.mean((y + 1.0 / n - f * (x + 1.0 / n)) / (1.0 - f), axis=0)
        rest[n] = float(np.max(np.abs(c - 1.0 / n)))
    f_all = num / den
    excitation = None
    if len(factor) >= 2:
        (na, fa), (nb, fb) = sorted(factor.items())[:2]
        excitation = (fa - fb) / (nb * fb - na * fa) / dt
    return IdleDecay(
        dt=dt,
        factor=factor,
        tau=dt / (1.0 - f_all),
        rest_deviation=rest,
        excitation=excitation,
        updates=counts,
        stretches=stretches,
    )


def idle_replay_error(
    before: NDArray[np.float64], after: NDArray[np.float64], params: DFTParams, dt: float
) -> float:
    """The largest ``|p' - step(p)|`` of :func:`~drake_disamb.core.inference.dft_euler_step` with no
    command from each ``before`` belief (``(k, n)``; 0 for none)."""
    if not len(before):
        return 0.0
    n = before.shape[1]
    replay = dft_euler_step(before, np.zeros((len(before), 3)), np.zeros(3), np.ones((n, 3)), params, dt)
    return float(np.max(np.abs(replay - after)))


# -- alpha ------------------------------------------------------------------------------------------


def _request_windows(trial: LoggedTrial) -> list[tuple[float, float]]:
    """``(press, switch)`` of each request (s), requests and their switches in time order."""
    presses = np.sort(np.asarray(trial.record.request_times, dtype=float))
    switches = np.sort(np.asarray(trial.request_switch_times, dtype=float))
    return list(zip(presses.tolist(), switches.tolist(), strict=False))


def _in_requests(trial: LoggedTrial, t: NDArray[np.float64]) -> NDArray[np.bool_]:
    inside = np.zeros(len(t), dtype=bool)
    for press, switch in _request_windows(trial):
        inside |= (t >= press) & (t < switch)
    return inside


def _top(belief: NDArray[np.float64], decimals: int | None) -> NDArray[np.float64]:
    top = np.max(belief, axis=1)
    return top if decimals is None else np.round(top, decimals)


@dataclass(frozen=True)
class AlphaLaw:
    """``alpha = alpha_max * clip((round(max p, decimals) - rho1) / (rho2 - rho1), 0, 1)``, 0 during a
    request; ``thresholds[n] = (rho1, rho2)``; ``fit_rows`` the rows of the linear part per goal
    count; ``match`` the share of rows matched per (interface, task) with ``rows`` counted."""

    alpha_max: float
    decimals: int | None
    thresholds: dict[int, tuple[float, float]]
    fit_rows: dict[int, int]
    match: dict[tuple[str, str], float]
    rows: dict[tuple[str, str], int]


def alpha_matches(trial: LoggedTrial, law: AlphaLaw) -> NDArray[np.bool_]:
    """True at the trial's rows whose logged alpha the law reproduces (within :data:`ALPHA_TOLERANCE`)."""
    belief = np.asarray(trial.trace["belief"], dtype=float)
    n = belief.shape[1]
    if n not in law.thresholds:
        return np.zeros(len(belief), dtype=bool)
    lo, hi = law.thresholds[n]
    predicted = np.asarray(blending_alpha(_top(belief, law.decimals), n, lo, hi, law.alpha_max))
    t = np.asarray(trial.trace["t"], dtype=float)
    predicted = np.where(_in_requests(trial, t), 0.0, predicted)
    return np.abs(predicted - np.asarray(trial.trace["alpha"], dtype=float)) <= ALPHA_TOLERANCE


def _line_fit(top: NDArray[np.float64], alpha: NDArray[np.float64]) -> tuple[float, float]:
    """``(slope, intercept)`` of the least-squares line, refitted once on the rows within
    :data:`ALPHA_TOLERANCE` of the first fit (a few rows off the law do not tilt it)."""
    A = np.column_stack((top, np.ones_like(top)))
    coef, *_ = np.linalg.lstsq(A, alpha, rcond=None)
    near = np.abs(A @ coef - alpha) <= ALPHA_TOLERANCE
    if near.sum() >= 2:
        coef, *_ = np.linalg.lstsq(A[near], alpha[near], rcond=None)
    return float(coef[0]), float(coef[1])


def _match_counts(trials: Sequence[LoggedTrial], law: AlphaLaw) -> dict[tuple[str, str], list[int]]:
    """``[rows matched, rows]`` per (interface, task)."""
    matched: dict[tuple[str, str], list[int]] = {}
    for trial in trials:
        ok = alpha_matches(trial, law)
        m = matched.setdefault((trial.record.interface, trial.record.task), [0, 0])
        m[0] += int(ok.sum())
        m[1] += len(ok)
    return dict(sorted(matched.items()))


def fit_alpha_law(trials: Sequence[LoggedTrial]) -> AlphaLaw:
    """:class:`AlphaLaw` of ``trials`` (module docstring): of the roundings tried, the one whose law
    matches the most rows."""
    alpha_max = max(float(np.max(t.trace["alpha"])) for t in trials if len(t.trace["alpha"]))
    if not alpha_max > 0:
        raise ValueError("trials: alpha is 0 on every logged row")
    interior: dict[int, list[tuple[NDArray[np.float64], NDArray[np.float64]]]] = {}
    for trial in trials:
        belief, alpha = trial.trace["belief"], np.asarray(trial.trace["alpha"], dtype=float)
        mid = (alpha > 1e-9) & (alpha < alpha_max - 1e-9)
        interior.setdefault(belief.shape[1], []).append((belief[mid], alpha[mid]))
    best: tuple[int, AlphaLaw, dict[tuple[str, str], list[int]]] | None = None
    for decimals in ALPHA_DECIMALS:
        thresholds, counts = {}, {}
        for n, parts in sorted(interior.items()):
            top = np.concatenate([_top(b, decimals) for b, _ in parts if len(b)] or [np.zeros(0)])
            alpha = np.concatenate([a for _, a in parts])
            if len(top) < 2:
                continue
            a, b = _line_fit(top, alpha)
            lo, hi = -b / a, (alpha_max - b) / a
            if decimals is not None:
                lo, hi = round(lo, decimals), round(hi, decimals)
            if 0.0 <= lo < hi <= 1.0:  # else this rounding does not give a law of this form
                thresholds[n], counts[n] = (float(lo), float(hi)), len(top)
        law = AlphaLaw(alpha_max, decimals, thresholds, counts, {}, {})
        matched = _match_counts(trials, law)
        total = sum(m[0] for m in matched.values())
        if best is None or total > best[0]:
            best = (total, law, matched)
    assert best is not None
    _, law, matched = best
    return dataclasses.replace(
        law,
        match={k: v[0] / max(v[1], 1) for k, v in matched.items()},
        rows={k: v[1] for k, v in matched.items()},
    )


# -- requests ---------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RequestTiming:
    """Seconds from a request's press to its mode switch over ``n`` requests; ``zero_share`` of the
    ``rows`` logged in between with alpha and the blended command 0; ``belief_change_share`` of
    them at which the belief differs from the row before, and ``belief_change_share_outside`` the
    same share over the other rows of the trials."""

    minimum: float
    median: float
    maximum: float
    n: int
    zero_share: float
    rows: int
    belief_change_share: float = math.nan
    belief_change_share_outside: float = math.nan


def request_timing(trials: Sequence[LoggedTrial]) -> RequestTiming:
    """:class:`RequestTiming` of every request of ``trials``."""
    waits, zero, rows = [], 0, 0
    changes = [0, 0, 0, 0]  # changed inside, rows inside (from the second), changed outside, rows outside
    for trial in trials:
        for press, switch in _request_windows(trial):
            waits.append(switch - press)
        t = np.asarray(trial.trace["t"], dtype=float)
        inside = _in_requests(trial, t)
        still = (np.asarray(trial.trace["alpha"]) == 0.0) & np.all(
            np.asarray(trial.trace["u"]) == 0.0, axis=1
        )
        zero += int(np.count_nonzero(still & inside))
        rows += int(np.count_nonzero(inside))
        changed = update_rows(np.asarray(trial.trace["belief"], dtype=float))
        within = inside.copy()
        within[1:] &= inside[:-1]  # a change from a row inside the window to the next one
        within[0] = False
        outside = ~inside
        outside[0] = False
        changes[0] += int(np.count_nonzero(changed & within))
        changes[1] += int(np.count_nonzero(within))
        changes[2] += int(np.count_nonzero(changed & outside))
        changes[3] += int(np.count_nonzero(outside))
    if not waits:
        raise ValueError("trials: no disambiguation requests")
    w = np.asarray(waits)
    return RequestTiming(
        float(w.min()),
        float(np.median(w)),
        float(w.max()),
        len(w),
        zero / max(rows, 1),
        rows,
        changes[0] / changes[1] if changes[1] else math.nan,
        changes[2] / changes[3] if changes[3] else math.nan,
    )


# -- the mode map -----------------------------------------------------------------------------------


@dataclass(frozen=True)
class ModeMap:
    """What the request scores show of one interface's modes (module docstring).

    ``column_dims[j]``: the dimensions score column ``j`` sums (``None`` when no subset fits), with
    the largest residual ``sum_residual``; ``id_column[mode id]``: the column that scored highest
    whenever the system switched to that mode id (``None``: never switched to, and not the single
    one left); ``mode_order``: the interface's arm mode ids in their order (the authors' ids) as
    dimension tuples; ``argmax_share`` of ``requests`` whose new mode is the argmax's."""

    interface: str
    column_dims: list[tuple[int, ...] | None]
    sum_residual: float
    id_column: dict[int, int | None]
    consistent: bool
    argmax_share: float
    requests: int

    @property
    def unresolved(self) -> tuple[list[int], list[tuple[int, ...] | None]]:
        """The mode ids without a column and the dimensions of the columns without an id: the
        requests did not tell which of these ids is which of these modes."""
        ids = [i for i, c in self.id_column.items() if c is None]
        used = {c for c in self.id_column.values() if c is not None}
        return ids, [d for j, d in enumerate(self.column_dims) if j not in used]

    @property
    def mode_order(self) -> list[tuple[int, ...] | None]:
        """The arm mode ids' dimensions in the order of the authors' ids (``None``: unresolved)."""
        out = []
        for mode_id in MODE_IDS[self.interface][:-1]:
            column = self.id_column.get(mode_id)
            out.append(None if column is None else self.column_dims[column])
        return out


def _request_modes(trial: LoggedTrial) -> NDArray[np.int64]:
    """The authors' mode id each request of the trial switched to (in request order)."""
    return np.asarray(trial.trace["request_mode_ids"], dtype=np.int64)


def _request_scores(
    trials: Sequence[LoggedTrial], interface: str
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """The mode scores, the dimension scores and the new mode id of every request of ``interface``."""
    modes, dims, new_ids = [], [], []
    for trial in trials:
        if trial.record.interface != interface or not trial.record.requests:
            continue
        m = np.asarray(trial.trace["request_mode_scores"], dtype=float)
        d = np.asarray(trial.trace["request_dim_scores"], dtype=float)
        if len(m) != len(trial.request_switch_times) or len(d) != len(m):
            raise ValueError(f"{trial.record.trial_id}: the request scores do not have one row per request")
        modes.append(m)
        dims.append(d)
        new_ids.append(_request_modes(trial))
    if not modes:
        raise ValueError(f"trials: no {interface} requests")
    return np.concatenate(modes), np.concatenate(dims), np.concatenate(new_ids)


def _column_dims(
    m: NDArray[np.float64], d: NDArray[np.float64]
) -> tuple[list[tuple[int, ...] | None], float]:
    """Per mode-score column of ``m``, the subset of the dimension-score columns of ``d`` whose sum
    it is (``None``: none within :data:`SCORE_TOLERANCE`), and the largest residual."""
    subsets = [s for k in range(1, d.shape[1] + 1) for s in itertools.combinations(range(d.shape[1]), k)]
    sums = np.stack([d[:, list(s)].sum(axis=1) for s in subsets], axis=1)  # (requests, subsets)
    column_dims: list[tuple[int, ...] | None] = []
    residual = 0.0
    for j in range(m.shape[1]):
        err = np.max(np.abs(sums - m[:, j : j + 1]), axis=0)
        k = int(np.argmin(err))
        column_dims.append(subsets[k] if err[k] <= SCORE_TOLERANCE else None)
        residual = max(residual, float(err[k]))
    return column_dims, residual


def _id_columns(
    m: NDArray[np.float64], ids: NDArray[np.int64], interface: str
) -> tuple[dict[int, int], dict[int, int | None]]:
    """The mode id the system switched to most often when each column scored highest, and per arm
    mode id of ``interface`` its column (the single one left when one id and one column are)."""
    winner = np.argmax(m, axis=1)
    column_id: dict[int, int] = {}
    for j in range(m.shape[1]):
        chosen, counts = np.unique(ids[winner == j], return_counts=True)
        if len(chosen):
            column_id[j] = int(chosen[np.argmax(counts)])
    id_column: dict[int, int | None] = {i: None for i in MODE_IDS[interface][:-1]}
    for j, mode_id in column_id.items():
        if mode_id in id_column:
            id_column[mode_id] = j
    free_ids = [i for i, c in id_column.items() if c is None]
    free_cols = sorted(set(range(m.shape[1])) - {c for c in id_column.values() if c is not None})
    if len(free_ids) == 1 and len(free_cols) == 1:
        id_column[free_ids[0]] = free_cols[0]
    return column_id, id_column


def identify_mode_map(trials: Sequence[LoggedTrial], interface: str) -> ModeMap:
    """:class:`ModeMap` of ``interface`` from its trials' requests."""
    m, d, ids = _request_scores(trials, interface)
    column_dims, residual = _column_dims(m, d)
    column_id, id_column = _id_columns(m, ids, interface)
    winner = np.argmax(m, axis=1)
    hits = np.array([column_id.get(int(c)) == int(i) for c, i in zip(winner, ids, strict=True)])
    return ModeMap(
        interface=interface,
        column_dims=column_dims,
        sum_residual=residual,
        id_column=id_column,
        consistent=len(set(column_id.values())) == len(column_id),
        argmax_share=float(np.mean(hits)),
        requests=len(ids),
    )


# -- the known-path trial ---------------------------------------------------------------------------


def _attractors(x: NDArray[np.float64], goals: NDArray[np.float64], speed: float) -> NDArray[np.float64]:
    """The core's potential field without repellers: unit gain, saturated at ``speed``; ``(..., n, 3)``."""
    config = PotentialFieldConfig(attractor_gain_translation=1.0, repeller_gain=0.0, max_linear_speed=speed)
    n = goals.shape[0]
    quat = np.broadcast_to(np.array([1.0, 0.0, 0.0, 0.0]), x.shape[:-1] + (4,))
    return potential_field_commands(x, quat, goals, np.tile([1.0, 0.0, 0.0, 0.0], (n, 1)), config)[..., :3]


def _path_residual(
    x: NDArray[np.float64], u: NDArray[np.float64], goals: NDArray[np.float64], speed: float
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """The commands ``u`` ``(T, ..., n, 3)`` minus the attractors at ``x`` ``(T, ..., 3)`` and the
    common repeller offset of all goals but the nearest; the offset and the nearest goal."""
    offset = u - _attractors(x, goals, speed)
    near = np.argmin(np.linalg.norm(x[..., None, :] - goals, axis=-1), axis=-1)
    others = np.arange(goals.shape[0]) != near[..., None]
    repel = np.sum(offset * others[..., None], axis=-2) / max(goals.shape[0] - 1, 1)
    return offset - repel[..., None, :] * others[..., None], repel, near


def solve_positions(
    u_a: NDArray[np.float64], goals: NDArray[np.float64], speed: float | None = None, iterations: int = 30
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], float]:
    """The end-effector positions ``(T, 3)`` whose per-goal commands are ``u_a`` ``(T, n, 3)``.

    Model: a unit-gain attractor towards each goal saturated at ``speed`` (default: the median
    command speed) plus one repeller offset shared by every goal's command but the nearest goal's.
    A coarse search along the ray of each goal's command, then Gauss-Newton on every sample at once.

    Returns:
        ``(x, rms, repel, speed)``: the positions, the residual rms per sample (m/s), the repeller
        offset ``(T, 3)`` and the attractor speed used.
    """
    u = np.asarray(u_a, dtype=float)
    goals = np.asarray(goals, dtype=float)
    T, n, _ = u.shape
    v = float(np.median(np.linalg.norm(u, axis=-1))) if speed is None else float(speed)
    reach = float(np.max(np.linalg.norm(goals[:, None] - goals[None], axis=-1))) + 1.0
    s_grid = np.arange(0.0, reach, 0.01)
    best = np.full(T, np.inf)
    x = np.zeros((T, 3))
    for j in range(n):
        direction = u[:, j] / np.maximum(np.linalg.norm(u[:, j], axis=-1, keepdims=True), 1e-12)
        cand = goals[j] - s_grid[None, :, None] * direction[:, None, :]  # (T, S, 3)
        res = _path_residual(cand, u[:, None], goals, v)[0]
        cost = np.sum(res * res, axis=(-1, -2))
        k = np.argmin(cost, axis=1)
        c = cost[np.arange(T), k]
        better = c < best
        best[better], x[better] = c[better], cand[np.arange(T), k][better]
    h = 1e-7
    for _ in range(iterations):
        r0 = _path_residual(x, u, goals, v)[0].reshape(T, -1)
        J = np.empty((T, r0.shape[1], 3))
        for a in range(3):
            xp = x.copy()
            xp[:, a] += h
            J[:, :, a] = (_path_residual(xp, u, goals, v)[0].reshape(T, -1) - r0) / h
        JT = J.transpose(0, 2, 1)
        step = np.linalg.solve(JT @ J + 1e-12 * np.eye(3), JT @ r0[..., None])[..., 0]
        x = x - step
        if np.max(np.abs(step)) < 1e-11:
            break
    res, repel, _ = _path_residual(x, u, goals, v)
    rms = np.sqrt(np.mean(res * res, axis=(-1, -2)))
    return x, rms, repel, v


@dataclass(frozen=True)
class BeliefReplay:
    """The logged belief of the known-path trial replayed from uniform by the core's Euler rollout:
    per-goal correlation, the share of updates whose argmax agrees, over ``updates``."""

    label: str
    lam: float
    tau: float
    correlation: list[float]
    argmax_agreement: float
    updates: int


@dataclass(frozen=True)
class KnownPath:
    """What the known-path trial shows (module docstring): the solved path's start and end (m),
    the share of samples solved to under 1e-4 m/s rms and the worst rms, the attractor speed
    (m/s), the largest distance to the nearest goal at which a repeller is felt (m), the median
    norm of the rotational commands (rad/s) and the share of the goal samples within 1 % of it; the blend
    law's share of rows with ``alpha > 0`` (within 1e-3) and with the user commanding; the best
    DFT gain's replay, the same with the proximity term added (radii :data:`PROXIMITY_RADII`),
    and another setting's."""

    trial_id: str
    samples: int
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    solved_share: float
    worst_rms: float
    attractor_speed: float
    repeller_radius: float | None
    rotation_speed: float
    rotation_share: float
    blend_share: float
    blend_rows: int
    blend_share_idle: float
    blend_rows_idle: int
    best: BeliefReplay
    proximity: list[BeliefReplay]
    other: BeliefReplay | None


def _nearest(times: NDArray[np.float64], at: NDArray[np.float64]) -> NDArray[np.int64]:
    """Index of the sample of ``times`` (ascending) nearest each of ``at``."""
    j = np.clip(np.searchsorted(times, at), 1, max(len(times) - 1, 1))
    return np.where(np.abs(times[j - 1] - at) <= np.abs(times[j] - at), j - 1, j)


def belief_replay(
    trial: LoggedTrial,
    t_path: NDArray[np.float64],
    path: NDArray[np.float64],
    goals: NDArray[np.float64],
    params: DFTParams,
    dt: float,
    label: str = "",
) -> BeliefReplay:
    """Replay the trial's belief updates from uniform with the core's rollout (``params``, ``dt``)."""
    belief = np.asarray(trial.trace["belief"], dtype=float)
    t = np.asarray(trial.trace["t"], dtype=float)
    rows = np.flatnonzero(update_rows(belief))
    rows = rows[(t[rows] >= t_path[0]) & (t[rows] <= t_path[-1])]
    t_u, u = _command_at(trial)
    u_k = u[_nearest(t_u, t[rows])]
    x_k = np.column_stack([np.interp(t[rows], t_path, path[:, a]) for a in range(3)])
    drives = dft_drive(u_k, x_k, goals, params)[:, None, :]  # (K, 1, n)
    n = goals.shape[0]
    replay = dft_euler_rollout(np.full((1, n), 1.0 / n), drives, params, dt)[:, 0]
    logged = belief[rows]
    corr = [
        float(np.corrcoef(replay[:, i], logged[:, i])[0, 1]) if np.std(logged[:, i]) > 0 else math.nan
        for i in range(n)
    ]
    agree = float(np.mean(np.argmax(replay, axis=1) == np.argmax(logged, axis=1)))
    lam = float(np.asarray(params.lam).ravel()[0])
    return BeliefReplay(label, lam, float(params.tau1), corr, agree, len(rows))


def _autonomy_commands(
    known_path: str | Path, n_goals: int
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The published autonomy commands ``(T, n, 6)`` of the known-path trial and their times ``(T,)``."""
    data = load_mat(Path(known_path))
    if "gv" not in data:
        raise ValueError(f"{known_path}: no variable 'gv'")
    gv = np.asarray(data["gv"], dtype=float)
    if gv.ndim != 3 or gv.shape[0] != 7 or gv.shape[2] != n_goals:
        raise ValueError(f"{known_path}: gv has shape {gv.shape}, expected (7, samples, {n_goals})")
    return gv[:6].transpose(1, 2, 0), gv[6, :, 0]


def _blend_law(
    trial: LoggedTrial, t_path: NDArray[np.float64], u_a: NDArray[np.float64]
) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """On the trial's rows with ``alpha > 0`` within the commands' times: whether the blend law
    ``(1 - alpha) u_h + alpha u_a(argmax p)`` gives the logged blended command (within 1e-3), and
    whether the user commanded."""
    t = np.asarray(trial.trace["t"], dtype=float)
    alpha = np.asarray(trial.trace["alpha"], dtype=float)
    belief = np.asarray(trial.trace["belief"], dtype=float)
    blended = np.asarray(trial.trace["u"], dtype=float)
    inside = (t >= t_path[0]) & (t <= t_path[-1]) & (alpha > 0)
    t_u, u = _command_at(trial)
    u_h = u[_nearest(t_u, t[inside])]
    ua = u_a[_nearest(t_path, t[inside])]
    g = np.argmax(belief[inside], axis=1)
    predicted = blend(u_h, ua[np.arange(len(g)), g], alpha[inside])
    ok = np.max(np.abs(predicted - blended[inside]), axis=1) <= 1e-3
    return ok, np.any(u_h != 0.0, axis=1)


def _best_replay(replay: Callable[[DFTParams, str], BeliefReplay], decay: IdleDecay) -> BeliefReplay:
    """Of the DFT gains :data:`LAMBDA_GRID` (directedness only, the identified decay), the ``replay``
    with the highest mean per-goal correlation."""
    best: BeliefReplay | None = None
    for lam in LAMBDA_GRID:
        r = replay(decay.params(lam=lam), "identified")
        if best is None or np.nanmean(r.correlation) > np.nanmean(best.correlation):
            best = r
    assert best is not None
    return best


def identify_known_path(
    trial: LoggedTrial,
    known_path: str | Path,
    goals: NDArray[np.float64],
    decay: IdleDecay,
    other: tuple[str, DFTParams] | None = None,
) -> KnownPath:
    """:class:`KnownPath` of the trial whose autonomy commands are in ``known_path`` (the .mat file)."""
    u_a, t_path = _autonomy_commands(known_path, len(goals))
    x, rms, repel, speed = solve_positions(u_a[..., :3], goals)
    dist = np.min(np.linalg.norm(x[:, None] - goals, axis=-1), axis=1)
    felt = np.linalg.norm(repel, axis=1) > _REPELLER_FLOOR
    # The rotational commands (no orientation was logged, so their law cannot be solved for): their
    # norm over every goal's samples, and how many sit at it (a saturation).
    w_norm = np.linalg.norm(u_a[..., 3:], axis=-1).ravel()
    rotation_speed = float(np.median(w_norm))
    rotation_share = float(np.mean(np.abs(w_norm - rotation_speed) <= 0.01 * rotation_speed))
    ok, commanding = _blend_law(trial, t_path, u_a)

    def replay(params: DFTParams, label: str) -> BeliefReplay:
        return belief_replay(trial, t_path, x, goals, params, decay.dt, label)

    best = _best_replay(replay, decay)
    proximity = [
        replay(decay.params(lam=best.lam, proximity=True, R=R), f"proximity R {R:g} m")
        for R in PROXIMITY_RADII
    ]
    other_replay = None if other is None else replay(other[1], other[0])
    return KnownPath(
        trial_id=trial.record.trial_id,
        samples=len(t_path),
        start=(float(x[0, 0]), float(x[0, 1]), float(x[0, 2])),
        end=(float(x[-1, 0]), float(x[-1, 1]), float(x[-1, 2])),
        solved_share=float(np.mean(rms < 1e-4)),
        worst_rms=float(np.max(rms)),
        attractor_speed=speed,
        repeller_radius=float(np.max(dist[felt])) if np.any(felt) else None,
        rotation_speed=rotation_speed,
        rotation_share=rotation_share,
        blend_share=float(np.mean(ok[commanding])) if np.any(commanding) else math.nan,
        blend_rows=int(np.count_nonzero(commanding)),
        blend_share_idle=float(np.mean(ok[~commanding])) if np.any(~commanding) else math.nan,
        blend_rows_idle=int(np.count_nonzero(~commanding)),
        best=best,
        proximity=proximity,
        other=other_replay,
    )


# -- the table ---------------------------------------------------------------------------------------


@dataclass
class Logs:
    """What the identifications read: the logs' folder and its trials, the reaching task's goal
    positions ``(5, 3)`` (m) for the known-path trial (``None``: the embedded reaching task's) and a
    labelled DFT setting to replay that trial with beside the identified one."""

    data_dir: Path
    trials: list[LoggedTrial]
    goals: NDArray[np.float64] | None = None
    other: tuple[str, DFTParams] | None = None
    _idle: dict[float, tuple[list[tuple[NDArray[np.float64], NDArray[np.float64]]], int]] = field(
        default_factory=dict, repr=False
    )

    def idle_steps(self, period: float) -> tuple[list[tuple[NDArray[np.float64], NDArray[np.float64]]], int]:
        """Per trial, the beliefs before and after its idle updates (:func:`idle_steps`, updates
        ``period`` s apart), and the number of idle stretches of all trials (computed once)."""
        if period not in self._idle:
            steps, stretches = [], 0
            for trial in self.trials:
                before, after, k = idle_steps(trial, period)
                steps.append((before, after))
                stretches += k
            self._idle[period] = (steps, stretches)
        return self._idle[period]


class Identification(Measured):
    """Everything :func:`identify` measured: the value of each of :data:`IDENTIFICATIONS` by its
    name, as a key or an attribute (``ident.decay``); :meth:`to_json` for ``--json``."""

    def to_json(self) -> dict[str, Any]:
        """The identified values under the documented keys (s, m, m/s, 1/s): the JSON of each of
        :data:`IDENTIFICATIONS` that has one, in the table's order."""
        out: dict[str, Any] = {}
        for row in IDENTIFICATIONS:
            if row.json is not None:
                out.update(row.json(self[row.name], self))
        return out


def _trials(logs: Logs, _: Identification) -> int:
    """The trials read."""
    return len(logs.trials)


def _subjects(logs: Logs, _: Identification) -> list[str]:
    """Their subjects."""
    return sorted({t.record.subject for t in logs.trials})


def _period(logs: Logs, _: Identification) -> UpdatePeriod:
    """The belief's update period (:func:`update_period`)."""
    return update_period(logs.trials)


def _decay(logs: Logs, found: Identification) -> IdleDecay:
    """The belief's decay with no command (:func:`fit_idle_decay`)."""
    steps, stretches = logs.idle_steps(found.period.period)
    return fit_idle_decay(steps, found.period.period, stretches)


def _idle_error(logs: Logs, found: Identification) -> float:
    """The largest error of the identified decay replayed from each belief before an idle update
    (:func:`idle_replay_error`)."""
    steps, _ = logs.idle_steps(found.period.period)
    params = found.decay.params()
    return max(idle_replay_error(b, a, params, found.period.period) for b, a in steps)


def _alpha(logs: Logs, _: Identification) -> AlphaLaw:
    """The alpha law (:func:`fit_alpha_law`)."""
    return fit_alpha_law(logs.trials)


def _requests(logs: Logs, _: Identification) -> RequestTiming:
    """The request time (:func:`request_timing`)."""
    return request_timing(logs.trials)


def _mode_maps(logs: Logs, _: Identification) -> dict[str, ModeMap]:
    """Per interface with requests, its mode map (:func:`identify_mode_map`)."""
    interfaces = sorted({t.record.interface for t in logs.trials if t.record.requests})
    return {i: identify_mode_map(logs.trials, i) for i in interfaces}


def _known_path(logs: Logs, found: Identification) -> KnownPath | None:
    """What the known-path trial shows (:func:`identify_known_path`; ``None`` where the logs lack
    :data:`KNOWN_PATH_FILE` or the trial :data:`KNOWN_PATH_TRIAL`)."""
    path = logs.data_dir / KNOWN_PATH_FILE
    by_id = {t.record.trial_id: t for t in logs.trials}
    if not path.is_file() or KNOWN_PATH_TRIAL not in by_id:
        return None
    goals = _reaching_goals() if logs.goals is None else np.asarray(logs.goals, dtype=float)
    return identify_known_path(by_id[KNOWN_PATH_TRIAL], path, goals, found.decay, logs.other)


def _reaching_goals() -> NDArray[np.float64]:
    """The embedded reaching task's goal positions (m), in the task's order."""
    return np.array([g.position for g in load_scenario("reaching").goals], dtype=float)


# -- the text and the JSON of each identification --------------------------------------------------


def _dims(d: tuple[int, ...] | None) -> str:
    return "?" if d is None else "{" + ", ".join(DIM_NAMES[k] for k in d) + "}"


def _modes_json(modes: Sequence[tuple[int, ...] | None]) -> list[list[int] | None]:
    return [None if d is None else list(d) for d in modes]


def _text_trials(trials: int, ident: Identification) -> str:
    return f"Trials: {trials} (subjects {', '.join(ident.subjects)})"


def _json_trials(trials: int, _: Identification) -> dict[str, Any]:
    return {"trials": trials}


def _json_subjects(subjects: list[str], _: Identification) -> dict[str, Any]:
    return {"subjects": subjects}


def _text_period(p: UpdatePeriod, _: Identification) -> str:
    return (
        f"Belief update period: {p.period:.3f} s ({p.n} intervals between updates; "
        f"{100 * p.share:.1f} % of the logged rows are updates)"
    )


def _json_period(p: UpdatePeriod, _: Identification) -> dict[str, Any]:
    return {"belief_update_period": p.period}


def _text_decay(d: IdleDecay, ident: Identification) -> list[str]:
    """The decay's lines, with the replay error of :func:`_idle_error`."""
    return [
        "Idle decay (no user command): "
        + ", ".join(f"{n} goals factor {f:.7f} ({d.updates[n]} updates)" for n, f in d.factor.items())
        + f"; {d.stretches} idle stretches",
        f"  explicit Euler step of {d.dt:.3f} s: tau1 = tau2 = {d.tau:.4f} s; replayed with dft_euler_step "
        f"to {ident.idle_error:.1e}",
        "  rest state: largest |c_i - 1/n| "
        + ", ".join(f"{v:.1e} ({n} goals)" for n, v in d.rest_deviation.items())
        + " (uniform)",
        "  zero-command excitation: "
        + (
            "cannot tell from one goal count"
            if d.excitation is None
            else f"{d.excitation:.1e} /s ({'yes' if d.zero_command_excitation else 'none'})"
        ),
    ]


def _json_decay(d: IdleDecay, ident: Identification) -> dict[str, Any]:
    """The decay's keys, with the replay error of :func:`_idle_error`."""
    return {
        "idle_tau": d.tau,
        "idle_factor": {str(n): f for n, f in d.factor.items()},
        "idle_updates": {str(n): k for n, k in d.updates.items()},
        "idle_stretches": d.stretches,
        "idle_replay_error": ident.idle_error,
        "rest_state_deviation": {str(n): v for n, v in d.rest_deviation.items()},
        "zero_command_excitation": d.zero_command_excitation,
        "zero_command_excitation_rate": d.excitation,
    }


def _text_alpha(a: AlphaLaw, _: Identification) -> list[str]:
    return [
        f"Alpha: {a.alpha_max:g} * clip((round(max p, {a.decimals}) - rho1) / (rho2 - rho1), 0, 1), "
        "0 from a request's press to its switch",
        "  "
        + "; ".join(
            f"{n} goals: rho1 {lo:g}, rho2 {hi:g} ({a.fit_rows[n]} rows of the linear part)"
            for n, (lo, hi) in a.thresholds.items()
        ),
        f"  rows matched within {ALPHA_TOLERANCE:g}: "
        + ", ".join(f"{i} {t} {100 * v:.1f} % of {a.rows[(i, t)]}" for (i, t), v in a.match.items()),
    ]


def _json_alpha(a: AlphaLaw, _: Identification) -> dict[str, Any]:
    return {
        "alpha_thresholds": {str(n): list(v) for n, v in a.thresholds.items()},
        "alpha_thresholds_above_uniform": {
            str(n): [round(lo - 1.0 / n, 9), round(hi - 1.0 / n, 9)] for n, (lo, hi) in a.thresholds.items()
        },
        "alpha_max": a.alpha_max,
        "alpha_belief_decimals": a.decimals,
        "alpha_match": {f"{i}/{t}": v for (i, t), v in a.match.items()},
    }


def _text_requests(r: RequestTiming, _: Identification) -> str:
    return (
        f"Request time (press to switch): min {r.minimum:.2f} s, median {r.median:.2f} s, "
        f"max {r.maximum:.2f} s ({r.n} requests); alpha and the blended command 0 on "
        f"{100 * r.zero_share:.1f} % of the {r.rows} rows in between; the belief changed on "
        f"{100 * r.belief_change_share:.1f} % of them (the other rows: "
        f"{100 * r.belief_change_share_outside:.1f} %)"
    )


def _json_requests(r: RequestTiming, _: Identification) -> dict[str, Any]:
    return {
        "request_time": {"min": r.minimum, "median": r.median, "max": r.maximum, "n": r.n},
        "request_zero_share": r.zero_share,
        "request_belief_change_share": r.belief_change_share,
    }


def _text_mode_map(name: str, m: ModeMap) -> list[str]:
    """The lines of one interface's mode map."""
    ids = MODE_IDS[name][:-1]
    lines = [
        f"Mode map, {name} ({m.requests} requests): the new mode is the argmax of the logged mode scores "
        f"on {100 * m.argmax_share:.1f} %; score columns sum dimensions "
        + " ".join(_dims(c) for c in m.column_dims)
        + f" (to {m.sum_residual:.0e})",
        "  mode ids "
        + ", ".join(f"{i} = {_dims(o)}" for i, o in zip(ids, m.mode_order, strict=True))
        + ("" if m.consistent else " (two columns led to the same mode id: inconsistent)"),
    ]
    ids_left, modes_left = m.unresolved
    if ids_left:
        lines.append(
            f"  not shown by these requests: which of ids {', '.join(map(str, ids_left))} is which of "
            + " ".join(_dims(d) for d in modes_left)
        )
    return lines


def _text_mode_maps(maps: dict[str, ModeMap], _: Identification) -> list[str]:
    return [line for name, m in maps.items() for line in _text_mode_map(name, m)]


def _pooled_argmax(maps: dict[str, ModeMap]) -> float:
    n = sum(m.requests for m in maps.values())
    return sum(m.argmax_share * m.requests for m in maps.values()) / n if n else math.nan


def _json_mode_maps(maps: dict[str, ModeMap], _: Identification) -> dict[str, Any]:
    return {
        "request_mode_is_argmax": _pooled_argmax(maps),
        "mode_order": {k: _modes_json(m.mode_order) for k, m in maps.items()},
        "mode_ids": {k: list(MODE_IDS[k][:-1]) for k in maps},
        "mode_order_unresolved": {
            k: {"ids": m.unresolved[0], "modes": _modes_json(m.unresolved[1])}
            for k, m in maps.items()
            if m.unresolved[0]
        },
    }


def _text_replay(rep: BeliefReplay) -> str:
    return (
        f"  belief replay ({rep.label}: tau {rep.tau:.2f} s, lambda {rep.lam:g}, "
        f"{rep.updates} updates): per-goal correlation "
        + " ".join(f"{c:.3f}" for c in rep.correlation)
        + f", argmax agreement {100 * rep.argmax_agreement:.1f} %"
    )


def _text_known_path(kp: KnownPath | None, _: Identification) -> list[str]:
    if kp is None:
        return [f"Known path: {KNOWN_PATH_TRIAL} or {KNOWN_PATH_FILE} not in the data"]
    lines = [
        f"Known path ({kp.trial_id}, {kp.samples} samples of the autonomy's commands): the end effector "
        f"solved from a {kp.attractor_speed:.3f} m/s unit attractor plus repeller, rms under 1e-4 m/s on "
        f"{100 * kp.solved_share:.1f} % of samples (worst {kp.worst_rms:.1e})",
        "  start ({:.3f}, {:.3f}, {:.3f}) m, end ({:.3f}, {:.3f}, {:.3f}) m".format(*kp.start, *kp.end)
        + (
            ""
            if kp.repeller_radius is None
            else f"; a repeller felt up to {kp.repeller_radius:.3f} m from the nearest goal"
        ),
        f"  rotational commands: norm {kp.rotation_speed:.3f} rad/s (the median), within 1 % of it on "
        f"{100 * kp.rotation_share:.1f} % of all goals' samples (a saturation; no orientation "
        "was logged to solve for their law)",
        "  blend law (1 - alpha) u_h + alpha u_a(argmax p), rows with alpha > 0: "
        f"{100 * kp.blend_share:.1f} % of {kp.blend_rows} with a user command, "
        f"{100 * kp.blend_share_idle:.1f} % of {kp.blend_rows_idle} without, within 1e-3",
    ]
    return lines + [_text_replay(rep) for rep in (kp.best, *kp.proximity, kp.other) if rep is not None]


def _json_known_path(kp: KnownPath | None, _: Identification) -> dict[str, Any]:
    if kp is None:
        return {}
    out: dict[str, Any] = {
        "trial": kp.trial_id,
        "start": list(kp.start),
        "end": list(kp.end),
        "solved_share": kp.solved_share,
        "attractor_speed": kp.attractor_speed,
        "repeller_radius": kp.repeller_radius,
        "rotation_speed": kp.rotation_speed,
        "rotation_share": kp.rotation_share,
        "blend_share": kp.blend_share,
        "blend_share_without_command": kp.blend_share_idle,
        "lambda": kp.best.lam,
        "correlation": kp.best.correlation,
        "argmax_agreement": kp.best.argmax_agreement,
        "proximity": [dataclasses.asdict(r) for r in kp.proximity],
    }
    if kp.other is not None:
        out["other"] = dataclasses.asdict(kp.other)
    return {"known_path": out}


@dataclass(frozen=True)
class Identifying:
    """One identification: its ``name`` (its key and attribute in :class:`Identification`), the
    function that measures it from the logs and what was identified before it, its text lines
    and its JSON keys (``None``: shown with another identification, which reads it)."""

    name: str
    identify: Callable[[Logs, Identification], Any]
    text: Callable[[Any, Identification], str | list[str]] | None
    json: Callable[[Any, Identification], dict[str, Any]] | None


IDENTIFICATIONS: tuple[Identifying, ...] = (
    Identifying("trials", _trials, _text_trials, _json_trials),
    Identifying("subjects", _subjects, None, _json_subjects),
    Identifying("period", _period, _text_period, _json_period),
    Identifying("decay", _decay, _text_decay, _json_decay),
    Identifying("idle_error", _idle_error, None, None),
    Identifying("alpha", _alpha, _text_alpha, _json_alpha),
    Identifying("requests", _requests, _text_requests, _json_requests),
    Identifying("mode_maps", _mode_maps, _text_mode_maps, _json_mode_maps),
    Identifying("known_path", _known_path, _text_known_path, _json_known_path),
)
"""What :func:`identify` measures (module docstring), in the order of the text and the JSON: adding
an identification is a function (with its text and JSON) and a row here."""


def identify(
    data_dir: str | Path,
    goals: NDArray[np.float64] | None = None,
    other: tuple[str, DFTParams] | None = None,
    trials: Sequence[LoggedTrial] | None = None,
) -> Identification:
    """Identify the study's system from the logs in ``data_dir`` (module docstring): each of
    :data:`IDENTIFICATIONS` in turn, each seeing those before it.

    Args:
        data_dir: The logs' folder (``H*/`` and the trial-order file; any subset of subjects).
        goals: The reaching task's goal positions ``(5, 3)`` (m) for the known-path trial; ``None``:
            the embedded reaching task's.
        other: A labelled DFT setting to replay the known-path trial with beside the identified one.
        trials: The trials already read from ``data_dir`` (read here if ``None``).

    Raises:
        ValueError: The logs are missing or malformed, or show no idle updates or no requests.
    """
    data_dir = Path(data_dir)
    logs = Logs(data_dir, read_trials(data_dir) if trials is None else list(trials), goals, other)
    values: dict[str, Any] = {}
    for row in IDENTIFICATIONS:
        values[row.name] = row.identify(logs, Identification(values))
    return Identification(values)


def format_identification(ident: Identification) -> str:
    """The identification as text, each value with its evidence (the text of each of
    :data:`IDENTIFICATIONS` that has one)."""
    return "\n".join(text_lines(IDENTIFICATIONS, ident))
