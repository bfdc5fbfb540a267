"""Algorithm 1 core (drake_disamb.core.disambiguation) against a slow loop-by-loop reference."""

from __future__ import annotations

import dataclasses
import itertools
import zlib

import numpy as np
import pytest
from support import integrate_pose

from drake_disamb.core.autonomy import potential_field_commands
from drake_disamb.core.disambiguation import (
    MICO_DFT,
    DisambiguationConfig,
    DisambiguationResult,
    authors_r3_config,
    disambiguate,
    mico_config,
    preset,
    select_mode,
)
from drake_disamb.core.geometry import orientation_error, quat_from_rotvec
from drake_disamb.core.inference import (
    BayesInference,
    DFTInference,
    MemoryInference,
    bayes_step,
    dft_euler_step,
)

HEAD_ARRAY_MODES = [[0], [1], [2], [3], [4], [5]]
JOYSTICK_MODES = [[0, 1], [0, 2], [3, 5], [4]]
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


# ----------------------------------------------------------------------------------------------
# Slow reference: one probe, one step, one goal pair at a time, written from the paper (Algorithm 1).
# ----------------------------------------------------------------------------------------------


def _reference(belief, position, orientation, goals, goal_quats, modes, cfg: DisambiguationConfig, current):  # type: ignore[no-untyped-def]
    n = len(goals)
    nb = round(cfg.t_b / cfg.delta_t)
    nc = round(cfg.t_c / cfg.delta_t)
    feats = {name: np.zeros((2, len(cfg.dimensions))) for name in ("gamma", "omega", "lambda", "upsilon")}
    D = np.zeros((2, len(cfg.dimensions)))
    for col, k in enumerate(cfg.dimensions):
        for row, sign in enumerate((1.0, -1.0)):
            u = np.zeros(6)
            u[k] = sign * (cfg.probe_speed_translation if k < 3 else cfg.probe_speed_rotation)
            p = np.array(belief, dtype=float)
            x = np.array(position, dtype=float)
            q = np.array(orientation, dtype=float)
            history = []
            for _ in range(nc):
                if isinstance(cfg.inference, DFTInference):
                    dft = cfg.inference.params
                    ua = potential_field_commands(x, q, goals, goal_quats, cfg.potential_field)
                    p = dft_euler_step(p, u, x, goals, dft, cfg.delta_t, ua if dft.agreement else None)
                else:
                    p = bayes_step(p, u, x, goals, cfg.inference.transition, cfg.inference.sigma)
                x, q = integrate_pose(x, q, u, cfg.delta_t)
                history.append((p.copy(), x.copy(), q.copy()))
            p_b, x_b, q_b = history[nb - 1]
            p_c, x_c, q_c = history[nc - 1]
            ordered = sorted(p_b.tolist(), reverse=True)
            gamma = ordered[0]
            omega = ordered[0] - (ordered[1] if n > 1 else 0.0)
            lam = sum(abs(p_b[i] - p_b[j]) for i in range(n) for j in range(i + 1, n))
            if k < 3:
                disp = x_c[k] - x_b[k]
            else:
                disp = orientation_error(q_b, q_c)[k - 3]
            divisor = {"displacement": abs(disp), "unit_probe": cfg.t_c - cfg.t_b, "none": 1.0}
            grad = (p_c - p_b) / divisor[cfg.upsilon_normalization]
            ups = sum(abs(grad[i] - grad[j]) for i in range(n) for j in range(i + 1, n))
            for name, value in zip(
                ("gamma", "omega", "lambda", "upsilon"), (gamma, omega, lam, ups), strict=True
            ):
                feats[name][row, col] = value
            D[row, col] = cfg.w * gamma * lam * omega + (1 - cfg.w) * ups
    D_k = D[0] + D[1]
    D_m = np.array([sum(D_k[cfg.dimensions.index(k)] for k in m if k in cfg.dimensions) for m in modes])
    top = D_m.max()
    equal = [abs(top - d) <= cfg.tie_tolerance * top for d in D_m]
    if all(equal) or (current is not None and current < len(modes) and equal[current]):
        mode = None
    else:
        mode = equal.index(True)
    return mode, D, D_m, feats


