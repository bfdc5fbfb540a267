"""What every mode-selection method shares once it has scored the modes: the tie rule, the
result's common part and the first lines of its explanation.

Ties: modes whose scores lie within ``tie_tolerance`` (relative to the largest) of the best are
equal. If every mode is equal the current mode is kept (``mode = None``); if the current mode is
among several equally best modes it is kept too; otherwise the first of the best modes wins.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from drake_disamb.core.disambiguation.request import DisambiguationRequest
from drake_disamb.core.layout import DIM_NAMES


def mode_label(dims: Sequence[int]) -> str:
    """A mode as people read it, e.g. ``{vx, vy}``."""
    return "{" + ", ".join(DIM_NAMES[k] for k in dims) + "}" if dims else "{}"


def select_mode(
    mode_scores: NDArray[np.float64], current_mode: int | None, tie_tolerance: float
) -> tuple[int | None, int]:
    """Apply the tie rule. Returns ``(mode or None when the current mode is kept, argmax)``.

    Modes within ``tie_tolerance`` (relative) of the best are equally best; the chosen mode is the
    first of them (lowest index) unless the current mode is one of them or all modes are.
    """
    scores = np.asarray(mode_scores, dtype=float).tolist()  # a few numbers: plain Python is faster
    best = max(range(len(scores)), key=scores.__getitem__)  # first of equal maxima, like argmax
    top = scores[best]
    threshold = top - tie_tolerance * abs(top)
    tied = [v >= threshold for v in scores]
    if all(tied):
        return None, best
    if current_mode is not None and 0 <= current_mode < len(scores) and tied[current_mode]:
        return None, best
    return tied.index(True), best  # the first of the equally best modes


def mean_over_probes(
    per_probe: NDArray[np.float64], request: DisambiguationRequest
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(per dimension, per mode)`` means of per-probe scores ``(2, n_k)``: a dimension's score is
    the mean of its two probes, a mode's the mean over its probed dimensions (0 if it has none)."""
    D_k = 0.5 * (per_probe[0] + per_probe[1])
    member = request.membership
    counts = member.sum(axis=1)
    scores = np.divide(member @ D_k, counts, out=np.zeros(len(request.modes)), where=counts > 0)
    return D_k, scores


