"""The typed YAML scenarios: embedded tasks, strict loading, validation, layers over a task."""

from __future__ import annotations

import copy
import math
import re
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

from drake_disamb.config import (
    MICO_REACH,
    MICO_SHOULDER_POSITION,
    Scenario,
    check_start_clearance,
    embedded_scenario_text,
    load_scenario,
    resolve_scenario,
    scenario_from_dict,
    scenario_from_yaml,
    scenario_to_dict,
)
from drake_disamb.core.geometry import orientation_error

STUDY_REACHING = [
    (0.328, -0.516, 0.100),
    (-0.116, -0.579, 0.132),
    (0.124, -0.531, 0.442),
    (-0.346, -0.389, 0.220),
    (-0.376, -0.180, 0.102),
]
STUDY_POURING = [
    (0.3314, -0.206, 0.100),
    (0.306, -0.550, 0.256),
    (-0.05, -0.627, 0.225),
    (-0.370, -0.555, 0.3955),
]


def _reaching_dict() -> dict:
    return yaml.safe_load(embedded_scenario_text("reaching"))


def test_reaching_has_the_study_goals_and_defaults() -> None:
    s = load_scenario("reaching")
    assert s.task == "reaching"
    assert s.interface == "head_array" and s.paradigm == "disambiguation"
    assert s.control_period == pytest.approx(0.01)
    assert s.duration == pytest.approx(60.0)
    assert s.success.position_tolerance == pytest.approx(0.02)
    assert s.success.orientation_tolerance == pytest.approx(0.15)
    assert s.n_stages == 1 and s.n_goals == 5
    np.testing.assert_allclose([g.position for g in s.goals], STUDY_REACHING)
    poses = s.stage_goal_poses(0)
    np.testing.assert_allclose(np.linalg.norm(poses[:, 3:], axis=1), 1.0)
    # Documented orientation: home (pointing down) leaned toward the object's azimuth; the red box's
    # lean points 10 degrees off it, toward the front (tasks/reaching.yaml says why).
    from drake_disamb.core.geometry import quat_to_matrix

    for pose, lean, off in zip(poses, [45, 35, 60, 25, 15], [10, 0, 0, 0, 0], strict=True):
        z_axis = quat_to_matrix(pose[3:])[:, 2]
        azimuth = math.atan2(pose[1], pose[0])
        assert math.degrees(math.acos(-z_axis[2])) == pytest.approx(lean, abs=0.1)
        lean_azimuth = math.degrees(math.atan2(z_axis[1], z_axis[0]))
        assert lean_azimuth == pytest.approx(round(math.degrees(azimuth)) + off, abs=0.6)


def test_pouring_has_two_stages_that_switch_goal_sets() -> None:
    s = load_scenario("pouring")
    assert s.n_stages == 2 and [len(s.stage_goals(k)) for k in range(2)] == [2, 2]
    assert [st.name for st in s.stages] == ["pour", "place"]
    pour = [tuple(g.position) for g in s.stage_goals(0)]
    place = [tuple(g.position) for g in s.stage_goals(1)]
    assert set(pour) == {STUDY_POURING[1], STUDY_POURING[3]}
    assert set(place) == {STUDY_POURING[0], STUDY_POURING[2]}
    assert s.carried_object is not None
    assert s.hold_time(0) == pytest.approx(1.0) and s.hold_time(1) == pytest.approx(s.success.hold_time)
    # the cup is let go at its place (the study's people ended pouring trials in the gripper mode)
    assert s.releases() == [False, True] and s.stages[1].release_opening == pytest.approx(0.10)
    # Side grasp: the cup's axis is the end-effector x axis; upright (x_E up) at the placing poses,
    # rolled about the horizontal approach axis (z_E) by 60-75 degrees at the pour poses.
    from drake_disamb.core.geometry import quat_to_matrix

    assert s.start_joint_positions is not None
    for pose in s.stage_goal_poses(1):
        R = quat_to_matrix(pose[3:])
        assert R[2, 0] == pytest.approx(1.0, abs=1e-3) and R[2, 2] == pytest.approx(0.0, abs=1e-3)
    for pose in s.stage_goal_poses(0):
        R = quat_to_matrix(pose[3:])
        assert R[2, 2] == pytest.approx(0.0, abs=1e-3)
        assert 59.9 <= math.degrees(math.acos(R[2, 0])) <= 75.1  # the cup tipped
    angle = np.linalg.norm(orientation_error(s.stage_goal_poses(0)[0, 3:], s.stage_goal_poses(0)[1, 3:]))
    assert angle > 0.5


