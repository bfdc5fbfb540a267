"""``study session``: a person's schedule from the protocol, what it refuses (one line, exit status
2, nothing written), a killed session resumed at the trial it was in, and the questionnaire in
``study report``. The page is driven here as a browser would drive it, through its HTTP input
(``tests/test_operator_browser.py`` drives it with a real browser)."""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import subprocess
import sys
import time
import urllib.request
from pathlib import Path
from typing import Any

import pytest
from support import SRC, cli_process, wait_for_line

from drake_disamb.study.analysis.survey import survey_rows, survey_text
from drake_disamb.study.data.surveys import SurveyRecord, append_survey, read_surveys
from drake_disamb.study.design.protocol import condition_order, protocol_from_yaml
from drake_disamb.study.design.survey import questionnaire
from drake_disamb.study.run.session import SESSIONS_FILE, plan_session, subject_schedule

PROTOCOL = """\
subjects: 2
interfaces: [head_array]
paradigms:
  - {name: manual, trials: 1}
  - {name: disambiguation, trials: 1}
request_latency: [0.5, 0.5]
duration: %(duration)s
tasks:
  - task: reaching
    start_poses:
      - {name: home}
"""


def protocol_file(folder: Path, duration: float = 3.0) -> Path:
    """A two-trial protocol (the head array, reaching; Manual then Disambiguation, counterbalanced)."""
    path = folder / "protocol.yaml"
    path.write_text(PROTOCOL % {"duration": duration})
    return path


def _main(*argv: str) -> tuple[int, str, str]:
    from drake_disamb.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(list(argv))
    return status, out.getvalue(), err.getvalue()


def _snapshot(folder: Path) -> dict[str, tuple[int, int]]:
    return (
        {
            str(p.relative_to(folder)): (p.stat().st_size, p.stat().st_mtime_ns)
            for p in sorted(folder.rglob("*"))
            if p.is_file()
        }
        if folder.exists()
        else {}
    )


# -- the schedule ---------------------------------------------------------------------------------------


def test_each_subject_takes_the_next_counterbalanced_row(tmp_path: Path) -> None:
    protocol = protocol_from_yaml(PROTOCOL % {"duration": 3.0})
    first = subject_schedule(protocol, 0, ["P07"], 0)
    second = subject_schedule(protocol, 0, ["P07", "A2"], 1)
    assert [s.trial_id for s in first] == [
        "P07-head_array-reaching-manual-r0",
        "P07-head_array-reaching-disambiguation-r0",
    ]
    assert [s.paradigm for s in second] == [p for _, _, p in condition_order(protocol, 1)]
    assert [s.paradigm for s in first] != [s.paradigm for s in second]  # the rows differ
    # A third subject of a two-subject protocol takes the first row again, with its own draws.
    third = subject_schedule(protocol, 0, ["P07", "A2", "Z3"], 2)
    assert [s.paradigm for s in third] == [s.paradigm for s in first]
    plan = plan_session(tmp_path / "s", protocol, "P07")
    assert [s.trial_id for s in plan.pending] == [s.trial_id for s in first]
    assert plan.index == 0 and (tmp_path / "s" / SESSIONS_FILE).is_file()
    plan.folder.release()
    plan = plan_session(tmp_path / "s", protocol, "A2")
    assert plan.index == 1 and [s.trial_id for s in plan.specs] == [s.trial_id for s in second]
    plan.folder.release()


def test_the_questionnaire_checks_every_answer() -> None:
    q = questionnaire(
        [("joystick", "reaching"), ("head_array", "reaching"), ("joystick", "reaching")],
        ["joystick", "head_array"],
        ["manual", "disambiguation"],
    )
    assert q.phases == (("joystick", "reaching"), ("head_array", "reaching"))
    page = q.for_page()
    assert [x["id"] for x in page] == ["Q1", "Q2", "Q3", "Q4", "Q5", "Q6", "Q7"]
    assert [i["key"] for i in page[0]["items"]] == ["joystick/reaching", "head_array/reaching"]
    good = {f"Q{k}": {"joystick/reaching": "6", "head_array/reaching": 3} for k in (1, 2, 3)}
    good |= {"Q4": "head_array", "Q5": "head_array", "Q6": "disambiguation", "Q7": "manual"}
    answers = q.check(good)
    assert answers.ratings["Q1"] == {"joystick/reaching": 6, "head_array/reaching": 3}
    with pytest.raises(
        ValueError, match=r"^Q2 \(Head array, reaching\): choose a rating from 1 to 7, got '8'$"
    ):
        q.check({**good, "Q2": {"joystick/reaching": "5", "head_array/reaching": "8"}})
    with pytest.raises(ValueError, match=r"^Q6: choose one of manual, disambiguation, got no answer$"):
        q.check({**good, "Q6": None})


