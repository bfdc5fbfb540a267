"""The study runner's speed: the protocol's wall time, trials per minute, and the runner's overhead.

Usage::

    python benchmarks/bench_study.py [--quick] [--subjects N] [--workers N] [--protocol FILE] [--out DIR]
    python benchmarks/bench_study.py --compare-workers [--quick | --subjects N]
    python benchmarks/bench_study.py --out DIR --only task=reaching [--only interface=joystick ...]

The first form runs the protocol (default: the paper's full protocol, 416 trials; ``--quick`` the
``study run --quick`` subset; ``--subjects N`` the first N subjects) into ``--out`` (default: a
temporary folder, deleted) on a process pool, and prints the trials, the wall time, the simulated
seconds, the trials per minute, the worker count and the runner's overhead: the study's wall time
times the worker count against the sum of the trials' own simulation wall times (what
``run_trial`` measured around ``Simulator.AdvanceTo``), so it counts the workers' start (imports,
loading the compiled kernels), building each trial's diagram, the records and the traces, and idle
workers at the end. Targets on the 2-core development machine: overhead under 10 % on the full
protocol, the full protocol in under 15 minutes.

``--compare-workers`` runs the same protocol with 1 and then 2 workers, checks that the records are
equal (apart from ``wall_time``) and prints the speed-up in trials per minute (target at least
1.8x). Both runs pay the workers' start once, so a small protocol understates the speed-up: use
at least ``--subjects 2``.

``--only FIELD=V1,V2`` (``interface``, ``task`` or ``paradigm``; repeatable) runs only the
protocol's trials of those conditions, each with the seed and draws it has in the whole protocol:
the records equal the whole run's for those trials, so a change to one condition can be measured in
minutes and compared trial by trial. The folder's ``study.yaml`` describes the whole protocol;
``study run`` on it resumes the rest.

A protocol that needs scenario fields this build lacks (the Automatic paradigm, the request
latency) is run without them, and the script says so.
"""

from __future__ import annotations

import argparse
import multiprocessing
import shutil
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from _host import HostMeter, host_summary

from drake_disamb.study.data.records import read_records
from drake_disamb.study.design import protocol as P
from drake_disamb.study.run.runner import default_workers, plan_study, records_by_id, run_study


def protocol_of(args: argparse.Namespace) -> P.Protocol:
    """The protocol to run: ``--protocol`` or the paper's, with ``--quick`` and ``--subjects``."""
    protocol = P.load_protocol(args.protocol) if args.protocol else P.default_protocol()
    if args.quick:
        protocol = P.quick_protocol(protocol)
    if args.subjects:
        data = P.protocol_to_dict(protocol)
        data["subjects"] = args.subjects
        protocol = P.protocol_from_dict(data)
    return protocol


ONLY_FIELDS = ("interface", "task", "paradigm")
"""The trial fields ``--only`` selects on."""


def parse_only(items: list[str]) -> dict[str, set[str]]:
    """``--only FIELD=V1,V2`` options as ``{field: values}`` (a bad one exits with a message)."""
    only: dict[str, set[str]] = {}
    for item in items:
        field, _, values = item.partition("=")
        if field not in ONLY_FIELDS or not values:
            sys.exit(
                f"--only: expected FIELD=V1[,V2...] with FIELD one of {', '.join(ONLY_FIELDS)}, got {item!r}"
            )
        only.setdefault(field, set()).update(v for v in values.split(",") if v)
    return only


def run_once(
    protocol: P.Protocol, out: Path, workers: int, seed: int, only: dict[str, set[str]] | None = None
) -> dict:
    """Run the protocol (or its ``only`` conditions) into ``out`` (which must be new); the figures."""
    plan = plan_study(out, protocol, seed)
    if plan.finished:
        sys.exit(f"{out} already holds {len(plan.finished)} records: give a new --out")
    if only:
        plan.pending = [s for s in plan.pending if all(getattr(s, f) in v for f, v in only.items())]
        if not plan.pending:
            sys.exit(f"--only: no trial of the protocol matches {only}")
        chosen = "; ".join(f"{f} {', '.join(sorted(v))}" for f, v in only.items())
        print(f"only {chosen}: {len(plan.pending)} trials", flush=True)
    with HostMeter() as host:
        start = time.perf_counter()
        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
            result = run_study(plan, pool)
        wall = time.perf_counter() - start
    records = read_records(out / "trials.jsonl")
    trial_wall = sum(r.wall_time for r in records)
    simulated = sum(r.duration for r in records)
    return {
        "trials": len(records),
        "errors": len(result.errors),
        "successes": sum(bool(r.success) for r in records),
        "wall": wall,
        "simulated": simulated,
        "trial_wall": trial_wall,
        "per_minute": 60.0 * len(records) / wall,
        "workers": workers,
        "overhead": (workers * wall - trial_wall) / trial_wall if trial_wall > 0 else float("nan"),
        "host": host.describe(),
        "records": records_by_id(records),
    }


def report(figures: dict) -> None:
    print(
        f"  trials {figures['trials']} ({figures['successes']} successful, {figures['errors']} errors) "
        f"on {figures['workers']} worker{'s' if figures['workers'] > 1 else ''}\n"
        f"  wall time {figures['wall']:.1f} s, simulated {figures['simulated']:.0f} s "
        f"({figures['simulated'] / figures['wall']:.1f}x real time)\n"
        f"  trials per minute {figures['per_minute']:.1f}\n"
        f"  trials' own simulation wall time {figures['trial_wall']:.1f} s; runner overhead "
        f"(workers x wall vs that) {100 * figures['overhead']:.1f} %\n"
        f"  {figures['host']}",
        flush=True,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the study run --quick subset")
    parser.add_argument("--subjects", type=int, default=None, help="run only this many subjects")
    parser.add_argument(
        "--workers", type=int, default=None, help="worker processes (default: the core count)"
    )
    parser.add_argument("--protocol", default=None, help="protocol YAML (default: the paper's)")
    parser.add_argument("--seed", type=int, default=0, help="study seed (default 0)")
    parser.add_argument(
        "--out", type=Path, default=None, help="keep the study here (default: a temporary folder)"
    )
    parser.add_argument("--compare-workers", action="store_true", help="1 vs 2 workers on the same trials")
    parser.add_argument(
        "--only",
        action="append",
        default=[],
        metavar="FIELD=V1,V2",
        help="run only these conditions (interface, task or paradigm; repeatable)",
    )
    args = parser.parse_args()
    only = parse_only(args.only)
    if only and args.compare_workers:
        sys.exit("--only: not with --compare-workers")

    protocol = protocol_of(args)
    print(host_summary(), flush=True)
    print(f"protocol: {protocol.n_trials} trials, seed {args.seed}", flush=True)
    tmp = Path(tempfile.mkdtemp(prefix="bench_study_")) if args.out is None else None
    base = args.out if args.out is not None else tmp
    try:
        if not args.compare_workers:
            figures = run_once(protocol, base, args.workers or default_workers(), args.seed, only)
            report(figures)
            return
        runs = []
        for workers in (1, 2):
            print(f"{workers} worker{'s' if workers > 1 else ''}:", flush=True)
            figures = run_once(protocol, base / f"workers{workers}", workers, args.seed)
            report(figures)
            runs.append(figures)
        same = runs[0]["records"] == runs[1]["records"]
        speedup = runs[1]["per_minute"] / runs[0]["per_minute"]
        print(
            f"speed-up with 2 workers: {speedup:.2f}x (target >= 1.8x); records equal apart from wall_time: "
            f"{'yes' if same else 'NO'}",
            flush=True,
        )
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