def test_round_trip_through_plain_data() -> None:
    for name in ("reaching", "pouring"):
        s = load_scenario(name)
        assert scenario_from_dict(scenario_to_dict(s)) == s


def test_load_from_path_and_yml(tmp_path: Path) -> None:
    path = tmp_path / "mine.yaml"
    path.write_text(embedded_scenario_text("reaching"))
    assert load_scenario(path) == load_scenario("reaching")
    assert load_scenario(str(path)) == load_scenario("reaching")


@pytest.mark.parametrize(
    ("mutate", "field"),
    [
        (lambda d: d.update(colour=1), "scenario.colour: unknown key"),
        (lambda d: d["goals"][2].update(position=[0.1, float("nan"), 0.2]), "scenario.goals[2].position"),
        (lambda d: d["goals"][1].update(position=[0.1, 0.2]), "scenario.goals[1].position"),
        (lambda d: d["goals"][0].update(position="far"), "scenario.goals[0].position"),
        (lambda d: d.update(goals=[]), "scenario.goals"),
        (lambda d: d["goals"][4].update(position=[0.0, -0.9, 0.1]), "scenario.goals[4].position"),
        (lambda d: d.update(interface="keyboard"), "scenario.interface"),
        (lambda d: d.update(paradigm="auto"), "scenario.paradigm"),
        (lambda d: d.update(control_period=float("inf")), "scenario.control_period"),
        (lambda d: d.update(seed=1.5), "scenario.seed"),
        (lambda d: d.update(seed=True), "scenario.seed"),
        (lambda d: d["success"].update(position_tolerance=-0.01), "scenario.success.position_tolerance"),
        (lambda d: d["user"].update(goals=[7]), "scenario.user.goals[0]"),
        (lambda d: d["user"].update(goals=[0, 1]), "scenario.user.goals"),
        (lambda d: d["goals"][0]["object"].update(shape="cone"), "scenario.goals[0].object.shape"),
        (lambda d: d["goals"][0]["object"].update(size=[0.1]), "scenario.goals[0].object.size"),
        (lambda d: d["goals"][1].update(name=d["goals"][0]["name"]), "scenario.goals[1].name"),
        (lambda d: d["goals"][1].update(stage=3), "scenario.goals[1].stage"),
        (lambda d: d["goals"][1].pop("position"), "scenario.goals[1].position: required"),
        (lambda d: d.update(disambiguation={"preset": "magic"}), "scenario.disambiguation.preset"),
        (lambda d: d["inference"].update(method="oracle"), "scenario.inference.method"),
        (lambda d: d["inference"].update(dft={"tau1": -1.0}), "scenario.inference.dft"),
        (lambda d: d["blending"].update(rho3=2.0), "scenario.blending"),
        (
            lambda d: d["user"]["config"].update(success_position_tolerance=0.05),
            "scenario.user.config.success_position_tolerance",
        ),
    ],
)
def test_bad_fields_name_the_field(mutate, field: str) -> None:
    data = _reaching_dict()
    data.setdefault("inference", {})
    data.setdefault("blending", {})
    mutate(data)
    with pytest.raises(ValueError, match=field.replace("[", r"\[").replace("]", r"\]")):
        scenario_from_dict(data)


def test_out_of_reach_message_gives_distance_and_value() -> None:
    data = _reaching_dict()
    far = [0.0, -0.8, 0.2755]
    data["goals"][3]["position"] = far
    with pytest.raises(ValueError) as err:
        scenario_from_dict(data)
    text = str(err.value)
    assert "scenario.goals[3].position" in text and "out of the arm's reach" in text and "0.8" in text
    # Just inside the reach is fine.
    data["goals"][3]["position"] = [0.0, -(MICO_REACH - 0.01), MICO_SHOULDER_POSITION[2]]
    scenario_from_dict(data)


def test_malformed_yaml_names_file_and_line(tmp_path: Path) -> None:
    path = tmp_path / "broken.yaml"
    path.write_text("task: reaching\ngoals: [\n  - name: a\n")
    with pytest.raises(ValueError, match=r"broken\.yaml: malformed YAML at line"):
        load_scenario(path)
    with pytest.raises(ValueError, match="empty YAML"):
        scenario_from_yaml("", "empty.yaml")
    with pytest.raises(ValueError, match="expected a mapping"):
        scenario_from_yaml("- 1\n- 2\n")