def test_the_survey_table_is_the_papers_beside_its_values(tmp_path: Path) -> None:
    for subject, q1, q6 in (("P1", (5, 7), "disambiguation"), ("P2", (4, 6), "manual")):
        ratings = {f"Q{k}": {"joystick/reaching": q1[0], "head_array/pouring": q1[1]} for k in (1, 2, 3)}
        prefs = {"Q4": "head_array", "Q5": "head_array", "Q6": q6, "Q7": "manual"}
        append_survey(tmp_path, SurveyRecord(subject, ratings, prefs, "2020-01-01T00:00:00+00:00"))
    rows = survey_rows(read_surveys(tmp_path))
    by = {(r["question"], r["group"]): r for r in rows}
    assert by[("Q1", "all")]["n"] == 4 and by[("Q1", "all")]["mean"] == pytest.approx(5.5)
    assert by[("Q1", "all")]["sd"] == pytest.approx(1.2909944)  # the sample standard deviation
    assert by[("Q1", "interface:joystick")]["mean"] == pytest.approx(4.5)
    assert by[("Q1", "task:pouring")]["mean"] == pytest.approx(6.5)
    assert by[("Q1", "task:pouring")]["paper_mean"] == 4.88 and by[("Q1", "all")]["paper_sd"] == 0.95
    assert by[("Q1", "interface:joystick")]["paper_mean"] is None  # the paper has no such column
    assert by[("Q6", "all")]["answer"] == "disambiguation/manual"  # a tie, as the paper's Q7
    assert by[("Q7", "all")]["answer"] == "manual" and by[("Q7", "all")]["paper"] == "disambiguation/manual"
    text = survey_text(rows, "here")
    assert "5.50 \u00b1 1.29" in text and "4.88 \u00b1 0.95" in text
    with pytest.raises(ValueError, match=r"surveys.jsonl:3: subject 'P1' answered twice"):
        append_survey(tmp_path, SurveyRecord("P1", {}, {}, "x"))
        read_surveys(tmp_path)


def test_a_questionnaire_cut_by_a_kill_is_named_as_such(tmp_path: Path) -> None:
    """Surveys are read as the records are: a last line without its newline is what a killed writer
    leaves, and the error says so."""
    append_survey(tmp_path, SurveyRecord("P1", {}, {}, "x"))
    with open(tmp_path / "surveys.jsonl", "a", encoding="utf-8") as f:
        f.write('{"subject": "P2", "rat')
    with pytest.raises(ValueError, match=r"surveys.jsonl:2: the last line is incomplete"):
        read_surveys(tmp_path)


# -- what is refused ------------------------------------------------------------------------------------


def test_a_subject_id_with_path_characters_is_refused_and_nothing_written(tmp_path: Path) -> None:
    out = tmp_path / "sessions"
    for subject in ("../P01", "a/b", "P 01", ""):
        status, stdout, err = _main("study", "session", "--subject", subject, "--out", str(out))
        assert status == 2 and stdout == ""
        assert err.count("\n") == 1 and err.startswith(
            "drake-disamb study session: error: --subject: expected"
        )
    assert not out.exists()


def test_a_folder_of_another_protocol_is_refused_and_nothing_written(tmp_path: Path) -> None:
    from drake_disamb.study.design.protocol import load_protocol

    out = tmp_path / "sessions"
    plan_session(out, load_protocol(protocol_file(tmp_path)), "P01").folder.release()
    before = _snapshot(out)
    (tmp_path / "other").mkdir()
    other = protocol_file(tmp_path / "other", 5.0)
    status, stdout, err = _main(
        "study", "session", "--subject", "P02", "--out", str(out), "--protocol", str(other)
    )
    assert status == 2 and stdout == "" and err.count("\n") == 1
    assert "holds the sessions of another protocol (protocol differs" in err
    status, _, err = _main(
        "study",
        "session",
        "--subject",
        "P02",
        "--out",
        str(out),
        "--seed",
        "3",
        "--protocol",
        str(tmp_path / "protocol.yaml"),
    )
    assert status == 2 and "another protocol (seed differs" in err
    study = tmp_path / "study"
    study.mkdir()
    (study / "study.yaml").write_text("format: 1\n")
    status, _, err = _main("study", "session", "--subject", "P02", "--out", str(study))
    assert status == 2 and "holds a simulated study" in err
    assert _snapshot(out) == before and sorted(p.name for p in study.iterdir()) == ["study.yaml"]


