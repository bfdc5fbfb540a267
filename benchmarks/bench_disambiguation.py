"""Latency of one disambiguation request (Algorithm 1, numpy core).

Prints the median and 95th-percentile wall time of one call of
:func:`drake_disamb.core.disambiguation.disambiguate` (validation, forward projection of all
probes, features, scores, mode choice) for:

- the MICO configuration: the ``mico`` preset, the 5 goals of the single-step reaching task
  (FACTS section 8) with seeded random orientations, 6 dimensions, the head array's 6 arm modes;
- the same with 2, 10 and 50 goals drawn (seeded) in the MICO workspace;
- the ``authors-r3`` preset (3 dimensions) for reference.

Each row cycles through ``--scenes`` seeded random requests (belief, end-effector pose) after a
warm-up. The paper reports 2 to 2.5 s per request on the robot; the target here is a median under
1 ms.

Usage: ``python benchmarks/bench_disambiguation.py [--repeats 300] [--seed 0]``

Measured on the shared 2-core development machine, MICO row, median ms (figures swing by up to
1.5-2x with the machine's state; compare versions in the same minute):

- before the caching/layout work (commit 1ad2845): 2.0 (quiet) to 3.5-3.9 (load ~3);
- after it (commit c154a60): 1.2 (quiet) to 2.0;
- after the goal-major DFT drive and the leaner kernels (2026-11-22): 0.90-0.93 in five of ten
  runs, 1.10-1.48 in five runs during slow spells of the machine (the ``authors-r3`` row, 0.59 at
  the usual speed, measured 0.92-1.08 in three of them). What remains is numpy's cost per call on
  small arrays, mostly in the 20-step recursion of the inference update;
- with the in-place Euler normalisation (later the same day), alternating with the previous commit
  in one run: best medians 0.886 vs 0.896. Sixteen runs against the speed gauge of ``_host.py``:
  0.885-0.917 at a gauge of 0.47-0.49 us (the usual speed), 1.15-1.34 at 0.6-1.2 us.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _host import HostMeter, host_summary

from drake_disamb.core.disambiguation import DisambiguationConfig, disambiguate, preset
from drake_disamb.core.geometry import quat_from_rotvec

REACHING_GOALS = np.array(
    [
        [0.328, -0.516, 0.100],
        [-0.116, -0.579, 0.132],
        [0.124, -0.531, 0.442],
        [-0.346, -0.389, 0.220],
        [-0.376, -0.180, 0.102],
    ]
)
HEAD_ARRAY_ARM_MODES = [[0], [1], [2], [3], [4], [5]]


def _scene(rng: np.random.Generator, n_goals: int) -> dict:
    if n_goals == len(REACHING_GOALS):
        goals = REACHING_GOALS
    else:
        goals = np.column_stack(
            [
                rng.uniform(-0.4, 0.4, n_goals),
                rng.uniform(-0.65, -0.15, n_goals),
                rng.uniform(0.05, 0.45, n_goals),
            ]
        )
    return {
        "belief": rng.dirichlet(np.ones(n_goals)),
        "position": np.array([0.0, -0.3, 0.3]) + rng.uniform(-0.1, 0.1, 3),
        "goal_positions": goals,
        "orientation": quat_from_rotvec(rng.normal(scale=0.3, size=3)),
        "goal_orientations": quat_from_rotvec(rng.normal(scale=0.6, size=(n_goals, 3))),
    }


def measure(
    config: DisambiguationConfig, n_goals: int, modes: list, repeats: int, scenes: int, seed: int
) -> np.ndarray:
    """Wall times (s) of ``repeats`` requests, cycling through ``scenes`` seeded scenes."""
    rng = np.random.default_rng(seed)
    requests = [_scene(rng, n_goals) for _ in range(scenes)]

    def call(s: dict) -> None:
        disambiguate(
            s["belief"],
            s["position"],
            s["goal_positions"],
            modes,
            config,
            orientation=s["orientation"],
            goal_orientations=s["goal_orientations"],
            current_mode=0,
        )

    for s in requests[: min(10, scenes)]:  # warm-up
        call(s)
    times = np.empty(repeats)
    for i in range(repeats):
        s = requests[i % scenes]
        start = time.perf_counter()
        call(s)
        times[i] = time.perf_counter() - start
    return times


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--repeats", type=int, default=300, help="requests per row (default 300)")
    parser.add_argument("--scenes", type=int, default=20, help="distinct seeded scenes per row (default 20)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    args = parser.parse_args()

    rows = [
        ("mico, 5 goals (MICO reaching task), 6 dims, 6 modes", preset("mico"), 5, HEAD_ARRAY_ARM_MODES),
        ("mico, 2 goals", preset("mico"), 2, HEAD_ARRAY_ARM_MODES),
        ("mico, 10 goals", preset("mico"), 10, HEAD_ARRAY_ARM_MODES),
        ("mico, 50 goals", preset("mico"), 50, HEAD_ARRAY_ARM_MODES),
        ("authors-r3, 5 goals, 3 dims, 3 modes", preset("authors-r3"), 5, [[0], [1], [2]]),
    ]
    print(f"One disambiguation request, {args.repeats} calls per row (seed {args.seed}); {host_summary()}")
    print(f"{'configuration':<55} {'median ms':>10} {'p95 ms':>10} {'steal':>7} {'gauge us':>9}")
    for label, config, n_goals, modes in rows:
        with HostMeter() as host:
            t = measure(config, n_goals, modes, args.repeats, args.scenes, args.seed) * 1e3
        steal = "n/a" if host.steal is None else f"{100 * host.steal:.0f} %"
        print(
            f"{label:<55} {np.median(t):>10.3f} {np.percentile(t, 95):>10.3f} {steal:>7} {host.gauge:>9.2f}"
        )
    print(
        "(steal: share of the CPU the hypervisor gave to other guests during the row; gauge: us per\n"
        " small numpy call around the row, the machine's speed: about 0.5 at the development machine's\n"
        " usual speed, 0.8-1.2 in its slow spells; see _host.py)"
    )


if __name__ == "__main__":
    main()
