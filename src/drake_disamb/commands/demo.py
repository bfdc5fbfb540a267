"""``drake-disamb demo``: one shared-control trial, shown in Meshcat, with its metrics and figures.

With no arguments: the reaching task, a simulated head-array user, the disambiguation paradigm.
Prints the Meshcat URL and the operator page's address, on a line of its own (unless
``--no-meshcat``; the page, docs/operator_page.md, shows the scene with a panel saying what the
robot believes and why, :mod:`drake_disamb.operator_page`), runs the trial, prints its metrics
(success, time, mode switches, disambiguation requests, button presses) and writes into ``--out``:

- ``metrics.json``: the printed metrics, machine-readable, with the scenario's identity (task,
  interface, paradigm, goals, seed) and ``"interrupted"``;
- ``goal_probabilities.png``: the goal probabilities over time in the style of the paper's figure
  (each goal in its object's colour, threshold rho1 dashed; requests, mode switches and non-zero
  command stretches in a strip below; the end of the trial and stage changes marked; a caption);
- ``recording.html``: the Meshcat recording as a self-contained HTML file (with Meshcat), the
  operator panel replayed beside the scene;
- ``diagram.dot`` / ``diagram.svg`` (when Graphviz is installed): the diagram's picture.

``--live`` replaces the simulated user by you: the interface is driven from the operator page
(:func:`~drake_disamb.interfaces.live.page_live_input`: keys, the panel's key buttons, or a browser
gamepad) and the trial runs at real time for up to 600 s (``--duration``).

``--live --record DIR --subject NAME`` also appends the person's trial to ``DIR/trials.jsonl`` as a
study record (``source: "human"``, the same :class:`~drake_disamb.study.data.records.TrialRecord` the
simulated study writes, made by the same function) and its time series to
``DIR/traces/<trial_id>.npz``, so ``study report DIR`` treats people like simulated subjects. A trial
ended with Ctrl-C is recorded too (``done: false``, ``extra.interrupted: true``). Before the trial
starts, the folder is checked and the record's names (the subject: ASCII letters, digits, ``_``
and ``-``, at most 64; the task: ``reaching`` or ``pouring``; the condition; the ``trial_id``) go
through the record's own check
(:func:`~drake_disamb.study.data.records.check_names`): a name the record would refuse is a
one-line error with exit status 2, before anything runs; so is a simulated study's folder (with
``study.yaml`` or ``ablation.json``), which takes only its own trials so that ``study run`` can
resume it. If the folder still does not take the trial at the end (a full disk, a permission, a
race), the record and its trace are kept in a new file beside it,
``DIR.unsaved-<trial_id>.npz`` (never over an existing file), which the one-line error names
(exit status 4); :func:`~drake_disamb.study.data.folder.read_unsaved` reads it back.

The trial's scenario is the whole experiment, its station included, made of layers that the one
scenario loader merges in order (:mod:`drake_disamb.config.yaml_io`): ``--task`` (an embedded task
or a YAML file), each ``--scenario-text YAML`` (e.g. ``'station: !Lcm {lcm_url: ...}'``,
``'{inference: {agreement: dot}}'``), then the shorthands ``--interface``, ``--paradigm``,
``--seed``, ``--station``, ``--lcm-url``, ``--goal`` and ``--duration``, each a layer of its one
field (``--duration`` cuts a trial short on purpose: unlike a ``duration`` in a file or a
``--scenario-text``, it need not outlast the hold times). A bad value is one line naming the layer
(the file or the option), the field and the value (exit status 2).

``--dump-scenario`` prints the fully resolved scenario (every field written out, the ``station:``
included) as YAML and exits: saved to a file, it loads back (``--task FILE``) to the same
scenario. Nothing is run and ``--out`` is not touched.

Run from a terminal with Meshcat, the demo first compiles what it needs (announced on a first run),
prints the addresses and waits up to 30 s for a browser to open the operator page (``--no-wait``
starts at once), runs at real time and keeps Meshcat and the page up 5 s afterwards. Run from a
script (standard input not a terminal) it prints the addresses, does not wait or hold, and runs as
fast as it can; the recording replays in simulated time either way.

``--out`` is checked (created if needed, a probe file written and deleted) before anything is
built. Ctrl-C (SIGINT) or SIGTERM stops the trial between simulator steps; the command then writes
everything above for the trial so far (``metrics.json`` with ``"interrupted": true``) and exits
130. That is also how a person ends a ``--live`` trial. A second Ctrl-C quits without waiting.

Exit status: 0 the trial succeeded, 1 it did not, 2 bad arguments or an unusable ``--out``,
4 the ``--record`` folder did not take the trial (kept beside it), 130 stopped by SIGINT or SIGTERM.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

from drake_disamb.commands._first_run import announce_kernel_compilation
from drake_disamb.commands._meshcat import (
    WAIT_FOR_BROWSER,
    add_meshcat_arguments,
    add_wait_argument,
    attended,
    start_meshcat,
    wait_for_browser,
)
from drake_disamb.commands._outputs import check_output_dir
from drake_disamb.commands._page import add_page_arguments, print_page_address, start_page
from drake_disamb.commands._record import NotRecorded, append_or_keep
from drake_disamb.commands._signals import EXIT_INTERRUPTED, StopRequest
from drake_disamb.commands._station import (
    EXIT_STATION_FAULT,
    add_scenario_text_argument,
    add_station_arguments,
    scenario_text_layers,
    station_layers,
)
from drake_disamb.commands.study_run import EXIT_WRITE_FAILED
from drake_disamb.interfaces import INTERFACES

HELP = "Run one shared-control trial (default: reaching, head array, disambiguation) and show it."


def _goal_arg(text: str) -> int | list[int]:
    """``--goal``: one index (every stage) or comma-separated indices, one per stage."""
    try:
        parts = [int(p) for p in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected an integer or comma-separated integers, got {text!r}"
        ) from None
    return parts[0] if len(parts) == 1 else parts


def _nonnegative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not value >= 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}")
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the ``demo`` options."""
    parser.add_argument(
        "--task",
        default="reaching",
        help="embedded task name (reaching, pouring) or a scenario YAML path (default: reaching)",
    )
    parser.add_argument(
        "--interface",
        default=None,
        help=f"{', '.join(INTERFACES)} (default: the scenario's)",
    )
    parser.add_argument(
        "--paradigm", default=None, help="manual, disambiguation or automatic (default: the scenario's)"
    )
    parser.add_argument(
        "--goal",
        type=_goal_arg,
        default=None,
        help="intended goal index (every stage) or one per stage, e.g. 1,0 (default: the scenario's)",
    )
    parser.add_argument("--seed", type=int, default=None, help="random seed (default: the scenario's)")
    parser.add_argument("--no-meshcat", action="store_true", help="run without Meshcat (no recording)")
    add_scenario_text_argument(parser)
    add_station_arguments(parser)
    add_meshcat_arguments(parser)
    add_page_arguments(parser)
    add_wait_argument(parser)
    parser.add_argument(
        "--out", type=Path, default=Path("out/demo"), help="output folder (default: out/demo)"
    )
    parser.add_argument(
        "--hold",
        type=_nonnegative_float,
        default=None,
        help="seconds Meshcat keeps serving after the trial (default: 5 with Meshcat in a terminal, else 0)",
    )
    parser.add_argument(
        "--realtime-rate",
        type=_nonnegative_float,
        default=None,
        help="target real-time rate (default: 1 with Meshcat from a terminal, else 0 = as fast as possible)",
    )
    parser.add_argument("--quiet", action="store_true", help="no progress display")
    parser.add_argument(
        "--live",
        action="store_true",
        help="drive the interface yourself from the operator page (keys, on-page buttons or a gamepad) "
        "instead of the simulated user; runs at real time",
    )
    parser.add_argument(
        "--duration",
        type=_nonnegative_float,
        default=None,
        help="simulated-time limit in s (default: the scenario's, 600 with --live)",
    )
    parser.add_argument(
        "--record",
        type=Path,
        default=None,
        metavar="DIR",
        help="with --live: append the trial to DIR/trials.jsonl (source human) and its trace to DIR/traces/",
    )
    parser.add_argument(
        "--subject", default=None, metavar="NAME", help="with --record: the person's name or code (e.g. P01)"
    )
    parser.add_argument(
        "--dump-scenario",
        action="store_true",
        help="print the resolved scenario (with the options above) as YAML and exit without running",
    )


