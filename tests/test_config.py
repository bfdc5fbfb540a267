"""The Drake-style configs: Drake's field names, the dump round trip, the strict checks in front of
Drake's loader, and the one resolution of a scenario into the frozen configs (rho thresholds, one
DFT parameter set and potential field for the live inference and every disambiguation preset)."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

from drake_disamb.builder import build_shared_control_diagram
from drake_disamb.cli import main
from drake_disamb.config import (
    EMBEDDED_TASKS,
    DFTSpec,
    InferenceSpec,
    UserBehaviorSpec,
    dump_scenario,
    embedded_scenario_text,
    load_scenario,
    resolve_scenario,
    scenario_from_yaml,
)
from drake_disamb.config.validation import check_scenario
from drake_disamb.core.disambiguation import preset
from drake_disamb.core.inference import DFTParams
from drake_disamb.study.run.runner import check_overrides
from drake_disamb.trial import run_trial
from drake_disamb.user import UserConfig


def _reaching_with(extra: str) -> str:
    """The reaching task's YAML with its simulator_config and plant_config replaced by ``extra``."""
    text = embedded_scenario_text("reaching")
    text = re.sub(r"\n(simulator_config|plant_config):\n(  .*\n)+", "\n", text)
    return text + extra


# ------------------------------------------------------------------------------------------------
# Drake's structs and field names
# ------------------------------------------------------------------------------------------------


def test_drake_field_names_set_the_plant_and_the_simulator() -> None:
    s = scenario_from_yaml(
        _reaching_with(
            "simulator_config: {integration_scheme: runge_kutta3}\nplant_config: {time_step: 0.002}\n"
        )
    )
    assert type(s.simulator_config).__name__ == "SimulatorConfig"
    assert type(s.plant_config).__name__ == "MultibodyPlantConfig"
    assert s.simulator_config.integration_scheme == "runge_kutta3"
    assert s.plant_config.time_step == 0.002
    # Keys left out keep the defaults (Drake's own for the rest of its structs).
    assert s.plant_config.discrete_contact_approximation == "sap" and s.plant_config.contact_model == "point"
    handles = build_shared_control_diagram(dataclasses.replace(s, duration=0.1))
    assert handles.plant.time_step() == 0.002
    assert handles.config.simulator.integration_scheme == "runge_kutta3"


def test_embedded_tasks_integrate_the_belief_by_euler_at_the_control_period() -> None:
    for name in EMBEDDED_TASKS:
        s = load_scenario(name)
        sim = s.simulator_config
        assert (sim.integration_scheme, sim.max_step_size, sim.use_error_control) == (
            "explicit_euler",
            0.01,
            False,
        )
        assert s.plant_config.time_step == s.control_period == 0.01