def _random_scene(rng: np.random.Generator, n: int):  # type: ignore[no-untyped-def]
    belief = rng.dirichlet(np.ones(n))
    position = rng.uniform(-0.3, 0.3, 3)
    orientation = quat_from_rotvec(rng.normal(scale=0.8, size=3))
    goals = position + rng.uniform(-0.4, 0.4, (n, 3))
    goal_quats = quat_from_rotvec(rng.normal(scale=0.8, size=(n, 3)))
    return belief, position, orientation, goals, goal_quats


@pytest.mark.parametrize(
    "name", ["mico", "authors-r3", "mico-bayes", "mico-undivided", "mico-displacement", "mico-cosine"]
)
def test_vectorised_core_matches_loop_reference(name: str) -> None:
    rng = np.random.default_rng(zlib.crc32(name.encode()))  # str hash() changes per process
    for trial in range(6):
        n = (1, 2, 3, 5, 4, 7)[trial]
        belief, position, orientation, goals, goal_quats = _random_scene(rng, n)
        if name == "authors-r3":
            P = np.eye(n) + rng.uniform(0, 0.01, (n, n))
            cfg = preset("authors-r3", transition=P / P.sum(axis=1, keepdims=True))
        elif name == "mico-bayes":
            cfg = mico_config(inference=BayesInference())
        elif name == "mico-undivided":
            cfg = mico_config(upsilon_normalization="none", w=0.3)
        elif name == "mico-displacement":
            cfg = mico_config(upsilon_normalization="displacement", t_c=2.5)
        elif name == "mico-cosine":
            cfg = mico_config(
                inference=DFTInference(dataclasses.replace(MICO_DFT, agreement_measure="cosine"))
            )
        else:
            cfg = preset("mico")
        modes = HEAD_ARRAY_MODES if trial % 2 else JOYSTICK_MODES
        current = int(rng.integers(0, len(modes) + 1))
        res = disambiguate(
            belief, position, goals, modes, cfg, orientation=orientation, goal_orientations=goal_quats,
            current_mode=current,
        )  # fmt: skip
        mode, D, D_m, feats = _reference(
            belief, position, orientation, goals, goal_quats, modes, cfg, current
        )
        np.testing.assert_allclose(res.scores_plus, D[0], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(res.scores_minus, D[1], rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(res.mode_scores, D_m, rtol=1e-9, atol=1e-9)
        for key, value in feats.items():
            np.testing.assert_allclose(res.features[key], value, rtol=1e-9, atol=1e-9, err_msg=key)
        assert res.mode == mode
        # The scores must carry information (guards against a reference and core that both return 0).
        if n > 1:
            assert res.mode_scores.max() > 1e-6


# ----------------------------------------------------------------------------------------------
# Scenes
# ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("cfg", [preset("mico"), preset("authors-r3")], ids=["mico", "authors-r3"])
def test_goals_differing_along_y_choose_a_mode_with_y(cfg: DisambiguationConfig) -> None:
    goals = np.array([[0.2, -0.25, 0.1], [0.2, 0.25, 0.1]])
    for modes in (HEAD_ARRAY_MODES, JOYSTICK_MODES, [[0], [2], [1, 4], [3]]):
        for current in range(len(modes) + 1):  # the last one is the gripper mode
            res = disambiguate([0.5, 0.5], [0.0, 0.0, 0.1], goals, modes, cfg, current_mode=current)
            effective = current if res.mode is None else res.mode
            assert effective < len(modes) and 1 in modes[effective], (modes, current, res.mode_scores)
            assert res.dimension == 1
            assert 1 in modes[res.best_mode]


def test_goals_differing_only_in_orientation_choose_a_rotational_mode() -> None:
    goals = np.array([[0.3, -0.3, 0.2], [0.3, -0.3, 0.2]])
    goal_quats = quat_from_rotvec([[0.0, 0.0, 0.6], [0.0, 0.0, -0.6]])
    res = disambiguate([0.5, 0.5], [0.0, -0.3, 0.2], goals, HEAD_ARRAY_MODES, goal_orientations=goal_quats)
    assert res.mode == 5, res.explain()  # wz: the axis the two goal orientations differ about
    res = disambiguate([0.5, 0.5], [0.0, -0.3, 0.2], goals, JOYSTICK_MODES, goal_orientations=goal_quats)
    assert res.mode == 2  # {wx, wz}
    # Without the agreement term nothing can tell them apart: the current mode is kept.
    cfg = mico_config(inference=DFTInference(dataclasses.replace(MICO_DFT, agreement=False)))
    res = disambiguate(
        [0.5, 0.5], [0.0, -0.3, 0.2], goals, HEAD_ARRAY_MODES, cfg, goal_orientations=goal_quats
    )
    assert res.mode is None


def _octahedron_scene():  # type: ignore[no-untyped-def]
    """Goals on +-axes, each rotated about its own axis: invariant under the cyclic x->y->z map."""
    a = 0.25
    goals = np.array([[a, 0, 0], [0, a, 0], [0, 0, a], [-a, 0, 0], [0, -a, 0], [0, 0, -a]])
    quats = quat_from_rotvec(np.sign(goals.sum(axis=1, keepdims=True)) * goals / a * 0.5)
    return goals, quats


@pytest.mark.parametrize("name", ["mico", "authors-r3"])
def test_scene_symmetric_in_every_dimension_keeps_the_current_mode(name: str) -> None:
    goals, quats = _octahedron_scene()
    if name == "mico":
        modes = [[0, 3], [1, 4], [2, 5]]
        res = disambiguate(np.full(6, 1 / 6), [0, 0, 0], goals, modes, preset(name), goal_orientations=quats,
                           current_mode=1)  # fmt: skip
    else:
        modes = [[0], [1], [2]]
        res = disambiguate(np.full(6, 1 / 6), [0, 0, 0], goals, modes, preset(name), current_mode=1)
    assert res.mode is None
    assert res.mode_scores.max() > 0  # symmetric, not trivially zero
    np.testing.assert_allclose(res.mode_scores, res.mode_scores[0], rtol=1e-9)
    # Breaking the symmetry (one goal moved along z) makes the modes differ: from the worst one,
    # the algorithm switches.
    moved = goals.copy()
    moved[2, 2] += 0.1
    res2 = disambiguate(np.full(6, 1 / 6), [0, 0, 0], moved, [[0], [1], [2]], preset(name))
    worst = int(np.argmin(res2.mode_scores))
    assert res2.mode_scores[worst] < res2.mode_scores.max() * (1 - 1e-3)
    res3 = disambiguate(
        np.full(6, 1 / 6), [0, 0, 0], moved, [[0], [1], [2]], preset(name), current_mode=worst
    )
    assert res3.mode is not None and res3.mode != worst


@pytest.mark.parametrize("name", ["mico", "authors-r3"])
def test_permuting_goals_changes_nothing(name: str) -> None:
    rng = np.random.default_rng(7)
    belief, position, orientation, goals, goal_quats = _random_scene(rng, 5)
    res = disambiguate(belief, position, goals, HEAD_ARRAY_MODES, preset(name), orientation=orientation,
                       goal_orientations=goal_quats, current_mode=2)  # fmt: skip
    for perm in itertools.islice(itertools.permutations(range(5)), 1, None, 17):
        perm = list(perm)
        kw = {"orientation": orientation, "goal_orientations": goal_quats[perm], "current_mode": 2}
        other = disambiguate(belief[perm], position, goals[perm], HEAD_ARRAY_MODES, preset(name), **kw)
        assert other.mode == res.mode
        np.testing.assert_allclose(other.mode_scores, res.mode_scores, rtol=1e-12, atol=1e-15)
        for key in res.features:
            np.testing.assert_allclose(other.features[key], res.features[key], rtol=1e-12, atol=1e-15)


def _assert_valid(res: DisambiguationResult, n_modes: int) -> None:
    for arr in (res.scores_plus, res.scores_minus, res.mode_scores, *res.features.values()):
        assert np.all(np.isfinite(arr)) and np.all(arr >= 0)
    assert res.mode is None or 0 <= res.mode < n_modes
    assert isinstance(res.explain(), str) and res.explain()


@pytest.mark.parametrize("name", ["mico", "authors-r3"])
def test_degenerate_scenes_give_valid_answers(name: str) -> None:
    cfg = preset(name)
    goals = np.array([[0.3, 0.0, 0.0], [0.0, 0.3, 0.0], [0.0, 0.0, 0.3]])
    # Certain belief, with exact zeros.
    res = disambiguate([1.0, 0.0, 0.0], [0, 0, 0], goals, HEAD_ARRAY_MODES, cfg, current_mode=0)
    _assert_valid(res, 6)
    # One goal: nothing to disambiguate; the current mode is kept.
    res = disambiguate([1.0], [0, 0, 0], goals[:1], HEAD_ARRAY_MODES, cfg, current_mode=3)
    _assert_valid(res, 6)
    assert res.mode is None and np.all(res.mode_scores == 0)
    # Every goal exactly at the robot.
    at_robot = np.zeros((3, 3))
    res = disambiguate(np.full(3, 1 / 3), [0, 0, 0], at_robot, HEAD_ARRAY_MODES, cfg, current_mode=1)
    _assert_valid(res, 6)
    # One goal at the robot, others away.
    mixed = goals.copy()
    mixed[0] = [0.0, 0.0, 0.0]
    res = disambiguate(np.full(3, 1 / 3), [0, 0, 0], mixed, HEAD_ARRAY_MODES, cfg)
    _assert_valid(res, 6)


def test_dimensions_outside_the_preset_score_zero() -> None:
    goals = np.array([[0.3, 0.0, 0.0], [-0.3, 0.0, 0.0]])
    res = disambiguate(
        [0.5, 0.5], [0, 0, 0], goals, [[3], [0, 3], [4, 5]], preset("authors-r3"), current_mode=2
    )
    assert res.dimensions == (0, 1, 2)
    assert res.mode_scores[0] == 0.0 and res.mode_scores[2] == 0.0
    assert res.mode == 1


def test_partial_tie_keeps_current_mode_if_among_best() -> None:
    goals = np.array([[0.3, 0.3, 0.0], [-0.3, -0.3, 0.0]])  # x and y equally informative
    res = disambiguate([0.5, 0.5], [0, 0, 0], goals, [[2], [0], [1]], preset("authors-r3"), current_mode=2)
    assert res.mode is None and res.best_mode in (1, 2)
    res = disambiguate([0.5, 0.5], [0, 0, 0], goals, [[2], [0], [1]], preset("authors-r3"), current_mode=0)
    assert res.mode == 1


def test_upsilon_normalizations() -> None:
    """The paper's unit probe divides every dimension by t_c - t_b; ours by the probe's own
    displacement (m or rad); the authors' code not at all."""
    rng = np.random.default_rng(3)
    belief, position, orientation, goals, goal_quats = _random_scene(rng, 4)
    kw = {"orientation": orientation, "goal_orientations": goal_quats}

    def upsilon(normalization: str, **overrides: float) -> np.ndarray:
        cfg = mico_config(upsilon_normalization=normalization, **overrides)
        return disambiguate(belief, position, goals, HEAD_ARRAY_MODES, cfg, **kw).features["upsilon"]

    none = upsilon("none")
    assert np.all(none > 0)
    # Displacement between t_b and t_c: 0.1 m (translation) and 0.2 rad (rotation).
    scale = np.array([0.1, 0.1, 0.1, 0.2, 0.2, 0.2])
    np.testing.assert_allclose(upsilon("displacement") * scale, none, rtol=1e-9)
    # The paper's unit probe: t_c - t_b = 1 s here, so the same numbers as the authors' code ...
    np.testing.assert_allclose(upsilon("unit_probe"), none, rtol=1e-12)
    # ... and with t_c - t_b = 1.5 s, 1.5 units for every dimension (no unit enters).
    np.testing.assert_allclose(upsilon("unit_probe", t_c=2.5) * 1.5, upsilon("none", t_c=2.5), rtol=1e-12)
    assert mico_config().upsilon_normalization == "unit_probe"  # the paper's by default
    with pytest.raises(ValueError, match=r"upsilon_normalization: expected one of .*got 'metres'"):
        mico_config(upsilon_normalization="metres")


def test_result_to_dict_and_explain() -> None:
    goals = np.array([[0.2, -0.25, 0.1], [0.2, 0.25, 0.1]])
    res = disambiguate([0.5, 0.5], [0.0, 0.0, 0.1], goals, HEAD_ARRAY_MODES, current_mode=0)
    d = res.to_dict()
    assert d["mode"] == 1 and len(d["dimension_scores"]["plus"]) == 6 and len(d["mode_scores"]) == 6
    assert set(d["features"]) == {"gamma", "omega", "lambda", "upsilon"}
    text = res.explain()
    assert "mode 1 {vy}" in text and "k* = vy" in text


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"belief": [0.5, 0.6]}, "belief"),
        ({"belief": [0.5, 0.5, 0.0]}, "belief"),
        ({"position": [0.0, 0.0]}, "position"),
        ({"goals": [[0.0, 0.0, np.nan], [1, 0, 0]]}, "goal_positions"),
        ({"modes": [[0], [7]]}, r"modes\[1\]"),
        ({"modes": []}, "modes"),
        ({"orientation": [0.0, 0.0, 0.0, 0.0]}, "orientation"),
        ({"orientation": [1e200, 0.0, 0.0, 0.0]}, "orientation: a quaternion's norm overflows"),
        ({"goal_orientations": [IDENTITY]}, "goal_orientations"),
        ({"goal_orientations": [IDENTITY, [0.0, 1e155, 0.0, 0.0]]}, "goal_orientations: .* overflows"),
        ({"position": [0.0, 1000.5, 0.0]}, r"position: expected coordinates within \+/-1000 m"),
        ({"goals": [[0.3, 0, 0], [0, 0, -1e300]]}, r"goal_positions\[1\]: expected coordinates within"),
        ({"goals": np.zeros((101, 3)), "belief": np.full(101, 1 / 101)}, r"n <= 100 \(MAX_GOALS\)"),
        ({"belief": [10**400, 0]}, "belief: expected an array of numbers"),
        ({"current_mode": -1}, "current_mode"),
        ({"config": preset("authors-r3", transition=np.eye(3))}, "transition"),
    ],
)
def test_bad_requests_raise_value_error(kwargs: dict, message: str) -> None:
    args = {
        "belief": [0.5, 0.5],
        "position": [0, 0, 0],
        "goals": [[0.3, 0, 0], [-0.3, 0, 0]],
        "modes": [[0], [1]],
    }
    args.update({k: kwargs[k] for k in ("belief", "position", "goals", "modes") if k in kwargs})
    extra = {k: v for k, v in kwargs.items() if k not in args}
    with pytest.raises(ValueError, match=message):
        disambiguate(args["belief"], args["position"], args["goals"], args["modes"], **extra)


