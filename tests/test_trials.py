"""Published-data replay, our generator, the vectorised replay, metrics, bad input and the CLI."""

from __future__ import annotations

import argparse
import functools
import hashlib
import json
import time
from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat, savemat

from drake_disamb.commands import inference_benchmark
from drake_disamb.comparison.replay import (
    METHODS,
    PUBLISHED_ACCURACY,
    authors_dft_params,
    replay_trials,
    score_trial_stream,
    score_trials,
    trial_accuracy,
)
from drake_disamb.comparison.trial_files import load_trial_mat, load_trials, save_trial_mat
from drake_disamb.comparison.trials import (
    GeneratorConfig,
    Trial,
    generate_trials,
    iter_generated_chunks,
)
from drake_disamb.core.inference import bayes_step, dft_euler_step, memory_step, uniform_belief
from drake_disamb.core.sampling import sample_von_mises_fisher

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "tnsre2018_simulated_trajectories"


def published_data() -> Path:
    if not DATA.is_dir():
        pytest.skip(f"published trajectories not found at {DATA} (the shared data folder beside the repo)")
    return DATA


def reference_replay(trial: Trial) -> dict[str, np.ndarray]:
    """Plain per-sample loop with the single-step core functions (the authors' loop, in Python)."""
    n, L = trial.n_goals, trial.n_steps
    params = authors_dft_params(transition=trial.transition)
    out = {m: np.empty((L + 1, n)) for m in METHODS}
    for m in METHODS:
        out[m][0] = uniform_belief(n)
    cost = 0.0
    for j in range(L):
        x, x1, u = trial.traj[j], trial.traj[j + 1], trial.u_h[j]
        out["dft"][j + 1] = dft_euler_step(out["dft"][j], u, x, trial.goals, params, trial.dt)
        out["bayes"][j + 1] = bayes_step(out["bayes"][j], u, x, trial.goals, trial.transition)
        out["memory"][j + 1], cost = memory_step(
            out["memory"][j], cost, x, x1, trial.traj[0], trial.goals, trial.transition
        )
    return out


@pytest.fixture(scope="module")
def generated_500() -> list[Trial]:
    return generate_trials(500, seed=2020)


# ----------------------------------------------------------------------------------------------
# Published data
# ----------------------------------------------------------------------------------------------


def test_published_numbers_are_reproduced() -> None:
    trials = load_trials(published_data())
    assert len(trials) == 100
    scores = score_trials(trials, replay_trials(trials))
    expected = {
        "dft": (0.8795, 0.8442),
        "bayes": (0.8879, 0.8547),
        "memory": (0.5951, 0.4390),
    }
    for m, (published, strict) in expected.items():
        assert abs(scores[m]["published"].mean() - published) < 0.0015, m
        assert abs(np.nanmean(scores[m]["strict"]) - strict) < 0.0015, m


def test_loader_matches_the_file() -> None:
    path = published_data() / "trajectory_1.mat"
    raw = loadmat(path)
    tr = load_trial_mat(path)
    n, L = int(raw["ng"][0, 0]), raw["uh_history_zeroed"].shape[1]
    assert (tr.n_goals, tr.n_steps) == (n, L)
    np.testing.assert_array_equal(tr.goals, raw["xg"].T)
    np.testing.assert_array_equal(tr.traj, raw["traj_zeroed"].T)
    np.testing.assert_array_equal(tr.u_h, raw["uh_history_zeroed"].T)
    np.testing.assert_array_equal(tr.true_goal, raw["true_goal_index_history"][0].astype(int) - 1)
    assert tr.zeroed_start == int(raw["min_ind"][0, 0]) - 1 and tr.zeroed_stop == int(raw["max_ind"][0, 0])
    assert np.all(tr.u_h[tr.zeroed_start : tr.zeroed_stop] == 0)