def format_metrics(result) -> str:  # noqa: ANN001 (TrialResult, imported lazily)
    """The trial's metrics as an aligned two-column table."""
    rows = [
        ("task", result.scenario.task),
        ("interface", result.scenario.interface),
        ("paradigm", result.scenario.paradigm),
        ("intended goal(s)", ", ".join(result.intended_goal_names)),
        ("reached goal(s)", ", ".join(result.reached_goal_names) or "-"),
        ("success", "yes" if result.success else "no"),
        ("completion time (s)", f"{result.time:.2f}" if result.done else f"- (stopped at {result.time:.2f})"),
    ]
    if result.scenario.n_stages > 1:
        for k, t in enumerate(result.stage_times):
            rows.append(
                (f"  stage {k} ({result.scenario.stages[k].name}) done at (s)", f"{t:.2f}" if t == t else "-")
            )
    rows += [
        ("mode switches", str(result.mode_switches)),
        ("disambiguation requests", str(result.requests)),
        ("button presses", str(result.button_presses)),
    ]
    if result.scenario.paradigm == "automatic":
        rows.append(("automatic switches", str(result.automatic_switches)))
    rows += [
        ("mean alpha while commanding", f"{result.mean_alpha:.3f}"),
        ("simulated / wall time (s)", f"{result.time:.2f} / {result.wall_time:.2f}"),
        ("real-time rate", f"{result.realtime_rate:.1f}x"),
    ]
    if getattr(result, "interrupted", False):
        rows.append(("interrupted", f"yes, at {result.time:.2f} s"))
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"  {k.ljust(width)}  {v}" for k, v in rows)


