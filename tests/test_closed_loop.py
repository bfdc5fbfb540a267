"""The full shared-control loop on the simulated MICO: both interfaces, every reaching goal, every pouring
(container, location) combination.

Each trial stops at success, so a passing run costs only the simulated time it needs.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest
from pydrake.systems.framework import LeafSystem

from drake_disamb.builder import build_shared_control_diagram
from drake_disamb.config import load_scenario
from drake_disamb.core.geometry import quat_to_matrix
from drake_disamb.trial import TrialResult, run_trial


@functools.cache
def _reaching(interface: str, goal: int, agreement: str | None = None) -> TrialResult:
    scenario = load_scenario("reaching", {"interface": interface, "user": {"goals": [goal]}})
    if agreement is not None:
        scenario.inference.agreement = agreement
    return run_trial(scenario, progress=False)


@pytest.mark.slow
@pytest.mark.parametrize("interface", ["head_array", "joystick"])
@pytest.mark.parametrize("goal", [0, 1, 2, 3, 4])
def test_reaching_every_goal(interface: str, goal: int) -> None:
    r = _reaching(interface, goal)
    assert r.success, f"{interface} goal {goal}: reached {r.reached_goals} at t={r.time:.1f}"
    assert r.time <= 60.0
    assert r.reached_goals == [goal]
    t, belief = r.logs["belief"]
    np.testing.assert_allclose(belief.sum(axis=1), 1.0, atol=1e-6)
    # The belief's argmax settles on the intended goal before arrival (arrival = end - hold time).
    arrival = r.stage_times[0] - r.scenario.hold_time(0)
    settled = t >= arrival - 0.5
    assert np.all(np.argmax(belief[settled], axis=1) == goal)
    # The autonomy helped on the way.
    _, alpha = r.logs["alpha"]
    assert np.max(alpha) > 0.0
    assert r.requests >= 1  # disambiguation paradigm: the simulated user asks at the start
    assert r.button_presses == r.requests + r.mode_switches


def test_request_switches_to_m_star_within_one_control_period() -> None:
    # The cosine agreement term (the default): at the start pose it makes Algorithm 1 pick a
    # rotation, so the first request switches away from the initial mode (vx).
    r = _reaching("head_array", 0, "cosine")
    period = r.scenario.control_period
    requests = [e for e in r.events if e.kind == "disambiguation_request"]
    switches = [e for e in r.events if e.kind == "disambiguation_switch"]
    assert requests and switches
    first = switches[0]
    assert any(abs(first.time - q.time) <= period + 1e-9 for q in requests)
    t, mode = r.logs["mode"]
    after = np.flatnonzero(t >= first.time + period - 1e-9)[0]
    assert int(mode[after, 0]) == first.to_mode != first.from_mode


def test_first_request_keeps_vx_with_the_papers_agreement_term() -> None:
    """With the paper's dot-product agreement term the rotations barely move the projected belief
    at the start pose: m* is a translation, the initial mode vx, which is kept."""
    r = _reaching("head_array", 0, "dot")
    assert r.scenario.inference.agreement == "dot"
    requests = [e for e in r.events if e.kind == "disambiguation_request"]
    assert requests and requests[0].time < 0.1 and requests[0].from_mode == 0
    assert not [
        e for e in r.events if e.kind == "disambiguation_switch" and e.time <= requests[0].time + 0.02
    ]
    t, mode = r.logs["mode"]
    assert int(mode[np.flatnonzero(t >= requests[0].time + 0.02)[0], 0]) == 0


def test_manual_paradigm_has_no_requests() -> None:
    scenario = load_scenario(
        "reaching", {"interface": "joystick", "paradigm": "manual", "user": {"goals": [3]}}
    )
    r = run_trial(scenario, progress=False)
    assert r.success and r.requests == 0 and r.button_presses == r.mode_switches
    assert "disambiguation" not in build_shared_control_diagram(scenario).systems


@functools.cache
def _pouring(interface: str, goals: tuple[int, int], goal_set: str = "stage") -> TrialResult:
    scenario = load_scenario("pouring", {"interface": interface, "user": {"goals": list(goals)}})
    scenario.inference.goal_set = goal_set
    return run_trial(scenario, progress=False)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("interface", "goals", "goal_set"),
    [
        ("head_array", (0, 0), "stage"),
        ("joystick", (0, 0), "stage"),
        ("head_array", (0, 1), "stage"),
        # With one belief over the 4 goals (the paper's) the arm takes another way and arrives ...
        ("head_array", (1, 0), "task"),
        # ... with a belief over each stage's 2 goals (the default) the elbow (joint 3) reaches
        # its limit on the way, where -z, +x and +y all need it further (the IK stops there, as it
        # must): the user backs off and routes around (UserConfig.backoff_after, backoff_time).
        ("head_array", (1, 0), "stage"),
        ("head_array", (1, 1), "stage"),
    ],
    ids=[
        "head_array-right-low",
        "joystick-right-low",
        "head_array-right-high",
        "head_array-left-low",
        "head_array-left-low-stage",
        "head_array-left-high",
    ],
)
def test_pouring_every_combination(interface: str, goals: tuple[int, int], goal_set: str) -> None:
    """Both stages at the intended (container, location) within the 60 s limit."""
    r = _pouring(interface, goals, goal_set)
    assert np.all(np.isfinite(r.stage_times)), f"{interface} {goals}: stage times {r.stage_times}"
    assert r.success and r.reached_goals == list(goals), f"{interface} {goals}: reached {r.reached_goals}"
    assert r.time <= 60.0
    # The pour was held for its stage's hold time before the goal set switched.
    assert r.stage_times[0] >= r.scenario.hold_time(0)
    _, belief = r.logs["belief"]
    np.testing.assert_allclose(belief.sum(axis=1), 1.0, atol=1e-6)


def test_pouring_completes_both_stages() -> None:
    r = _pouring("joystick", (0, 0))
    assert np.isfinite(r.stage_times[0]), "stage one (pour) not completed"
    assert r.success and r.reached_goals == [0, 0]
    # The cup is let go at its place: the trial ends in the gripper mode (the last), changed to
    # after the end effector got there, and the stage completed once the gripper opened.
    t, mode = r.logs["mode"]
    from drake_disamb.interfaces import gripper_mode

    grip = gripper_mode("joystick")
    assert mode[-1, 0] == grip
    entered = t[np.flatnonzero(mode[:, 0] != grip)[-1] + 1]
    assert r.stage_times[0] < entered < r.stage_times[1]


def test_pouring_task_goal_set_keeps_one_belief_over_the_four_goals() -> None:
    """The paper's study: one belief over the task's 4 goals, uniform at the start only."""
    r = _pouring("joystick", (0, 0), "task")
    assert r.scenario.inference.goal_set == "task" and r.success
    t, belief = r.logs["belief"]
    assert belief.shape[1] == 4
    np.testing.assert_allclose(belief[0], 0.25, atol=1e-9)
    # No reset at the stage change: the belief moves on continuously (at most a control step's
    # change between samples) ...
    k = np.flatnonzero(t > r.stage_times[0])[0]
    assert np.max(np.abs(belief[k] - belief[k - 1])) < 0.02
    # ... and ends on the intended placing location (goal 0 of stage 1 = slot 2).
    assert r.scenario.belief_slot(1, 0) == 2 and int(np.argmax(belief[-1])) == 2


def test_pouring_switches_goal_set_after_the_pour() -> None:
    r = _pouring("joystick", (0, 0), "stage")
    scenario = r.scenario
    assert r.reached_goals[0] == 0 and np.isfinite(r.stage_times[0])
    t, stage = r.logs["stage"]
    assert stage[0, 0] == 0 and np.any(stage[:, 0] == 1)
    # The inference resets to uniform over the placing goals when the goal set changes.
    _, belief = r.logs["belief"]
    k = np.flatnonzero(t > r.stage_times[0] + 2 * scenario.control_period)[0]
    np.testing.assert_allclose(belief[k], [0.5, 0.5], atol=0.05)
    # The cup stays rolled over the container for the pour's hold, then comes back upright.
    _, ee = r.logs["ee_pose"]
    cup_axis = quat_to_matrix(scenario.carried_object.orientation)[:, 2]
    upright = [float((quat_to_matrix(q) @ cup_axis)[2]) for q in ee[[0, k, -1], 3:]]
    assert upright[0] > 0.99 and upright[1] < 0.5 and upright[2] > 0.95


class _NaNSource(LeafSystem):
    """A raw-signal source (output ``raw``, 4) that presses ``left`` but sends NaN every other tick."""

    def __init__(self) -> None:
        super().__init__()
        self.DeclareVectorOutputPort("raw", 4, self._calc)

    def _calc(self, context, output) -> None:  # noqa: ANN001
        k = int(round(context.get_time() / 0.01))
        output.SetFromVector([np.nan, np.inf, 0.0, 0.0] if k % 2 else [1.0, 0.0, 0.0, 0.0])


def test_nan_input_never_reaches_the_arm() -> None:
    scenario = dataclasses.replace(load_scenario("reaching"), duration=1.0)
    handles = build_shared_control_diagram(scenario, input_source=_NaNSource())
    with pytest.warns(RuntimeWarning):
        r = run_trial(handles, progress=False, stop_at_success=False)
    for name in ("u_h", "u", "ee_pose", "belief"):
        assert np.all(np.isfinite(r.logs[name][1])), name
    _, ee = r.logs["ee_pose"]
    # The valid presses moved the arm (each one ramps up from the stop the NaN tick before caused).
    assert np.linalg.norm(ee[-1, :3] - ee[0, :3]) > 0.004


@pytest.mark.parametrize("method", ["bayes", "memory"])
def test_baseline_inference_methods_build_and_run(method: str) -> None:
    paradigm = "manual" if method == "memory" else "disambiguation"  # memory has no forward projection
    s = load_scenario("reaching", {"paradigm": paradigm})
    s = dataclasses.replace(s, inference=dataclasses.replace(s.inference, method=method), duration=0.5)
    r = run_trial(s, progress=False)
    _, belief = r.logs["belief"]
    assert type(build_shared_control_diagram(s).systems["inference"]).__name__.lower().find(method) >= 0
    np.testing.assert_allclose(belief.sum(axis=1), 1.0, atol=1e-9)


def test_unknown_names_and_bad_scenarios() -> None:
    with pytest.raises(ValueError, match="interface"):
        load_scenario("reaching", {"interface": "chin_switch"})
    with pytest.raises(ValueError, match="task"):
        load_scenario("knitting")
    s = load_scenario("reaching")
    goals = list(s.goals)
    goals[0] = dataclasses.replace(goals[0], position=[0.0, -0.35, 0.3])  # the gripper's start
    with pytest.raises(ValueError, match=r"scenario\.goals\[0\]\.position: goal 'red_box' is on top of"):
        build_shared_control_diagram(dataclasses.replace(s, goals=goals))


class _Untouchable:
    """Stands in for the scenario once it is resolved: any read of it fails."""

    def __getattr__(self, name: str) -> object:
        raise AssertionError(f"the builder read scenario.{name}, not the resolved config")


@pytest.mark.parametrize("paradigm", ["disambiguation", "automatic"])
def test_the_builder_reads_only_the_resolved_config(monkeypatch: pytest.MonkeyPatch, paradigm: str) -> None:
    """Once resolved, the scenario is only kept on the handle: every system, period, goal set, name
    and connection comes from the resolved config (here a 20 ms loop, a belief over the pouring
    task's four goals, the loop paused while a request is computed)."""
    from drake_disamb import builder as module
    from drake_disamb.config import resolve_scenario

    layer = {
        "control_period": 0.02,
        "plant_config": {"time_step": 0.02},
        "simulator_config": {"max_step_size": 0.02},
        "paradigm": paradigm,
        "inference": {"goal_set": "task"},
        "disambiguation": {"hold_while_computing": True},
    }
    config = resolve_scenario(load_scenario("pouring", layer))
    monkeypatch.setattr(module, "resolve_scenario", lambda scenario: config)
    scenario = _Untouchable()
    handles = build_shared_control_diagram(scenario)  # type: ignore[arg-type]
    assert handles.scenario is scenario and handles.config is config
    assert handles.goal_names(1) == ["platform_low", "platform_high"]
    assert handles.systems["user"].releases == (False, True)  # the place ends by letting go
    assert handles.diagram.get_name() == "shared_control_pouring"
    # Every system but the simulated user (its decision period: 0.1 s) ticks at 20 ms.
    discrete = (
        "task",
        "ee_pose_sampler",
        "autonomy",
        "blender",
        "disambiguation",
        "diff_ik",
        "gripper_controller",
    )
    ticks = {
        name: handles.systems[name].GetUniquePeriodicDiscreteUpdateAttribute().period_sec()
        for name in discrete
    }
    ticks["interface"] = handles.systems["interface"].config.control_period  # (unrestricted updates)
    ticks["inference"] = handles.systems["inference"].control_period
    assert ticks == dict.fromkeys(ticks, pytest.approx(0.02))
    source = handles.systems["task_goal_poses"]  # the belief's one goal set
    goal_set = source.GetOutputPort("goal_poses").Eval(source.CreateDefaultContext())
    np.testing.assert_array_equal(goal_set, config.task_goal_poses.ravel())
    connections = handles.diagram.connection_map()
    paused = handles.systems["interface"].GetOutputPort("paused")
    for name in ("inference", "blender", "user"):
        system = handles.systems[name]
        source = connections[(system, system.GetInputPort("paused").get_index())]
        assert source == (paused.get_system(), paused.get_index()), name
    assert ("automatic_trigger" in handles.systems) == (paradigm == "automatic")


def test_direct_mode_selection_reaches_with_fewer_mode_button_presses() -> None:
    # The same joystick trial (same seed), cycling vs direct selection: the simulated user reaches
    # its target modes in one press each instead of cycling through the modes on the way.
    results = {}
    for selection in ("cycle", "direct"):
        scenario = load_scenario("reaching", {"interface": "joystick", "user": {"goals": [1]}, "seed": 0})
        scenario.interface_mode_selection = selection
        scenario.duration = 20.0
        results[selection] = run_trial(scenario, progress=False)
    cycle, direct = results["cycle"], results["direct"]
    assert cycle.success and direct.success
    assert 0 < direct.mode_switches < cycle.mode_switches