def test_a_second_session_in_the_folder_is_refused_and_nothing_written(tmp_path: Path) -> None:
    out = tmp_path / "sessions"
    protocol = protocol_file(tmp_path)
    holder = subprocess.Popen(  # another process's session holds the folder
        [
            sys.executable,
            "-c",
            "import sys, time; from drake_disamb.study.design.protocol import load_protocol; "
            "from drake_disamb.study.run.session import plan_session; "
            f"plan_session({str(out)!r}, load_protocol({str(protocol)!r}), 'P01'); "
            "print('held', flush=True); time.sleep(60)",
        ],
        stdout=subprocess.PIPE,
        text=True,
        env=dict(os.environ, PYTHONPATH=str(SRC)),
    )
    try:
        assert holder.stdout.readline().strip() == "held"
        before = _snapshot(out)
        for subject in ("P01", "P02"):
            status, stdout, err = _main(
                "study", "session", "--subject", subject, "--out", str(out), "--protocol", str(protocol)
            )
            assert status == 2 and stdout == "" and err.count("\n") == 1
            assert f"is being written by another process (PID {holder.pid})" in err
        assert _snapshot(out) == before
    finally:
        holder.kill()
        holder.wait()


# -- a session killed mid-trial -----------------------------------------------------------------------------


class Page:
    """The operator page of a running ``study session``, driven through its HTTP input."""

    def __init__(self, url: str) -> None:
        self.url = url

    def post(self, body: dict[str, Any]) -> None:
        data = json.dumps({"page": "test", **body}).encode()
        request = urllib.request.Request(self.url + "input", data, {"Content-Type": "application/json"})
        urllib.request.urlopen(request, timeout=10)

    def state(self) -> dict[str, Any]:
        return json.loads(urllib.request.urlopen(self.url + "state", timeout=10).read())


def _session(out: Path, protocol: Path) -> tuple[subprocess.Popen, Page, list[str]]:
    proc = cli_process("study", "session", "--subject", "P01", "--out", str(out), "--protocol", str(protocol))
    lines = wait_for_line(proc, "http://localhost:71", timeout=180)
    url = next(line.strip() for line in lines if line.startswith("http://"))
    return proc, Page(url), lines


def test_a_session_killed_mid_trial_resumes_at_that_trial(tmp_path: Path) -> None:
    out = tmp_path / "sessions"
    protocol = protocol_file(tmp_path, duration=20.0)
    proc, page, _ = _session(out, protocol)
    try:
        wait_for_line(proc, "trial 1 of 2", timeout=120)
        page.post({"type": "action", "name": "start"})
        wait_for_line(proc, "trial 1 of 2 (P01-head_array-reaching-manual-r0): running", timeout=60)
        page.post({"type": "action", "name": "end_trial"})  # the experimenter's key
        wait_for_line(proc, "recorded", timeout=60)
        wait_for_line(proc, "trial 2 of 2", timeout=120)
        page.post({"type": "action", "name": "start"})
        wait_for_line(proc, "running", timeout=60)
        time.sleep(1.0)
        proc.send_signal(signal.SIGKILL)  # killed mid-trial
        proc.wait(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    records = [json.loads(line) for line in (out / "trials.jsonl").read_text().splitlines()]
    assert [r["trial_id"] for r in records] == ["P01-head_array-reaching-manual-r0"]
    first = records[0]
    assert first["source"] == "human" and first["success"] is False
    assert first["extra"]["end_reason"] == "given up" and first["extra"]["ended_by"] == "experimenter"
    proc, page, lines = _session(out, protocol)
    try:
        assert any(
            "resuming at trial 2 of 2 (P01-head_array-reaching-disambiguation-r0)" in line for line in lines
        )
        wait_for_line(proc, "trial 2 of 2", timeout=120)
        assert page.state()["screen"]["title"].startswith(
            "Trial 2 of 2: Head array, reaching, disambiguation"
        )
        page.post({"type": "action", "name": "start"})
        wait_for_line(proc, "running", timeout=60)
        page.post({"type": "action", "name": "end_trial"})
        wait_for_line(proc, "questionnaire is on the page", timeout=60)
        questions = page.state()["screen"]["questions"]
        answers: dict[str, Any] = {}
        for q in questions:
            answers[q["id"]] = (
                {item["key"]: "6" for item in q["items"]}
                if q["kind"] == "likert"
                else q["options"][-1]["value"]
            )
        page.post({"type": "survey", "answers": answers})
        stdout, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    records = [json.loads(line) for line in (out / "trials.jsonl").read_text().splitlines()]
    assert [r["trial_id"] for r in records] == [
        "P01-head_array-reaching-manual-r0",
        "P01-head_array-reaching-disambiguation-r0",
    ]
    assert sorted(p.name for p in (out / "traces").iterdir()) == sorted(
        f"{r['trial_id']}.npz" for r in records
    )
    (survey,) = read_surveys(out)
    assert survey.subject == "P01" and survey.ratings["Q2"] == {"head_array/reaching": 6}
    status, _, err = _main(
        "study", "session", "--subject", "P01", "--out", str(out), "--protocol", str(protocol)
    )
    assert status == 2 and "the subject's session in" in err and "is complete" in err
    status, stdout, _ = _main("study", "report", str(out), "--no-mixed-model")
    assert status == 0
    assert (
        "Questionnaire" in stdout
        and "Q2        all" in stdout
        and "6.00" in stdout
        and "6.19 \u00b1 0.75" in stdout
    )