def _finite_or_none(value: float) -> float | None:
    value = float(value)
    return value if math.isfinite(value) else None


def metrics_dict(result, live: bool = False) -> dict[str, Any]:  # noqa: ANN001 (TrialResult)
    """The printed metrics as a JSON-ready dict (non-finite numbers become ``None``)."""
    sc = result.scenario
    return {
        "task": sc.task,
        "interface": sc.interface,
        "paradigm": sc.paradigm,
        "goal": list(result.intended_goals),
        "intended_goal_names": list(result.intended_goal_names),
        "seed": sc.seed,
        "duration_limit": sc.duration,
        "live": bool(live),
        "interrupted": bool(getattr(result, "interrupted", False)),
        "success": bool(result.success),
        "done": bool(result.done),
        "time": float(result.time),
        "stage_times": [_finite_or_none(t) for t in result.stage_times],
        "reached_goals": list(result.reached_goals),
        "reached_goal_names": list(result.reached_goal_names),
        "mode_switches": int(result.mode_switches),
        "disambiguation_requests": int(result.requests),
        "button_presses": int(result.button_presses),
        "request_times": [float(t) for t in result.request_times],
        "mode_switch_times": [float(t) for t in result.mode_switch_times],
        "automatic_switches": int(result.automatic_switches),
        "automatic_switch_times": [float(t) for t in result.automatic_switch_times],
        "mean_alpha": _finite_or_none(result.mean_alpha),
        "wall_time": float(result.wall_time),
        "realtime_rate": _finite_or_none(result.realtime_rate),
        **({"station_fault": result.fault} if getattr(result, "fault", "") else {}),
    }


def write_metrics(result, out: Path, live: bool = False) -> Path:  # noqa: ANN001 (TrialResult)
    """Write :func:`metrics_dict` to ``out / "metrics.json"`` (through a temporary file, then renamed)."""
    path = out / "metrics.json"
    tmp = out / ".metrics.json.tmp"
    tmp.write_text(json.dumps(metrics_dict(result, live), indent=2) + "\n", encoding="utf-8")
    tmp.replace(path)
    return path


def check_record_dir(path: Path) -> Path:
    """``--record``: a writable study folder no other process writes (its writer lock is taken and
    held), not a simulated study's (which takes only its own trials), whose ``trials.jsonl``, if
    any, reads (raises ``ValueError``)."""
    from drake_disamb.study.data.folder import StudyFolder

    try:
        folder = StudyFolder(path).prepare()
        folder.check_source("human")
        folder.read_records(repair=True)
    except ValueError as exc:
        raise ValueError(f"--record: {exc}") from None
    return folder.path