def test_unknown_task_name_and_missing_file() -> None:
    with pytest.raises(ValueError, match="task: expected one of reaching, pouring"):
        load_scenario("juggling")
    with pytest.raises(ValueError, match="no such scenario file"):
        load_scenario("/nonexistent/dir/task.yaml")


def test_layers_over_a_task() -> None:
    s = load_scenario("pouring")
    layer = {"interface": "joystick", "paradigm": "manual", "user": {"goals": [1, 1]}, "seed": 7}
    o = load_scenario("pouring", layer)
    assert (o.interface, o.paradigm, o.user.goals, o.seed) == ("joystick", "manual", [1, 1], 7)
    assert load_scenario("pouring", "user: {goals: [1, 0]}").user.goals == [1, 0]
    assert o.user.config == s.user.config  # a struct merges: user.goals changed, user.config kept
    assert s.user.goals == [0, 0]  # the task is untouched
    with pytest.raises(ValueError, match=r"^<layer 1>: scenario\.interface: expected one of"):
        load_scenario("pouring", {"interface": "chin_switch"})
    with pytest.raises(ValueError, match=r"<layer 2>: scenario\.paradigm"):
        load_scenario("pouring", {}, {"paradigm": "telepathy"})
    with pytest.raises(ValueError, match=r"^<layer 1>: scenario\.user\.goals\[0\]: expected a goal index in"):
        load_scenario("pouring", {"user": {"goals": [2, 0]}})
    with pytest.raises(ValueError, match=r"user\.goals: expected one intended goal index per stage \(2\)"):
        load_scenario("pouring", {"user": {"goals": [0, 0, 0]}})
    with pytest.raises(ValueError, match=r"^<layer 1>: scenario\.seed"):
        load_scenario("pouring", "seed: -1")


def test_stages_need_equal_goal_counts() -> None:
    data = yaml.safe_load(embedded_scenario_text("pouring"))
    extra = copy.deepcopy(data["goals"][2])
    extra["name"] = "third_coaster"
    extra["position"] = [0.2, -0.4, 0.1]
    data["goals"].append(extra)
    with pytest.raises(ValueError, match=r"scenario\.stages\[1\]: every stage needs the same number"):
        scenario_from_dict(data)


def test_start_clearance() -> None:
    s = load_scenario("reaching")
    config = resolve_scenario(s)
    check_start_clearance(config, [0.0, -0.3, 0.4])
    with pytest.raises(ValueError, match=r"scenario\.goals\[1\]\.position: goal 'green_can' is on top of"):
        check_start_clearance(config, np.asarray(s.goals[1].position) + 0.01)
    # Only the first stage's goals, each named by its own field.
    p = load_scenario("pouring")
    check_start_clearance(resolve_scenario(p), np.asarray(p.goals[2].position))  # a goal of stage 1
    with pytest.raises(
        ValueError, match=r"^scenario\.goals\[1\]\.position: goal 'container_left' is on top of"
    ):
        check_start_clearance(resolve_scenario(p), np.asarray(p.goals[1].position))


def test_default_scenario_object_is_invalid_without_goals() -> None:
    from drake_disamb.config import validate_scenario

    with pytest.raises(ValueError, match=r"scenario\.goals: expected at least one goal"):
        validate_scenario(Scenario())


# ------------------------------------------------------------------------------------------------
# Validation that matches docs/scenarios.md: trials it lets through can be run
# ------------------------------------------------------------------------------------------------


def _rejected_fast(data: dict | str, match: str) -> str:
    """Load ``data`` (plain data or YAML text); it must fail in under 2 s naming ``match``."""
    start = time.perf_counter()
    with pytest.raises(ValueError, match=match) as err:
        if isinstance(data, str):
            scenario_from_yaml(data, "probe.yaml")
        else:
            scenario_from_dict(data)
    assert time.perf_counter() - start < 2.0
    return str(err.value)


@pytest.fixture(scope="module", autouse=True)
def _warm() -> None:
    """Load both tasks once, so timings measure the checks, not pydrake's first import."""
    load_scenario("reaching")
    load_scenario("pouring")