@dataclass(frozen=True)
class DisambiguationResult:
    """What every mode-selection method's result has: the chosen mode and every mode's score.

    Each method's result is a subclass with its own details and explanation; ``method`` names the
    method (its registry name) and ``score_name`` what its mode scores are.

    Attributes:
        mode: The chosen mode as an index into ``modes``, or ``None`` when the current mode is kept.
        best_mode: The best-scoring mode before the tie rule (first of equal maxima).
        mode_scores: Every mode's score, shape ``(n_modes,)`` (larger is better).
        modes: The control modes (dimension indices).
        current_mode: The mode in use when the request came (``None`` if not given).
        tie_tolerance: Relative tie tolerance used.
    """

    method: ClassVar[str]
    score_name: ClassVar[str]

    mode: int | None
    best_mode: int
    mode_scores: NDArray[np.float64]
    modes: tuple[tuple[int, ...], ...]
    current_mode: int | None
    tie_tolerance: float

    @property
    def kept(self) -> bool:
        """True when the current mode is kept (no switch)."""
        return self.mode is None

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dictionary (the ``disambiguate`` command's output format)."""
        return {"method": self.method, "mode": self.mode, "best_mode": self.best_mode, **self.details()}

    def details(self) -> dict[str, Any]:
        """The method's own JSON fields (after ``method``, ``mode`` and ``best_mode``)."""
        return {"mode_scores": self.mode_scores.tolist()}

    def explain(self) -> str:
        """A short human-readable account of why the mode won, then the method's own lines."""
        return "\n".join([*self._choice_lines(), *self.explain_details()])

    def explain_details(self) -> list[str]:
        """The method's own lines of :meth:`explain` (what drove the scores)."""
        return []

    def _choice_lines(self) -> list[str]:
        lines: list[str] = []
        sym = self.score_name
        order = np.argsort(-self.mode_scores, kind="stable")
        best = int(order[0])
        scores = ", ".join(
            f"{i} {mode_label(m)} = {s:.4g}"
            for i, (m, s) in enumerate(zip(self.modes, self.mode_scores, strict=True))
        )
        if self.mode is None:
            cur = "the current mode" if self.current_mode is None else f"the current mode {self.current_mode}"
            top = self.mode_scores.max()
            if np.all(self.mode_scores >= top - self.tie_tolerance * abs(top)):
                lines.append(
                    f"Kept {cur}: every mode scores the same within {self.tie_tolerance:g} (relative); "
                    "moving in any mode would tell the goals apart equally (or not at all)."
                )
            else:
                lines.append(
                    f"Kept {cur}: it is among the equally best modes (within {self.tie_tolerance:g})."
                )
        else:
            runner = [int(i) for i in order if int(i) != self.mode]
            label = mode_label(self.modes[self.mode])
            text = f"Chose mode {self.mode} {label} with {sym} = {self.mode_scores[self.mode]:.4g}"
            if self.mode != best:
                text += (
                    f": it ties with mode {best} {mode_label(self.modes[best])} ({sym} = "
                    f"{self.mode_scores[best]:.4g}) within {self.tie_tolerance:g} (relative), and the first "
                    "of the equally best modes wins"
                )
            elif runner:
                r = runner[0]
                ratio = (
                    self.mode_scores[self.mode] / self.mode_scores[r] if self.mode_scores[r] > 0 else np.inf
                )
                text += f"; runner-up mode {r} {mode_label(self.modes[r])} scores {self.mode_scores[r]:.4g}"
                text += f" ({ratio:.3g}x)" if np.isfinite(ratio) else " (nothing to disambiguate there)"
            lines.append(text + ".")
        lines.append(f"Mode scores {sym}: {scores}.")
        return lines


@dataclass(frozen=True)
class ProbeResult(DisambiguationResult):
    """The result of a method that scores each probe of the forward projection (``+/- s e_k``).

    Attributes:
        dimension: The best probed dimension ``k*`` (0 = vx ... 5 = wz).
        dimensions: The probed dimensions; the per-dimension arrays follow this order.
        scores_plus: The ``+e_k`` probes' scores, ``(n_k,)``.
        scores_minus: The ``-e_k`` probes' scores, ``(n_k,)``.
        dimension_scores: Each dimension's score, ``(n_k,)``.
        features: The method's per-probe quantities, name -> ``(2, n_k)`` (row 0 ``+e_k``).
    """

    dimension: int
    dimensions: tuple[int, ...]
    scores_plus: NDArray[np.float64]
    scores_minus: NDArray[np.float64]
    dimension_scores: NDArray[np.float64]
    features: dict[str, NDArray[np.float64]]

    @classmethod
    def chosen(
        cls,
        request: DisambiguationRequest,
        per_probe: NDArray[np.float64],
        dimension_scores: NDArray[np.float64],
        mode_scores: NDArray[np.float64],
        features: dict[str, NDArray[np.float64]],
        **extra: Any,
    ) -> ProbeResult:
        """The result for ``request`` whose probes scored ``per_probe`` (``(2, n_k)``, row 0
        ``+e_k``): the tie rule applied to ``mode_scores``, the best dimension the argmax of
        ``dimension_scores``; ``extra`` are the subclass's own fields."""
        cfg = request.config
        mode, best = select_mode(mode_scores, request.current_mode, cfg.tie_tolerance)
        return cls(
            mode=mode,
            best_mode=best,
            mode_scores=mode_scores,
            modes=request.modes,
            current_mode=request.current_mode,
            tie_tolerance=cfg.tie_tolerance,
            dimension=cfg.dimensions[int(np.argmax(dimension_scores))],
            dimensions=cfg.dimensions,
            scores_plus=per_probe[0],
            scores_minus=per_probe[1],
            dimension_scores=dimension_scores,
            features=features,
            **extra,
        )

    def details(self) -> dict[str, Any]:
        return {
            "dimension": self.dimension,
            "dimensions": list(self.dimensions),
            "dimension_scores": {
                "plus": self.scores_plus.tolist(),
                "minus": self.scores_minus.tolist(),
                "total": self.dimension_scores.tolist(),
            },
            "mode_scores": self.mode_scores.tolist(),
            "features": {
                name: {"plus": values[0].tolist(), "minus": values[1].tolist()}
                for name, values in self.features.items()
            },
        }