def human_trial_id(folder: Path, subject: str, scenario: Any) -> tuple[str, int]:
    """The ``trial_id`` and ``repetition`` of a person's next trial of ``scenario`` in the study
    folder ``folder`` (whose lock this process holds): ``<subject>-<interface>-<task>-<paradigm>-h<n>``,
    ``n`` counting that person's earlier trials of the condition there.

    Its names and the scenario's goals pass the record's own checks
    (:func:`~drake_disamb.study.data.records.check_names`,
    :func:`~drake_disamb.study.data.records.check_goals`: any goal the trial could reach), so
    ``--record`` calls it before the trial runs: what the record would refuse stops the command
    before anything is run.

    Raises:
        ValueError: A name the record refuses (names the field and the value), or the folder's
            records cannot be read.
    """
    from drake_disamb.study.data.folder import StudyFolder
    from drake_disamb.study.data.records import check_goals, check_names
    from drake_disamb.study.run.outcome import record_condition

    condition = record_condition(scenario)
    stem = f"{subject}-{condition['interface']}-{condition['task']}-{condition['paradigm']}-h"
    ids = {r.trial_id for r in StudyFolder(folder).read_records(repair=True)}
    n = 0
    while f"{stem}{n}" in ids:
        n += 1
    trial_id = f"{stem}{n}"
    check_names(trial_id=trial_id, subject=subject, source="human", **condition)
    largest = [len(scenario.stage_goals(k)) - 1 for k in range(scenario.n_stages)]
    check_goals(scenario.task, list(scenario.user.goals), largest)
    return trial_id, n


def record_human_trial(result, folder: Path, subject: str, trial_id: str, repetition: int) -> str:  # noqa: ANN001 (TrialResult)
    """Append a person's trial to the study folder ``folder`` (source ``human``) with its trace in
    ``folder/traces/``, and return its ``trial_id``.

    ``trial_id`` and ``repetition`` are :func:`human_trial_id`'s at the start; they are taken again
    now (under the folder's lock, held since the start, the same unless a writer that ignores the
    lock added one of this person's trials meanwhile: then the next free one).

    Raises:
        NotRecorded: The folder did not take the trial (it cannot be used now, its records cannot
            be read, a write failed): the record and its trace are kept in a new file beside it
            (:func:`~drake_disamb.study.data.folder.keep_unsaved`), which the message names.
        ValueError: A value of the trial the record refuses (names the field).
    """
    from drake_disamb.study.data.folder import StudyFolder
    from drake_disamb.study.run.outcome import record_from_result, trace_arrays

    sc = result.scenario
    study = StudyFolder(folder)
    failure: Exception | None = None
    try:
        study.prepare()
        trial_id, repetition = human_trial_id(folder, subject, sc)
    except ValueError as exc:
        failure = exc
    trace = trace_arrays(result)
    record = record_from_result(
        result,
        trial_id=trial_id,
        subject=subject,
        repetition=repetition,
        seed=None,
        start_pose=0 if sc.start_joint_positions is None else None,
        source="human",
        trace=trace,
        wall_time=0.0,
        extra={"live": True, "scenario_seed": sc.seed},
    )
    append_or_keep(study, record, trace, failure)
    return trial_id


def _record_failed(message: object) -> int:
    print(f"drake-disamb demo: error: --record: {message}", file=sys.stderr, flush=True)
    return EXIT_WRITE_FAILED


def _say(line: str) -> None:
    print(line, flush=True)


LIVE_DURATION = 600.0
"""Simulated-time limit (s) of a ``--live`` trial without ``--duration``."""

WARM_UP = 0.05
"""Simulated seconds of a headless trial run before a watched one, to have its kernels ready (the
simulated user asks for disambiguation at the start, so the first ticks use them all)."""


def _waits_for_browser(args: argparse.Namespace) -> bool:
    """Whether the demo waits for a browser: with Meshcat, from a terminal, without ``--no-wait``."""
    return not (args.no_meshcat or args.no_wait) and attended()


