"""study.identify: the study's system from its logs.

Unit tests on small synthetic logs made with the core's own functions (so CI without the data still
tests the identification), then the replays of the authors' logs (skipped where they are absent).
"""

from __future__ import annotations

import functools
import json
from pathlib import Path

import numpy as np
import pytest

from drake_disamb.core.autonomy import PotentialFieldConfig, potential_field_commands
from drake_disamb.core.blending import blending_alpha
from drake_disamb.core.inference import DFTParams, dft_euler_step
from drake_disamb.interfaces import INTERFACES
from drake_disamb.study.data.folder import LoggedTrial
from drake_disamb.study.data.records import TrialRecord
from drake_disamb.study.measures.identify import (
    alpha_matches,
    fit_alpha_law,
    fit_idle_decay,
    identify_mode_map,
    idle_replay_error,
    idle_steps,
    solve_positions,
    update_period,
    update_rows,
)

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "tnsre2020_human_study"
HAVE_DATA = (DATA / "trial_order_testing_8.mat").is_file()
needs_data = pytest.mark.skipif(
    not HAVE_DATA,
    reason=f"the authors' human-study logs are not at {DATA} (../shared/data/tnsre2020_human_study)",
)
DT = 0.05  # the logs' row period (s)


def _record(interface: str = "head_array", task: str = "reaching", requests: list[float] | None = None):
    requests = requests or []
    return TrialRecord(
        trial_id="S", subject="S01", interface=interface, task=task, paradigm="disambiguation",
        disambiguation_method="algorithm1", repetition=0, seed=0, start_pose=0, initial_mode="vx",
        intended_goals=[0], reached_goals=None, success=None, done=None, duration=10.0,
        completion_time=10.0, mode_switches=0, requests=len(requests), automatic_switches=0,
        button_presses=len(requests), request_times=list(requests), mode_switch_times=[],
        mode_switch_modes=[], automatic_switch_times=[], mean_alpha=None, assistance_onset=None,
        wall_time=0.0, valid=True, source="authors",
    )  # fmt: skip


