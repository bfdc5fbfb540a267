"""``drake-disamb study session --subject ID --out DIR``: a person's session of the protocol, at the
operator page.

The subject's counterbalanced schedule of the protocol (default: the paper's; ``--protocol FILE``
another) runs at the operator page (docs/operator_page.md), one trial after another
(:mod:`drake_disamb.study.run.session`): before each trial the page shows the trial's place in the
session, a rest before a new block, the goal and what the condition means, and the trial starts
when the person (or the experimenter) presses Enter or clicks Start. The person drives from the
page (keys, on-page buttons or a gamepad) at real time. A trial ends at its goal, at its time limit,
by the protocol's experimenter's rule (``give_up_after``), or when the experimenter presses Esc:
that ends it as the rule does (a failure, ``end_reason`` "given up", ``extra.ended_by``
"experimenter"). Each trial is appended to ``DIR/trials.jsonl`` as a record (``source: human``)
with its trace in ``DIR/traces/``; with ``--recordings`` its Meshcat recording, with the panel the
person saw replayed beside the scene, is saved as ``DIR/recordings/<trial_id>.html`` too (some
megabytes per minute of trial). After the last trial the page asks the paper's questionnaire
(:mod:`drake_disamb.study.design.survey`); the answers go to ``DIR/surveys.jsonl``. ``study report
DIR`` then adds the questionnaire's table beside the paper's.

Resume: a session stopped or killed mid-trial keeps every trial recorded before; the same command
starts at the trial it was in (from its start), or at the questionnaire.

Refused, with one line and exit status 2, before anything is written: a subject id with anything
but letters, digits, ``_`` and ``-`` (no path characters), a folder of another protocol (or of a
simulated study, or of another command's records), a subject whose session is complete, and a
second session while one runs in the folder.

Exit status: 0 the session is complete; 2 bad input; 3 a station fault on the wire (the trial is
not recorded: the same command runs it again); 4 a record could not be written (kept beside the
folder); 130 stopped by SIGINT or SIGTERM (the trial running then is not recorded).
"""

from __future__ import annotations

import argparse
import datetime
import sys
import time
from pathlib import Path
from typing import Any

from drake_disamb.commands._meshcat import add_meshcat_arguments, start_meshcat
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
from drake_disamb.commands.study_run import EXIT_WRITE_FAILED, error

HELP = "Run a person's session of the protocol at the operator page: the trials, then the questionnaire."

POLL = 0.2
"""Seconds between two looks at the stop request while waiting for the page."""

DONE_HOLD = 3.0
"""Seconds the page stays up after the session, showing that it is complete."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the ``study session`` options."""
    parser.add_argument("--subject", required=True, metavar="ID", help="the person's id (e.g. P01)")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="the folder of the sessions")
    parser.add_argument("--protocol", type=Path, default=None, help="protocol YAML (default: the paper's)")
    parser.add_argument(
        "--seed", type=int, default=0, help="seed of the trials' draws (goals, modes, poses; default: 0)"
    )
    parser.add_argument(
        "--recordings",
        action="store_true",
        help="also save each trial's recording, the panel the person saw beside the scene, as "
        "DIR/recordings/<trial_id>.html",
    )
    add_scenario_text_argument(parser)
    add_station_arguments(parser)
    add_meshcat_arguments(parser)
    add_page_arguments(parser)


def run(args: argparse.Namespace) -> int:
    """``study session``: the exit statuses are in the module docstring."""
    with StopRequest() as stop:
        try:
            return _run(args, stop)
        except KeyboardInterrupt:
            print(
                "drake-disamb study session: interrupted again; the trial running is not recorded",
                file=sys.stderr,
            )
            return EXIT_INTERRUPTED


def _layers(args: argparse.Namespace, spec: Any, plan: Any) -> list[Any]:
    """A trial's scenario layers: the schedule's, then ``--scenario-text`` and the station's."""
    from drake_disamb.study.run.runner import trial_layers

    layers = [*trial_layers(spec, plan.context), *scenario_text_layers(args)]
    return layers + station_layers(args, layers)