def _show_url(meshcat: Any, page: Any, args: argparse.Namespace, stop: StopRequest) -> None:
    """Print the Meshcat URL and the operator page's address (once) and, from a terminal, wait for
    a browser to open the page."""
    print(f"Meshcat: {meshcat.web_url()} (the scene alone)", flush=True)
    print_page_address(page, args.live)
    if not _waits_for_browser(args):
        return
    print(
        f"the trial starts when the page is open (waiting up to {WAIT_FOR_BROWSER:g} s; "
        "--no-wait starts at once)",
        flush=True,
    )
    if wait_for_browser(page, WAIT_FOR_BROWSER, stop=lambda: bool(stop)):
        print("the page is open", flush=True)
    elif not stop:
        print(f"no browser opened the page within {WAIT_FOR_BROWSER:g} s: starting anyway", flush=True)


def _error(message: object) -> int:
    print(f"drake-disamb demo: error: {message}", file=sys.stderr)
    return 2


def run(args: argparse.Namespace) -> int:
    """Run the demo: 0 on a successful trial, 1 on an unsuccessful one, 2 on bad arguments or an
    unusable ``--out``, 130 when stopped by SIGINT or SIGTERM (after writing what it has)."""
    with StopRequest() as stop:
        try:
            return _run(args, stop)
        except KeyboardInterrupt:
            print(
                f"drake-disamb demo: interrupted again ({stop.signal_name or 'SIGINT'}); "
                f"the files in {args.out} may be incomplete",
                file=sys.stderr,
            )
            return EXIT_INTERRUPTED


def _scenario(args: argparse.Namespace) -> Any:
    """The scenario of ``--task``, ``--scenario-text`` and the shorthands, in that order, each a
    layer (module docstring; raises ``ValueError`` naming the layer and the field)."""
    from drake_disamb.config import data_layer, load_layers, merge_layers, task_layer, validate_scenario
    from drake_disamb.config.checks import check_duration

    layers = [task_layer(args.task), *scenario_text_layers(args)]
    for option, value in (
        ("--interface", args.interface),
        ("--paradigm", args.paradigm),
        ("--seed", args.seed),
    ):
        if value is not None:
            layers.append(data_layer({option[2:]: value}, option))
    layers += station_layers(args, layers)
    if args.goal is not None:
        goals = [args.goal] * merge_layers(layers).n_stages if isinstance(args.goal, int) else args.goal
        layers.append(data_layer({"user": {"goals": goals}}, "--goal"))
    scenario = load_layers(layers)
    if args.duration is None and not args.live:
        return scenario
    # A trial cut short (or lengthened) on purpose: the hold times are not held to its duration.
    if args.duration is not None:
        check_duration(args.duration, "--duration")
    duration = data_layer(
        {"duration": LIVE_DURATION if args.duration is None else args.duration}, "--duration"
    )
    return load_layers([duration], base=scenario, check=validate_scenario)


def _run(args: argparse.Namespace, stop: StopRequest) -> int:
    if args.dump_scenario:
        from drake_disamb.config import dump_scenario

        try:
            print(dump_scenario(_scenario(args)), end="")
        except ValueError as exc:
            return _error(exc)
        return 0
    if args.live and args.no_meshcat:
        return _error("--live needs Meshcat (drop --no-meshcat)")
    if args.record is not None and not args.live:
        return _error("--record records a person's trial: it needs --live")
    if args.record is not None and args.subject is None:
        return _error("--record needs --subject NAME (the person's name or code, e.g. P01)")
    if args.subject is not None and args.record is None:
        return _error("--subject names the person of a recorded trial: it needs --record DIR")
    # First, before the heavy imports and anything is built: a bad folder costs nothing.
    try:
        out = check_output_dir(args.out, "--out")
        if args.record is not None:
            check_record_dir(args.record)
    except ValueError as exc:
        return _error(exc)
    try:
        scenario = _scenario(args)
    except ValueError as exc:
        return _error(exc)
    record = None
    if args.record is not None:
        try:  # every name the record takes, by the record's own check, before the trial runs
            record = human_trial_id(args.record, args.subject, scenario)
        except ValueError as exc:
            return _error(f"--record: the trial's record would be refused: {exc}")
    meshcat = page = None
    if not args.no_meshcat:
        try:
            meshcat = start_meshcat(args)
            page = start_page(
                args, meshcat, title=f"drake-disamb demo: {scenario.task}, {scenario.interface}"
            )
        except (ValueError, RuntimeError) as exc:
            return _error(exc)
    try:
        return _shown_trial(args, stop, scenario, out, meshcat, page, record)
    finally:
        if page is not None:
            page.close()


