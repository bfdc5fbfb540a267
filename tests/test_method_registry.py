"""The method registries: mode selection and inference as typed variants chosen by name."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from typing import ClassVar

import numpy as np
import pytest

from drake_disamb.config import resolve_scenario
from drake_disamb.config.yaml_io import embedded_scenario_text, scenario_from_yaml
from drake_disamb.core.disambiguation import (
    MICO_DFT,
    MODE_SELECTION_METHODS,
    Algorithm1Result,
    DisambiguationRequest,
    DisambiguationResult,
    EntropyResult,
    KLResult,
    ModeSelectionMethod,
    mico_config,
    mode_selection_method,
    select_disambiguating_mode,
    select_mode,
)
from drake_disamb.core.inference import (
    INFERENCE_METHODS,
    BayesInference,
    DFTInference,
    MemoryInference,
    ProjectedInference,
    bayes_step,
    dft_euler_step,
)
from drake_disamb.core.registry import Registry


def _reaching(extra: str) -> str:
    """The embedded reaching scenario's YAML with the top-level block ``extra`` added."""
    return embedded_scenario_text("reaching") + "\n" + extra + "\n"


GOALS = np.array([[0.3, 0.1, 0.05], [0.25, -0.2, 0.1], [0.4, 0.0, -0.1]])
BELIEF = np.array([0.5, 0.3, 0.2])
MODES = [[0], [1], [2], [3], [4], [5]]


# ----------------------------------------------------------------------------------------------
# The registry
# ----------------------------------------------------------------------------------------------


def test_registry_lists_the_registered_names_for_an_unknown_one() -> None:
    registry: Registry = Registry("widget")

    @registry.register
    class A:
        name = "a"

    @registry.register
    class B:
        name = "b"

    assert registry.get("b") is B and registry.names() == ("a", "b") and list(registry) == ["a", "b"]
    assert "a" in registry and "c" not in registry and 3 not in registry and len(registry) == 2
    with pytest.raises(ValueError, match=r"^widget: expected one of a, b, got 'c'$"):
        registry.get("c")
    with pytest.raises(ValueError, match=r"widget 'a': already registered \(A\)"):
        registry.register(type("A2", (), {"name": "a"}))
    with pytest.raises(ValueError, match="non-empty string name"):
        registry.register(type("Nameless", (), {}))
    registry.unregister("a")
    assert registry.names() == ("b",)


def test_the_registries_hold_the_papers_methods_in_order() -> None:
    assert MODE_SELECTION_METHODS.names() == ("algorithm1", "entropy", "kl")
    assert INFERENCE_METHODS.names() == ("dft", "bayes", "memory")
    assert [m.label for m in INFERENCE_METHODS.variants()] == [
        "field-theoretic",
        "recursive Bayes",
        "memory-based",
    ]
    with pytest.raises(
        ValueError, match=r"^inference method: expected one of dft, bayes, memory, got 'kalman'$"
    ):
        INFERENCE_METHODS.get("kalman")
    with pytest.raises(
        ValueError, match=r"^mode-selection method: expected one of algorithm1, entropy, kl, got 'fisher'$"
    ):
        mode_selection_method("fisher")


def test_an_unknown_method_in_a_scenario_names_the_field_and_the_registered_ones() -> None:
    for block, message in (
        (
            "inference: {method: kalman}",
            r"inference\.method: expected one of dft, bayes, memory, got 'kalman'",
        ),
        (
            "disambiguation: {method: fisher}",
            r"disambiguation\.method: expected one of algorithm1, entropy, kl, got 'fisher'",
        ),
    ):
        with pytest.raises(ValueError, match=message):
            resolve_scenario(scenario_from_yaml(_reaching(block)))


