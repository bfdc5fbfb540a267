"""``benchmarks/bench_belief_integrator.py``: the DFT belief integrated by each scheme on published trials."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from support import benchmark_module

from drake_disamb.comparison.trial_files import load_trials

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "tnsre2018_simulated_trajectories"


@pytest.fixture(scope="module")
def bench():  # noqa: ANN201 (the benchmark module)
    with benchmark_module("bench_belief_integrator") as module:
        yield module


@pytest.fixture(scope="module")
def trials():  # noqa: ANN201
    if not DATA.is_dir():
        pytest.skip(f"published trajectories not found at {DATA} (the shared data folder beside the repo)")
    return load_trials(DATA, limit=2)


@pytest.fixture(scope="module")
def result_10ms(bench, trials):  # noqa: ANN001, ANN201
    return bench.run_benchmark(trials, bench.PARAMS["authors"], 0.01)


def test_tick_trial_takes_every_stride_th_sample(bench, trials) -> None:  # noqa: ANN001
    trial = trials[0]
    same = bench.tick_trial(trial, trial.dt)
    assert same.n_steps == trial.n_steps and np.array_equal(same.zeroed_mask(), trial.zeroed_mask())
    ticked = bench.tick_trial(trial, 0.01)
    idx = np.arange(trial.n_steps // 5 + 1) * 5
    assert ticked.dt == 0.01 and ticked.n_steps == trial.n_steps // 5
    assert np.array_equal(ticked.traj, trial.traj[idx]) and np.array_equal(ticked.u_h, trial.u_h[idx[:-1]])
    assert np.array_equal(ticked.true_goal, trial.true_goal[idx])
    assert np.array_equal(ticked.zeroed_mask(), trial.zeroed_mask()[idx])
    with pytest.raises(ValueError, match="period: expected a whole multiple"):
        bench.tick_trial(trial, 0.003)


def test_every_scheme_gives_probability_vectors_at_its_cost(bench, trials, result_10ms) -> None:  # noqa: ANN001
    runs = result_10ms.runs
    assert set(runs) == {*bench.SCHEMES, bench.REFERENCE}
    for name, run in runs.items():
        assert len(run.beliefs) == len(trials)
        for belief, trial in zip(run.beliefs, result_10ms.tick_trials, strict=True):
            assert belief.shape == (trial.n_steps + 1, trial.n_goals), name
            assert np.all(np.isfinite(belief)) and np.all(belief > 0), name
            np.testing.assert_allclose(belief.sum(axis=1), 1.0, atol=1e-12, err_msg=name)
        # The mass-conserving flow keeps sum(p) = 1 under every explicit Runge-Kutta scheme.
        assert run.max_sum_error < 1e-12, name
    table = bench.summarize(result_10ms)
    for scheme, evaluations in zip(bench.SCHEMES, (1, 2, 3), strict=True):
        assert table[scheme].steps_per_tick == 1.0
        assert table[scheme].evaluations_per_tick == evaluations
    assert table[bench.REFERENCE].steps_per_tick == pytest.approx(100.0)


def test_euler_error_against_the_reference_is_bounded_and_rk_is_closer(bench, result_10ms) -> None:  # noqa: ANN001
    table = bench.summarize(result_10ms)
    euler, rk2, rk3 = (table[s] for s in bench.SCHEMES)
    # Measured on these two trials with the authors' parameters (lambda = 200, stiff at 10 ms):
    # Euler 0.15 max / 0.0089 mean, RK2 0.058 / 0.0048, RK3 0.017 / 0.0011.
    assert np.isfinite(euler.max_error) and 0.0 < euler.max_error < 0.3
    assert euler.mean_error < 0.03
    assert rk3.max_error < rk2.max_error < euler.max_error
    assert rk3.mean_error < rk2.mean_error < euler.mean_error
    assert table[bench.REFERENCE].max_error == 0.0


def test_reference_at_the_data_rate_scores_like_the_core_replay(bench, trials) -> None:  # noqa: ANN001
    """At the data's 2 ms every sample is a tick: the continuous flow scores as the authors' Euler."""
    params = bench.PARAMS["authors"]
    result = bench.run_benchmark(trials, params, 0.002, schemes=("explicit_euler",), reference_step=2.5e-4)
    table = bench.summarize(result)
    replay = bench.core_replay_accuracy(trials, params)
    assert table["explicit_euler"].max_error < 0.03
    assert table[bench.REFERENCE].published == pytest.approx(replay[0], abs=0.01)
    assert table[bench.REFERENCE].strict == pytest.approx(replay[1], abs=0.01)


def test_missing_data_folder_is_a_clear_message(bench, tmp_path: Path, capsys) -> None:  # noqa: ANN001
    assert bench.main(["--data", str(tmp_path / "absent")]) == 2
    err = capsys.readouterr().err
    assert "published trials are not at" in err and str(tmp_path / "absent") in err
