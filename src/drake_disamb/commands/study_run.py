"""``drake-disamb study run``: run the study protocol with simulated subjects into a folder.

``study run --out DIR`` runs every trial of the protocol (default: the paper's, embedded in
``drake_disamb/study/design/protocol.yaml``; ``--protocol FILE`` another) and writes ``DIR/study.yaml``,
one record per finished trial to ``DIR/trials.jsonl`` and its time series to
``DIR/traces/<trial_id>.npz`` (:mod:`drake_disamb.study.run.runner`). Rerunning the same command
resumes: finished trials are skipped, a half-written last record (a killed run) is cut and its
trial run again. ``--quick``: 2 subjects, both interfaces, reaching only, one trial per paradigm.

Trials run in parallel: ``--workers N`` processes on this machine (default: the core count), or
``--scheduler ADDRESS`` on an existing Dask cluster (``dask scheduler`` and ``dask worker ADDRESS``
on the machines; each worker needs drake-disamb installed; the results come back to this process,
which writes them). Every input (protocol, options, ``--out``, the scheduler) is checked before the
first trial runs; an address that names no scheduler is refused before the folder is made.

The folder has one writer: a second ``study run`` (or ``ablate``, ``import-authors``, ``demo
--record``) into it is refused at once, naming the process that writes it. SIGINT (Ctrl-C, to the
process or its whole group) and SIGTERM stop the run alike: the pending trials are cancelled, the
worker processes ended (they ignore SIGINT and die with this process, so none is left behind and
none prints a traceback), what was written is kept and a rerun resumes. A second signal quits at
once.

Exit status: 0 every trial ran (whatever its success); 1 some trial raised an error (its message is
printed; rerun to retry it); 2 bad input, or the folder holds another study or is being written by
another process; 3 the executor failed (a worker process died, the Dask scheduler was lost); 4 a
record or trace could not be written (a full disk); 130 stopped by SIGINT or SIGTERM. 1, 3, 4 and 130
keep every record written before and print how many; rerunning the same command resumes.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from drake_disamb.extras import import_optional

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

    from drake_disamb.study.design.protocol import load_protocol, quick_protocol, validate_protocol

    protocol = load_protocol(args.protocol)
    if args.quick:
        protocol = quick_protocol(protocol)
    if args.subjects is not None:
        protocol = validate_protocol(dataclasses.replace(protocol, subjects=args.subjects))
    return protocol


@contextlib.contextmanager
def open_executor(workers: int | None, scheduler: str | None) -> Iterator[tuple[Any, str]]:
    """A ``concurrent.futures.Executor`` and its description: a spawn-started process pool of
    ``workers`` processes (:func:`~drake_disamb.commands._signals.worker_init`: they ignore SIGINT
    and die with this process), or the executor of a Dask client connected to ``scheduler``. On an
    exception (a stop, a fault) the pool's processes are ended at once, never left behind.

    While the Dask client is open the process's log is held back (:func:`_log_held_back`): Dask logs
    a lost scheduler with its tracebacks, and the caller reports it in one line.

    Raises:
        ValueError: ``scheduler`` is not a scheduler's address (:func:`check_scheduler_address`), or
            the scheduler cannot be reached within :data:`SCHEDULER_TIMEOUT` seconds.
        MissingExtra: ``scheduler`` given without Dask ``distributed`` (the ``study`` extra).
    """
    if scheduler is not None:
        check_scheduler_address(scheduler)
        distributed = import_optional("distributed", "study")

        with _log_held_back():
            try:
                client = distributed.Client(scheduler, timeout=SCHEDULER_TIMEOUT, set_as_default=False)
            except Exception as exc:  # OSError, TimeoutError
                raise ValueError(
                    f"--scheduler: cannot reach a Dask scheduler at {scheduler!r} within "
                    f"{SCHEDULER_TIMEOUT:g} s ({type(exc).__name__}: {exc}); start one with `dask scheduler` "
                    "and workers with `dask worker ADDRESS`"
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
                with contextlib.suppress(Exception):  # a lost scheduler: nothing left to close
                    client.close(timeout=SCHEDULER_TIMEOUT)
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from drake_disamb.commands._signals import end_workers, worker_init
    from drake_disamb.study.run.runner import default_workers

    n = workers or default_workers()
    pool = ProcessPoolExecutor(
        max_workers=n, mp_context=multiprocessing.get_context("spawn"), initializer=worker_init
    )
    try:
        yield pool, f"{n} worker process{'es' if n > 1 else ''}"
    except BaseException:
        end_workers()
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown(wait=True)


def check_scheduler_address(address: str | None) -> None:
    """Refuse (``ValueError`` naming ``--scheduler``) an address that names no scheduler: no port, an
    unknown scheme, a port outside 1..65535. Dask's client would take it, fail inside, and leave a
    half-made client that the interpreter waits 10 s to close at exit. ``None`` (no ``--scheduler``)
    passes; an address without Dask ``distributed`` installed raises
    :class:`~drake_disamb.extras.MissingExtra`."""
    if address is None:
        return
    comm = import_optional("distributed.comm", "study")

    try:
        host, port = comm.get_address_host_port(address)
    except ValueError as exc:
        reason = str(exc)
    else:
        if host and 0 < port < 65536:
            return
        reason = "expected a host and a port in 1..65535"
    raise ValueError(
        f"--scheduler: {address!r} is not a Dask scheduler's address ({reason}); expected one like "
        "tcp://HOST:8786, as `dask scheduler` prints it"
    )


@contextlib.contextmanager
def _log_held_back() -> Iterator[None]:
    """Drop every log record while inside (``logging.disable``), then restore the previous level."""
    import logging

    level = logging.root.manager.disable
    logging.disable(logging.CRITICAL)
    try:
        yield
    finally:
        logging.disable(level)


EXIT_TRIAL_ERROR = 1
EXIT_BAD_INPUT = 2
EXIT_EXECUTOR_LOST = 3
EXIT_WRITE_FAILED = 4
"""Exit statuses of ``study run`` and ``study ablate`` (and 0, and 130 interrupted: module docstring)."""


def error(command: str, message: object) -> int:
    print(f"drake-disamb study {command}: error: {message}", file=sys.stderr)
    return EXIT_BAD_INPUT


def stopped_before_the_first_trial(command: str) -> int:
    print(f"drake-disamb study {command}: stopped before the first trial (nothing was run)", file=sys.stderr)
    return 130


def _written(plans: list[Any], skipped: int) -> str:
    """How many records the folders hold now (read back: only what was written is claimed)."""
    records = 0
    for plan in plans:
        with contextlib.suppress(ValueError):
            records += len(plan.folder.read_records())
    where = plans[0].records_path if len(plans) == 1 else f"{plans[0].out.parent}/*/trials.jsonl"
    return f"{records} records in {where} ({records - skipped} written now)"


def execute(plans: list[Any], args: argparse.Namespace, command: str) -> int:
    """Run the pending trials of ``plans`` on one executor, with a progress display; SIGINT and
    SIGTERM stop it (the exit statuses are in the module docstring)."""
    from drake_disamb.commands._signals import EXIT_INTERRUPTED, StopRequest
    from drake_disamb.progress import TrialProgress
    from drake_disamb.study.data.folder import FolderWriteError
    from drake_disamb.study.run.runner import ExecutorLost, run_study

    total = sum(len(p.pending) for p in plans)
    skipped = sum(len(p.finished) for p in plans)
    errors = 0
    resume = "rerun the same command to resume"
    progress = None
    with StopRequest() as stop:
        try:
            with open_executor(args.workers, args.scheduler) as (executor, where):
                print(f"{total} trials to run ({skipped} already done) on {where}", flush=True)
                progress = TrialProgress(total, quiet=args.quiet)
                for plan in plans:
                    result = run_study(plan, executor, on_result=progress.update, stop=stop)
                    errors += len(result.errors)
                    if result.stopped:
                        raise KeyboardInterrupt
        except ValueError as exc:
            return error(command, exc)
        except KeyboardInterrupt:
            _close(progress)
            name = stop.signal_name or "SIGINT"
            print(
                f"drake-disamb study {command}: stopped by {name}; {_written(plans, skipped)}; {resume}",
                file=sys.stderr,
            )
            return EXIT_INTERRUPTED
        except ExecutorLost as exc:
            _close(progress)
            print(
                f"drake-disamb study {command}: error: {exc}; {_written(plans, skipped)}; {resume}",
                file=sys.stderr,
            )
            return EXIT_EXECUTOR_LOST
        except FolderWriteError as exc:
            _close(progress)
            print(
                f"drake-disamb study {command}: error: {exc.strerror}; {_written(plans, skipped)}; "
                f"free the space (or fix the folder) and {resume}",
                file=sys.stderr,
            )
            return EXIT_WRITE_FAILED
    _close(progress)
    print(progress.line(), flush=True)
    traces = "each setting's traces/" if len(plans) > 1 else plans[0].traces_dir
    print(f"{_written(plans, skipped)}, traces in {traces}", flush=True)
    if errors:
        print(f"{errors} trials raised (no record): {resume} retries them", flush=True)
    return EXIT_TRIAL_ERROR if errors else 0


def _close(progress: Any) -> None:
    if progress is not None:
        progress.close()


def run(args: argparse.Namespace) -> int:
    """``study run``: 0 all trials ran, 1 a trial raised, 2 bad input, 130 interrupted."""
    from drake_disamb.commands._outputs import check_output_dir
    from drake_disamb.commands._signals import sigterm_as_sigint
    from drake_disamb.study.run.runner import plan_study

    try:
        with sigterm_as_sigint():
            check_scheduler_address(args.scheduler)
            protocol = build_protocol(args)
            plan = plan_study(check_output_dir(args.out, "--out"), protocol, args.seed)
    except ValueError as exc:
        return error("run", exc)
    except KeyboardInterrupt:
        return stopped_before_the_first_trial("run")
    hours = plan.protocol.simulated_time_bound / 3600.0
    print(
        f"study in {plan.out}: {len(plan.specs)} trials (at most {hours:.1f} h simulated), seed {plan.seed}, "
        f"subjects from {plan.population}",
        flush=True,
    )
    return execute([plan], args, "run")