def _shown_trial(
    args: argparse.Namespace,
    stop: StopRequest,
    scenario: Any,
    out: Path,
    meshcat: Any,
    page: Any,
    record: Any,
) -> int:
    """Build and run the trial (on the operator page ``page`` beside ``meshcat``'s scene, if any),
    then print, write and record what it did; the exit status."""
    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.progress import SimulationProgress
    from drake_disamb.trial import run_trial

    watching = meshcat is not None and attended()  # someone at a terminal may watch the page
    realtime = args.realtime_rate if args.realtime_rate is not None else (1.0 if watching else 0.0)
    source = None
    if args.live:
        from drake_disamb.interfaces import InterfaceConfig
        from drake_disamb.interfaces.live import page_live_input

        interface = InterfaceConfig(kind=scenario.interface, control_period=scenario.control_period)
        source = page_live_input(page, interface)
        source.set_name("live_input")
        realtime = args.realtime_rate if args.realtime_rate is not None else 1.0
    watched = meshcat is not None and (args.live or _waits_for_browser(args))
    with announce_kernel_compilation(_say):
        try:
            handles = build_shared_control_diagram(scenario, meshcat=meshcat, input_source=source, page=page)
        except (ValueError, RuntimeError) as exc:
            return _error(exc)
        if watched:
            # Someone will watch from the first tick: compile (or load) every kernel now, not then
            # (on the simulated station: the arm on a wire is the watched trial's only).
            from drake_disamb.station.backends import Sim

            run_trial(dataclasses.replace(scenario, duration=WARM_UP, station=Sim()), progress=False)
    if meshcat is not None:
        _show_url(meshcat, page, args, stop)
    if args.live:
        print(INTERFACES[scenario.interface].live_help, flush=True)
    print(
        f"running the trial (up to {scenario.duration:g} s simulated); Ctrl-C stops it and keeps the results",
        flush=True,
    )
    progress = False if args.quiet else SimulationProgress(scenario.duration)
    try:
        with announce_kernel_compilation(progress.write if progress else _say):
            result = run_trial(handles, progress=progress, realtime_rate=realtime, stop_requested=stop)
    finally:
        if source is not None:
            source.remove_controls()
    return _report(args, stop, result, handles, out, record, watching)


def _report(
    args: argparse.Namespace,
    stop: StopRequest,
    result: Any,
    handles: Any,
    out: Path,
    record: Any,
    watching: bool,
) -> int:
    """Print the trial's metrics, write its files and record it (``--record``); the exit status."""
    from drake_disamb.plotting import write_trial_figures

    if result.interrupted:
        print(f"stopped by {stop.signal_name or 'KeyboardInterrupt'} at {result.time:.2f} s", flush=True)
    if result.fault:
        print(f"station fault at {result.time:.2f} s: {result.fault}", file=sys.stderr, flush=True)
    print(format_metrics(result))
    try:
        written = [write_metrics(result, out, live=args.live)]
        written += write_trial_figures(result, handles, out)
    except OSError as exc:
        return _error(f"--out: writing into {out} failed ({exc})")
    if args.record is not None:
        try:
            trial_id = record_human_trial(result, args.record, args.subject, *record)
        except NotRecorded as exc:
            return _record_failed(exc)
        except ValueError as exc:  # a value of the trial the record refuses (names the field)
            return _record_failed(f"the trial's record is refused ({exc})")
        written.append(args.record / "trials.jsonl")
        print(f"recorded trial {trial_id} of {args.subject}")
    for path in written:
        print(f"wrote {path}")
    if result.fault:
        return EXIT_STATION_FAULT
    if result.interrupted:
        return EXIT_INTERRUPTED
    hold = args.hold if args.hold is not None else (5.0 if watching else 0.0)
    if handles.meshcat is not None and hold > 0 and not stop:
        print(f"Meshcat and the operator page stay up for {hold:g} s (Ctrl-C to quit)", flush=True)
        end = time.monotonic() + hold
        while not stop and time.monotonic() < end:
            time.sleep(min(0.1, max(0.0, end - time.monotonic())))
    return 0 if result.success else 1
