"""The study's statistics: the paper's rank-sum tests over trials, effect sizes, a per-subject check.

For every source, metric (:data:`drake_disamb.study.measures.metrics.METRICS`), interface (``joystick``,
``head_array`` or ``all``) and task (``reaching``, ``pouring`` or ``all``), and every pair of
paradigms present (:data:`PAIRS`: manual vs disambiguation, manual vs automatic,
disambiguation vs automatic), over the analysed trials with a value (valid and not failed,
:attr:`~drake_disamb.study.measures.metrics.TrialMetrics.analysed`):

- ``test = "ranksum"``: the paper's Wilcoxon rank-sum test, ``scipy.stats.mannwhitneyu(a, b,
  alternative="two-sided")`` (its default method: exact for small samples without ties, else the
  normal approximation with tie and continuity correction, as MATLAB's ``ranksum``); ``statistic``
  is U of ``a``; ``stars`` the paper's marks (``***`` p < 0.001, ``**`` p < 0.01, ``*`` p < 0.05,
  ``n.s.``); ``effect_size`` the rank-biserial correlation ``2 U / (n_a n_b) - 1`` (positive: ``a``
  tends to be larger), with a percentile bootstrap 95 % interval (``ci_low``, ``ci_high``;
  :data:`BOOTSTRAP` resamples of each group with replacement, seeded: the same records give the
  same interval). The authors compared all Manual trials with 3 of the 5 Disambiguation trials
  drawn without a seed; we use every trial.
- ``test = "signed_rank_subject_means"``: trials of one subject are not independent, so the same
  comparison on subject means: ``scipy.stats.wilcoxon`` over the subjects that have both
  paradigms (``n_a = n_b`` = subjects; null p where every difference is zero or there are none).
- ``test = "mixedlm"`` (for :data:`MIXED_METRICS`): ``value ~ paradigm`` with a random intercept per subject
  (``statsmodels`` ``mixedlm``, REML), ``statistic`` the paradigm coefficient (b minus a),
  ``p_value`` its Wald p; where the model cannot be fitted (too few subjects, a singular fit, no
  variance) the row has null numbers and ``note`` says why; without ``statsmodels`` (the ``study``
  extra) :func:`run_tests` raises :class:`~drake_disamb.extras.MissingExtra` instead.
"""

from __future__ import annotations

import math
import warnings
import zlib
from collections.abc import Sequence
from typing import Any

import numpy as np

from drake_disamb.extras import import_optional
from drake_disamb.interfaces import INTERFACES
from drake_disamb.study.data.records import TrialRecord
from drake_disamb.study.measures.metrics import METRICS, TrialMetrics, trial_metrics

__all__ = [
    "BOOTSTRAP",
    "MIXED_METRICS",
    "INTERFACE_STRATA",
    "PAIRS",
    "TASKS",
    "rank_biserial",
    "run_tests",
    "stars",
    "values_of",
]

PAIRS: tuple[tuple[str, str], ...] = (
    ("manual", "disambiguation"),
    ("manual", "automatic"),
    ("disambiguation", "automatic"),
)
INTERFACE_STRATA = (*INTERFACES, "all")
"""The interface strata of the tests: every registered interface, and all together."""
TASKS = ("reaching", "pouring", "all")
BOOTSTRAP = 2000
"""Bootstrap resamples for the effect size's confidence interval."""
MIXED_METRICS = ("button_presses", "completion_time")
"""Metrics that also get the mixed model (a fit takes about half a second; the signed-rank check on
subject means covers every metric)."""


def stars(p: float | None) -> str:
    """The paper's significance marks: ``***`` p < 0.001, ``**`` p < 0.01, ``*`` p < 0.05."""
    if p is None or not math.isfinite(p):
        return ""
    return "***" if p < 0.001 else "**" if p < 0.01 else "*" if p < 0.05 else "n.s."