def test_the_simulator_config_reaches_the_simulator() -> None:
    """The belief integrated by explicit Euler differs from RK2's: run_trial applies the scenario's scheme."""
    beliefs = []
    for scheme in ("runge_kutta2", "explicit_euler"):
        s = scenario_from_yaml(_reaching_with(f"simulator_config: {{integration_scheme: {scheme}}}\n"))
        r = run_trial(dataclasses.replace(s, duration=1.5), progress=False, stop_at_success=False)
        beliefs.append(r.logs["belief"][1])
    assert beliefs[0].shape == beliefs[1].shape
    assert not np.array_equal(beliefs[0], beliefs[1])
    np.testing.assert_allclose(beliefs[0], beliefs[1], atol=0.05)  # both integrate the same ODE


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (
            "simulator_config: {integration: runge_kutta3}\n",
            r"scenario\.simulator_config\.integration: unknown key \(known keys of SimulatorConfig: ",
        ),
        (
            "simulator_config: {integration_scheme: warp_drive}\n",
            r"scenario\.simulator_config\.integration_scheme: expected one of .*, got 'warp_drive'",
        ),
        (
            "simulator_config: {max_step_size: .nan}\n",
            r"scenario\.simulator_config\.max_step_size: expected a finite",
        ),
        ("simulator_config: {start_time: 1.0}\n", r"scenario\.simulator_config\.start_time: expected 0"),
        (
            "plant_config: {time_step: fast}\n",
            r"scenario\.plant_config\.time_step: expected a finite number, got 'fast'",
        ),
        (
            "plant_config: {time_step: 0.2}\n",
            r"scenario\.plant_config\.time_step: expected a finite number in \[0\.001, 0\.1\] s, got 0\.2",
        ),
        (
            "plant_config: {time_step: 0.02}\n",
            r"scenario\.plant_config\.time_step: expected at most the control",
        ),
        (
            "plant_config: {discrete_contact_approximation: tamsi}\n",
            r"scenario\.plant_config\.discrete_contact_approximation: expected one of sap, similar, lagged, "
            r"got 'tamsi'",
        ),
        (
            "plant_config: [0.01]\n",
            r"scenario\.plant_config: expected a mapping of MultibodyPlantConfig fields",
        ),
    ],
)
def test_drake_structs_are_checked_with_field_paths(extra: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        scenario_from_yaml(_reaching_with(extra))


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        # Drake's loader alone would read the string as the list of its characters, [1.0, 2.0, 3.0].
        (
            "position: [0.328, -0.516, 0.100]",
            'position: "123"',
            r"scenario\.goals\[0\]\.position: expected 3",
        ),
        # ... a quoted number as a number, and a NaN as a number.
        ("seed: 0", 'seed: "3"', r"scenario\.seed: expected an integer, got '3'"),
        ("duration: 60.0", "duration: .nan", r"scenario\.duration: expected a finite number, got nan"),
        ("duration: 60.0", "duration: 'nan'", r"scenario\.duration: expected a finite number, got 'nan'"),
        # ... and would fail on an assert with a number where a mapping belongs.
        (
            "stages:\n  - name: reach",
            "stages:\n  - 5",
            r"scenario\.stages\[0\]: expected a mapping of StageSpec",
        ),
    ],
)
def test_what_drakes_loader_would_let_through_is_refused(old: str, new: str, message: str) -> None:
    text = embedded_scenario_text("reaching")
    assert old in text
    with pytest.raises(ValueError, match=message):
        scenario_from_yaml(text.replace(old, new), "t.yaml")


def test_core_configs_are_declared_once() -> None:
    """The scenario forms of the core configs have the core's fields (less those the resolver sets:
    the agreement term's form is ``inference.agreement``)."""
    dft = [f.name for f in dataclasses.fields(DFTParams) if f.name != "agreement_measure"]
    assert [f.name for f in dataclasses.fields(DFTSpec)] == dft
    core = [name for name in UserConfig.flat_types() if name not in ("seed", "rho1")]
    assert [f.name for f in dataclasses.fields(UserBehaviorSpec)] == core
    assert DFTSpec().to_config(agreement_measure=InferenceSpec().agreement) == preset("mico").inference.params


# ------------------------------------------------------------------------------------------------
# The dump round trip
# ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("task", "overrides"),
    [
        ("reaching", {}),
        ("pouring", {}),
        ("reaching", {"interface": "joystick", "user": {"goals": [2]}}),
        ("pouring", {"interface": "joystick", "user": {"goals": [1, 0]}, "paradigm": "manual", "seed": 7}),
        ("reaching", {"station": {"_tag": "!Lcm", "lcm_url": "memq://", "status_timeout": 0.05}}),
    ],
)
def test_dump_loads_back_equal(task: str, overrides: dict, tmp_path: Path) -> None:
    s = load_scenario(task, overrides)
    text = dump_scenario(s)
    assert scenario_from_yaml(text) == s
    path = tmp_path / "dumped.yaml"
    path.write_text(text)
    assert load_scenario(path) == s
    assert dump_scenario(load_scenario(path)) == text


def test_dump_keeps_every_change() -> None:
    s = load_scenario("pouring")
    s.user.config.stall_time = None  # an optional field whose embedded value is not None
    s.inference.goal_set = "task"  # one belief over the 4 goals ...
    s.inference.dft.rest = [0.3, 0.3, 0.2, 0.2]  # ... so a rest state of 4
    s.inference.agreement = "dot" if s.inference.agreement == "cosine" else "cosine"
    s.disambiguation.upsilon_normalization = "displacement"
    s.blending.assist_without_input = not s.blending.assist_without_input
    s.simulator_config.integration_scheme = "runge_kutta3"
    s.plant_config.time_step = 0.005
    s.goals[1].position[2] += 0.01
    back = scenario_from_yaml(dump_scenario(s))
    assert back == s and back != load_scenario("pouring")
    assert back.user.config.stall_time is None and back.inference.dft.rest == [0.3, 0.3, 0.2, 0.2]