def test_vectorised_replay_equals_the_plain_loop() -> None:
    """Published trials with different goal counts and lengths, plus generated ones, in one batch."""
    trials = [t for t in generate_trials(8, seed=5) if t.n_steps < 500][:3]
    if DATA.is_dir():
        trials += [load_trial_mat(DATA / f"trajectory_{k}.mat") for k in (3, 8, 13)]
    assert len({t.n_goals for t in trials}) > 1
    fast = replay_trials(trials)
    for i, tr in enumerate(trials):
        ref = reference_replay(tr)
        for m in METHODS:
            np.testing.assert_allclose(fast[m][i], ref[m], rtol=1e-10, atol=1e-300, err_msg=f"{m} trial {i}")


# ----------------------------------------------------------------------------------------------
# Generator
# ----------------------------------------------------------------------------------------------


SCORES_500_SEED_2020 = "b30cda6813f0e41e2e75ecd704259843e932bcd3f387f17d77ccb555796f56b2"
"""sha256 of the per-trial scores of generate_trials(500, seed=2020) before the generator was chunked."""


def _digest(scores: dict) -> str:
    h = hashlib.sha256()
    for m in METHODS:
        for k in ("published", "strict"):
            h.update(np.asarray(scores[m][k], dtype=np.float64).tobytes())
    return h.hexdigest()


def test_generated_trials_reproduce_the_paper(generated_500: list[Trial]) -> None:
    scores = score_trials(generated_500, replay_trials(generated_500))
    # Chunked seeding keeps the first 500 trials of a seed exactly those of the unchunked generator.
    assert _digest(scores) == SCORES_500_SEED_2020
    acc = {m: scores[m]["published"].mean() for m in METHODS}
    assert abs(acc["dft"] - PUBLISHED_ACCURACY["dft"]) < 0.03
    assert abs(acc["bayes"] - PUBLISHED_ACCURACY["bayes"]) < 0.03
    assert acc["memory"] < min(acc["dft"], acc["bayes"]) - 0.15


def test_generated_trials_follow_the_protocol(generated_500: list[Trial]) -> None:
    cfg = GeneratorConfig()
    lengths = np.array([t.n_steps for t in generated_500])
    assert 450 < lengths.mean() < 800  # the paper's data: mean 614 steps
    assert set(t.n_goals for t in generated_500) == {2, 3, 4, 5}
    for tr in generated_500[:100]:
        n, L = tr.n_goals, tr.n_steps
        assert tr.traj.shape == (L + 1, 3) and tr.u_h.shape == (L, 3) and tr.true_goal.shape == (L + 1,)
        assert tr.true_goal.min() >= 0 and tr.true_goal.max() < n
        np.testing.assert_allclose(tr.transition.sum(axis=1), 1.0)
        assert np.all(np.diag(tr.transition) > 0.9)
        assert np.all(np.abs(tr.goals) <= 0.5) and np.all(np.abs(tr.x_start) <= 0.5)
        # The raw path ends within the tolerance of the final goal.
        assert np.linalg.norm(tr.traj_raw[-1] - tr.goals[tr.true_goal[-1]]) < cfg.goal_tolerance
        # Commands: unit speed or dropped (whole or one component) — never longer than 1 m/s.
        speed = np.linalg.norm(tr.u_h_raw, axis=1)
        assert np.all(speed <= 1 + 1e-9)
        # Zeroed stretch: starts in the first half, lasts at most 201 samples, commands zero.
        assert 0 <= tr.zeroed_start < (L + 1) // 2 + 1
        assert tr.zeroed_stop - tr.zeroed_start <= cfg.max_zeroed + 1
        assert np.all(tr.u_h[tr.zeroed_start : tr.zeroed_stop] == 0)
        np.testing.assert_array_equal(tr.traj[0], tr.x_start)
        np.testing.assert_array_equal(tr.traj[-1], tr.traj[-2])  # as the authors' files


def test_generator_is_seeded() -> None:
    a, b, c = generate_trials(4, seed=7), generate_trials(4, seed=7), generate_trials(4, seed=8)
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x.traj, y.traj)
        np.testing.assert_array_equal(x.u_h, y.u_h)
    assert any(
        x.n_steps != z.n_steps or not np.array_equal(x.goals, z.goals) for x, z in zip(a, c, strict=True)
    )