def _idle_trial(n: int, params: DFTParams, period: float, seed: int) -> LoggedTrial:
    """A trial whose belief updates every ``period`` s with the core's Euler step: commanded for the
    first 2 s (towards goal 0 of ``n``), then idle; logged every :data:`DT`."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 8.0, DT)
    goals = rng.normal(size=(n, 3))
    p = np.full(n, 1.0 / n)
    belief = np.empty((len(t), n))
    every = round(period / DT)
    for k in range(len(t)):
        if k and k % every == 0:
            u = (goals[0] - np.zeros(3)) if t[k] < 2.0 else np.zeros(3)
            p = dft_euler_step(p, u, np.zeros(3), goals, params, period)
        belief[k] = p
    t_u = np.arange(0.0, 8.0, 0.01)
    u_h = np.zeros((len(t_u), 6))
    u_h[t_u < 2.0, :3] = goals[0]
    trace = {
        "t": t,
        "belief": belief,
        "alpha": np.zeros(len(t)),
        "u": np.zeros((len(t), 6)),
        "u_h": u_h,
        "t_u_h": t_u,
        "mode": np.zeros(len(t), dtype=np.int64),
    }
    return LoggedTrial(_record(), trace, request_switch_times=np.zeros(0))


def test_update_rows_and_period() -> None:
    trial = _idle_trial(4, DFTParams(tau1=3.0, tau2=3.0, lam=1.0, zero_command_excitation=False), 0.1, 0)
    changed = update_rows(trial.trace["belief"])
    assert not changed[0] and changed.sum() > 10
    assert update_period([trial]).period == pytest.approx(0.1)


def test_an_identification_is_one_function_and_one_row_of_the_table(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from drake_disamb.study.measures import identify as module

    assert [row.name for row in module.IDENTIFICATIONS] == [
        "trials", "subjects", "period", "decay", "idle_error", "alpha", "requests", "mode_maps", "known_path",
    ]  # fmt: skip
    params = DFTParams(tau1=3.0, tau2=3.0, lam=1.0, zero_command_excitation=False)
    trials = [_idle_trial(4, params, 0.1, seed) for seed in range(2)]

    def updates(logs: module.Logs, found: module.Identification) -> int:  # reads one found before it
        return found.period.n + len(logs.trials)

    table = (
        *module.IDENTIFICATIONS[:3],
        module.Identifying("updates", updates, lambda v, _: f"Updates: {v}", lambda v, _: {"updates": v}),
    )
    monkeypatch.setattr(module, "IDENTIFICATIONS", table)
    ident = module.identify(tmp_path, trials=trials)
    assert list(ident) == ["trials", "subjects", "period", "updates"]
    assert ident.updates == ident.period.n + 2 == ident["updates"]
    text = module.format_identification(ident).splitlines()
    assert text[0] == "Trials: 2 (subjects S01)" and text[-1] == f"Updates: {ident.updates}"
    assert len(text) == 3 and text[1].startswith("Belief update period: 0.100 s")
    assert ident.to_json() == {
        "trials": 2, "subjects": ["S01"], "belief_update_period": 0.1, "updates": ident.updates,
    }  # fmt: skip


@pytest.mark.parametrize("excite", [False, True])
def test_idle_decay_recovers_tau_rest_and_excitation(excite: bool) -> None:
    params = DFTParams(tau1=3.0, tau2=3.0, lam=1.0, zero_command_excitation=excite)
    trials = [_idle_trial(n, params, 0.1, n) for n in (4, 5)]
    steps = [idle_steps(t, 0.1) for t in trials]
    assert all(len(b) > 10 for b, _, _ in steps)
    decay = fit_idle_decay([(b, a) for b, a, _ in steps], 0.1, sum(k for *_, k in steps))
    assert decay.stretches == 2
    assert max(decay.rest_deviation.values()) < 1e-9  # uniform rest state
    assert decay.zero_command_excitation is excite
    if not excite:
        assert decay.tau == pytest.approx(3.0, rel=1e-9)
        assert max(idle_replay_error(b, a, decay.params(), 0.1) for b, a, _ in steps) < 1e-12
    else:  # the uniform excitation lambda * sigma(0.5) of the zero command's directedness 0.5
        assert decay.excitation == pytest.approx(1.0 * (1 / (1 + np.exp(-0.5)) - 0.5), rel=1e-6)


def test_idle_decay_with_one_goal_count_cannot_tell_excitation() -> None:
    trial = _idle_trial(4, DFTParams(tau1=3.0, tau2=3.0, zero_command_excitation=False), 0.1, 1)
    b, a, _ = idle_steps(trial, 0.1)
    assert fit_idle_decay([(b, a)], 0.1).zero_command_excitation is None
    with pytest.raises(ValueError, match="no idle belief updates"):
        fit_idle_decay([], 0.1)


def _alpha_trial(n: int, lo: float, hi: float, seed: int, requests: tuple[float, float] | None = None):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 10.0, DT)
    top = rng.uniform(1.0 / n, 0.6, len(t))
    rest = (1.0 - top) / (n - 1)
    belief = np.column_stack([top] + [rest] * (n - 1))
    alpha = np.asarray(blending_alpha(np.round(top, 3), n, lo, hi, 0.7))
    presses, switches = [], np.zeros(0)
    if requests is not None:
        alpha[(t >= requests[0]) & (t < requests[1])] = 0.0
        presses, switches = [requests[0]], np.array([requests[1]])
    trace = {"t": t, "belief": belief, "alpha": alpha, "u": np.zeros((len(t), 6))}
    task = "reaching" if n == 5 else "pouring"
    return LoggedTrial(_record(task=task, requests=presses), trace, request_switch_times=switches)


def test_alpha_law_recovers_thresholds_rounding_and_requests() -> None:
    trials = [_alpha_trial(5, 0.25, 0.30, 0, (2.0, 4.6)), _alpha_trial(4, 0.30, 0.35, 1)]
    law = fit_alpha_law(trials)
    assert law.alpha_max == pytest.approx(0.7)
    assert law.decimals == 3
    assert law.thresholds == {5: (0.25, 0.3), 4: (0.3, 0.35)}
    assert all(v == 1.0 for v in law.match.values())
    # Without the request's window the law would miss the rows during the request.
    trial = trials[0]
    no_request = LoggedTrial(_record(task="reaching"), trial.trace, request_switch_times=np.zeros(0))
    assert not alpha_matches(no_request, law).all()


def test_request_timing_counts_the_belief_changes_in_the_windows() -> None:
    from drake_disamb.study.measures.identify import request_timing

    trial = _alpha_trial(5, 0.25, 0.30, 0, (2.0, 4.6))  # a random belief: it changes at every row
    timing = request_timing([trial])
    assert timing.n == 1 and timing.median == pytest.approx(2.6)
    assert timing.belief_change_share == pytest.approx(1.0)
    t = trial.trace["t"]
    held = dict(trial.trace)
    held["belief"] = trial.trace["belief"].copy()
    inside = np.nonzero((t >= 2.0) & (t < 4.6))[0]
    held["belief"][inside] = held["belief"][inside[0]]  # held from the press to the switch
    timing = request_timing([LoggedTrial(trial.record, held, request_switch_times=np.array([4.6]))])
    assert timing.belief_change_share == 0.0 and timing.belief_change_share_outside > 0.9


def test_solve_positions_from_attractors_and_a_repeller() -> None:
    rng = np.random.default_rng(3)
    goals = np.array([[0.3, -0.5, 0.1], [-0.1, -0.6, 0.1], [0.1, -0.5, 0.4], [-0.3, -0.4, 0.2]])
    x = np.vstack([rng.uniform([-0.3, -0.5, 0.1], [0.3, -0.2, 0.4], (40, 3)), goals[2] + [0.05, 0.0, 0.0]])
    config = PotentialFieldConfig(attractor_gain_translation=1.0, repeller_gain=0.0, max_linear_speed=0.1)
    q = np.tile([1.0, 0.0, 0.0, 0.0], (len(goals), 1))
    u = potential_field_commands(x, np.tile([1.0, 0.0, 0.0, 0.0], (len(x), 1)), goals, q, config)[..., :3]
    near = np.argmin(np.linalg.norm(x[:, None] - goals, axis=-1), axis=1)
    d = x - goals[near]
    repel = 0.001 * d / np.sum(d * d, axis=1, keepdims=True)
    repel[np.linalg.norm(d, axis=1) > 0.1] = 0.0
    assert np.any(repel != 0.0)
    u = u + repel[:, None, :] * (np.arange(len(goals)) != near[:, None])[..., None]
    solved, rms, offset, speed = solve_positions(u, goals)
    assert speed == pytest.approx(0.1)
    assert np.max(np.abs(solved - x)) < 1e-6
    assert np.max(rms) < 1e-8
    assert np.max(np.abs(offset - repel)) < 1e-6


def _scores_trial(keep_winners: set[int]) -> LoggedTrial:
    """Requests of a head array whose mode ids 1..6 are the dimensions vx, vy, vz, wz, wx, wy, and
    whose score columns are in dimension order; only requests won by ``keep_winners`` columns."""
    rng = np.random.default_rng(4)
    dims = rng.uniform(0.0, 1.0, (36, 6))
    dims[np.arange(36), np.arange(36) % 6] += 2.0  # every column wins some requests
    order = [(0,), (1,), (2,), (5,), (3,), (4,)]
    winner = np.argmax(dims, axis=1)
    dims = dims[np.isin(winner, list(keep_winners))]
    ids = np.array([1 + order.index((int(w),)) for w in np.argmax(dims, axis=1)])
    trace = {"request_mode_scores": dims.copy(), "request_dim_scores": dims, "request_mode_ids": ids}
    k = len(ids)
    return LoggedTrial(_record(requests=[1.0] * k), trace, request_switch_times=np.ones(k))


def test_mode_map_from_scores() -> None:
    m = identify_mode_map([_scores_trial(set(range(6)))], "head_array")
    assert m.column_dims == [(0,), (1,), (2,), (3,), (4,), (5,)] and m.sum_residual < 1e-12
    assert m.argmax_share == 1.0 and m.consistent
    assert m.mode_order == [(0,), (1,), (2,), (5,), (3,), (4,)]
    assert m.unresolved == ([], [])
    # wx never scores highest: id 5 is the one left (elimination); with wy neither, both unresolved.
    m = identify_mode_map([_scores_trial({0, 1, 2, 4, 5})], "head_array")
    assert m.mode_order == [(0,), (1,), (2,), (5,), (3,), (4,)]
    m = identify_mode_map([_scores_trial({0, 1, 2, 5})], "head_array")
    assert m.mode_order == [(0,), (1,), (2,), (5,), None, None]
    assert m.unresolved == ([5, 6], [(3,), (4,)])
    # A switch that does not follow the scores counts against the argmax share.
    trial = _scores_trial(set(range(6)))
    trial.trace["request_mode_ids"][0] = 7
    assert identify_mode_map([trial], "head_array").argmax_share < 1.0


# -- the authors' logs ------------------------------------------------------------------------------


@functools.cache
def _logs():
    from drake_disamb.study.data.authors import read_trials
    from drake_disamb.study.measures.identify import identify

    trials = read_trials(DATA)
    return trials, identify(DATA, trials=trials)


@needs_data
def test_logs_idle_decay_replays_every_trial() -> None:
    trials, ident = _logs()
    assert ident.period.period == pytest.approx(0.1)
    assert ident.decay.zero_command_excitation is False
    params = ident.decay.params()
    checked = 0
    for trial in trials:
        before, after, _ = idle_steps(trial, ident.period.period)
        err = idle_replay_error(before, after, params, ident.period.period)
        assert err < 1e-6, trial.record.trial_id
        checked += len(before) > 0
    assert checked > 100


@needs_data
def test_logs_alpha_law_on_every_interface_and_task() -> None:
    _, ident = _logs()
    assert len(ident.alpha.match) == 4
    for key, share in ident.alpha.match.items():
        assert share >= 0.99, key


@needs_data
def test_logs_request_mode_is_the_argmax_of_the_scores() -> None:
    _, ident = _logs()
    for name, m in ident.mode_maps.items():
        assert m.argmax_share == 1.0, name
        assert m.consistent and m.sum_residual < 1e-6
    assert ident.mode_maps["joystick"].mode_order == [(0, 1), (0, 2), (3, 5), (4,)]
    assert ident.mode_maps["head_array"].mode_order[:4] == [(0,), (1,), (2,), (5,)]


@needs_data
def test_logs_known_path_blend_law_and_belief_replay() -> None:
    _, ident = _logs()
    kp = ident.known_path
    if kp is None:
        pytest.skip(f"{DATA / 'known_path'} or trial H3PH1REHAT10 is absent")
    assert kp.solved_share > 0.95
    assert np.linalg.norm(np.subtract(kp.start, (0.399, -0.201, 0.276))) < 0.01
    assert kp.blend_share > 0.85 and kp.blend_share_idle > 0.9
    # The rotational commands sit at one speed (a saturation), 0.7 rad/s, nearly always.
    assert kp.rotation_speed == pytest.approx(0.7, abs=0.005) and kp.rotation_share > 0.9
    assert min(kp.best.correlation) > 0.9
    assert kp.best.argmax_agreement > 0.75
    # The proximity term does not replay it (the study's system has none, at any radius tried).
    assert all(np.mean(r.correlation) < np.mean(kp.best.correlation) - 0.1 for r in kp.proximity)


@needs_data
def test_cli_identify_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from drake_disamb.cli import main

    out = tmp_path / "identify.json"
    assert main(["study", "identify", str(DATA), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "Belief update period: 0.100 s" in text and "Request time" in text
    values = json.loads(out.read_text())
    for key in (
        "belief_update_period",
        "idle_tau",
        "zero_command_excitation",
        "alpha_thresholds",
        "alpha_max",
        "request_time",
        "request_mode_is_argmax",
        "mode_order",
    ):
        assert key in values
    assert values["idle_tau"] == pytest.approx(5.1, abs=1e-4)
    assert values["alpha_thresholds"] == {"4": [0.3, 0.35], "5": [0.25, 0.3]}
    assert set(values["request_time"]) >= {"min", "median", "max"}


def test_cli_identify_bad_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from drake_disamb.cli import main

    assert main(["study", "identify", str(tmp_path)]) == 2
    assert "trial-order file is missing" in capsys.readouterr().err


# -- the study's system as a preset -----------------------------------------------------------------


def test_blending_thresholds_above_uniform() -> None:
    from drake_disamb.core.blending import BlendingConfig

    config = BlendingConfig(rho1_above_uniform=0.05, rho2_above_uniform=0.10)
    assert config.rhos(4) == pytest.approx((0.30, 0.35, 0.7))
    assert config.rhos(5) == pytest.approx((0.25, 0.30, 0.7))
    assert BlendingConfig().rhos(5) == pytest.approx((0.24, 0.28, 0.7))  # the paper's
    with pytest.raises(ValueError, match="rho1 or rho1_above_uniform, not both"):
        BlendingConfig(rho1=0.3, rho1_above_uniform=0.05)
    with pytest.raises(ValueError, match=r"rho2_above_uniform: expected a number in \[-1, 1\]"):
        BlendingConfig(rho2_above_uniform=float("nan"))
    with pytest.raises(ValueError, match="rho1: expected a number in"):
        BlendingConfig(rho1_above_uniform=0.9).rhos(2)


def _preset_scenario(task: str, name: str):
    from drake_disamb.config import load_scenario, resolve_scenario
    from drake_disamb.config.system_presets import system_layer

    scenario = load_scenario(task, system_layer(name))
    return scenario, resolve_scenario(scenario)


def test_system_presets_load_and_resolve() -> None:
    from drake_disamb.config.system_presets import SYSTEM_PRESETS, system_layer

    assert system_layer("mico").data == {}
    with pytest.raises(ValueError, match="system: expected one of mico, tnsre2020_study, got 'nope'"):
        system_layer("nope")
    for name in SYSTEM_PRESETS:
        for task in ("reaching", "pouring"):
            _preset_scenario(task, name)
    scenario, cfg = _preset_scenario("reaching", "tnsre2020_study")
    assert cfg.rhos == pytest.approx((0.25, 0.30, 0.7))
    dft = cfg.inference.params
    assert (dft.tau1, dft.tau2, dft.euler_equivalent_step) == (5.1, 5.1, 0.1)
    assert not (dft.proximity or dft.zero_command_excitation)
    # the paper's dot product: the logs' requests chose translation modes, which the cosine does not give
    assert dft.agreement and dft.agreement_measure == "dot"
    assert cfg.blending.assist_without_input and scenario.inference.goal_set == "task"
    _, cfg = _preset_scenario("pouring", "tnsre2020_study")
    assert cfg.rhos == pytest.approx((0.30, 0.35, 0.7))
    _, mico = _preset_scenario("reaching", "mico")
    assert mico.rhos == pytest.approx((0.24, 0.28, 0.7)) and mico.inference.params.tau1 == 4.0


def test_protocol_names_a_system() -> None:
    from drake_disamb.study.design.protocol import default_protocol_text, protocol_from_yaml

    text = default_protocol_text()
    assert "\nsystem: tnsre2020_study\n" in text and protocol_from_yaml(text).system == "tnsre2020_study"
    assert protocol_from_yaml(text.replace("system: tnsre2020_study", "system: mico")).system == "mico"
    with pytest.raises(ValueError, match="protocol.system: expected one of mico, tnsre2020_study"):
        protocol_from_yaml(text.replace("system: tnsre2020_study", "system: nope"))
    without = "\n".join(line for line in text.splitlines() if not line.startswith("system:"))
    assert protocol_from_yaml(without).system == "tnsre2020_study"  # the default


def test_the_preset_runs_the_head_array_in_the_studys_mode_order() -> None:
    _, head = _preset_scenario("reaching", "tnsre2020_study")
    assert head.interface.kind == "head_array"
    assert head.interface.modes == ((0,), (1,), (2,), (5,), (3,), (4,), (6,))  # vx vy vz wz wx wy
    _, mico = _preset_scenario("reaching", "mico")
    assert mico.interface.modes == ((0,), (1,), (2,), (3,), (4,), (5,), (6,))  # ours, registered


@needs_data
def test_study_preset_holds_the_identified_values() -> None:
    from drake_disamb.config.system_presets import system_layer

    _, ident = _logs()
    preset = system_layer("tnsre2020_study").data
    dft, blending = preset["inference"]["dft"], preset["blending"]
    assert dft["tau1"] == dft["tau2"] == pytest.approx(ident.decay.tau, abs=1e-3)
    assert dft["euler_equivalent_step"] == pytest.approx(ident.period.period)
    assert dft["zero_command_excitation"] is ident.decay.zero_command_excitation
    assert dft["lam"] == pytest.approx(ident.known_path.best.lam, rel=0.05)
    assert blending["rho3"] == pytest.approx(ident.alpha.alpha_max)
    for n, (lo, hi) in ident.alpha.thresholds.items():
        assert (blending["rho1_above_uniform"], blending["rho2_above_uniform"]) == pytest.approx(
            (lo - 1.0 / n, hi - 1.0 / n)
        )
    assert blending["assist_without_input"] is (ident.known_path.blend_share_idle > 0.9)
    # The loop paused while a request was computed: the belief held, alpha and the command 0.
    held = ident.requests.belief_change_share < 0.01 and ident.requests.zero_share > 0.99
    assert ident.requests.belief_change_share_outside > 0.3  # it updates elsewhere
    assert preset["disambiguation"]["hold_while_computing"] is held
    # The mode order: every mode the logs resolve is where the preset puts it (the rest is ours).
    for kind, order in ident.to_json()["mode_order"].items():
        ours = preset.get("interface_mode_order", {}).get(kind)
        ours = [list(m) for m in ours] if ours is not None else None
        for k, dims in enumerate(order):
            if dims is not None:
                expected = ours[k] if ours is not None else list(INTERFACES[kind].mode_order[k])
                assert sorted(dims) == sorted(expected), (kind, k, dims, expected)


@needs_data
def test_the_protocols_request_latency_is_the_logged_range() -> None:
    from drake_disamb.study.design.protocol import default_protocol

    _, ident = _logs()
    lo, hi = default_protocol().request_latency
    got = ident.to_json()["request_time"]
    assert lo == pytest.approx(got["min"], abs=0.01) and hi == pytest.approx(got["max"], abs=0.01)
