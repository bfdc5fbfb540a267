"""Peak memory of ``drake-disamb inference-benchmark --generate N`` for growing N.

Runs the command in a fresh subprocess per N (``--quiet``, default seed 0) and reads that child's
peak resident set size from ``os.wait4`` (``ru_maxrss``, the kernel's high-water mark of the whole
process: interpreter, numpy, numba and the trials). The command streams trials in chunks of 500
(generate, replay, score, drop), so the peak should not grow with N beyond the 48 bytes of
scores kept per trial; the target is the largest N within 2x of the smallest.

Usage: python benchmarks/bench_inference_memory.py [--sizes 500 20000] [--seed S]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

from _host import HostMeter, host_summary

SRC = Path(__file__).resolve().parents[1] / "src"


def measure(n: int, seed: int) -> tuple[float, float, str]:
    """``(peak RSS in MB, wall seconds, the DFT row of the table)`` of one ``--generate n`` run.

    The child's own peak is read with ``os.wait4`` (``RUSAGE_CHILDREN`` would be the maximum over
    every child so far); Linux reports ``ru_maxrss`` in kB.
    """
    env = dict(os.environ, PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    cmd = [sys.executable, "-m", "drake_disamb.cli", "inference-benchmark", "--generate", str(n)]
    cmd += ["--seed", str(seed), "--quiet"]
    start = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True, env=env)
    out = proc.stdout.read()
    proc.stdout.close()
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        raise SystemExit(f"--generate {n}: the command exited with {proc.returncode}")
    dft = next((ln for ln in out.splitlines() if ln.startswith("field-theoretic")), "")
    return usage.ru_maxrss / 1024.0, wall, dft


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--sizes", type=int, nargs="+", default=[500, 20000])
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    print(host_summary())
    peaks = []
    for n in args.sizes:
        with HostMeter() as meter:
            peak, wall, dft = measure(n, args.seed)
        peaks.append(peak)
        print(f"--generate {n:>7}: peak RSS {peak:8.1f} MB, wall {wall:7.1f} s  ({meter.describe()})")
        print(f"    {dft}")
    for n, peak in zip(args.sizes[1:], peaks[1:], strict=True):
        ratio = peak / peaks[0]
        verdict = "within" if ratio <= 2.0 else "NOT within"
        print(f"peak at N = {n} / peak at N = {args.sizes[0]}: {ratio:.2f} ({verdict} the 2x target)")


if __name__ == "__main__":
    main()
