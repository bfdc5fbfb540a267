"""Latency of one disambiguation request (Algorithm 1, numpy core).

Prints the median and 95th-percentile wall time of one call of
:func:`drake_disamb.core.disambiguation.disambiguate` (validation, forward projection of all
probes, features, scores, mode choice) for:

- the MICO configuration: the ``mico`` preset, the 5 goals of the single-step reaching task
  (docs/facts.md section 9) with seeded random orientations, 6 dimensions, the head array's 6 arm modes;
- the same with 2, 10 and 50 goals drawn (seeded) in the MICO workspace;
- the ``authors-r3`` preset (3 dimensions) for reference.

Each row cycles through ``--scenes`` seeded random requests (belief, end-effector pose) after a
warm-up. The rows are interleaved: every round runs one request of each row (starting at a
different row each round) and reads a short speed gauge, so all rows sample the same stretch of
the machine's time, slow spells included. The paper reports 2 to 2.5 s per request on the robot;
the target here is a median under 1 ms.

Usage: ``python benchmarks/bench_disambiguation.py [--rounds 1000] [--seed 0]``

Measured on the shared 2-core development machine, MICO row, median ms (figures swing by up to
1.5-2x with the machine's state; compare versions in the same minute):

- before the caching/layout work (commit 1ad2845): 2.0 (quiet) to 3.5-3.9 (load ~3);
- after it (commit c154a60): 1.2 (quiet) to 2.0;
- numpy kernels at their leanest (commit 63d3d50): 0.885-0.93 at the usual speed (gauge about
  0.5 us), 1.07-1.48 in slow spells; 1.51-1.57 interleaved on 2026-11-22 morning (gauge about
  1.0 us, hypervisor steal 14-20 %);
- with the numba row kernels for xi, the potential field, the quaternions and the Euler rollout
  (commits fc3fc38, aae9d86), the same morning at the same gauge (about 1.0 us): 0.67, 0.67 and
  0.69 in three runs (p95 0.81-0.88);
- with the kernels addressing rows by index (commit 75b1964), alternating with commit 63d3d50 in
  the same minutes (gauge medians 0.61-0.71 us): 0.52 and 0.52 against 1.20 and 1.08; 2 goals
  0.43-0.45, 10 goals 0.65-0.66, 50 goals 1.90, ``authors-r3`` 0.39-0.41. At gauge medians of
  0.87-0.98 us: 0.60-0.71 (p95 0.84-0.88). What remains is mostly validation, features and the
  numpy calls around the kernels.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _host import HostMeter, host_summary, speed_gauge

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


def request_call(config: DisambiguationConfig, n_goals: int, modes: list, scenes: int, seed: int):
    """A function ``call(i)`` running request ``i`` (cycling through ``scenes`` seeded scenes)."""
    rng = np.random.default_rng(seed)
    requests = [_scene(rng, n_goals) for _ in range(scenes)]

    def call(i: int) -> None:
        s = requests[i % scenes]
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

    return call


def measure_interleaved(calls: list, rounds: int) -> tuple[np.ndarray, np.ndarray]:
    """Wall times (s) ``(rounds, len(calls))`` and a speed-gauge reading (us) per round.

    Each round runs one request of every row, starting at a different row each round, and reads a
    short speed gauge; so every row samples the same stretch of the machine's time and its slow
    spells (which come and go within seconds) weigh on every row alike.
    """
    for call in calls:  # warm-up: caches, first-call costs
        for i in range(10):
            call(i)
    times = np.empty((rounds, len(calls)))
    gauges = np.empty(rounds)
    clock = time.perf_counter
    for r in range(rounds):
        for j in range(len(calls)):
            k = (r + j) % len(calls)
            start = clock()
            calls[k](r)
            times[r, k] = clock() - start
        gauges[r] = speed_gauge(calls=200, batches=1)
    return times, gauges


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--rounds", type=int, default=1000, help="requests per row, interleaved (default 1000)"
    )
    parser.add_argument("--scenes", type=int, default=20, help="distinct seeded scenes per row (default 20)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    args = parser.parse_args()
    if args.rounds < 1 or args.scenes < 1:
        parser.error(f"--rounds and --scenes must be >= 1, got {args.rounds} and {args.scenes}")

    rows = [
        ("mico, 5 goals (MICO reaching task), 6 dims, 6 modes", preset("mico"), 5, HEAD_ARRAY_ARM_MODES),
        ("mico, 2 goals", preset("mico"), 2, HEAD_ARRAY_ARM_MODES),
        ("mico, 10 goals", preset("mico"), 10, HEAD_ARRAY_ARM_MODES),
        ("mico, 50 goals", preset("mico"), 50, HEAD_ARRAY_ARM_MODES),
        ("authors-r3, 5 goals, 3 dims, 3 modes", preset("authors-r3"), 5, [[0], [1], [2]]),
    ]
    print(
        f"One disambiguation request, {args.rounds} calls per row interleaved with the other rows "
        f"(seed {args.seed}); {host_summary()}"
    )
    calls = [request_call(config, n, modes, args.scenes, args.seed) for _, config, n, modes in rows]
    with HostMeter() as host:
        times, gauges = measure_interleaved(calls, args.rounds)
    times *= 1e3
    print(f"{'configuration':<55} {'median ms':>10} {'p95 ms':>10}")
    for (label, *_), t in zip(rows, times.T, strict=True):
        print(f"{label:<55} {np.median(t):>10.3f} {np.percentile(t, 95):>10.3f}")
    q10, q50, q90 = np.percentile(gauges, [10, 50, 90])
    print(f"{host.describe()}; gauge per round: median {q50:.2f} us (10-90 %: {q10:.2f}-{q90:.2f})")
    print(
        "(steal: share of the CPU the hypervisor gave to other guests during the run; gauge: us per\n"
        " small numpy call, the machine's speed: about 0.5 at the development machine's usual speed,\n"
        " 0.8-1.2 in its slow spells; see _host.py)"
    )


if __name__ == "__main__":
    main()
