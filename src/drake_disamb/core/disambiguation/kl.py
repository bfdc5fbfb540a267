"""Maximum expected KL divergence: the mode whose motion is expected to change the belief most.

The authors' KL method (docs/facts.md section 5) on Algorithm 1's forward projection (the same
probes, inference update and horizons): each probe's score is ``KL(p(t_b) || p(t_a))`` (bits,
:func:`kl_bits`) of its projected belief at ``t_b`` (1 s in both presets, the authors' horizon)
from the current one; a mode's score is the mean over its probes (2 per probed dimension), and the
mode with the **maximum** expected divergence is chosen, as in the authors' code. A mode that
cannot change the belief scores 0, the least possible; a mode none of whose dimensions is probed
also scores 0. Probes and ties as in :mod:`~drake_disamb.core.disambiguation.entropy` (the axis
probes of Algorithm 1; :func:`~drake_disamb.core.disambiguation.selection.select_mode`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core.disambiguation.projection import forward_projection
from drake_disamb.core.disambiguation.registry import MODE_SELECTION_METHODS, ModeSelectionMethod
from drake_disamb.core.disambiguation.request import DisambiguationRequest
from drake_disamb.core.disambiguation.selection import ProbeResult, mean_over_probes
from drake_disamb.core.layout import DIM_NAMES

_REALMIN = float(np.finfo(float).tiny)
"""MATLAB's ``realmin``: the authors' guard inside their logarithms."""


def kl_bits(p: ArrayLike, q: ArrayLike) -> NDArray[np.float64]:
    """``KL(p || q)`` in bits over the last axis (>= 0, 0 when ``p == q``).

    The authors' ``-sum p log2(q / p + realmin)`` with its guards written so that no entry is a
    NaN: a term with ``p_i = 0`` is 0, and ``q_i`` is read as at least ``realmin`` (so the
    divergence from a belief with an exactly zero entry is large and finite, about 1022 bits per unit of
    ``p_i``, instead of infinite).
    """
    a = np.asarray(p, dtype=float)
    b = np.asarray(q, dtype=float)
    ratio = np.log2(np.maximum(a, _REALMIN)) - np.log2(np.maximum(b, _REALMIN))
    return np.sum(np.where(a > 0, a * ratio, 0.0), axis=-1)


@dataclass(frozen=True)
class KLResult(ProbeResult):
    """The KL method's result: ``scores_plus`` / ``scores_minus`` the per-probe divergence (bits),
    ``dimension_scores`` their mean, ``mode_scores`` the expected divergence per mode, ``features =
    {"kl": ...}`` (the same ``(2, n_k)`` divergences)."""

    method: ClassVar[str] = "kl"
    score_name: ClassVar[str] = "expected KL (bits)"

    def explain_details(self) -> list[str]:
        """The best dimension's divergences."""
        k = self.dimensions.index(self.dimension)
        name = DIM_NAMES[self.dimension]
        d = self.features["kl"][:, k]
        return [
            f"Best dimension k* = {name}: moving +{name} / -{name} changes the belief by KL = {d[0]:.4g} / "
            f"{d[1]:.4g} bits at t_b."
        ]


@MODE_SELECTION_METHODS.register
class ExpectedKL(ModeSelectionMethod):
    """The maximum expected KL divergence of the projected belief (see the module docstring)."""

    name: ClassVar[str] = "kl"
    label: ClassVar[str] = "the maximum expected KL divergence of the projected belief"

    def select(self, request: DisambiguationRequest) -> KLResult:
        proj = forward_projection(request)
        per_probe = kl_bits(proj.p_b, request.belief)  # (2, n_k)
        D_k, scores = mean_over_probes(per_probe, request)
        return KLResult.chosen(request, per_probe, D_k, scores, {"kl": per_probe})