@pytest.mark.parametrize("kappa", [2.0, 20.0, 2e5])
def test_von_mises_fisher_sampler(kappa: float) -> None:
    rng = np.random.default_rng(1)
    mu = rng.normal(size=3)
    x = sample_von_mises_fisher(np.tile(mu, (40000, 1)), kappa, rng)
    np.testing.assert_allclose(np.linalg.norm(x, axis=1), 1.0, atol=1e-12)
    w = x @ (mu / np.linalg.norm(mu))
    mean_w = 1 / np.tanh(kappa) - 1 / kappa  # mean resultant length in 3-D
    assert abs(w.mean() - mean_w) < 5 * np.sqrt(max(w.var(), 1e-30) / len(w)) + 1e-12
    # The orthogonal part is isotropic: its mean direction vanishes.
    ortho = x - w[:, None] * (mu / np.linalg.norm(mu))
    assert np.linalg.norm(ortho.mean(axis=0)) < 5 * np.sqrt((1 - mean_w**2 + 1e-12) / len(w)) + 1e-9
    assert np.all(sample_von_mises_fisher(np.zeros((3, 3)), kappa, rng) == 0)


def test_save_and_load_round_trip(tmp_path: Path) -> None:
    tr = generate_trials(1, seed=3)[0]
    save_trial_mat(tr, tmp_path / "trajectory_1.mat")
    back = load_trial_mat(tmp_path / "trajectory_1.mat")
    for name in ("goals", "transition", "traj", "u_h", "true_goal", "x_start", "traj_raw", "u_h_raw"):
        np.testing.assert_array_equal(getattr(back, name), getattr(tr, name), err_msg=name)
    assert (back.zeroed_start, back.zeroed_stop, back.dt) == (tr.zeroed_start, tr.zeroed_stop, tr.dt)


# ----------------------------------------------------------------------------------------------
# Metrics
# ----------------------------------------------------------------------------------------------


def test_metrics_count_the_zeroed_stretch_as_the_authors() -> None:
    L = 9
    tr = Trial(
        goals=np.zeros((2, 3)),
        transition=np.eye(2),
        dt=0.002,
        traj=np.zeros((L + 1, 3)),
        u_h=np.zeros((L, 3)),
        true_goal=np.array([0, 0, 0, 0, 1, 1, 1, 1, 1, 1]),
        zeroed_start=2,
        zeroed_stop=5,
        x_start=np.zeros(3),
    )
    belief = np.tile([0.5, 0.5], (L + 1, 1))  # ties -> goal 0 (first index, as MATLAB's max)
    belief[7:] = [0.2, 0.8]
    published, strict = trial_accuracy(belief, tr)
    # correct: samples 0, 1 (outside), 7, 8, 9; samples 2..4 are the stretch.
    assert published == pytest.approx(8 / 10)
    assert strict == pytest.approx(5 / 7)
    with pytest.raises(ValueError, match="belief"):
        trial_accuracy(belief[:-1], tr)


# ----------------------------------------------------------------------------------------------
# Bad input
# ----------------------------------------------------------------------------------------------


@functools.cache
def _one_trial() -> Trial:
    return generate_trials(1, seed=11)[0]


def _write(tmp_path: Path, name: str = "trajectory_1.mat", **changes: object) -> Path:
    tr = _one_trial()
    path = tmp_path / name
    save_trial_mat(tr, path)
    data = {k: v for k, v in loadmat(path).items() if not k.startswith("__")}
    for key, value in changes.items():
        if value is None:
            del data[key]
        else:
            data[key] = value
    savemat(path, data)
    return path


