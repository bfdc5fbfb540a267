"""Wall time of the inference comparison: load N trial files and replay them with all three methods.

Generates N trials with our seeded generator (default 500, the size of the paper's comparison),
writes them as .mat files in the authors' format to a temporary folder (not timed), then times
``load_trials`` + ``replay_trials`` (DFT, recursive Bayes, memory-based) + ``score_trials``, i.e.
the whole ``drake-disamb inference-benchmark --data DIR`` pipeline without printing. If the
published trajectories are present beside the repository (../shared/data/...), they are timed too.

Usage: python benchmarks/bench_inference.py [--trials N] [--seed S] [--repeats R]
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from drake_disamb.comparison.replay import METHODS, replay_trials, score_trials
from drake_disamb.comparison.trial_files import load_trials, save_trial_mat
from drake_disamb.comparison.trials import generate_trials

PUBLISHED = (
    Path(__file__).resolve().parents[1].parent / "shared" / "data" / "tnsre2018_simulated_trajectories"
)


def time_pipeline(folder: Path, repeats: int) -> tuple[list[float], dict, int, int]:
    """Wall and CPU seconds of load + replay + score, best of ``repeats``; last scores."""
    walls, cpus = [], []
    for _ in range(repeats):
        w, c = time.perf_counter(), time.process_time()
        trials = load_trials(folder)
        loads = time.perf_counter() - w
        scores = score_trials(trials, replay_trials(trials))
        walls.append(time.perf_counter() - w)
        cpus.append(time.process_time() - c)
    steps = sum(t.n_steps for t in trials)
    return walls, {"cpu": cpus, "load": loads, "scores": scores}, len(trials), steps


def report(name: str, walls: list[float], extra: dict, n: int, steps: int) -> None:
    print(f"{name}: {n} trials, {steps} samples, 3 methods")
    print(
        f"  wall time load+replay+score: best {min(walls):.2f} s, median {statistics.median(walls):.2f} s "
        f"over {len(walls)} runs (CPU best {min(extra['cpu']):.2f} s; file loading {extra['load']:.2f} s "
        f"in the last run)"
    )
    for m in METHODS:
        s = extra["scores"][m]
        print(
            f"  {m:<7} paper metric {100 * s['published'].mean():6.2f} %   "
            f"strict {100 * np.nanmean(s['strict']):6.2f} %"
        )


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--trials", type=int, default=500)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    t = time.perf_counter()
    trials = generate_trials(args.trials, seed=args.seed)
    took = time.perf_counter() - t
    print(f"generated {args.trials} trials (seed {args.seed}) in {took:.2f} s (not timed below)")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for i, tr in enumerate(trials):
            save_trial_mat(tr, folder / f"trajectory_{i + 1}.mat")
        report("generated trials as .mat files", *time_pipeline(folder, args.repeats))
    if PUBLISHED.is_dir():
        report("published trajectories", *time_pipeline(PUBLISHED, args.repeats))
    else:
        print(f"published trajectories not found at {PUBLISHED}: skipped")


if __name__ == "__main__":
    main()
