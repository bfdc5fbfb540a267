"""Paper Algorithm 1: the mode whose motion best disambiguates the goals, from the features
of the forward projection.

From the projected beliefs (paper Section "Features of D_k", equation (DK)):

- at ``t_b``: ``Gamma = max p``, ``Omega = max p - second max p`` and
  ``Lambda = sum_{i<j} |p_i - p_j|``;
- between ``t_b`` and ``t_c``: ``Upsilon = sum_{i<j} |g_i - g_j|`` with
  ``g = (p(t_c) - p(t_b)) / dx_k``, where ``dx_k`` depends on ``upsilon_normalization``
  (:data:`UPSILON_NORMALIZATIONS`): ``"unit_probe"`` (the paper) the displacement along ``k`` of
  the paper's unit probe ``e_k`` (1 m/s or 1 rad/s) between ``t_b`` and ``t_c``, i.e. ``t_c - t_b``
  units for every dimension; ``"displacement"`` the displacement of our probe, metres for a
  translational dimension and the rotation angle about axis ``k`` (rad) for a rotational one (so
  with probes of 0.1 m/s and 0.2 rad/s a translation's gradient counts twice a rotation's);
  ``"none"`` (the authors' code) ``dx_k = 1``;
- ``D = w Gamma Lambda Omega + (1 - w) Upsilon`` per probe, ``D_k = D_k+ + D_k-``,
  ``D_m = sum_{k in m} D_k``, ``m* = argmax D_m`` and ``k* = argmax D_k``.

Ties as in :func:`~drake_disamb.core.disambiguation.selection.select_mode`. Degenerate scenes (one
goal, goals at the robot, a certain belief, zero displacement) give valid, finite results: every
division is guarded.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core.disambiguation.config import DisambiguationConfig
from drake_disamb.core.disambiguation.projection import forward_projection
from drake_disamb.core.disambiguation.registry import (
    MODE_SELECTION_METHODS,
    ModeSelectionMethod,
    select_disambiguating_mode,
)
from drake_disamb.core.disambiguation.request import DisambiguationRequest
from drake_disamb.core.disambiguation.selection import ProbeResult
from drake_disamb.core.layout import DIM_NAMES

FEATURE_NAMES: tuple[str, ...] = ("gamma", "omega", "lambda", "upsilon")

_MIN_DISPLACEMENT = 1e-12
"""Displacements (m or rad) below this are treated as zero: the gradient is then taken as 0."""


def _pairwise_abs_sum(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """``sum_{i<j} |a_i - a_j|`` over the last axis.

    Sorted ascending, entry ``k`` (0-based) is the larger of a pair ``k`` times and the smaller
    ``n - 1 - k`` times, so the sum is ``sum_k (2k - n + 1) a_(k)``: ``O(n log n)`` instead of all
    ``n^2`` pairs (which dominate a request with 50 goals).
    """
    n = a.shape[-1]
    return np.sort(a, axis=-1) @ np.arange(1.0 - n, n, 2.0)


def belief_features(
    p_b: NDArray[np.float64], p_c: NDArray[np.float64], displacement: NDArray[np.float64], divide: bool
) -> dict[str, NDArray[np.float64]]:
    """Gamma, Omega, Lambda (at ``t_b``) and Upsilon (``t_c`` vs ``t_b``), each shape ``(...)``.

    With one goal the second maximum is taken as 0 (so ``Omega = Gamma``; ``Lambda = 0`` anyway).
    With ``divide``, displacements below 1e-12 give a zero gradient instead of a division by zero.
    """
    srt = np.sort(p_b, axis=-1)
    gamma = srt[..., -1]
    second = srt[..., -2] if p_b.shape[-1] > 1 else np.zeros_like(gamma)
    diff = p_c - p_b
    if divide:
        d = np.abs(displacement)[..., None]
        ok = d > _MIN_DISPLACEMENT
        diff = np.where(ok, diff / np.where(ok, d, 1.0), 0.0)
    lam, ups = _pairwise_abs_sum(np.stack((p_b, diff)))  # both spreads in one pass
    return {"gamma": gamma, "omega": gamma - second, "lambda": lam, "upsilon": ups}


def upsilon_divisor(config: DisambiguationConfig, displacement: NDArray[np.float64]) -> NDArray[np.float64]:
    """What ``p(t_c) - p(t_b)`` of each probe is divided by (``config.upsilon_normalization``).

    ``displacement`` is the projection's ``(2, n_k)`` displacement along ``k`` (m or rad). For
    ``"unit_probe"`` every probe gets ``t_c - t_b``: the displacement of the paper's unit-speed
    probe ``e_k`` (1 m/s or 1 rad/s) over that time, one value for every dimension. ``"none"``
    gives ones (the caller does not divide).
    """
    mode = config.upsilon_normalization
    if mode == "displacement":
        return displacement
    if mode == "unit_probe":
        return np.full(np.shape(displacement), config.t_c - config.t_b)
    return np.ones(np.shape(displacement))


@dataclass(frozen=True)
class Algorithm1Result(ProbeResult):
    """Algorithm 1's result: the probe scores are ``D``, the mode scores ``D_m``.

    Attributes (beyond :class:`~drake_disamb.core.disambiguation.selection.ProbeResult`'s):
        ``scores_plus`` / ``scores_minus`` are ``D_k+`` / ``D_k-``, ``dimension_scores``
        ``D_k = D_k+ + D_k-``, ``mode_scores`` ``D_m``; ``features`` holds ``{"gamma", "omega",
        "lambda", "upsilon"}`` -> ``(2, n_k)``.
        w: Weight of the short-term term used.
    """

    method: ClassVar[str] = "algorithm1"
    score_name: ClassVar[str] = "D_m"

    w: float

    def explain_details(self) -> list[str]:
        """Which features drove the winning (or best) mode, and the best dimension's features."""
        lines: list[str] = []
        best = int(np.argsort(-self.mode_scores, kind="stable")[0])
        # Which features drove the winning (or best) mode.
        focus = self.mode if self.mode is not None else best
        idx = [self.dimensions.index(k) for k in self.modes[focus] if k in self.dimensions]
        if idx:
            g, o, lam, ups = (self.features[n][:, idx] for n in FEATURE_NAMES)
            short = float(np.sum(self.w * g * lam * o))
            long = float(np.sum((1 - self.w) * ups))
            total = short + long
            if total > 0:
                share = short / total
                dom = (
                    "short-term certainty at t_b (w*Gamma*Lambda*Omega)"
                    if share >= 0.5
                    else ("long-term spread of belief gradients (1-w)*Upsilon")
                )
                lines.append(
                    f"In mode {focus} the score is {100 * max(share, 1 - share):.0f} % {dom}: "
                    f"short-term {short:.4g}, long-term {long:.4g}."
                )
            else:
                lines.append(f"Mode {focus} leaves the belief unchanged: every feature is zero.")
        k = self.dimensions.index(self.dimension)
        sign = 0 if self.scores_plus[k] >= self.scores_minus[k] else 1
        f = {n: float(self.features[n][sign, k]) for n in FEATURE_NAMES}
        lines.append(
            f"Best dimension k* = {DIM_NAMES[self.dimension]} (D_k = {self.dimension_scores[k]:.4g}; "
            f"D+ = {self.scores_plus[k]:.4g}, D- = {self.scores_minus[k]:.4g}); moving "
            f"{'+' if sign == 0 else '-'}{DIM_NAMES[self.dimension]} gives Gamma = {f['gamma']:.3f}, "
            f"Omega = {f['omega']:.3f}, Lambda = {f['lambda']:.3f}, Upsilon = {f['upsilon']:.4g}."
        )
        return lines


@MODE_SELECTION_METHODS.register
class Algorithm1(ModeSelectionMethod):
    """The paper's Algorithm 1 (see the module docstring)."""

    name: ClassVar[str] = "algorithm1"
    label: ClassVar[str] = "the paper's Algorithm 1"

    def select(self, request: DisambiguationRequest) -> Algorithm1Result:
        cfg = request.config
        proj = forward_projection(request)
        feats = belief_features(
            proj.p_b, proj.p_c, upsilon_divisor(cfg, proj.displacement), cfg.upsilon_normalization != "none"
        )
        D = (
            cfg.w * feats["gamma"] * feats["lambda"] * feats["omega"] + (1.0 - cfg.w) * feats["upsilon"]
        )  # (2, n_k)
        D_k = D[0] + D[1]
        D_m = request.membership @ D_k
        return Algorithm1Result.chosen(request, D, D_k, D_m, feats, w=cfg.w)


def disambiguate(
    belief: ArrayLike,
    position: ArrayLike,
    goal_positions: ArrayLike,
    modes: Sequence[Sequence[int]],
    config: DisambiguationConfig | None = None,
    *,
    orientation: ArrayLike | None = None,
    goal_orientations: ArrayLike | None = None,
    current_mode: int | None = None,
) -> Algorithm1Result:
    """Run Algorithm 1 on a request and pick the disambiguating control mode.

    The arguments and errors are those of
    :func:`~drake_disamb.core.disambiguation.request.make_request`.
    """
    return select_disambiguating_mode(
        Algorithm1(),
        belief,
        position,
        goal_positions,
        modes,
        config,
        orientation=orientation,
        goal_orientations=goal_orientations,
        current_mode=current_mode,
    )