def _run(args: argparse.Namespace, stop: StopRequest) -> int:
    from drake_disamb.config import load_layers
    from drake_disamb.study.design.protocol import load_protocol
    from drake_disamb.study.run.session import check_subject, plan_session

    try:
        check_subject(args.subject)
        protocol = load_protocol(args.protocol)
        if args.seed < 0:
            raise ValueError(f"--seed: expected a non-negative integer, got {args.seed}")
        plan = plan_session(args.out, protocol, args.subject, args.seed)
    except ValueError as exc:
        return error("session", exc)
    try:  # every trial's scenario, before the first starts (the options' errors name them)
        scenarios = {spec.trial_id: load_layers(_layers(args, spec, plan)) for spec in plan.pending}
        meshcat = start_meshcat(args)
        page = start_page(args, meshcat, title=f"drake-disamb session: {args.subject}")
    except (ValueError, RuntimeError) as exc:
        return error("session", exc)
    try:
        return _session(plan, scenarios, meshcat, page, stop, args.recordings)
    finally:
        page.close()


def _say(line: str) -> None:
    print(line, flush=True)


def _session(
    plan: Any, scenarios: dict[str, Any], meshcat: Any, page: Any, stop: StopRequest, recordings: bool
) -> int:
    total, pending = len(plan.specs), plan.pending
    where = f"{len(plan.specs) - len(pending)} recorded before" if len(pending) < total else "a new session"
    _say(f"session of {plan.subject} in {plan.folder.path}: {total} trials ({where}), then the questionnaire")
    if pending and len(pending) < total:
        first = pending[0]
        _say(f"resuming at trial {plan.specs.index(first) + 1} of {total} ({first.trial_id}), from its start")
    _say(f"Meshcat: {meshcat.web_url()} (the scene alone)")
    print_page_address(page, live=True)
    for spec in pending:
        status = _one_trial(plan, spec, scenarios[spec.trial_id], meshcat, page, stop, recordings)
        if status is not None:
            return status
    if not plan.survey_done:
        status = _questionnaire(plan, page, stop)
        if status is not None:
            return status
    page.set_screen(
        {"id": "done", "kind": "message", "title": "Thank you!", "lines": ["The session is complete."]}
    )
    _say(f"session of {plan.subject} complete: {total} trials and the questionnaire in {plan.folder.path}")
    end = time.monotonic() + DONE_HOLD
    while not stop and time.monotonic() < end:
        time.sleep(0.05)
    return 0


def _wait(page: Any, action: str, stop: StopRequest) -> Any:
    """The payload of the next ``action`` from the page, or ``None`` once ``stop`` is set."""
    while not stop:
        got = page.wait_action({action}, POLL)
        if got is not None:
            return got
    return None


def _stopped(what: str) -> int:
    print(f"drake-disamb study session: stopped {what}; the same command resumes there", file=sys.stderr)
    return EXIT_INTERRUPTED


def _one_trial(
    plan: Any, spec: Any, scenario: Any, meshcat: Any, page: Any, stop: StopRequest, recordings: bool
) -> int | None:
    """Show the trial's screen, run it from the start press, record it; ``None`` to go on, else the
    exit status."""
    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.commands._first_run import announce_kernel_compilation
    from drake_disamb.interfaces import InterfaceConfig
    from drake_disamb.interfaces.live import page_live_input
    from drake_disamb.study.run.session import trial_screen
    from drake_disamb.trial import run_trial

    n = f"trial {plan.specs.index(spec) + 1} of {len(plan.specs)} ({spec.trial_id})"
    source = page_live_input(
        page, InterfaceConfig(kind=scenario.interface, control_period=scenario.control_period)
    )
    source.set_name("live_input")
    with announce_kernel_compilation(_say):
        handles = build_shared_control_diagram(scenario, meshcat=meshcat, input_source=source, page=page)
    try:
        page.clear_actions()
        page.set_screen(trial_screen(plan, spec, scenario), {"Enter": "start"})
        _say(f"{n}: the page shows its instructions; it starts when Enter is pressed there")
        if _wait(page, "start", stop) is None:
            return _stopped(f"before {n}")
        page.reset_controls()
        page.clear_actions()
        page.set_screen(None, {"Escape": "end_trial"})
        _say(f"{n}: running (Esc on the page ends it as the experimenter's rule does)")
        ended: list[str] = []

        def stop_requested() -> bool:
            if page.wait_action({"end_trial"}, 0.0) is not None:
                ended.append("experimenter")
            return bool(stop) or bool(ended)

        result = run_trial(handles, progress=False, realtime_rate=1.0, stop_requested=stop_requested)
    finally:
        source.remove_controls()
        page.set_screen(None)
    if stop and not ended:
        return _stopped(f"during {n} (not recorded)")
    if result.fault:
        print(f"drake-disamb study session: station fault in {n}: {result.fault}", file=sys.stderr)
        return EXIT_STATION_FAULT
    return _record(plan, spec, result, handles, ended[0] if ended else result.end_reason, n, recordings)


