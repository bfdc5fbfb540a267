"""The switches for every deviation from the paper (docs/choices.md, "Where we differ from the paper"): each
scenario option selects the paper's behaviour or ours, reaches the code that uses it, and refuses a
bad value naming the field and the value."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from drake_disamb.builder import build_shared_control_diagram
from drake_disamb.config import load_scenario, resolve_scenario
from drake_disamb.config.schema import Scenario
from drake_disamb.core.disambiguation import disambiguate
from drake_disamb.core.inference import DFTParams, agreement, dft_xi
from drake_disamb.systems.blending import SharedControlBlender

# ------------------------------------------------------------------------------------------------
# inference.agreement: dot (paper) | cosine
# ------------------------------------------------------------------------------------------------

# Robot at the origin; goal 0 straight ahead along +x, goal 1 along +y. The user moves along +x at
# 0.1 m/s and turns about +z at 0.2 rad/s; the autonomy turns toward goal 0 at (0, 0.3, 0.4) rad/s
# (|.| = 0.5) and toward goal 1 at (0, 0, -0.1) rad/s.
X_R = np.zeros(3)
GOALS = np.array([[0.1, 0.0, 0.0], [0.0, 0.1, 0.0]])
U_H = np.array([0.1, 0.0, 0.0, 0.0, 0.0, 0.2])
U_A = np.array([[0.0, 0.0, 0.0, 0.0, 0.3, 0.4], [0.0, 0.0, 0.0, 0.0, 0.0, -0.1]])


@pytest.mark.parametrize(
    ("measure", "expected"),
    [
        # directedness (1 + cos)/2: goal 0 cos 1 -> 1.0, goal 1 cos 0 -> 0.5; agreement:
        # dot 0.2 * 0.4 = 0.08 and 0.2 * -0.1 = -0.02
        ("dot", [1.0 + 0.08, 0.5 - 0.02]),
        # cosine 0.2 * 0.4 / (0.2 * 0.5) = 0.8 and -1
        ("cosine", [1.0 + 0.8, 0.5 - 1.0]),
    ],
)
def test_xi_of_a_hand_computed_example(measure: str, expected: list[float]) -> None:
    params = DFTParams(directedness=True, agreement=True, agreement_measure=measure)
    np.testing.assert_allclose(dft_xi(U_H, X_R, GOALS, params, U_A), expected, rtol=1e-12)
    np.testing.assert_allclose(
        agreement(U_H, U_A, measure), np.asarray(expected) - [1.0, 0.5], rtol=1e-12, atol=1e-15
    )


def test_dot_agreement_ignores_non_finite_autonomy_components() -> None:
    params = DFTParams(directedness=False, agreement=True, agreement_measure="dot")
    u_a = U_A.copy()
    u_a[0, 4] = np.nan  # only wz remains: 0.2 * 0.4
    np.testing.assert_allclose(dft_xi(U_H, X_R, GOALS, params, u_a), [0.08, -0.02], rtol=1e-12)
    with pytest.raises(
        ValueError, match=r"DFTParams\.agreement_measure: expected one of dot, cosine, got 'sine'"
    ):
        DFTParams(agreement_measure="sine")


@pytest.mark.parametrize("measure", ["dot", "cosine"])
def test_scenario_agreement_reaches_the_live_inference_and_the_projection(measure: str) -> None:
    s = load_scenario("reaching")
    s.inference.agreement = measure
    handles = build_shared_control_diagram(s)
    assert handles.config.inference.params.agreement_measure == measure
    assert handles.systems["inference"].params.agreement_measure == measure
    projection = handles.systems["disambiguation"].config
    assert projection.inference is handles.config.inference  # the forward projection runs the same update


def test_agreement_measure_decides_the_start_pose_mode() -> None:
    """At the reaching task's start pose with the head array, the cosine term (of order 1) alone
    makes Algorithm 1 pick a rotation; the paper's dot product (at most about 0.08) leaves the
    choice to the translations."""
    picks = {}
    for measure in ("dot", "cosine"):
        s = load_scenario("reaching")
        s.inference.agreement = measure
        handles = build_shared_control_diagram(s)
        context = handles.diagram.CreateDefaultContext()
        handles.initialize(context)
        pose = handles.station.diagram.GetOutputPort("ee_pose").Eval(
            handles.station.diagram.GetMyContextFromRoot(context)
        )
        goals = s.belief_goal_poses(0)
        res = disambiguate(
            np.full(s.n_goals, 1.0 / s.n_goals),
            pose[:3],
            goals[:, :3],
            [list(m) for m in handles.systems["interface"].arm_modes],
            handles.config.disambiguation,
            orientation=pose[3:],
            goal_orientations=goals[:, 3:],
        )
        picks[measure] = handles.modes[res.best_mode]
    assert all(k < 3 for k in picks["dot"]), picks
    assert all(k >= 3 for k in picks["cosine"]), picks


def test_bad_agreement_names_the_field_and_the_value() -> None:
    s = load_scenario("reaching")
    s.inference.agreement = "angle"
    with pytest.raises(
        ValueError, match=r"scenario\.inference\.agreement: expected one of dot, cosine, got 'angle'"
    ):
        resolve_scenario(s)


# ------------------------------------------------------------------------------------------------
# blending.assist_without_input
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("assist", [True, False])
def test_blending_without_input_follows_the_switch(assist: bool) -> None:
    """The paper's law is always active: a confident belief and no input still move the arm toward
    g* at rho3 u_a. Ours (False) gives no command without input."""
    s = load_scenario("reaching")
    s.blending.assist_without_input = assist
    config = resolve_scenario(s)
    blender = SharedControlBlender(config.loop, config.blending)
    context = blender.CreateDefaultContext()
    u_a = np.zeros((5, 6))
    u_a[2] = [0.1, -0.05, 0.0, 0.0, 0.2, 0.0]
    blender.GetInputPort("u_h").FixValue(context, np.zeros(6))
    blender.GetInputPort("belief").FixValue(context, [0.1, 0.1, 0.6, 0.1, 0.1])  # above rho2 = 0.28
    blender.GetInputPort("u_a").FixValue(context, u_a.ravel())
    u = blender.GetOutputPort("u").Eval(context)
    alpha = blender.GetOutputPort("alpha").Eval(context)[0]
    if assist:
        assert alpha == pytest.approx(0.7)
        np.testing.assert_allclose(u, 0.7 * u_a[2], rtol=1e-12)
    else:
        assert alpha == 0.0 and not np.any(u)


def test_bad_assist_without_input_names_the_field_and_the_value() -> None:
    s = load_scenario("reaching")
    s.blending.assist_without_input = "yes"  # type: ignore[assignment]
    with pytest.raises(ValueError, match=r"scenario\.blending\.assist_without_input: expected .*got 'yes'"):
        resolve_scenario(s)


# ------------------------------------------------------------------------------------------------
# inference.goal_set: task (paper) | stage
# ------------------------------------------------------------------------------------------------


def _pouring(goal_set: str, goals: tuple[int, int] = (1, 0)) -> Scenario:
    s = load_scenario("pouring")
    s.inference.goal_set = goal_set
    s.user.goals = list(goals)
    return s


def test_task_goal_set_is_one_belief_over_every_goal_of_the_pouring_task() -> None:
    s = _pouring("task")
    config = resolve_scenario(s)
    assert config.n_goals == 4 and s.n_goals == 4
    assert [g.name for g in s.belief_goals(1)] == [g.name for g in s.goals]
    assert config.rhos[:2] == pytest.approx((1.2 / 4, 1.4 / 4))  # the paper's rho for n_g = 4
    # The user's intended goals (container_left, then platform_low) as belief slots.
    assert config.user_goals == (1, 2)
    handles = build_shared_control_diagram(s)
    context = handles.diagram.CreateDefaultContext()
    handles.initialize(context)
    task = handles.systems["task"]
    # Every consumer sees the 4 goals, whatever the stage; the task manager completes a stage only at
    # one of that stage's 2 goals.
    for name in ("inference", "autonomy", "blender", "interface", "user"):
        port = handles.systems[name].GetInputPort("goal_poses" if name != "blender" else "belief")
        assert port.size() == (4 * 7 if name != "blender" else 4), name
    goal_poses = handles.systems["inference"].GetInputPort("goal_poses")
    inference_context = handles.systems["inference"].GetMyContextFromRoot(context)
    np.testing.assert_allclose(goal_poses.Eval(inference_context), s.belief_goal_poses(0).ravel())
    assert task.n_goals == 2
    assert handles.systems["user"].goal_indices == (1, 2)


def test_stage_goal_set_is_two_goals_per_stage() -> None:
    s = _pouring("stage")
    config = resolve_scenario(s)
    assert config.n_goals == 2 and config.user_goals == (1, 0)
    assert config.rhos[:2] == pytest.approx((0.6, 0.7))
    handles = build_shared_control_diagram(s)
    assert handles.systems["inference"].GetInputPort("goal_poses").size() == 2 * 7
    assert "task_goal_poses" not in [system.get_name() for system in handles.diagram.GetSystems()]


def test_bad_goal_set_names_the_field_and_the_value() -> None:
    s = _pouring("all")
    with pytest.raises(
        ValueError, match=r"scenario\.inference\.goal_set: expected one of stage, task, got 'all'"
    ):
        resolve_scenario(s)


# ------------------------------------------------------------------------------------------------
# disambiguation.upsilon_normalization: unit_probe (paper) | displacement | none
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("preset", "value", "expected"),
    [
        ("mico", None, "unit_probe"),
        ("authors-r3", None, "none"),
        ("mico", "displacement", "displacement"),
        ("authors-r3", "unit_probe", "unit_probe"),
    ],
)
def test_upsilon_normalization_reaches_the_projection(preset: str, value: str | None, expected: str) -> None:
    s = load_scenario("reaching")
    s.disambiguation.preset = preset
    s.disambiguation.upsilon_normalization = value
    assert resolve_scenario(s).disambiguation.upsilon_normalization == expected


def test_unit_probe_upsilon_weighs_every_dimension_alike() -> None:
    """The paper's probe is the unit velocity e_k: dividing by its displacement over t_c - t_b scales
    every dimension alike, so translations and rotations keep their ratio from the undivided form;
    dividing by our probe's displacement (0.1 m, 0.2 rad) favours translations twice over."""
    s = load_scenario("reaching")
    config = resolve_scenario(s).disambiguation
    goals = s.belief_goal_poses(0)
    kw = {"orientation": [1.0, 0.0, 0.0, 0.0], "goal_orientations": goals[:, 3:]}
    args = ([0.3, 0.2, 0.2, 0.2, 0.1], [0.0, -0.4, 0.3], goals[:, :3], [[k] for k in range(6)])

    def ups(value: str) -> np.ndarray:
        cfg = dataclasses.replace(config, upsilon_normalization=value)
        return disambiguate(*args, cfg, **kw).features["upsilon"].sum(axis=0)

    unit, displaced, none = ups("unit_probe"), ups("displacement"), ups("none")
    np.testing.assert_allclose(unit, none * 1.0, rtol=1e-12)  # t_c - t_b = 1 s
    np.testing.assert_allclose(displaced, none / [0.1, 0.1, 0.1, 0.2, 0.2, 0.2], rtol=1e-9)


def test_bad_upsilon_normalization_names_the_field_and_the_value() -> None:
    s = load_scenario("reaching")
    s.disambiguation.upsilon_normalization = "metres"
    with pytest.raises(
        ValueError,
        match=r"scenario\.disambiguation\.upsilon_normalization: expected one of unit_probe, displacement, "
        r"none, got 'metres'",
    ):
        resolve_scenario(s)