def test_bad_files_name_the_file_and_field(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="missing.mat: no such file"):
        load_trial_mat(tmp_path / "missing.mat")
    junk = tmp_path / "junk.mat"
    junk.write_bytes(b"this is not a MATLAB file at all" * 10)
    with pytest.raises(ValueError, match="junk.mat: not a readable MATLAB"):
        load_trial_mat(junk)
    path = _write(tmp_path, traj_zeroed=None)
    with pytest.raises(ValueError, match=r"trajectory_1.mat: missing field 'traj_zeroed'"):
        load_trial_mat(path)
    path = _write(tmp_path, uh_history_zeroed=np.zeros((3, 5)))
    with pytest.raises(ValueError, match=r"trajectory_1.mat: field 'uh_history_zeroed' has shape \(3, 5\)"):
        load_trial_mat(path)
    path = _write(tmp_path, xg=np.zeros((3, 9)))
    with pytest.raises(ValueError, match="field 'xg' has shape"):
        load_trial_mat(path)
    path = _write(tmp_path, true_goal_index_history=np.zeros((1, 3)))
    with pytest.raises(ValueError, match="field 'true_goal_index_history'"):
        load_trial_mat(path)
    path = _write(tmp_path, goal_transition_P=np.full((5, 5), 0.5))
    with pytest.raises(ValueError, match="goal_transition_P"):
        load_trial_mat(path)
    path = _write(tmp_path, delta_t=np.array([[-1.0]]))
    with pytest.raises(ValueError, match="field 'delta_t'"):
        load_trial_mat(path)
    path = _write(tmp_path, traj_zeroed=np.full((3, 4), np.nan))
    with pytest.raises(ValueError, match="field 'traj_zeroed' has non-finite"):
        load_trial_mat(path)
    path = _write(tmp_path, min_ind=np.array([[0]]))
    with pytest.raises(ValueError, match="'min_ind'/'max_ind'"):
        load_trial_mat(path)


def test_bad_folders(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="no .mat trajectory files"):
        load_trials(tmp_path)
    with pytest.raises(ValueError, match="no such directory"):
        load_trials(tmp_path / "nowhere")
    with pytest.raises(ValueError, match="nothing to replay"):
        replay_trials([])
    with pytest.raises(ValueError, match="methods"):
        replay_trials(generate_trials(1, seed=0), methods=("oracle",))


# ----------------------------------------------------------------------------------------------
# CLI
# ----------------------------------------------------------------------------------------------


def _cli(*argv: str) -> int:
    parser = argparse.ArgumentParser()
    inference_benchmark.add_arguments(parser)
    return inference_benchmark.run(parser.parse_args(list(argv)))


