"""Two checkouts of the project measured side by side, in one run: the speed figures a change must
keep (the quick study's time, the reaching loop's real-time factor, one disambiguation request).

Usage: ``python benchmarks/side_by_side.py BEFORE AFTER [--rounds 2] [--workers 1]``, where
``BEFORE`` and ``AFTER`` are the roots of two checkouts (e.g. a ``git worktree add ../before
<commit>`` of the main before a change, and this one). Each round runs, for each checkout in turn
(the order alternates from round to round, so that a slow spell of the machine falls on both):

- the quick study (``drake-disamb study run --quick --seed 0 --quiet --workers W`` into a
  temporary folder): its wall time and the CPU time of the process and its workers;
- ``benchmarks/bench_loop.py --seconds 8 --repeats 3 --time-step 0.01`` (the checkout's own
  script): the reaching loop's real-time factor, wall and CPU (the best of its runs);
- ``benchmarks/bench_disambiguation.py --rounds 300``: the median time of one request of the MICO
  reaching task (5 goals, 6 dimensions).

Every command runs with ``PYTHONPATH=<checkout>/src`` in this interpreter, so both checkouts use
the same installed Drake and numpy. It prints each round, then per figure the median over the
rounds of each checkout and their ratio (AFTER / BEFORE). The machine may be shared: the CPU
times are the steadier figures, and the host's load is printed with them.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

LOOP_LINE = re.compile(r"plant time step 0\.01 s: loop\s+([\d.]+)x real time \(wall\),\s+([\d.]+)x \(CPU\)")
MICO_ROW = re.compile(r"^mico, 5 goals.*?\s([\d.]+)\s+([\d.]+)\s*$", re.M)


@dataclass
class Figures:
    """One checkout's figures, one entry per round."""

    study_wall: list[float] = field(default_factory=list)
    study_cpu: list[float] = field(default_factory=list)
    loop_wall: list[float] = field(default_factory=list)
    loop_cpu: list[float] = field(default_factory=list)
    request_ms: list[float] = field(default_factory=list)


def _run(root: Path, argv: list[str]) -> tuple[str, float, float]:
    """Run ``argv`` with ``root``'s sources first on the path; its stdout, wall and CPU seconds
    (the process and every process it waited for: the study's workers). A failure stops the
    benchmark with its stderr."""
    env = dict(os.environ, PYTHONPATH=str(root / "src"), MPLBACKEND="Agg")
    before, start = os.times(), time.monotonic()
    proc = subprocess.run(argv, cwd=root, env=env, capture_output=True, text=True)
    wall, now = time.monotonic() - start, os.times()
    if proc.returncode != 0:
        sys.exit(
            f"side_by_side: {' '.join(argv)} in {root} failed ({proc.returncode}): {proc.stderr[-2000:]}"
        )
    cpu = (now.children_user - before.children_user) + (now.children_system - before.children_system)
    return proc.stdout, wall, cpu


def measure(root: Path, workers: int, figures: Figures) -> str:
    """One round of the three measurements for the checkout ``root``; a line describing it."""
    python = sys.executable
    with tempfile.TemporaryDirectory() as tmp:
        _, wall, cpu = _run(
            root,
            [python, "-m", "drake_disamb.cli", "study", "run", "--quick", "--seed", "0", "--quiet",
             "--workers", str(workers), "--out", str(Path(tmp) / "quick")],
        )  # fmt: skip
        figures.study_wall.append(wall)
        figures.study_cpu.append(cpu)
    out, _, _ = _run(
        root, [python, "benchmarks/bench_loop.py", "--seconds", "8", "--repeats", "3", "--time-step", "0.01"]
    )
    m = LOOP_LINE.search(out)
    if m is None:
        sys.exit(f"side_by_side: no loop figure in bench_loop.py's output in {root}:\n{out}")
    figures.loop_wall.append(float(m[1]))
    figures.loop_cpu.append(float(m[2]))
    out, _, _ = _run(root, [python, "benchmarks/bench_disambiguation.py", "--rounds", "300"])
    m = MICO_ROW.search(out)
    if m is None:
        sys.exit(f"side_by_side: no MICO row in bench_disambiguation.py's output in {root}:\n{out}")
    figures.request_ms.append(float(m[1]))
    return (
        f"quick study {figures.study_wall[-1]:6.1f} s wall {figures.study_cpu[-1]:6.1f} s CPU | loop "
        f"{figures.loop_wall[-1]:5.2f}x wall {figures.loop_cpu[-1]:5.2f}x CPU | request "
        f"{figures.request_ms[-1]:.3f} ms | load {os.getloadavg()[0]:.2f}"
    )


ROWS = (
    ("quick study, wall (s)", "study_wall", "at most 1.15x"),
    ("quick study, CPU (s)", "study_cpu", ""),
    ("reaching loop, real-time factor (wall)", "loop_wall", "not lower"),
    ("reaching loop, real-time factor (CPU)", "loop_cpu", "not lower"),
    ("one disambiguation request, median (ms)", "request_ms", "under 1 ms"),
)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("before", type=Path, help="root of the checkout before the change")
    parser.add_argument("after", type=Path, help="root of the checkout after the change")
    parser.add_argument("--rounds", type=int, default=2, help="rounds (default 2)")
    parser.add_argument("--workers", type=int, default=1, help="the quick study's workers (default 1)")
    args = parser.parse_args(argv)
    roots = {"before": args.before.resolve(), "after": args.after.resolve()}
    for name, root in roots.items():
        if not (root / "src" / "drake_disamb").is_dir() or not (root / "benchmarks").is_dir():
            parser.error(
                f"{name}: {root} is not a checkout of drake-disamb (no src/drake_disamb, benchmarks)"
            )
    figures = {name: Figures() for name in roots}
    for k in range(args.rounds):
        order = list(roots) if k % 2 == 0 else list(reversed(roots))
        for name in order:
            line = measure(roots[name], args.workers, figures[name])
            print(f"round {k + 1} {name:<6} {line}", flush=True)
    print(f"\nmedians over {args.rounds} rounds ({roots['before']} -> {roots['after']})")
    print(f"{'figure':<42}{'before':>10}{'after':>10}{'ratio':>8}  target")
    for label, attr, target in ROWS:
        b = statistics.median(getattr(figures["before"], attr))
        a = statistics.median(getattr(figures["after"], attr))
        print(f"{label:<42}{b:>10.3f}{a:>10.3f}{a / b:>8.3f}  {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