def _record(
    plan: Any, spec: Any, result: Any, handles: Any, ended_by: str, n: str, recordings: bool
) -> int | None:
    """Append the trial's record (and save its recording); ``None``, or the exit status of a failure."""
    from drake_disamb.study.run.session import session_record

    record, trace = session_record(result, spec, plan.context, ended_by)
    try:
        append_or_keep(plan.folder, record, trace)
    except NotRecorded as exc:
        print(f"drake-disamb study session: error: {exc}", file=sys.stderr)
        return EXIT_WRITE_FAILED
    outcome = "goal reached" if record.success else f"not successful ({record.extra.get('end_reason')})"
    _say(f"{n}: recorded ({outcome}, {record.duration:.1f} s, ended by {ended_by})")
    if recordings:
        _save_recording(plan, spec, result, handles, n)
    handles.meshcat.DeleteRecording()
    return None


def _save_recording(plan: Any, spec: Any, result: Any, handles: Any, n: str) -> None:
    """``DIR/recordings/<trial_id>.html``: the trial's recording with the panel the person saw."""
    from drake_disamb.display import legend_rows
    from drake_disamb.plotting import save_recording

    panel = handles.systems["panel"]
    try:
        path = plan.folder.path / "recordings" / f"{spec.trial_id}.html"
        title = f"{plan.subject}: {spec.trial_id}"
        save_recording(handles.meshcat, path, legend_rows(result.scenario), title, panel.recorder.log)
    except OSError as exc:  # the record is what counts: a recording that cannot be written is said
        print(
            f"drake-disamb study session: warning: the recording of {n} was not saved ({exc})",
            file=sys.stderr,
        )


def _questionnaire(plan: Any, page: Any, stop: StopRequest) -> int | None:
    """Ask the questionnaire on the page until its answers are complete, and save them."""
    from drake_disamb.study.data.surveys import SurveyRecord, append_survey

    questions = plan.questionnaire()
    screen = {
        "id": "survey",
        "kind": "survey",
        "title": "Questionnaire",
        "lines": [
            "Please rate each statement from 1 (strongly disagree) to 7 (strongly agree) for each interface "
            "and task you used, then answer the four questions.",
        ],
        "questions": questions.for_page(),
        "button": "Send the answers",
    }
    page.clear_actions()
    page.set_screen(screen)
    _say("the questionnaire is on the page")
    while True:
        got = _wait(page, "survey", stop)
        if got is None:
            return _stopped("at the questionnaire (not saved)")
        try:
            answers = questions.check(got[1])
        except ValueError as exc:
            page.set_screen({**screen, "error": str(exc)})
            continue
        break
    submitted = datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")
    record = SurveyRecord(plan.subject, answers.ratings, answers.preferences, submitted)
    try:
        path = append_survey(plan.folder.path, record)
    except OSError as exc:
        print(f"drake-disamb study session: error: the answers were not saved ({exc})", file=sys.stderr)
        return EXIT_WRITE_FAILED
    _say(f"the answers are saved in {path}")
    return None