# ----------------------------------------------------------------------------------------------
# Inference variants
# ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("method", [DFTInference(MICO_DFT), BayesInference(sigma=0.9)], ids=["dft", "bayes"])
def test_a_projected_method_splits_its_own_step_into_evidence_and_rollout(method: ProjectedInference) -> None:
    """The forward projection's update (evidence, then rollout) is the method's own step, bit for bit."""
    rng = np.random.default_rng(3)
    U = rng.normal(scale=0.1, size=(4, 2, 6))  # 4 steps of 2 probes
    X = rng.normal(scale=0.1, size=(4, 2, 3))
    UA = rng.normal(scale=0.1, size=(4, 2, 3, 6)) if method.needs_autonomy else None
    beliefs = method.rollout(BELIEF, method.evidence(U, X, GOALS, UA), 0.1)
    for probe in range(2):
        p = BELIEF
        for s in range(4):
            if isinstance(method, DFTInference):
                p = dft_euler_step(p, U[s, probe], X[s, probe], GOALS, method.params, 0.1, UA[s, probe])
            else:
                p = bayes_step(p, U[s, probe], X[s, probe], GOALS, method.transition, method.sigma)
            np.testing.assert_array_equal(beliefs[s, probe], p)


def test_inference_variants_hold_and_check_their_configuration() -> None:
    assert DFTInference.continuous and not BayesInference.continuous and not MemoryInference.continuous
    assert DFTInference.from_settings(MICO_DFT).params is MICO_DFT
    assert BayesInference.from_settings(MICO_DFT) == BayesInference()
    assert not isinstance(MemoryInference(), ProjectedInference)
    P = [[0.9, 0.1], [0.2, 0.8]]
    assert np.array_equal(DFTInference(MICO_DFT).with_transition(P).transition, P)
    assert np.array_equal(BayesInference().with_transition(P).transition, P)
    with pytest.raises(ValueError, match=r"BayesInference\.sigma: expected a finite positive angle"):
        BayesInference(sigma=0.0)
    with pytest.raises(ValueError, match=r"MemoryInference\.transition: rows must sum to 1"):
        MemoryInference(transition=[[0.5, 0.4], [0.5, 0.5]])
    with pytest.raises(ValueError, match=r"DFTInference\.params: expected DFTParams"):
        DFTInference("dft")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"transition: expected a 3x3 matrix"):
        BayesInference(transition=P).check_goal_count(3)


def test_the_scenario_resolves_one_inference_method_for_the_live_system_and_the_projection() -> None:
    from drake_disamb.systems.inference import (
        FieldTheoreticIntentInference,
        MemoryBasedIntentInference,
        RecursiveBayesIntentInference,
        inference_system,
    )
    from drake_disamb.systems.loop import ControlLoop

    for name, cls, system in (
        ("dft", DFTInference, FieldTheoreticIntentInference),
        ("bayes", BayesInference, RecursiveBayesIntentInference),
        ("memory", MemoryInference, MemoryBasedIntentInference),
    ):
        text = _reaching(f"inference: {{method: {name}}}")
        if name == "memory":  # it has no forward projection
            text = text.replace("paradigm: disambiguation", "paradigm: manual", 1)
        s = scenario_from_yaml(text)
        c = resolve_scenario(s)
        assert type(c.inference) is cls
        assert c.disambiguation is None or c.disambiguation.inference is c.inference
        assert type(inference_system(c.inference, c.loop)) is system

    @dataclasses.dataclass(frozen=True)
    class Unbuilt(MemoryInference):
        name: ClassVar[str] = "unbuilt"

    # A subclass of a variant gets that variant's system; a method nobody gave one is an error.
    assert type(inference_system(Unbuilt(), ControlLoop(2))) is MemoryBasedIntentInference
    with pytest.raises(
        ValueError, match=r"inference method 'orphan': no Drake system is registered for _Orphan"
    ):
        inference_system(_Orphan(), ControlLoop(2))


@dataclasses.dataclass(frozen=True)
class _Orphan(ProjectedInference):
    """An inference method nobody gave a Drake system."""

    name: ClassVar[str] = "orphan"
    label: ClassVar[str] = "orphan"
    transition: None = None

    def evidence(self, u_h, x_r, x_g, u_a=None):  # type: ignore[no-untyped-def]
        return np.ones(np.shape(x_g)[:-1])

    def rollout(self, p, evidence, dt):  # type: ignore[no-untyped-def]
        return np.broadcast_to(p, np.shape(evidence)).copy()

    def with_transition(self, transition):  # type: ignore[no-untyped-def]
        return self

    def check_goal_count(self, n: int) -> None:
        return None


