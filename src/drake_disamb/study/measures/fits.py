"""Distributions fitted to behaviour samples: lognormal summaries, a von Mises concentration, request decay.

The samples are those :mod:`drake_disamb.study.measures.calibration` measures on the people's logs (or on a
simulated study); the fits summarise them per subject and pooled, as the population
(:mod:`drake_disamb.user.population`) draws them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True)
class LogNormalFit:
    """A positive quantity summarised as a lognormal: ``median`` and ``log_sd``, from ``n`` values,
    with the between-subject log-sd of the per-subject medians (``subject_log_sd``) and the
    largest value (``maximum``: a lognormal's upper tail may be heavier than the samples')."""

    median: float
    log_sd: float
    n: int
    subject_medians: dict[str, float]
    maximum: float = float("nan")

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
        maximum=float(np.max(pooled)),
    )


def von_mises_kappa(mean_cos: float) -> float:
    """The 2-D von Mises concentration whose mean cosine ``I1(k) / I0(k)`` is ``mean_cos``."""
    from scipy.optimize import brentq
    from scipy.special import i0e, i1e

    if not 0 < mean_cos < 1:
        return float("inf") if mean_cos >= 1 else 0.0
    return float(brentq(lambda k: i1e(k) / i0e(k) - mean_cos, 1e-9, 1e6))


@dataclass(frozen=True)
class RequestDecayFit:
    """``P(a mode change is made by a request | it is made at t s) = p0[subject] * exp(-t / tau)``,
    the maximum-likelihood fit over the Disambiguation trials' mode changes (``n``; a request or
    the first switch of a burst of the user's own), ``tau`` shared by the subjects. ``tau`` is
    ``inf`` when no decay fits better."""

    p0: dict[str, float]
    tau: float
    n: int


LOG_TAU_MAX = 12.0
"""The fit's largest ``log(tau)`` (about 1.6e5 s: no decay within any trial; reported as ``inf``)."""


def fit_request_decay(events: Sequence[tuple[str, float, bool]]) -> RequestDecayFit:
    """:class:`RequestDecayFit` of ``(subject, time s, made by a request)`` events."""
    from scipy.optimize import minimize

    if not events:
        return RequestDecayFit({}, math.nan, 0)
    subjects = sorted({e[0] for e in events})
    index = np.array([subjects.index(e[0]) for e in events])
    t = np.array([e[1] for e in events], dtype=float)
    y = np.array([e[2] for e in events], dtype=float)

    def log_tau(theta: NDArray[np.float64]) -> float:
        return min(max(float(theta[-1]), 0.0), LOG_TAU_MAX)  # tau in [1 s, e^12 s]

    def logistic(v: NDArray[np.float64]) -> NDArray[np.float64]:  # p0 in (0, 1) from its logit
        return 1.0 / (1.0 + np.exp(-np.clip(v, -50.0, 50.0)))

    def nll(theta: NDArray[np.float64]) -> float:
        p0 = logistic(theta[:-1])
        q = np.clip(p0[index] * np.exp(-t * math.exp(-log_tau(theta))), 1e-12, 1.0 - 1e-12)
        return float(-np.sum(y * np.log(q) + (1.0 - y) * np.log1p(-q)))

    start = np.append(np.zeros(len(subjects)), math.log(60.0))  # theta[-1] = log(tau)
    res = minimize(nll, start, method="Nelder-Mead", options={"maxiter": 20000, "xatol": 1e-6, "fatol": 1e-9})
    tau = math.exp(log_tau(res.x))
    return RequestDecayFit(
        p0=dict(zip(subjects, logistic(res.x[:-1]).tolist(), strict=True)),
        tau=tau if tau < 1e5 else math.inf,
        n=len(events),
    )
