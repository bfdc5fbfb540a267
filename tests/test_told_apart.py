"""Which goals a mode's motion tells apart, from the forward projection every mode-selection method
scores (:mod:`drake_disamb.core.disambiguation.told_apart`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

from drake_disamb.core.disambiguation import (
    DEFAULT_CONFIG,
    MODE_SELECTION_METHODS,
    DisambiguationResult,
    make_request,
    mode_selection_method,
)
from drake_disamb.core.disambiguation.told_apart import told_apart

GOALS = np.array([[0.25, 0.0, 0.0], [-0.25, 0.0, 0.0], [0.0, 0.0, 0.6]])
"""Goals to the right (+x) and to the left (-x) of the gripper, a third far above."""
MODES = ((0,), (1,), (2,))


def _request(current_mode: int | None = 1):  # noqa: ANN202
    return make_request(
        np.full(3, 1 / 3), np.zeros(3), GOALS, MODES, DEFAULT_CONFIG, current_mode=current_mode
    )


@pytest.mark.parametrize("method", ["algorithm1", "entropy", "kl"])
def test_moving_along_x_leads_toward_the_goal_on_each_side(method: str) -> None:
    request = _request()
    result = mode_selection_method(method).select(request)
    assert result.mode == 0  # every method chooses moving along x here
    told = told_apart(request, result)
    assert told is not None and told.mode == 0 and told.dimension == 0
    assert (told.plus_goal, told.minus_goal) == (0, 1) and told.goals == (0, 1)
    assert told.plus_gain > 0 and told.minus_gain > 0


def test_a_kept_mode_is_read_for_the_mode_kept() -> None:
    request = _request(current_mode=0)
    result = mode_selection_method("algorithm1").select(request)
    assert result.mode is None  # already the best: kept
    told = told_apart(request, result)
    assert told is not None and told.mode == 0 and (told.plus_goal, told.minus_goal) == (0, 1)


def test_a_mode_without_a_probed_dimension_tells_nothing() -> None:
    config = DEFAULT_CONFIG.__class__(dimensions=(0, 1))
    request = make_request(np.full(3, 1 / 3), np.zeros(3), GOALS, ((2,), (0,)), config, current_mode=None)
    result = mode_selection_method("algorithm1").select(request)
    forced = type(result)(**{**result.__dict__, "mode": 0})  # the z mode, which is not probed
    assert told_apart(request, forced) is None


def test_a_method_without_dimension_scores_is_read_from_the_projection() -> None:
    @dataclass(frozen=True)
    class Plain(DisambiguationResult):
        method: ClassVar[str] = "plain"
        score_name: ClassVar[str] = "score"

    request = _request()
    result = Plain(
        mode=0,
        best_mode=0,
        mode_scores=np.array([1.0, 0.0, 0.0]),
        modes=MODES,
        current_mode=1,
        tie_tolerance=0.0,
    )
    told = told_apart(request, result)
    assert told is not None and (told.dimension, told.plus_goal, told.minus_goal) == (0, 0, 1)
    assert "plain" not in MODE_SELECTION_METHODS  # nothing registered
