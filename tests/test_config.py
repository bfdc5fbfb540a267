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
    with_overrides,
)
from drake_disamb.config.validation import check_scenario
from drake_disamb.core.disambiguation import preset
from drake_disamb.core.inference import DFTParams
from drake_disamb.core.user import UserConfig
from drake_disamb.study.run.runner import check_overrides
from drake_disamb.trial import run_trial


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
        ("reaching", {"interface": "joystick", "goal": 2}),
        ("pouring", {"interface": "joystick", "goal": [1, 0], "paradigm": "manual", "seed": 7}),
    ],
)
def test_dump_loads_back_equal(task: str, overrides: dict, tmp_path: Path) -> None:
    s = with_overrides(load_scenario(task), **overrides)
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
    expected = dataclasses.replace(
        with_overrides(load_scenario("reaching"), interface="joystick", goal=2), duration=5.0
    )
    assert scenario_from_yaml(text) == expected
    assert "integration_scheme: explicit_euler" in text and "time_step: 0.01" in text
    assert not out.exists()
    assert main(["demo", "--dump-scenario", "--goal", "9"]) == 2
    assert "goal: expected an index in [0, 4]" in capsys.readouterr().err


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
    assert resolve_scenario(with_overrides(s, paradigm="manual")).disambiguation is None


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