# ----------------------------------------------------------------------------------------------
# Mode-selection variants
# ----------------------------------------------------------------------------------------------


def test_each_method_has_its_own_result_and_explanation() -> None:
    results = {
        name: select_disambiguating_mode(name, BELIEF, np.zeros(3), GOALS, MODES, current_mode=0)
        for name in MODE_SELECTION_METHODS
    }
    assert mode_selection_method("kl") == mode_selection_method("kl") != mode_selection_method("entropy")
    assert repr(mode_selection_method("algorithm1")) == "Algorithm1()"
    assert type(results["algorithm1"]) is Algorithm1Result
    assert type(results["entropy"]) is EntropyResult and type(results["kl"]) is KLResult
    for name, result in results.items():
        assert result.method == name and result.to_dict()["method"] == name
    assert "Gamma" in results["algorithm1"].explain() and "w" in Algorithm1Result.__dataclass_fields__
    assert "projected entropy" in results["entropy"].explain()
    assert "KL =" in results["kl"].explain()
    assert set(results["entropy"].features) == {"entropy"} and set(results["kl"].features) == {"kl"}


@dataclasses.dataclass(frozen=True)
class _LastModeResult(DisambiguationResult):
    method: ClassVar[str] = "last_mode"
    score_name: ClassVar[str] = "index"

    def explain_details(self) -> list[str]:
        return ["The last mode always wins."]


class _LastMode(ModeSelectionMethod):
    """A test-only method: the highest-numbered mode (no projection at all)."""

    name: ClassVar[str] = "last_mode"
    label: ClassVar[str] = "the last mode"

    def select(self, request: DisambiguationRequest) -> _LastModeResult:
        scores = np.arange(len(request.modes), dtype=float)
        mode, best = select_mode(scores, request.current_mode, request.config.tie_tolerance)
        return _LastModeResult(
            mode=mode,
            best_mode=best,
            mode_scores=scores,
            modes=request.modes,
            current_mode=request.current_mode,
            tie_tolerance=request.config.tie_tolerance,
        )


@pytest.fixture
def last_mode() -> Iterator[type[_LastMode]]:
    MODE_SELECTION_METHODS.register(_LastMode)
    try:
        yield _LastMode
    finally:
        MODE_SELECTION_METHODS.unregister("last_mode")


def test_a_registered_method_is_selectable_from_yaml_and_runs_in_the_diagram(last_mode: type) -> None:
    """Registering a method is all it takes: the scenario's YAML names it, the schema accepts it, the
    resolver and the disambiguation system run it (no other module edited)."""
    from drake_disamb.builder import build_shared_control_diagram

    scenario = scenario_from_yaml(_reaching("disambiguation: {method: last_mode}"))
    assert scenario.disambiguation.method == "last_mode"
    config = resolve_scenario(scenario)
    assert type(config.disambiguation_method) is last_mode
    handles = build_shared_control_diagram(scenario)
    system = handles.systems["disambiguation"]
    assert type(system.method) is last_mode
    result = select_disambiguating_mode(
        "last_mode", BELIEF, np.zeros(3), GOALS, MODES, mico_config(), current_mode=0
    )
    assert result.mode == 5 and result.to_dict() == {
        "method": "last_mode",
        "mode": 5,
        "best_mode": 5,
        "mode_scores": [0.0, 1.0, 2.0, 3.0, 4.0, 5.0],
    }
    assert result.explain().endswith("The last mode always wins.")
    from pydrake.systems.analysis import Simulator

    from drake_disamb.systems.disambiguation import LatchedRequest

    context = system.CreateDefaultContext()  # the system serves it like any method
    n = system.n_goals
    goal_poses = np.hstack([np.arange(3.0 * n).reshape(-1, 3) / 10, np.tile([1.0, 0, 0, 0], (n, 1))])
    request = LatchedRequest(1.0, np.full(n, 1.0 / n), np.array([0.0, 0.0, 0.1, 1.0, 0.0, 0.0, 0.0]),
                             goal_poses.ravel(), 0.0)  # fmt: skip
    system.GetInputPort("request").FixValue(context, request.to_vector())
    Simulator(system, context).AdvanceTo(0.005)  # the update at t = 0 answers it
    assert system.GetOutputPort("answer").Eval(context).tolist() == [1.0, len(system.modes) - 1]


