"""Minimum expected entropy: the mode whose motion is expected to leave the belief most certain.

The authors' entropy method (docs/facts.md section 5) on Algorithm 1's forward projection
(:func:`~drake_disamb.core.disambiguation.projection.forward_projection`: the same probes,
inference update and horizons): each probe ``+/- s e_k``'s projected belief at ``t_b`` (1 s in
both presets, the authors' horizon) has entropy ``H_k+/-`` (bits, :func:`entropy_bits`). A mode's
expected projected entropy is the mean over its probes (2 per probed dimension). The score
maximised is the expected **entropy reduction** ``H(p(t_a)) - mean H`` (bits), so the mode chosen
is the one with the **minimum** expected entropy. The authors' code takes the maximum expected
entropy, which picks the mode that leaves the belief least certain; that reads as a sign slip (the
informative choice is the one that sharpens the belief), and this method implements the minimum.

Differences from the authors' code: the probes are the axis probes of Algorithm 1 (``+/- s e_k``
per dimension of the mode), not every sign combination of the mode's dimensions at once (identical
for the one-dimensional modes of the head array; for a joystick mode the corner probes are not
projected); and a mode none of whose dimensions is probed scores 0 (as if it left the belief
unchanged).

Ties as in :func:`~drake_disamb.core.disambiguation.selection.select_mode` (``tie_tolerance``
relative to the best score): a mode that cannot change the belief scores 0; if no mode can, every
score is 0 and the current mode is kept. A mode whose motion makes the belief less certain scores
below 0.
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


def entropy_bits(p: ArrayLike) -> NDArray[np.float64]:
    """Shannon entropy (bits) over the last axis, the authors' ``-sum p log2(p + realmin)``.

    ``[0.5, 0.5]`` has 1 bit, a certain belief 0 bits, the uniform belief over ``n`` goals
    ``log2 n``.
    """
    a = np.asarray(p, dtype=float)
    return -np.sum(a * np.log2(a + _REALMIN), axis=-1)


@dataclass(frozen=True)
class EntropyResult(ProbeResult):
    """The entropy method's result: ``scores_plus`` / ``scores_minus`` the per-probe entropy
    reduction (bits), ``dimension_scores`` their mean, ``mode_scores`` the expected entropy reduction
    per mode, ``features = {"entropy": H}`` (``(2, n_k)`` projected entropies, bits)."""

    method: ClassVar[str] = "entropy"
    score_name: ClassVar[str] = "expected entropy reduction (bits)"

    def explain_details(self) -> list[str]:
        """The best dimension's projected entropies."""
        k = self.dimensions.index(self.dimension)
        name = DIM_NAMES[self.dimension]
        h = self.features["entropy"][:, k]
        return [
            f"Best dimension k* = {name}: moving +{name} / -{name} leaves a projected entropy of "
            f"{h[0]:.4g} / {h[1]:.4g} bits at t_b (mean reduction {self.dimension_scores[k]:.4g} bits)."
        ]


@MODE_SELECTION_METHODS.register
class ExpectedEntropy(ModeSelectionMethod):
    """The minimum expected entropy of the projected belief (see the module docstring)."""

    name: ClassVar[str] = "entropy"
    label: ClassVar[str] = "the minimum expected entropy of the projected belief"

    def select(self, request: DisambiguationRequest) -> EntropyResult:
        proj = forward_projection(request)
        feature = entropy_bits(proj.p_b)  # (2, n_k)
        per_probe = entropy_bits(request.belief) - feature  # entropy reduction: larger is better
        D_k, scores = mean_over_probes(per_probe, request)
        return EntropyResult.chosen(request, per_probe, D_k, scores, {"entropy": feature})