@pytest.mark.parametrize(
    ("overrides", "message"),
    [
        ({"dimensions": (0, 0)}, "dimensions"),
        ({"dimensions": (6,)}, "dimensions"),
        ({"t_b": 1.05}, "t_b"),
        ({"t_c": 1.0}, "t_c"),
        ({"w": 1.5}, r"\.w"),
        ({"delta_t": 0.0}, "delta_t"),
        (
            {"inference": MemoryInference()},
            r"inference: expected an inference method with a forward projection \(dft, bayes\)",
        ),
        ({"tie_tolerance": -1.0}, "tie_tolerance"),
        ({"probe_speed_rotation": 4.0}, "probe_speed_rotation"),
    ],
)
def test_config_validation(overrides: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        mico_config(**overrides)


def test_presets() -> None:
    r3 = authors_r3_config()
    assert r3.dimensions == (0, 1, 2) and r3.probe_speed_translation == 0.2
    assert r3.upsilon_normalization == "none"
    dft = r3.inference.params
    assert (dft.tau1, dft.tau2, dft.lam) == (10.0, 10.0, 200.0)
    assert dft.directedness and not dft.agreement and not dft.proximity
    assert (r3.steps_b, r3.steps_c, r3.w) == (10, 20, 0.5)
    assert preset("mico") == DisambiguationConfig()
    for name in ("mico", "authors-r3"):
        with pytest.raises(ValueError, match="transition"):
            preset(name, transition=[[0.5, 0.5], [0.0, 0.9]])
    with pytest.raises(ValueError, match="BayesInference.transition"):
        mico_config(inference=BayesInference()).with_transition([[0.5, 0.5], [0.0, 0.9]])
    with pytest.raises(ValueError, match="preset"):
        preset("nope")


# ----------------------------------------------------------------------------------------------
# Caches and the scene-independent probe plan
# ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["mico", "authors-r3"])
def test_probe_plan_displacement_matches_integrated_poses(name: str) -> None:
    """The cached displacements equal those of poses integrated step by step from any start pose."""
    from drake_disamb.core.disambiguation import forward_projection, make_request

    cfg = preset(name)
    rng = np.random.default_rng(11)
    belief, position, orientation, goals, goal_quats = _random_scene(rng, 3)
    request = make_request(
        belief, position, goals, [[0]], cfg, orientation=orientation, goal_orientations=goal_quats
    )
    proj = forward_projection(request)
    assert proj.displacement.shape == (2, len(cfg.dimensions))
    for col, k in enumerate(cfg.dimensions):
        for row, sign in enumerate((1.0, -1.0)):
            u = np.zeros(6)
            u[k] = sign * (cfg.probe_speed_translation if k < 3 else cfg.probe_speed_rotation)
            x, q = position, orientation
            poses = []
            for _ in range(cfg.steps_c):
                x, q = integrate_pose(x, q, u, cfg.delta_t)
                poses.append((x, q))
            (x_b, q_b), (x_c, q_c) = poses[cfg.steps_b - 1], poses[cfg.steps_c - 1]
            expected = x_c[k] - x_b[k] if k < 3 else orientation_error(q_b, q_c)[k - 3]
            assert proj.displacement[row, col] == pytest.approx(expected, rel=1e-12, abs=1e-15)
    proj.displacement[:] = 0.0  # a copy: the cached plan is untouched
    again = forward_projection(request)
    assert np.all(np.abs(again.displacement) > 0)


def test_cached_mode_validation_still_rejects_bad_modes() -> None:
    from drake_disamb.core.disambiguation import validate_modes

    assert validate_modes([[0, 1], (2,)]) == ((0, 1), (2,))
    assert validate_modes([[np.int64(3)], [4]]) == ((3,), (4,))  # numpy ints: the general path
    for bad, match in (
        ([[True]], r"modes\[0\]"),
        ([[0], [0, 0]], r"modes\[1\]: repeated"),
        ([[6]], r"modes\[0\]"),
        ([[0], "ab"], r"modes\[1\]"),
        ([], "modes"),
        ("01", "modes"),
    ):
        for _ in range(2):  # a failed validation is never cached
            with pytest.raises(ValueError, match=match):
                validate_modes(bad)
    assert validate_modes([[1]]) == ((1,),)
    with pytest.raises(ValueError, match=r"modes\[0\]"):
        validate_modes([[1.0]])  # a float that equals a cached int key must not pass


def test_repeated_requests_give_identical_results() -> None:
    """Caches (plan, modes, membership) make no difference to the result."""
    rng = np.random.default_rng(12)
    belief, position, orientation, goals, goal_quats = _random_scene(rng, 4)
    kw = {"orientation": orientation, "goal_orientations": goal_quats, "current_mode": 1}
    first = disambiguate(belief, position, goals, JOYSTICK_MODES, preset("mico"), **kw)
    first.mode_scores[:] = -1.0  # results are the caller's to change
    for modes in (JOYSTICK_MODES, tuple(tuple(m) for m in JOYSTICK_MODES)):
        again = disambiguate(belief, position, goals, modes, mico_config(), **kw)
        ref = _reference(belief, position, orientation, goals, goal_quats, JOYSTICK_MODES, mico_config(), 1)
        np.testing.assert_allclose(again.mode_scores, ref[2], rtol=1e-9, atol=1e-9)
        assert again.modes == tuple(tuple(m) for m in JOYSTICK_MODES)


def test_near_ties_go_to_the_first_of_the_equally_best_modes() -> None:
    # Modes 0 and 1 within 1e-3 (relative) of each other: equally best, so mode 0 (the first),
    # although mode 1 scores a little higher; the current mode is kept when it is one of them.
    scores = np.array([2.28189848, 2.28278605, 1.59616141])
    assert select_mode(scores, current_mode=2, tie_tolerance=1e-3) == (0, 1)
    assert select_mode(scores, current_mode=None, tie_tolerance=1e-3) == (0, 1)
    assert select_mode(scores, current_mode=1, tie_tolerance=1e-3) == (None, 1)
    assert select_mode(scores, current_mode=2, tie_tolerance=1e-5) == (1, 1)  # no longer tied
    assert select_mode(np.array([1.0, 1.0, 1.0]), current_mode=0, tie_tolerance=1e-3) == (None, 0)


def test_explain_names_a_near_tie() -> None:
    belief, position, orientation, goals, goal_quats = _random_scene(np.random.default_rng(3), 3)
    res = disambiguate(
        belief, position, goals, HEAD_ARRAY_MODES, preset("mico"), orientation=orientation,
        goal_orientations=goal_quats,
    )  # fmt: skip
    scores = np.array([2.2819, 2.2828, 1.5962, 1.2301, 1.0939, 0.8483])[: len(HEAD_ARRAY_MODES)]
    mode, best = select_mode(scores, None, res.tie_tolerance)
    tied = dataclasses.replace(res, mode_scores=scores, mode=mode, best_mode=best)
    assert (mode, best) == (0, 1)
    text = tied.explain()
    assert "ties with mode 1" in text and "the first of the equally best modes wins" in text


@pytest.mark.parametrize("n", [1, 2, 5, 50])
def test_pairwise_spread_by_sorting_equals_the_sum_over_all_pairs(n: int) -> None:
    from drake_disamb.core.disambiguation.algorithm1 import _pairwise_abs_sum

    rng = np.random.default_rng(n)
    a = rng.normal(size=(2, 3, n))
    brute = np.array(
        [[sum(abs(x[i] - x[j]) for i, j in itertools.combinations(range(n), 2)) for x in row] for row in a]
    )
    np.testing.assert_allclose(_pairwise_abs_sum(a), brute, rtol=1e-12, atol=1e-15)
    assert np.all(_pairwise_abs_sum(np.full((4, n), 1.0 / n)) == 0.0)  # uniform: exactly no spread