def _u_statistic(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """U of ``a`` over the last axis: pairs with a > b plus half the ties (batched)."""
    d = a[..., :, None] - b[..., None, :]
    return (d > 0).sum(axis=(-1, -2)) + 0.5 * (d == 0).sum(axis=(-1, -2))


def rank_biserial(a: Sequence[float], b: Sequence[float]) -> float:
    """Rank-biserial correlation ``2 U_a / (n_a n_b) - 1`` (in [-1, 1]; positive: a larger)."""
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(2.0 * _u_statistic(x, y) / (len(x) * len(y)) - 1.0)


def _bootstrap_ci(a: np.ndarray, b: np.ndarray, seed: int) -> tuple[float, float]:
    rng = np.random.default_rng(seed)
    ra = a[rng.integers(0, len(a), size=(BOOTSTRAP, len(a)))]
    rb = b[rng.integers(0, len(b), size=(BOOTSTRAP, len(b)))]
    r = 2.0 * _u_statistic(ra, rb) / (len(a) * len(b)) - 1.0
    lo, hi = np.percentile(r, [2.5, 97.5])
    return float(lo), float(hi)


def values_of(
    trials: Sequence[TrialMetrics], metric: str, interface: str, task: str, paradigm: str
) -> list[tuple[str, float]]:
    """``(subject, value)`` of ``metric`` over the analysed trials of a group (``all`` matches any)."""
    out = []
    for m in trials:
        r = m.record
        if not m.analysed or r.paradigm != paradigm:
            continue
        if interface != "all" and r.interface != interface:
            continue
        if task != "all" and r.task != task:
            continue
        v = m.value(metric)
        if v is not None and math.isfinite(v):
            out.append((r.subject, v))
    return out


def _seed(*parts: str) -> int:
    """A seed from the test's name: stable across runs and processes (unlike ``hash``)."""
    return zlib.crc32("|".join(parts).encode())


def _ranksum(a: list[float], b: list[float], seed: int) -> dict[str, Any]:
    from scipy.stats import mannwhitneyu

    x, y = np.asarray(a), np.asarray(b)
    res = mannwhitneyu(x, y, alternative="two-sided")
    p = float(res.pvalue)
    lo, hi = _bootstrap_ci(x, y, seed)
    return {
        "test": "ranksum",
        "statistic": float(res.statistic),
        "p_value": p if math.isfinite(p) else None,
        "stars": stars(p),
        "effect_size": rank_biserial(x, y),
        "ci_low": lo,
        "ci_high": hi,
        "n_a": len(x),
        "n_b": len(y),
        "mean_a": float(np.mean(x)),
        "mean_b": float(np.mean(y)),
    }


def _subject_means(pairs: list[tuple[str, float]]) -> dict[str, float]:
    by: dict[str, list[float]] = {}
    for s, v in pairs:
        by.setdefault(s, []).append(v)
    return {s: float(np.mean(v)) for s, v in by.items()}


def _signed_rank(a: list[tuple[str, float]], b: list[tuple[str, float]]) -> dict[str, Any]:
    from scipy.stats import wilcoxon

    ma, mb = _subject_means(a), _subject_means(b)
    subjects = sorted(set(ma) & set(mb))
    row: dict[str, Any] = {
        "test": "signed_rank_subject_means",
        "n_a": len(subjects),
        "n_b": len(subjects),
        "statistic": None,
        "p_value": None,
        "stars": "",
    }
    diffs = [mb[s] - ma[s] for s in subjects]
    if not subjects or all(d == 0 for d in diffs):
        row["note"] = "no subject with both paradigms" if not subjects else "every difference is zero"
        return row
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = wilcoxon([ma[s] for s in subjects], [mb[s] for s in subjects])
    p = float(res.pvalue)
    row.update(statistic=float(res.statistic), p_value=p if math.isfinite(p) else None, stars=stars(p))
    row["mean_a"] = float(np.mean([ma[s] for s in subjects]))
    row["mean_b"] = float(np.mean([mb[s] for s in subjects]))
    return row


def _mixedlm(a: list[tuple[str, float]], b: list[tuple[str, float]]) -> dict[str, Any]:
    row: dict[str, Any] = {
        "test": "mixedlm",
        "n_a": len(a),
        "n_b": len(b),
        "statistic": None,
        "p_value": None,
        "stars": "",
    }
    subjects = {s for s, _ in a} | {s for s, _ in b}
    values = np.array([v for _, v in a] + [v for _, v in b])
    if len(subjects) < 3:
        row["note"] = f"{len(subjects)} subjects: too few for a random intercept"
        return row
    if np.ptp(values) == 0:
        row["note"] = "no variance"
        return row
    pd = import_optional("pandas", "study")
    smf = import_optional("statsmodels.formula.api", "study")
    try:
        frame = pd.DataFrame(
            {
                "value": values,
                "b": [0.0] * len(a) + [1.0] * len(b),
                "subject": [s for s, _ in a] + [s for s, _ in b],
            }
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = smf.mixedlm("value ~ b", frame, groups=frame["subject"]).fit(reml=True)
        coef, p = float(fit.params["b"]), float(fit.pvalues["b"])
    except Exception as err:  # statsmodels raises many kinds (LinAlgError, ValueError, ...)
        row["note"] = f"could not be fitted: {type(err).__name__}: {err}"
        return row
    if not (math.isfinite(coef) and math.isfinite(p)):
        row["note"] = "could not be fitted: non-finite estimate"
        return row
    row.update(statistic=coef, p_value=p, stars=stars(p), converged=bool(fit.converged))
    return row


def run_tests(
    records: Sequence[TrialRecord],
    metrics: Sequence[str] = METRICS,
    per_subject: bool = True,
    mixed_metrics: Sequence[str] = MIXED_METRICS,
) -> list[dict[str, Any]]:
    """Every test (see the module docstring) as a list of JSON-ready objects with at least
    ``metric``, ``interface``, ``task``, ``a``, ``b``, ``test``, ``statistic``, ``p_value``,
    ``n_a``, ``n_b`` (and ``source``). Pairs where a side has no value are skipped.

    Args:
        records: The trials (invalid ones are left out).
        metrics: The metrics tested.
        per_subject: Add the per-subject checks (signed-rank on subject means for every metric,
            the mixed model for those in ``mixed_metrics``).
        mixed_metrics: The metrics that get the mixed model.
    """
    for name in metrics:
        if name not in METRICS:
            raise ValueError(f"metric: expected one of {METRICS}, got {name!r}")
    trials = [trial_metrics(r) for r in records]
    rows: list[dict[str, Any]] = []
    for source in sorted({r.source for r in records}):
        mine = [m for m in trials if m.record.source == source]
        for metric in metrics:
            for interface in INTERFACE_STRATA:
                for task in TASKS:
                    for a, b in PAIRS:
                        va = values_of(mine, metric, interface, task, a)
                        vb = values_of(mine, metric, interface, task, b)
                        if not va or not vb:
                            continue
                        key = {
                            "source": source,
                            "metric": metric,
                            "interface": interface,
                            "task": task,
                            "a": a,
                            "b": b,
                        }
                        seed = _seed(source, metric, interface, task, a, b)
                        rows.append({**key, **_ranksum([v for _, v in va], [v for _, v in vb], seed)})
                        if per_subject:
                            rows.append({**key, **_signed_rank(va, vb)})
                            if metric in mixed_metrics:
                                rows.append({**key, **_mixedlm(va, vb)})
    return rows