def test_table_top_comes_from_the_station_model() -> None:
    from drake_disamb.station import MICO_HOME_Q, build_station
    from drake_disamb.station.geometry import model_geometry

    geometry = model_geometry()
    assert geometry.table_top == pytest.approx(0.0, abs=1e-12)
    assert geometry.arm_lowest_point(MICO_HOME_Q)[0] > 0.1
    assert geometry.arm_lowest_point(load_scenario("pouring").start_joint_positions)[0] > 0.1
    # A built station measures its own plant, with the same answers.
    own = build_station().geometry
    assert own.plant is not geometry.plant
    assert own.table_top == geometry.table_top
    assert own.arm_lowest_point(MICO_HOME_Q) == geometry.arm_lowest_point(MICO_HOME_Q)
    assert np.array_equal(own.gripper_points_in_ee(), geometry.gripper_points_in_ee())


def test_goal_under_the_table_is_rejected() -> None:
    data = _reaching_dict()
    data["goals"][1]["position"] = [-0.116, -0.579, -0.4]
    msg = _rejected_fast(data, r"scenario\.goals\[1\]\.position: goal 'green_can' is too low")
    assert "table top (z = 0 m)" in msg and "got [-0.116, -0.579, -0.4]" in msg
    # Just above the table, the fingers (2 cm past the end effector) still reach into it.
    data["goals"][1]["position"] = [-0.116, -0.579, 0.03]
    _rejected_fast(data, r"scenario\.goals\[1\]\.position: .* mico_link_finger_\w+ would reach z = -0\.0")


def test_goal_too_low_for_its_object_is_rejected() -> None:
    data = _reaching_dict()
    data["goals"][0]["position"] = [0.328, -0.516, 0.09]  # the red box (top 3 cm under the goal) sinks 1 cm
    msg = _rejected_fast(data, r"scenario\.goals\[0\]\.position: goal 'red_box' is too low for its object")
    assert "z = -0.010 m" in msg and "got [0.328, -0.516, 0.09]" in msg


def test_carried_object_counts_at_the_goals() -> None:
    data = yaml.safe_load(embedded_scenario_text("pouring"))
    data["goals"][2]["position"] = [0.3314, -0.206, 0.045]  # the cup's bottom hangs 4.5 cm under the gripper
    data["goals"][2]["object"]["offset"] = [0.0043, 0.0246, -0.0225]
    _rejected_fast(data, r"scenario\.goals\[2\]\.position: goal 'platform_low' is too low: .* carried_object")
    data["carried_object"] = None  # without the cup the gripper itself is clear
    scenario_from_dict(data)


@pytest.mark.parametrize("offset", [0.0, 0.01, 0.039])
def test_goals_closer_than_twice_the_tolerance_are_rejected(offset: float) -> None:
    data = _reaching_dict()
    twin = copy.deepcopy(data["goals"][0])
    twin["name"] = "twin"
    twin["position"][0] += offset
    data["goals"].append(twin)
    msg = _rejected_fast(
        data,
        r"scenario\.goals\[5\]\.position: goal 'twin' is 0\.0\d\d m from goal 'red_box' "
        r"\(scenario\.goals\[0\]\)",
    )
    assert "at least 0.04 m apart" in msg and "position_tolerance" in msg


def test_goal_separation_follows_the_tolerance_and_the_stage() -> None:
    from drake_disamb.config import SuccessSpec, min_goal_separation

    assert min_goal_separation(SuccessSpec(position_tolerance=0.03)) == pytest.approx(0.06)
    data = _reaching_dict()
    twin = copy.deepcopy(data["goals"][0])
    twin["name"] = "twin"
    twin["position"][0] += 0.05
    data["goals"].append(twin)
    scenario_from_dict(data)  # 5 cm apart: fine at 2 cm tolerance
    data["success"]["position_tolerance"] = 0.03
    _rejected_fast(data, r"scenario\.goals\[5\]\.position: .* at least 0\.06 m apart")
    # Goals of different stages may coincide: only one stage's goals compete.
    pour = yaml.safe_load(embedded_scenario_text("pouring"))
    pour["goals"][2]["position"] = pour["goals"][0]["position"]
    pour["goals"][2]["orientation"] = pour["goals"][0]["orientation"]
    scenario_from_dict(pour)