def test_a_registered_method_is_selectable_from_the_protocol_and_the_command_line(
    last_mode: type, tmp_path, capsys: pytest.CaptureFixture[str]
) -> None:  # type: ignore[no-untyped-def]
    import json

    from drake_disamb import cli
    from drake_disamb.study.design.protocol import default_protocol, protocol_from_dict, protocol_to_dict

    data = protocol_to_dict(default_protocol())
    data["disambiguation_method"] = "last_mode"
    assert protocol_from_dict(data).disambiguation_method == "last_mode"
    data["disambiguation_method"] = "fisher"
    with pytest.raises(
        ValueError, match=r"disambiguation_method: expected one of algorithm1, entropy, kl, last_mode"
    ):
        protocol_from_dict(data)

    cases = tmp_path / "cases.json"
    cases.write_text(
        json.dumps(
            [
                {
                    "belief": [0.5, 0.5],
                    "position": [0, 0, 0],
                    "goals": [[0.3, 0.1, 0], [0.3, -0.1, 0]],
                    "modes": [[0], [1]],
                }
            ]
        )
    )
    assert cli.main(["disambiguate", "--cases", str(cases), "--method", "last_mode"]) == 0
    assert json.loads(capsys.readouterr().out)[0]["method"] == "last_mode"
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["disambiguate", "--cases", str(cases), "--method", "fisher"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'fisher'" in err  # argparse lists the choices: the registered names
    assert all(
        name in err.split("choose from", 1)[1] for name in ("algorithm1", "entropy", "kl", "last_mode")
    )


@dataclasses.dataclass(frozen=True)
class _Stubborn(ProjectedInference):
    """A test-only inference method: the belief never moves (evidence 1 for every goal)."""

    name: ClassVar[str] = "stubborn"
    label: ClassVar[str] = "stubborn"
    transition: None = None

    def evidence(self, u_h, x_r, x_g, u_a=None):  # type: ignore[no-untyped-def]
        return np.ones(np.broadcast_shapes(np.shape(x_r)[:-1], np.shape(x_g)[:-2]) + (np.shape(x_g)[-2],))

    def rollout(self, p, evidence, dt):  # type: ignore[no-untyped-def]
        return np.broadcast_to(p, np.shape(evidence)).copy()

    def with_transition(self, transition):  # type: ignore[no-untyped-def]
        return self

    def check_goal_count(self, n: int) -> None:
        return None

    def recorded_evidence(self, samples, x_g):  # type: ignore[no-untyped-def]
        return np.ones((len(samples.u_h), np.shape(x_g)[-2]))


def test_a_registered_inference_method_is_selectable_from_yaml() -> None:
    """A new inference method registers itself and its Drake system; the scenario names it, and the
    live system and the forward projection both run it (no other module edited)."""
    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.systems.inference import RecursiveBayesIntentInference, inference_system

    INFERENCE_METHODS.register(_Stubborn)
    try:
        inference_system.register(_Stubborn)(lambda method, loop: RecursiveBayesIntentInference(loop))
        scenario = scenario_from_yaml(_reaching("inference: {method: stubborn}"))
        config = resolve_scenario(scenario)
        assert type(config.inference) is _Stubborn and config.disambiguation.inference is config.inference
        handles = build_shared_control_diagram(scenario)
        assert type(handles.systems["inference"]) is RecursiveBayesIntentInference
        result = select_disambiguating_mode(
            "algorithm1", BELIEF, np.zeros(3), GOALS, MODES, config.disambiguation, current_mode=0
        )
        # A belief that never moves: every mode scores the same, the current mode is kept.
        assert result.mode is None and np.ptp(result.mode_scores) == 0
    finally:
        INFERENCE_METHODS.unregister("stubborn")