def test_cli_on_files_writes_json_and_plot(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    data = tmp_path / "data"
    data.mkdir()
    for i, tr in enumerate(generate_trials(3, seed=4)):
        save_trial_mat(tr, data / f"trajectory_{i + 1}.mat")
    out_json, out_png = tmp_path / "r.json", tmp_path / "r.png"
    code = _cli("--data", str(data), "--json", str(out_json), "--plot", str(out_png), "--quiet")
    assert code == 0
    printed = capsys.readouterr().out
    assert "field-theoretic" in printed and "strict" in printed
    result = json.loads(out_json.read_text())
    assert result["trials"] == 3
    assert set(result["methods"]) == {"dft", "bayes", "memory"}
    for m in result["methods"].values():
        assert 0.0 <= m["published_metric"] <= 1.0 and 0.0 <= m["strict_metric"] <= 1.0
    assert out_png.stat().st_size > 10_000


def test_cli_generate_matches_the_library(tmp_path: Path) -> None:
    out_json = tmp_path / "g.json"
    assert _cli("--generate", "5", "--seed", "9", "--json", str(out_json), "--quiet") == 0
    trials = generate_trials(5, seed=9)
    scores = score_trials(trials, replay_trials(trials))
    got = json.loads(out_json.read_text())["methods"]
    for m in METHODS:
        assert got[m]["published_metric"] == pytest.approx(scores[m]["published"].mean())


def test_cli_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert _cli("--data", str(tmp_path), "--quiet") == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and str(tmp_path) in err
    path = _write(tmp_path, xg=None)
    assert _cli("--data", str(path.parent), "--quiet") == 2
    assert "missing field 'xg'" in capsys.readouterr().err
    assert _cli("--generate", "0") == 2


# ----------------------------------------------------------------------------------------------
# Streaming (bounded memory) and robustness of the command
# ----------------------------------------------------------------------------------------------


def test_generated_trial_does_not_depend_on_how_many(monkeypatch: pytest.MonkeyPatch) -> None:
    from drake_disamb.comparison import trials as trials_module

    monkeypatch.setattr(trials_module, "GENERATOR_CHUNK", 6)
    many, few = generate_trials(17, seed=12), generate_trials(8, seed=12)
    assert [len(c) for c in iter_generated_chunks(17, seed=12)] == [6, 6, 5]
    for a, b in zip(many[:8], few, strict=True):
        np.testing.assert_array_equal(a.traj, b.traj)
        np.testing.assert_array_equal(a.u_h, b.u_h)
        assert a.source == b.source
    assert many[16].source == "generated(seed=12, trial=16)"
    assert not np.array_equal(many[0].goals, many[6].goals)  # chunks have their own seeds


def test_streamed_scores_equal_the_all_at_once_path(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    from drake_disamb.comparison import trials as trials_module

    monkeypatch.setattr(trials_module, "GENERATOR_CHUNK", 7)
    trials = generate_trials(20, seed=6)
    whole = score_trials(trials, replay_trials(trials))
    streamed = score_trial_stream(iter_generated_chunks(20, seed=6), keep=15)
    assert streamed.n_trials == 20 and streamed.example.source == trials[15].source
    for m in METHODS:
        for k in ("published", "strict"):
            np.testing.assert_array_equal(streamed.scores[m][k], whole[m][k])
    out_json = tmp_path / "s.json"
    assert _cli("--generate", "20", "--seed", "6", "--json", str(out_json), "--quiet") == 0
    per_trial = json.loads(out_json.read_text())["per_trial"]
    for m in METHODS:
        np.testing.assert_array_equal(np.asarray(per_trial[m]["published"]), whole[m]["published"])


def _fake_v73(path: Path) -> Path:
    """The 128-byte header of a MATLAB v7.3 file (version 0x0200), then the HDF5 signature."""
    text = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 ."
    path.write_bytes(text.ljust(116) + bytes(8) + b"\x00\x02IM" + b"\x89HDF\r\n\x1a\n" + bytes(64))
    return path


def test_matlab_v73_file_is_a_clear_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = _fake_v73(tmp_path / "trajectory_1.mat")
    with pytest.raises(
        ValueError, match=r"trajectory_1.mat: MATLAB v7.3 \(HDF5\) .mat files are not supported"
    ):
        load_trial_mat(path)
    assert _cli("--data", str(tmp_path), "--quiet") == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and "re-save it as v7" in err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--generate", "1000000000"], "--generate: expected a number of trials in [1, 1000000]"),
        (["--generate", "5", "--seed", "-1"], "--seed: expected an integer >= 0, got -1"),
        (["--json", "{dir}"], "--json: '{dir}' is a folder, expected a file name"),
        (["--json", "{file}/r.json"], "{file} is a file, expected a folder"),
        (["--plot", "{dir}/r.xyz"], "--plot: {dir}/r.xyz: expected a file name ending in one of"),
        (["--plot", "{file}/r.png"], "{file} is a file, expected a folder"),
        (["--plot", "{dir}/r.png", "--example", "500"], "--example: expected a trial index in [0, 499]"),
    ],
)
def test_cli_bad_options_fail_before_the_work(
    argv: list[str], message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("x")
    fill = {"dir": str(tmp_path), "file": str(blocker)}
    start = time.perf_counter()
    assert _cli(*[a.format(**fill) for a in argv], "--quiet") == 2
    assert time.perf_counter() - start < 2.0  # nothing generated or replayed
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message.format(**fill) in err
    assert blocker.read_text() == "x"


@pytest.mark.parametrize("target", ["missing.mat", "trajectory_1.mat"], ids=["dangling", "itself"])
def test_a_broken_mat_link_is_named_not_skipped(tmp_path: Path, target: str) -> None:
    _write(tmp_path, "trajectory_0.mat")  # one good file beside it
    (tmp_path / "trajectory_1.mat").symlink_to(tmp_path / target)
    with pytest.raises(ValueError, match=r"trajectory_1.mat: a broken link"):
        load_trials(tmp_path)