def test_start_posture_inside_the_table_is_rejected() -> None:
    text = embedded_scenario_text("reaching").replace(
        "initial_mode: 0",
        "initial_mode: 0\nstart_joint_positions: [-1.3837, 0.0972, 5.7374, 2.4721, -1.1269, -0.8566]",
    )  # the home posture with the shoulder lowered by 1 rad: the gripper dips 3 cm into the table
    msg = _rejected_fast(
        text, r"scenario\.start_joint_positions: the start posture puts mico_link_finger_\w+ at z = -0\.03"
    )
    assert "got [-1.3837, 0.0972, 5.7374, 2.4721, -1.1269, -0.8566]" in msg
    data = _reaching_dict()
    data["start_joint_positions"] = [-1.3837, 1.0972, 0.5, 2.4721, -1.1269, -0.8566]
    _rejected_fast(
        data, r"scenario\.start_joint_positions\[2\]: expected an angle within joint 3's limits .* got 0\.5"
    )


def test_start_posture_counts_the_carried_object() -> None:
    from drake_disamb.clearance import Solid, pose_matrix
    from drake_disamb.station.geometry import model_geometry

    arm_lowest_point = model_geometry().arm_lowest_point
    q = load_scenario("pouring").start_joint_positions
    cup = Solid("cup", "cylinder", (0.035, 0.6), pose_matrix([0.0, 0.0, 0.0, 0.7071, 0.0, 0.7071, 0.0]))
    low, part = arm_lowest_point(q, [cup])  # a 60 cm cup, upright in the gripper 30 cm above the table
    assert part == "cup" and low == pytest.approx(0.0, abs=0.01)
    # The pouring start with the shoulder lowered by 0.64 rad: the fingers stay 7 mm above the table,
    # the cup (its bottom 4.5 cm under the end effector) goes 2 mm into it.
    data = yaml.safe_load(embedded_scenario_text("pouring"))
    data["start_joint_positions"] = [-1.2404, 0.2584, 6.9803, 3.3018, -4.7936, 0.5631]
    assert arm_lowest_point(data["start_joint_positions"])[0] > 0.005
    _rejected_fast(
        data, r"scenario\.start_joint_positions: the start posture puts carried_object at z = -0\.0019"
    )


@pytest.mark.parametrize(
    ("line", "field", "value"),
    [
        ("control_period: 1e-6", "control_period", "1e-06"),
        ("control_period: 0.0005", "control_period", "0.0005"),
        ("control_period: 0.2", "control_period", "0.2"),
        ("control_period: 0.01\nplant_config: {time_step: 1e-9}", "plant_config.time_step", "1e-09"),
        ("control_period: 0.01\nplant_config: {time_step: 0.0}", "plant_config.time_step", "0.0"),
    ],
)
def test_control_period_and_plant_step_within_1ms_and_100ms(line: str, field: str, value: str) -> None:
    text = embedded_scenario_text("reaching").replace("control_period: 0.01", line)
    if "plant_config: {" in line:  # replaces the task's own plant_config
        text = re.sub(r"\nplant_config:\n(  .*\n)+", "\n", text)
    _rejected_fast(
        text, rf"scenario\.{field}: expected a finite number in \[0\.001, 0\.1\] s, got {re.escape(value)}$"
    )


def test_period_bounds_are_inclusive() -> None:
    for period, step in ((0.001, 0.001), (0.1, 0.1), (0.1, 0.001)):
        data = _reaching_dict()
        data.update(control_period=period, plant_config={"time_step": step})
        s = scenario_from_dict(data)
        assert (s.control_period, s.plant_config.time_step) == (period, step)


def test_too_many_stages_or_goals_fail_before_any_quadratic_work() -> None:
    from drake_disamb.core.validation import MAX_GOALS

    data = _reaching_dict()
    data["stages"] = [{"name": f"s{k}"} for k in range(20_000)]
    _rejected_fast(data, r"scenario\.stages: every stage needs a goal, got 20000 stages for 5 goals")
    data = _reaching_dict()
    data["goals"] = [dict(data["goals"][0], name=f"g{k}") for k in range(MAX_GOALS + 1)]
    _rejected_fast(data, rf"scenario\.goals: expected at most {MAX_GOALS} goals, got {MAX_GOALS + 1}")


@pytest.mark.parametrize("opening", [0.05, 0.08, 0.2, float("nan")])
def test_a_release_opening_must_open_the_gripper_beyond_its_start(opening: float) -> None:
    from drake_disamb.config import validate_scenario

    s = load_scenario("pouring")
    s.stages[1].release_opening = opening
    message = r"pouring\.stages\[1\]\.release_opening: expected .*got (0\.05|0\.08|0\.2|nan)"
    with pytest.raises(ValueError, match=message):
        validate_scenario(s, "pouring")
