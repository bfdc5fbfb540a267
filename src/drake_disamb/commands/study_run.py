"""``drake-disamb study run``: run the study protocol with simulated subjects into a folder.

``study run --out DIR`` runs every trial of the protocol (default: the paper's, embedded in
``drake_disamb/study/protocol.yaml``; ``--protocol FILE`` another) and writes ``DIR/study.yaml``,
one record per finished trial to ``DIR/trials.jsonl`` and its time series to
``DIR/traces/<trial_id>.npz`` (:mod:`drake_disamb.study.runner`). Rerunning the same command
resumes: finished trials are skipped, a half-written last record (a killed run) is cut and its
trial run again. ``--quick``: 2 subjects, both interfaces, reaching only, one trial per paradigm.

Trials run in parallel: ``--workers N`` processes on this machine (default: the core count), or
``--scheduler ADDRESS`` on an existing Dask cluster (``dask scheduler`` and ``dask worker ADDRESS``
on the machines; each worker needs drake-disamb installed; the results come back to this process,
which writes them). Every input (protocol, options, ``--out``, the scheduler) is checked before the
first trial runs.

Exit status: 0 every trial ran (whatever its success), 1 some trial raised an error (its message is
printed; rerun to retry it), 2 bad input, 130 interrupted.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

HELP = "Run the study protocol with simulated subjects (records in DIR/trials.jsonl, traces in DIR/traces)."

SCHEDULER_TIMEOUT = 5.0
"""Seconds to wait for a Dask scheduler before giving up."""


def _int_at_least(minimum: int, what: str) -> Callable[[str], int]:
    """An argparse type: an integer >= ``minimum``, else an error saying ``expected <what>``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = minimum - 1
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return value

    return parse


_positive_int = _int_at_least(1, "a positive integer")
_seed = _int_at_least(0, "a non-negative integer")


def add_common_arguments(parser: argparse.ArgumentParser) -> None:
    """The options ``study run`` and ``study ablate`` share."""
    parser.add_argument(
        "--out", type=Path, required=True, help="the study folder (created; resumed if it exists)"
    )
    parser.add_argument("--protocol", type=Path, default=None, help="protocol YAML (default: the paper's)")
    parser.add_argument(
        "--subjects", type=_positive_int, default=None, help="number of subjects (default: the protocol's)"
    )
    parser.add_argument("--seed", type=_seed, default=0, help="study seed (default: 0)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument(
        "--workers", type=_positive_int, default=None, help="worker processes (default: the core count)"
    )
    where.add_argument(
        "--scheduler", default=None, metavar="ADDRESS", help="run on a Dask cluster (tcp://host:8786)"
    )
    parser.add_argument(
        "--quick",
        action="store_true",
        help="2 subjects, both interfaces, reaching only, one trial per paradigm",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bar")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the ``study run`` options."""
    add_common_arguments(parser)


def build_protocol(args: argparse.Namespace) -> Any:
    """The protocol of ``--protocol``, ``--quick`` and ``--subjects`` (raises ``ValueError``)."""
    import dataclasses

    from drake_disamb.study.protocol import load_protocol, quick_protocol, validate_protocol

    protocol = load_protocol(args.protocol)
    if args.quick:
        protocol = quick_protocol(protocol)
    if args.subjects is not None:
        protocol = validate_protocol(dataclasses.replace(protocol, subjects=args.subjects))
    return protocol


@contextlib.contextmanager
def open_executor(workers: int | None, scheduler: str | None) -> Iterator[tuple[Any, str]]:
    """A ``concurrent.futures.Executor`` and its description: a spawn-started process pool of
    ``workers`` processes, or the executor of a Dask client connected to ``scheduler``.

    Raises:
        ValueError: the scheduler cannot be reached within :data:`SCHEDULER_TIMEOUT` seconds.
    """
    if scheduler is not None:
        from distributed import Client

        try:
            client = Client(scheduler, timeout=SCHEDULER_TIMEOUT, set_as_default=False)
        except Exception as exc:  # OSError, TimeoutError, ValueError for a malformed address
            raise ValueError(
                f"--scheduler: cannot reach a Dask scheduler at {scheduler!r} within {SCHEDULER_TIMEOUT:g} s "
                f"({type(exc).__name__}: {exc}); start one with `dask scheduler` and workers with "
                "`dask worker ADDRESS`"
            ) from None
        try:
            n = len(client.scheduler_info().get("workers", {}))
            if n == 0:
                print(
                    f"warning: the scheduler at {scheduler} has no workers yet: the trials wait for "
                    f"`dask worker {scheduler}`",
                    file=sys.stderr,
                    flush=True,
                )
            yield client.get_executor(), f"Dask scheduler {scheduler} ({n} workers now)"
        finally:
            client.close()
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from drake_disamb.study.runner import default_workers

    n = workers or default_workers()
    pool = ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context("spawn"))
    try:
        yield pool, f"{n} worker process{'es' if n > 1 else ''}"
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


def error(command: str, message: object) -> int:
    print(f"drake-disamb study {command}: error: {message}", file=sys.stderr)
    return 2


def execute(plans: list[Any], args: argparse.Namespace, command: str) -> int:
    """Run the pending trials of ``plans`` on one executor, with a progress display."""
    from drake_disamb.progress import TrialProgress
    from drake_disamb.study.runner import run_study

    total = sum(len(p.pending) for p in plans)
    skipped = sum(len(p.finished) for p in plans)
    try:
        with open_executor(args.workers, args.scheduler) as (executor, where):
            print(f"{total} trials to run ({skipped} already done) on {where}", flush=True)
            progress = TrialProgress(total, quiet=args.quiet)
            errors = 0
            try:
                for plan in plans:
                    result = run_study(plan, executor, on_result=progress.update)
                    errors += len(result.errors)
            finally:
                progress.close()
    except ValueError as exc:
        return error(command, exc)
    except KeyboardInterrupt:
        print(f"drake-disamb study {command}: interrupted; rerun the same command to resume", file=sys.stderr)
        return 130
    print(progress.line(), flush=True)
    for plan in plans:
        print(f"wrote {plan.records_path} and {plan.traces_dir}", flush=True)
    return 1 if errors else 0


def run(args: argparse.Namespace) -> int:
    """``study run``: 0 all trials ran, 1 a trial raised, 2 bad input, 130 interrupted."""
    from drake_disamb.commands._outputs import check_output_dir
    from drake_disamb.study.runner import plan_study

    try:
        protocol = build_protocol(args)
        plan = plan_study(check_output_dir(args.out, "--out"), protocol, args.seed)
    except ValueError as exc:
        return error("run", exc)
    print(
        f"study in {plan.out}: {len(plan.specs)} trials, seed {plan.seed}, subjects from {plan.population}",
        flush=True,
    )
    return execute([plan], args, "run")