def test_demo_dump_scenario_prints_the_resolved_scenario(capsys, tmp_path: Path) -> None:
    out = tmp_path / "never_created"
    argv = ["demo", "--dump-scenario", "--interface", "joystick", "--goal", "2", "--duration", "5"]
    assert main([*argv, "--out", str(out)]) == 0
    text = capsys.readouterr().out
    expected = load_scenario("reaching", {"interface": "joystick", "user": {"goals": [2]}, "duration": 5.0})
    assert scenario_from_yaml(text) == expected
    assert "integration_scheme: explicit_euler" in text and "time_step: 0.01" in text
    assert "\nstation: {}\n" in text  # the simulated station: Drake writes no tag for the first variant
    assert not out.exists()
    assert main(["demo", "--dump-scenario", "--goal", "9"]) == 2
    assert "--goal: scenario.user.goals[0]: expected a goal index in [0, 4], got 9" in capsys.readouterr().err
    assert (
        main(["demo", "--dump-scenario", "--task", "pouring", "--goal", "1"]) == 0
    )  # one index, every stage
    assert scenario_from_yaml(capsys.readouterr().out).user.goals == [1, 1]


def test_demo_scenario_text_sets_the_station(capsys) -> None:
    from drake_disamb.station.backends import Lcm, Sim

    assert main(["demo", "--dump-scenario", "--scenario-text", "station: !Lcm {}"]) == 0
    text = capsys.readouterr().out
    assert "\nstation: !Lcm\n  lcm_url: udpm://239.255.76.67:7667?ttl=0\n" in text
    back = scenario_from_yaml(text)
    assert isinstance(back.station, Lcm) and back == load_scenario("reaching", "station: !Lcm {}")
    assert main(["demo", "--dump-scenario", "--station", "lcm"]) == 0  # the shorthand writes the same layer
    assert capsys.readouterr().out == text
    argv = ["--scenario-text", "station: !Lcm {status_timeout: 0.05}", "--lcm-url", "memq://"]
    assert main(["demo", "--dump-scenario", *argv]) == 0  # the same tag merges: both settings kept
    station = scenario_from_yaml(capsys.readouterr().out).station
    assert (station.lcm_url, station.status_timeout) == ("memq://", 0.05)
    argv = ["--scenario-text", "station: !Lcm {}", "--scenario-text", "station: {}"]
    assert main(["demo", "--dump-scenario", *argv]) == 0  # no tag: the first backend, the simulation
    assert isinstance(scenario_from_yaml(capsys.readouterr().out).station, Sim)
    assert main(["demo", "--dump-scenario", "--scenario-text", "station: !Lcm {lcm_url: nourl}"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error: --scenario-text: scenario.station.lcm_url: expected a URL" in err


def test_the_builder_builds_the_scenarios_station() -> None:
    # No driver on this bus: the station on the wire waits for a status that never comes.
    s = load_scenario("reaching", "station: !Lcm {lcm_url: 'memq://', start_timeout: 0.05}")
    assert resolve_scenario(s).backend == s.station
    with pytest.raises(
        RuntimeError, match=r"station: no usable arm status on 'KINOVA_JACO_STATUS' at memq://"
    ):
        build_shared_control_diagram(s)


# ------------------------------------------------------------------------------------------------
# The one loader: layers merged by Drake's yaml_load_typed with defaults=
# ------------------------------------------------------------------------------------------------


def test_a_layer_merges_structs_and_maps_and_replaces_lists_and_scalars() -> None:
    from drake_disamb.config import data_layer, load_layers, task_layer, text_layer
    from drake_disamb.station.backends import Lcm, Sim

    base = load_scenario("pouring")
    layer = text_layer(
        """
        inference: {dft: {tau1: 3.0}}          # a struct: the other fields of dft kept
        goals: [{name: a, position: [0.3, -0.45, 0.3]}, {name: b, position: [-0.3, -0.45, 0.3]}]
        stages: [{name: reach}]                # lists: replaced whole
        user: {goals: [0]}
        interface_mode_order: {joystick: [[0, 1], [2], [3, 4], [5]]}
        carried_object: null                   # an optional: cleared
        seed: 5
        """,
        "layer.yaml",
    )
    s = load_layers(
        [
            task_layer("pouring"),
            data_layer({"interface_mode_order": {"head_array": [[0], [1], [2], [5], [3], [4]]}}),
            layer,
        ]
    )
    assert s.inference.dft.tau1 == 3.0 and s.inference.dft.tau2 == base.inference.dft.tau2
    assert s.inference.dft.lam == base.inference.dft.lam and s.user.config == base.user.config
    assert [g.name for g in s.goals] == ["a", "b"] and len(s.stages) == 1 and s.carried_object is None
    assert set(s.interface_mode_order) == {"head_array", "joystick"}  # a map: key by key
    assert s.seed == 5 and s.duration == base.duration
    # A variant: the same tag merges into the value below, another tag (or none: Sim) starts afresh.
    layers = [task_layer("reaching"), data_layer({"station": {"_tag": "!Lcm", "lcm_url": "memq://"}})]
    same = load_layers([*layers, data_layer({"station": {"_tag": "!Lcm", "status_timeout": 0.05}})]).station
    assert isinstance(same, Lcm) and (same.lcm_url, same.status_timeout) == ("memq://", 0.05)
    assert isinstance(load_layers([*layers, data_layer({"station": {}})]).station, Sim)
    fresh = load_layers(
        [*layers, data_layer({"station": {}}), data_layer({"station": {"_tag": "!Lcm"}})]
    ).station
    assert fresh == Lcm()


def test_an_error_names_the_layer_that_wrote_the_field() -> None:
    from drake_disamb.config import data_layer, load_layers, task_layer, text_layer

    task = task_layer("reaching")
    with pytest.raises(
        ValueError,
        match=r"^--switch: scenario\.control_period: expected a finite number in \[0\.001, 0\.1\] s, got 0",
    ):
        load_layers([task, data_layer({"control_period": 0.5}, "--switch")])
    with pytest.raises(ValueError, match=r"^t\.yaml: scenario\.goals\[1\]\.position: goal 'b' is out of"):
        goals = "goals: [{name: a, position: [0.3, -0.45, 0.3]}, {name: b, position: [2.0, 0.0, 0.3]}]"
        load_layers([task, data_layer({"seed": 1}, "a"), text_layer(goals, "t.yaml"), data_layer({}, "b")])
    with pytest.raises(ValueError, match=r"^t\.yaml, line 2: duplicate key 'seed'"):
        load_layers([task, text_layer("seed: 1\nseed: 2\n", "t.yaml")])  # the text's hardening, per layer
    with pytest.raises(
        ValueError, match=r"^b: scenario\.user\.goals\[0\]: expected a goal index in \[0, 4\]"
    ):
        load_layers([task, data_layer({"user": {"goals": [7]}}, "b")])
    # A field no layer wrote (the blending thresholds, for the one goal left): every layer is named.
    one = data_layer({"goals": [{"name": "a", "position": [0.3, -0.45, 0.3]}]}, "c")
    with pytest.raises(ValueError, match=r"^<embedded reaching\.yaml> \+ c: scenario\.blending: rho1: "):
        load_layers([task, one])


def test_every_task_preset_and_example_loads_through_the_one_loader() -> None:
    from drake_disamb.config import load_layers, task_layer
    from drake_disamb.config.system_presets import SYSTEM_PRESETS, system_layer
    from drake_disamb.study.design.protocol import (
        default_protocol,
        expand_trials,
        load_protocol,
        protocol_to_dict,
    )
    from drake_disamb.study.run.runner import StudyContext, draw_study_subjects, trial_layers

    for task in EMBEDDED_TASKS:
        assert load_layers([task_layer(task)]) == load_scenario(task)
        for name in SYSTEM_PRESETS:
            s = load_layers([task_layer(task), system_layer(name)])
            assert scenario_from_yaml(dump_scenario(s)) == s
    examples = Path(__file__).resolve().parents[1] / "examples"
    protocols = [default_protocol(), *(load_protocol(p) for p in sorted(examples.glob("*.yaml")))]
    assert len(protocols) >= 2
    for protocol in protocols:  # every condition and start pose of the protocol's tasks, every subject
        subjects, _ = draw_study_subjects(protocol.subjects, 0)
        context = StudyContext(protocol_to_dict(protocol), subject_users=dict(subjects))
        seen = set()
        for spec in expand_trials(protocol, 0, [n for n, _ in subjects]):
            for pose in range(len(next(t for t in protocol.tasks if t.task == spec.task).start_poses)):
                key = (spec.task, spec.interface, spec.paradigm, pose, spec.subject)
                if key[:4] in seen and spec.subject in seen:
                    continue
                seen |= {key[:4], spec.subject}
                layers = trial_layers(dataclasses.replace(spec, start_pose=pose), context)
                assert [layer.source for layer in layers[:3]] == [
                    f"<embedded {spec.task}.yaml>",
                    f"<system {protocol.system}.yaml>",
                    "protocol",
                ]
                s = load_layers(layers)
                assert (s.task, s.interface, s.paradigm, s.seed) == (
                    spec.task,
                    spec.interface,
                    spec.paradigm,
                    spec.scenario_seed,
                )


# ------------------------------------------------------------------------------------------------
# One resolution: rho thresholds, DFT parameters and potential field shared by every preset
# ------------------------------------------------------------------------------------------------


def test_rho_thresholds_are_resolved_once() -> None:
    s = load_scenario("reaching")
    handles = build_shared_control_diagram(s)
    config = handles.config
    assert config.rhos == pytest.approx((1.2 / 5, 1.4 / 5, 0.7))
    assert (config.blending.rho1, config.blending.rho2) == config.rhos[:2]  # written out for the blender
    assert handles.systems["blender"].rhos == config.rhos
    assert handles.systems["user"].config.rho1 == config.rhos[0]
    s.blending.rho1, s.blending.rho2 = 0.3, 0.5
    resolved = resolve_scenario(s)
    assert resolved.rhos == (0.3, 0.5, 0.7) and resolved.user.rho1 == 0.3
    s.blending.rho1 = 0.6
    with pytest.raises(ValueError, match=r"scenario\.blending: rho2: expected rho2 > rho1 = 0\.6, got 0\.5"):
        resolve_scenario(s)


@pytest.mark.parametrize("method", ["dft", "bayes"])
def test_a_non_mico_preset_projects_with_the_live_inference(method: str) -> None:
    """The correctness trap: with the ``authors-r3`` preset the projection once ran the preset's own
    DFT (tau 10 s, lambda 200) while the live belief ran the scenario's."""
    s = load_scenario("reaching")
    s.disambiguation.preset = "authors-r3"
    s.inference.method = method
    s.inference.dft.tau1 = 5.0  # the live parameters differ from both presets'
    handles = build_shared_control_diagram(s)
    projection = handles.systems["disambiguation"].config
    live_dft = s.inference.dft.to_config(agreement_measure=s.inference.agreement)
    assert projection.inference is handles.config.inference  # the very same method, parameters and all
    assert projection.inference.name == method
    if method == "dft":
        assert projection.inference.params == live_dft
        assert projection.inference.params != preset("authors-r3").inference.params
    assert projection.potential_field == handles.systems["autonomy"].config == s.autonomy.to_config()
    # The preset still decides how the projection probes.
    authors = preset("authors-r3")
    assert (projection.dimensions, projection.probe_speed_translation, projection.upsilon_normalization) == (
        authors.dimensions,
        authors.probe_speed_translation,
        authors.upsilon_normalization,
    )
    if method == "bayes":
        assert type(handles.systems["inference"]).__name__ == "RecursiveBayesIntentInference"


def test_memory_inference_has_no_projection_to_disambiguate_with() -> None:
    s = load_scenario("reaching")
    s.inference.method = "memory"
    with pytest.raises(
        ValueError, match=r"scenario\.inference\.method: the disambiguation paradigm .* got 'memory'"
    ):
        resolve_scenario(s)
    assert resolve_scenario(dataclasses.replace(s, paradigm="manual")).disambiguation is None


def test_core_config_errors_name_the_scenario_field() -> None:
    s = load_scenario("reaching")
    s.inference.dft.transition = [[1.0, 0.0], [0.0, 1.0]]
    with pytest.raises(ValueError, match=r"scenario\.inference\.dft\.transition: expected a 5 x 5 matrix"):
        resolve_scenario(s)
    s = load_scenario("reaching")
    s.user.config.position_tolerance = 0.05
    with pytest.raises(ValueError, match=r"scenario\.user\.config: UserConfig\.success_position_tolerance"):
        resolve_scenario(s)
    s = load_scenario("reaching")
    s.initial_mode = 9
    with pytest.raises(ValueError, match=r"scenario\.initial_mode: InterfaceConfig\.initial_mode: .* got 9"):
        resolve_scenario(s)


@pytest.mark.parametrize(
    ("scheme", "step", "lam", "ok"),
    [
        ("explicit_euler", 0.01, 3.0, True),  # the mico parameters: h D = 0.08
        ("explicit_euler", 0.01, 200.0, False),  # the authors' lambda: h D up to 5, unstable
        ("runge_kutta2", 0.01, 200.0, False),
        ("explicit_euler", 0.002, 200.0, True),  # a shorter step is stable again
    ],
)
def test_an_unstable_fixed_step_belief_integrator_is_refused(
    scheme: str, step: float, lam: float, ok: bool
) -> None:
    text = embedded_scenario_text("reaching").replace(
        "integration_scheme: explicit_euler", f"integration_scheme: {scheme}"
    )
    text = text.replace("max_step_size: 0.01", f"max_step_size: {step}")
    s = scenario_from_yaml(text)
    s = dataclasses.replace(
        s, inference=dataclasses.replace(s.inference, dft=dataclasses.replace(s.inference.dft, lam=lam))
    )
    if ok:
        check_scenario(s)
    else:
        with pytest.raises(ValueError, match=r"scenario\.simulator_config\.max_step_size: .* too long for"):
            check_scenario(s)


def test_interface_mode_selection_reaches_the_joystick_only() -> None:
    s = load_scenario("reaching")
    assert s.interface_mode_selection == "cycle"
    assert resolve_scenario(s).interface.mode_selection == "cycle"
    s = scenario_from_yaml(_reaching_with("interface_mode_selection: direct\n"))
    s.interface = "joystick"
    assert resolve_scenario(s).interface.mode_selection == "direct"
    # The head array has no stick: it cycles, so one setting serves both interfaces of a study.
    s.interface = "head_array"
    assert resolve_scenario(s).interface.mode_selection == "cycle"
    with pytest.raises(
        ValueError, match=r"scenario\.interface_mode_selection: expected one of cycle, direct, got 'sector'"
    ):
        scenario_from_yaml(_reaching_with("interface_mode_selection: sector\n"))
    s.interface_mode_selection = "sector"
    with pytest.raises(
        ValueError, match=r"scenario\.interface_mode_selection: expected one of cycle, direct, got 'sector'"
    ):
        resolve_scenario(s)


def test_interface_mode_selection_is_an_ablation_switch() -> None:
    check_overrides({"interface_mode_selection": "direct"})
    with pytest.raises(ValueError, match=r"overrides interface_mode_selection='sector'"):
        check_overrides({"interface_mode_selection": "sector"})


def test_interface_mode_order_is_a_scenario_option_per_interface() -> None:
    from drake_disamb.config import load_scenario, resolve_scenario, scenario_from_dict, scenario_to_dict

    plain = scenario_to_dict(load_scenario("reaching"))
    plain["interface_mode_order"] = {
        "head_array": [[2], [1], [0], [3], [4], [5]],
        "joystick": [[0, 1], [0, 2], [3, 5], [4]],
    }
    config = resolve_scenario(scenario_from_dict(plain))
    assert config.interface.modes[:3] == ((2,), (1,), (0,)) and config.interface.modes[-1] == (6,)
    plain["interface"] = "sip_and_puff"  # a kind left out keeps its registered order
    assert resolve_scenario(scenario_from_dict(plain)).interface.modes[:3] == ((0,), (1,), (2,))
    for bad, message in (
        (
            {"head_array": [[0], [1]]},
            r"interface_mode_order\.head_array: HeadArray\.mode_order: expected modes that cover",
        ),
        ({"wheel": [[0]]}, r"interface_mode_order: unknown key 'wheel' \(one of joystick, head_array"),
        (
            {"head_array": [[0], [0], [1], [2], [3], [4], [5]]},
            r"interface_mode_order\.head_array: .*distinct modes",
        ),
        ({"head_array": "vx"}, r"interface_mode_order\.head_array: expected a list"),
        (
            {"head_array": [[0.5], [1], [2], [3], [4], [5]]},
            r"interface_mode_order\.head_array\[0\]\[0\]: expected an integer",
        ),
    ):
        plain["interface_mode_order"] = bad
        with pytest.raises(ValueError, match=message):
            scenario_from_dict(plain)
