"""The alternative mode-selection methods (expected entropy, expected KL) of the disambiguation core."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from support import integrate_pose

from drake_disamb.core.autonomy import potential_field_commands
from drake_disamb.core.disambiguation import (
    MODE_SELECTION_METHODS,
    DisambiguationConfig,
    authors_r3_config,
    disambiguate,
    entropy_bits,
    kl_bits,
    mico_config,
    select_disambiguating_mode,
)
from drake_disamb.core.inference import dft_euler_step

HEAD_ARRAY_MODES = [[0], [1], [2], [3], [4], [5]]
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
# Two goals mirrored in y about the end effector's x-z plane: moving along x, z or rotating
# approaches (or leaves) both alike, so only vy can tell them apart.
MIRRORED = np.array([[0.3, 0.15, 0.0], [0.3, -0.15, 0.0]])
METHODS = {name: functools.partial(select_disambiguating_mode, name) for name in ("entropy", "kl")}


def test_entropy_and_kl_by_hand() -> None:
    assert entropy_bits([0.5, 0.5]) == pytest.approx(1.0)
    assert entropy_bits([1.0, 0.0]) == pytest.approx(0.0, abs=1e-12)
    assert entropy_bits(np.full(4, 0.25)) == pytest.approx(2.0)
    assert kl_bits([0.3, 0.7], [0.3, 0.7]) == pytest.approx(0.0, abs=1e-15)
    assert kl_bits([1.0, 0.0], [0.5, 0.5]) == pytest.approx(1.0)  # log2(1 / 0.5)
    assert kl_bits([0.75, 0.25], [0.5, 0.5]) == pytest.approx(0.75 * np.log2(1.5) + 0.25 * np.log2(0.5))
    # A zero entry of q: large and finite, never NaN.
    value = kl_bits([0.5, 0.5], [1.0, 0.0])
    assert np.isfinite(value) and value > 100


def _projected_beliefs_at_t_b(belief, position, goals, cfg: DisambiguationConfig):  # type: ignore[no-untyped-def]
    """Slow reference: each axis probe projected step by step to t_b (update, then move)."""
    out = np.zeros((2, len(cfg.dimensions), len(goals)))
    quats = np.tile(IDENTITY, (len(goals), 1))
    for col, k in enumerate(cfg.dimensions):
        for row, sign in enumerate((1.0, -1.0)):
            u = np.zeros(6)
            u[k] = sign * (cfg.probe_speed_translation if k < 3 else cfg.probe_speed_rotation)
            p, x, q = np.array(belief, dtype=float), np.array(position, dtype=float), IDENTITY.copy()
            for _ in range(round(cfg.t_b / cfg.delta_t)):
                ua = potential_field_commands(x, q, goals, quats, cfg.potential_field)
                dft = cfg.inference.params
                p = dft_euler_step(p, u, x, goals, dft, cfg.delta_t, ua if dft.agreement else None)
                x, q = integrate_pose(x, q, u, cfg.delta_t)
            out[row, col] = p
    return out


@pytest.mark.parametrize("method", ["entropy", "kl"])
def test_scores_equal_a_loop_reference(method: str) -> None:
    goals = np.array([[0.3, 0.1, 0.05], [0.25, -0.2, 0.1], [0.4, 0.0, -0.1]])
    belief = np.array([0.5, 0.3, 0.2])
    cfg = mico_config()
    res = METHODS[method](belief, np.zeros(3), goals, HEAD_ARRAY_MODES, cfg)
    P = _projected_beliefs_at_t_b(belief, np.zeros(3), goals, cfg)
    if method == "entropy":
        per_probe = entropy_bits(belief) - entropy_bits(P)
        np.testing.assert_allclose(res.features["entropy"], entropy_bits(P), atol=1e-9)
    else:
        per_probe = kl_bits(P, belief)
    np.testing.assert_allclose(res.scores_plus, per_probe[0], atol=1e-9)
    np.testing.assert_allclose(res.scores_minus, per_probe[1], atol=1e-9)
    # One-dimensional modes: each mode's score is the mean over its two probes.
    np.testing.assert_allclose(res.mode_scores, per_probe.mean(axis=0), atol=1e-9)
    assert res.method == method and res.to_dict()["method"] == method
    assert res.best_mode == int(np.argmax(res.mode_scores))


@pytest.mark.parametrize("method", ["entropy", "kl"])
def test_only_the_mode_that_tells_mirrored_goals_apart_scores(method: str) -> None:
    res = METHODS[method]([0.5, 0.5], np.zeros(3), MIRRORED, HEAD_ARRAY_MODES, mico_config(), current_mode=0)
    assert res.mode == 1  # vy
    # Every other mode leaves the belief uniform: it scores 0, the worst possible for KL.
    others = np.delete(res.mode_scores, 1)
    np.testing.assert_allclose(others, 0.0, atol=1e-12)
    assert res.mode_scores[1] > 1e-3
    text = res.explain()
    assert "Chose mode 1 {vy}" in text and "bits" in text


def test_entropy_picks_the_minimum_expected_entropy() -> None:
    goals = np.array([[0.3, 0.1, 0.05], [0.25, -0.2, 0.1], [0.4, 0.0, -0.1]])
    belief = np.array([0.4, 0.35, 0.25])
    res = METHODS["entropy"](belief, np.zeros(3), goals, HEAD_ARRAY_MODES)
    expected_entropy = res.features["entropy"].mean(axis=0)  # per 1-D mode
    assert res.mode == int(np.argmin(expected_entropy))
    np.testing.assert_allclose(res.mode_scores, entropy_bits(belief) - expected_entropy, atol=1e-12)


@pytest.mark.parametrize("method", ["entropy", "kl"])
def test_a_single_goal_keeps_the_current_mode(method: str) -> None:
    res = METHODS[method]([1.0], np.zeros(3), [[0.3, 0.0, 0.0]], HEAD_ARRAY_MODES, current_mode=4)
    assert res.mode is None and np.all(res.mode_scores == 0.0)
    assert "every mode scores the same" in res.explain()


@pytest.mark.parametrize("method", ["entropy", "kl"])
def test_ties_follow_algorithm_1s_rule(method: str) -> None:
    modes = [[1], [0], [1]]  # modes 0 and 2 are the same (vy): equally best
    run = METHODS[method]
    assert run([0.5, 0.5], np.zeros(3), MIRRORED, modes, current_mode=2).mode is None  # among the best
    assert run([0.5, 0.5], np.zeros(3), MIRRORED, modes, current_mode=1).mode == 0  # first of the best
    assert run([0.5, 0.5], np.zeros(3), MIRRORED, modes).mode == 0


@pytest.mark.parametrize("method", ["entropy", "kl"])
def test_a_mode_without_probed_dimensions_scores_zero(method: str) -> None:
    # authors-r3 probes x, y, z only: the rotational mode cannot be scored.
    res = METHODS[method]([0.5, 0.5], np.zeros(3), MIRRORED, [[3], [1]], authors_r3_config())
    assert res.mode_scores[0] == 0.0 and res.mode_scores[1] > 0 and res.mode == 1


def test_joystick_mode_scores_the_mean_over_its_probes() -> None:
    goals = np.array([[0.3, 0.1, 0.05], [0.25, -0.2, 0.1]])
    res = METHODS["kl"]([0.6, 0.4], np.zeros(3), goals, [[0, 1], [0, 2], [3, 5], [4]])
    D = res.dimension_scores  # per dimension, mean of its two probes
    np.testing.assert_allclose(
        res.mode_scores, [(D[0] + D[1]) / 2, (D[0] + D[2]) / 2, (D[3] + D[5]) / 2, D[4]]
    )


def test_dispatch_by_name() -> None:
    args = ([0.5, 0.5], np.zeros(3), MIRRORED, HEAD_ARRAY_MODES)
    assert MODE_SELECTION_METHODS.names() == ("algorithm1", "entropy", "kl")
    a1 = select_disambiguating_mode("algorithm1", *args, current_mode=0)
    np.testing.assert_array_equal(a1.mode_scores, disambiguate(*args, current_mode=0).mode_scores)
    assert a1.method == "algorithm1"
    for name in ("entropy", "kl"):
        got = select_disambiguating_mode(name, *args, current_mode=0)
        np.testing.assert_array_equal(got.mode_scores, METHODS[name](*args, current_mode=0).mode_scores)
    with pytest.raises(
        ValueError, match=r"mode-selection method: expected one of algorithm1, entropy, kl, got .fisher."
    ):
        select_disambiguating_mode("fisher", *args)


@pytest.mark.parametrize("method", ["entropy", "kl"])
def test_bad_requests_name_the_argument(method: str) -> None:
    with pytest.raises(ValueError, match=r"belief: expected non-negative entries summing to 1"):
        METHODS[method]([0.9, 0.9], np.zeros(3), MIRRORED, HEAD_ARRAY_MODES)
    with pytest.raises(ValueError, match=r"modes\[1\]"):
        METHODS[method]([0.5, 0.5], np.zeros(3), MIRRORED, [[0], [7]])


@pytest.mark.parametrize("method", ["entropy", "kl"])
def test_disambiguate_command_method_option(method: str, tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    import json

    from drake_disamb import cli

    case = {
        "belief": [0.5, 0.5],
        "position": [0, 0, 0],
        "goals": MIRRORED.tolist(),
        "modes": HEAD_ARRAY_MODES,
    }
    path = tmp_path / "cases.json"
    path.write_text(json.dumps([case]))
    assert cli.main(["disambiguate", "--cases", str(path), "--method", method]) == 0
    (result,) = json.loads(capsys.readouterr().out)
    core = METHODS[method]([0.5, 0.5], np.zeros(3), MIRRORED, HEAD_ARRAY_MODES)
    assert result["method"] == method and result["mode"] == core.mode == 1
    np.testing.assert_allclose(result["mode_scores"], core.mode_scores, rtol=1e-12)
