"""Blending law (core) and the SharedControlBlender system in isolation."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_disamb.core.blending import (
    BlendingConfig,
    blend,
    blending_alpha,
    clamp_speed,
    has_input,
    resolve_rhos,
    shared_control,
)

# ---------------------------------------------------------------------------------------------
# core: alpha
# ---------------------------------------------------------------------------------------------


def test_paper_defaults() -> None:
    assert resolve_rhos(4) == pytest.approx((0.3, 0.35, 0.7))
    assert resolve_rhos(5) == pytest.approx((0.24, 0.28, 0.7))


@pytest.mark.parametrize("n", [2, 3, 4, 5])
def test_alpha_pieces(n: int) -> None:
    r1, r2 = 1.2 / n, 1.4 / n
    assert blending_alpha(1.0 / n, n) == 0.0  # uniform belief: no assistance
    assert blending_alpha(r1, n) == 0.0  # "<= rho1" is still zero
    mid = 0.5 * (r1 + r2)
    assert blending_alpha(mid, n) == pytest.approx(0.35)  # halfway up the ramp to 0.7
    assert blending_alpha(r2, n) == pytest.approx(0.7)  # ramp reaches rho3 at rho2
    assert blending_alpha(min(1.0, r2 + 1e-6), n) == pytest.approx(0.7)
    assert blending_alpha(1.0, n) == pytest.approx(0.7)


def test_alpha_custom_and_vectorised() -> None:
    p = np.array([0.0, 0.2, 0.3, 0.4, 0.6, 1.0])
    a = blending_alpha(p, 3, rho1=0.2, rho2=0.6, rho3=1.0)
    np.testing.assert_allclose(a, [0.0, 0.0, 0.25, 0.5, 1.0, 1.0])
    assert blending_alpha(np.nan, 3) == 0.0


@given(p=st.floats(0.0, 1.0), n=st.integers(2, 8))
@settings(max_examples=60, deadline=None)
def test_alpha_monotone_and_bounded(p: float, n: int) -> None:
    a = blending_alpha(p, n)
    assert 0.0 <= a <= 0.7
    assert blending_alpha(min(1.0, p + 0.01), n) >= a


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"rho1": 0.5, "rho2": 0.4}, "rho2"),
        ({"rho1": 0.5, "rho2": 0.5}, "rho2"),
        ({"rho1": -0.1}, "rho1"),
        ({"rho2": 1.5}, "rho2"),
        ({"rho3": 1.2}, "rho3"),
        ({"rho3": float("nan")}, "rho3"),
    ],
)
def test_bad_rhos(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        blending_alpha(0.5, 3, **kwargs)


def test_single_goal_needs_explicit_rhos() -> None:
    with pytest.raises(ValueError, match="rho1.*1.2.*n_goals=1"):
        resolve_rhos(1)
    assert blending_alpha(1.0, 1, rho1=0.5, rho2=0.9) == pytest.approx(0.7)
    with pytest.raises(ValueError, match="n_goals"):
        resolve_rhos(0)


# ---------------------------------------------------------------------------------------------
# core: blend, clamp, shared_control
# ---------------------------------------------------------------------------------------------


def test_blend_law() -> None:
    u_h = np.array([0.1, 0, 0, 0, 0, 0.2])
    u_a = np.array([0, 0.2, 0, 0.4, 0, 0])
    np.testing.assert_allclose(blend(u_h, u_a, 0.0), u_h)
    np.testing.assert_allclose(blend(u_h, u_a, 1.0), u_a)
    np.testing.assert_allclose(blend(u_h, u_a, 0.25), [0.075, 0.05, 0, 0.1, 0, 0.15])
    batch = blend(np.tile(u_h, (2, 1)), np.tile(u_a, (2, 1)), np.array([0.0, 1.0]))
    np.testing.assert_allclose(batch, [u_h, u_a])
    with pytest.raises(ValueError, match="alpha"):
        blend(u_h, u_a, 1.5)


def test_clamp_speed_keeps_direction() -> None:
    u = np.array([0.3, 0.4, 0.0, 0.0, 0.0, 0.1])
    c = clamp_speed(u, 0.25, 0.67)
    np.testing.assert_allclose(c, [0.15, 0.2, 0, 0, 0, 0.1])  # translation 0.5 -> 0.25, rotation kept
    c = clamp_speed(np.array([0, 0, 0, 2.0, 0, 0]), 1.0, 0.5)
    np.testing.assert_allclose(c, [0, 0, 0, 0.5, 0, 0])
    np.testing.assert_allclose(clamp_speed(np.zeros(6), 0.1, 0.1), np.zeros(6))


def test_shared_control_picks_argmax_goal_and_respects_input_flag() -> None:
    u_a = np.zeros((3, 6))
    u_a[0, 0] = 0.2
    u_a[1, 1] = 0.2
    u_a[2, 2] = 0.2
    belief = np.array([0.1, 0.8, 0.1])  # g* = 1, p* = 0.8 > rho2 = 0.467 -> alpha = 0.7
    u_h = np.array([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
    u, alpha, g = shared_control(u_h, belief, u_a, BlendingConfig())
    assert g == 1 and alpha == pytest.approx(0.7)
    np.testing.assert_allclose(u, [0, 0.14, 0.03, 0, 0, 0])

    still = np.zeros(6)
    u, alpha, g = shared_control(still, belief, u_a, BlendingConfig())
    assert g == 1 and alpha == 0.0
    np.testing.assert_allclose(u, 0.0)
    u, alpha, _ = shared_control(still, belief, u_a, BlendingConfig(assist_without_input=True))
    assert alpha == pytest.approx(0.7)
    np.testing.assert_allclose(u, [0, 0.14, 0, 0, 0, 0])
    assert has_input(u_h) and not has_input(still)


def test_blending_config_validation() -> None:
    with pytest.raises(ValueError, match="max_linear_speed"):
        BlendingConfig(max_linear_speed=0.0)
    with pytest.raises(ValueError, match="assist_without_input"):
        BlendingConfig(assist_without_input="yes")  # type: ignore[arg-type]


# ---------------------------------------------------------------------------------------------
# SharedControlBlender system
# ---------------------------------------------------------------------------------------------


def _blender_context(blender, u_h, belief, u_a):
    ctx = blender.CreateDefaultContext()
    blender.GetInputPort("u_h").FixValue(ctx, np.asarray(u_h, dtype=float))
    blender.GetInputPort("belief").FixValue(ctx, np.asarray(belief, dtype=float))
    blender.GetInputPort("u_a").FixValue(ctx, np.asarray(u_a, dtype=float).reshape(-1))
    return ctx


def test_blender_system_outputs() -> None:
    from drake_disamb.systems.blending import SharedControlBlender
    from drake_disamb.systems.loop import ControlLoop

    n = 4
    blender = SharedControlBlender(ControlLoop(n))
    u_a = np.zeros((n, 6))
    u_a[:, 0] = [0.1, 0.2, -0.2, 0.0]
    u_a[2, 3] = 0.3
    u_h = [0.0, 0.1, 0.0, 0.0, 0.0, 0.0]
    # p* = 0.325: halfway between rho1 = 0.3 and rho2 = 0.35 -> alpha = 0.35, g* = 2.
    ctx = _blender_context(blender, u_h, [0.225, 0.225, 0.325, 0.225], u_a)
    assert blender.GetOutputPort("g_star").Eval(ctx)[0] == 2
    assert blender.GetOutputPort("alpha").Eval(ctx)[0] == pytest.approx(0.35)
    np.testing.assert_allclose(
        blender.GetOutputPort("u").Eval(ctx), [0.35 * -0.2, 0.65 * 0.1, 0, 0.35 * 0.3, 0, 0]
    )
    # Uniform belief: no assistance, u = u_h.
    ctx = _blender_context(blender, u_h, np.full(n, 0.25), u_a)
    assert blender.GetOutputPort("alpha").Eval(ctx)[0] == 0.0
    np.testing.assert_allclose(blender.GetOutputPort("u").Eval(ctx), u_h)
    assert blender.HasDirectFeedthrough(blender.GetInputPort("u_h").get_index(), 0)


def test_blender_system_speed_limit_and_no_input() -> None:
    from drake_disamb.systems.blending import SharedControlBlender
    from drake_disamb.systems.loop import ControlLoop

    blender = SharedControlBlender(ControlLoop(2), max_linear_speed=0.1, assist_without_input=True)
    u_a = np.zeros((2, 6))
    u_a[0, :3] = [0.3, 0.0, 0.4]
    ctx = _blender_context(blender, np.zeros(6), [0.9, 0.1], u_a)
    u = blender.GetOutputPort("u").Eval(ctx)
    assert np.linalg.norm(u[:3]) == pytest.approx(0.1)
    np.testing.assert_allclose(u[:3] / np.linalg.norm(u[:3]), [0.6, 0.0, 0.8])
    default = SharedControlBlender(ControlLoop(2))  # assists only while the user commands
    ctx = _blender_context(default, np.zeros(6), [0.9, 0.1], u_a)
    np.testing.assert_allclose(default.GetOutputPort("u").Eval(ctx), 0.0)
    assert default.GetOutputPort("alpha").Eval(ctx)[0] == 0.0


def test_blender_system_nonfinite_inputs_never_reach_the_arm() -> None:
    from pydrake.systems.analysis import Simulator

    from drake_disamb.systems.blending import SharedControlBlender
    from drake_disamb.systems.loop import ControlLoop

    blender = SharedControlBlender(ControlLoop(2, control_period=0.01))
    u_a = np.full((2, 6), np.nan)
    ctx = _blender_context(blender, [np.inf, 0.05, 0, 0, 0, np.nan], [np.nan, 0.2], u_a)
    u = blender.GetOutputPort("u").Eval(ctx)
    assert np.all(np.isfinite(u))
    np.testing.assert_allclose(u, [0, 0.05, 0, 0, 0, 0])  # belief [0, 0.2] -> g* = 1, p* below rho1
    count = blender.GetOutputPort("sanitized_input_count")
    assert count.Eval(ctx)[0] == 0
    with pytest.warns(RuntimeWarning, match="non-finite input") as record:
        Simulator(blender, ctx).AdvanceTo(0.035)  # ticks at 0, 0.01, 0.02, 0.03
    assert len(record) == 1 and count.Eval(ctx)[0] == 4
    np.testing.assert_allclose(blender.GetOutputPort("u").Eval(ctx), [0, 0.05, 0, 0, 0, 0])
    # Finite inputs are not counted; a new context starts from zero.
    fine = _blender_context(blender, np.zeros(6), [0.5, 0.5], np.zeros((2, 6)))
    Simulator(blender, fine).AdvanceTo(0.035)
    assert count.Eval(fine)[0] == 0
    assert not blender.HasDirectFeedthrough(0, count.get_index())


@pytest.mark.parametrize("error", [ValueError("u_a: expected shape (2, 6)"), RuntimeError("bug")])
def test_blender_system_other_errors_propagate(monkeypatch: pytest.MonkeyPatch, error: Exception) -> None:
    from pydrake.systems.analysis import Simulator

    from drake_disamb.systems import blending as module
    from drake_disamb.systems.loop import ControlLoop

    def broken(*args: object) -> None:
        raise error

    blender = module.SharedControlBlender(ControlLoop(2))
    ctx = _blender_context(blender, [0.1, 0, 0, 0, 0, 0], [0.9, 0.1], np.zeros((2, 6)))
    monkeypatch.setattr(module, "shared_control", broken)
    with pytest.raises(type(error), match=re.escape(str(error))):
        blender.GetOutputPort("u").Eval(ctx)
    ctx = _blender_context(blender, [np.nan, 0, 0, 0, 0, 0], [0.9, 0.1], np.zeros((2, 6)))
    with pytest.raises(type(error), match=re.escape(str(error))):  # also after sanitising
        blender.GetOutputPort("alpha").Eval(ctx)
    with pytest.warns(RuntimeWarning, match="non-finite"):  # the count's update does not need the core
        Simulator(blender, ctx).AdvanceTo(0.005)
    assert blender.GetOutputPort("sanitized_input_count").Eval(ctx)[0] == 1


def test_blender_rejects_bad_config() -> None:
    from drake_disamb.systems.blending import SharedControlBlender
    from drake_disamb.systems.loop import ControlLoop

    with pytest.raises(ValueError, match="rho2"):  # the config's own check
        SharedControlBlender(ControlLoop(3), rho1=0.5, rho2=0.2)
    with pytest.raises(AssertionError):  # the loop's bounds are the resolved scenario's (test_bounds.py)
        SharedControlBlender(ControlLoop(2), config={"rho1": 0.5})  # type: ignore[arg-type]
    blender = SharedControlBlender(ControlLoop(2, control_period=0.02))
    assert blender.GetUniquePeriodicDiscreteUpdateAttribute().period_sec() == 0.02


def test_resolve_rhos_checks_survive_its_cache() -> None:
    assert resolve_rhos(1, 0.1, 0.2) == (0.1, 0.2, 0.7)  # now cached
    with pytest.raises(ValueError, match="n_goals"):
        resolve_rhos(True, 0.1, 0.2)  # equal to 1 as a key, but a bool
    with pytest.raises(ValueError, match="rho1"):
        resolve_rhos(5, [0.1], None)  # unhashable: checked without the cache


def test_one_step_is_a_row_of_the_batch() -> None:
    """A single step (the control loop's) gives exactly the numbers of the same row in a batch."""
    rng = np.random.default_rng(5)
    n = 4
    u_h = rng.normal(scale=0.2, size=(6, 6))
    u_h[0] = 0.0  # no input
    belief = rng.dirichlet(np.ones(n) * 0.3, size=6)
    u_a = rng.normal(scale=0.3, size=(6, n, 6))
    for config in (BlendingConfig(), BlendingConfig(assist_without_input=True, max_linear_speed=0.1)):
        u, alpha, g_star = shared_control(u_h, belief, u_a, config)
        for b in range(6):
            one = shared_control(u_h[b], belief[b], u_a[b], config)
            np.testing.assert_array_equal(one[0], u[b])
            assert (one[1], one[2]) == (alpha[b], g_star[b])
            assert isinstance(one[1], float) and isinstance(one[2], int)


def test_blender_paused_pauses_the_loop() -> None:
    """``paused`` above 0.5 (a request being computed by the study's system): nothing reaches the arm
    and alpha is 0, whatever the inputs; g_star is still the belief's argmax."""
    from drake_disamb.systems.blending import SharedControlBlender
    from drake_disamb.systems.loop import ControlLoop

    n = 4
    blender = SharedControlBlender(ControlLoop(n), assist_without_input=True)
    u_a = np.zeros((n, 6))
    u_a[:, 0] = [0.1, 0.2, -0.2, 0.0]
    ctx = _blender_context(blender, [0.0, 0.1, 0.0, 0.0, 0.0, 0.0], [0.1, 0.1, 0.7, 0.1], u_a)
    assert blender.GetOutputPort("alpha").Eval(ctx)[0] > 0  # unconnected: never paused
    blender.GetInputPort("paused").FixValue(ctx, [1.0])
    np.testing.assert_array_equal(blender.GetOutputPort("u").Eval(ctx), np.zeros(6))
    assert blender.GetOutputPort("alpha").Eval(ctx)[0] == 0.0
    assert blender.GetOutputPort("g_star").Eval(ctx)[0] == 2
    blender.GetInputPort("paused").FixValue(ctx, [0.0])
    assert blender.GetOutputPort("alpha").Eval(ctx)[0] == pytest.approx(0.7)
