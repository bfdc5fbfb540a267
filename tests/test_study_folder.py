"""The study folder: one writer (the lock), the one check of records and traces, and a report that
writes nothing outside ``report/``. Each bad input is planted by a fixture and must give one line
naming the file, the line and the field, never a traceback."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from test_records import _record
from test_study_report import digest, synthetic_records, write_study

from drake_disamb.cli import main
from drake_disamb.study.data.folder import FolderBusy, StudyFolder, TraceError, check_trace
from drake_disamb.study.data.records import RecordError, read_records

SRC = Path(__file__).resolve().parents[1] / "src"


# ----------------------------------------------------------------------------------------------
# One writer


@pytest.fixture
def held_folder(tmp_path: Path):
    """A study folder whose lock another process holds (it prints its PID, then sleeps)."""
    folder = tmp_path / "study"
    code = (
        "import sys, time; from drake_disamb.study.data.folder import StudyFolder; "
        f"StudyFolder({str(folder)!r}).prepare(); print('locked', flush=True); time.sleep(60)"
    )
    env = dict(os.environ, PYTHONPATH=str(SRC))
    child = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True, env=env)
    assert child.stdout.readline().strip() == "locked"
    yield folder, child
    child.kill()
    child.wait()


def test_a_second_writer_is_refused_at_once_naming_the_folder_and_pid(held_folder) -> None:
    folder, child = held_folder
    start = time.monotonic()
    with pytest.raises(FolderBusy, match=rf"{folder}.*PID {child.pid}"):
        StudyFolder(folder).prepare()
    assert time.monotonic() - start < 1.0
    child.kill()
    child.wait()  # the kernel releases the lock of a dead process
    StudyFolder(folder).prepare()
    StudyFolder(folder).release()


@pytest.mark.parametrize(
    "argv",
    [
        ["study", "run", "--quick", "--out", "{folder}", "--workers", "1", "--quiet"],
        ["study", "ablate", "--quick", "--out", "{folder}", "--switch", "inference.agreement=dot", "--quiet"],
        ["study", "import-authors", "{data}", "--out", "{folder}"],
    ],
    ids=["run", "ablate", "import-authors"],
)
def test_every_writer_takes_the_lock(
    held_folder, argv: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    folder, child = held_folder
    data = Path(__file__).resolve().parents[2] / "shared" / "data" / "tnsre2020_human_study"
    if "import-authors" in argv and not data.is_dir():
        pytest.skip(f"needs the published data in {data}")
    argv = [a.format(folder=folder, data=data) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"PID {child.pid}" in err and "Traceback" not in err


def test_demo_record_takes_the_lock(held_folder) -> None:
    from drake_disamb.commands.demo import check_record_dir

    folder, child = held_folder
    with pytest.raises(ValueError, match=rf"--record: .*PID {child.pid}"):
        check_record_dir(folder)


DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "tnsre2020_human_study"


def _files(folder: Path) -> dict[str, str]:
    return {k: v for k, v in digest(folder).items() if k != StudyFolder.LOCK_NAME}


@pytest.fixture(params=["study.yaml", "ablation.json"])
def simulated_study(request: pytest.FixtureRequest, tmp_path: Path) -> Path:
    """A simulated study's folder: a planned ``study run`` (its ``study.yaml``, one record), or an
    ablation's (its ``ablation.json``); this process does not hold its lock."""
    from drake_disamb.study.design.protocol import quick_protocol
    from drake_disamb.study.run.runner import plan_study

    folder = tmp_path / "study"
    if request.param == "study.yaml":
        plan = plan_study(folder, quick_protocol(), 0, check_scenarios=False)
        spec = plan.specs[0]
        record = _record(
            spec.trial_id, subject=spec.subject, interface=spec.interface, task=spec.task,
            paradigm=spec.paradigm, repetition=spec.repetition, seed=spec.seed, start_pose=spec.start_pose,
        )  # fmt: skip
        plan.folder.append(record, _trace())
    else:
        folder.mkdir()
        (folder / "ablation.json").write_text('{"format": 1, "settings": []}\n')
    StudyFolder(folder).release()
    return folder


@pytest.mark.parametrize("writer", ["demo", "import-authors", "append"])
def test_a_simulated_studys_folder_takes_no_other_records(
    simulated_study: Path, writer: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``demo --record`` and ``study import-authors`` into a simulated study's folder are refused
    before anything runs (one line, status 2, nothing written); the study still resumes."""
    before = _files(simulated_study)
    message = f"study folder {simulated_study} holds a simulated study ({simulated_study}/"
    if writer == "append":
        folder = StudyFolder(simulated_study).prepare()
        with pytest.raises(ValueError, match="holds a simulated study"):
            folder.append(_record("h", source="human"), _trace())
        folder.release()
    else:
        if writer == "import-authors" and not DATA.is_dir():
            pytest.skip(f"needs the published data in {DATA}")
        argv = {
            "demo": ["demo", "--quiet", "--live", "--no-wait", "--duration", "1", "--record",
                     str(simulated_study), "--subject", "P01", "--out", str(tmp_path / "demo")],
            "import-authors": ["study", "import-authors", str(DATA), "--out", str(simulated_study)],
        }[writer]  # fmt: skip
        assert main(argv) == 2
        captured = capsys.readouterr()
        (line,) = captured.err.strip().splitlines()
        assert f"error: {'--record: ' if writer == 'demo' else ''}{message}" in line
        assert "running the trial" not in captured.out and "imported" not in captured.out
    assert _files(simulated_study) == before
    StudyFolder(simulated_study).release()
    if (simulated_study / "study.yaml").exists():
        from drake_disamb.study.design.protocol import quick_protocol
        from drake_disamb.study.run.runner import plan_study

        plan = plan_study(simulated_study, quick_protocol(), 0, check_scenarios=False)
        assert len(plan.finished) == 1 and len(plan.pending) == len(plan.specs) - 1
        plan.folder.release()


def test_append_needs_the_lock_and_reads_back(tmp_path: Path) -> None:
    folder = StudyFolder(tmp_path / "s")
    trace = {"t": np.arange(3.0), "belief": np.full((3, 2), 0.5), "alpha": np.zeros(3)}
    trace |= {"u": np.zeros((3, 6)), "u_h": np.zeros((3, 6)), "mode": np.zeros(3)}
    with pytest.raises(RuntimeError, match="lock"):
        folder.append(_record("a"), trace)
    folder.prepare()
    folder.append(_record("a"), trace)
    folder.release()
    (trial,) = StudyFolder(tmp_path / "s").read_trials()
    assert trial.record.trial_id == "a" and np.array_equal(trial.trace["t"], trace["t"])


def test_a_full_disk_names_the_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import errno

    import drake_disamb.study.data.folder as F

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    folder = StudyFolder(tmp_path).prepare()
    monkeypatch.setattr(F, "append_record", full)
    trace = {"t": np.arange(2.0), "belief": np.ones((2, 1)), "alpha": np.zeros(2), "mode": np.zeros(2)}
    trace |= {"u": np.zeros((2, 6)), "u_h": np.zeros((2, 6))}
    with pytest.raises(F.FolderWriteError, match=r"trials.jsonl: No space left on device"):
        folder.append(_record("a"), trace)
    folder.release()


def test_an_unsaved_trial_is_kept_whole_or_not_at_all(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import errno

    import drake_disamb.study.data.folder as F

    folder = tmp_path / "people"
    first = F.keep_unsaved(folder, _record("a"), _trace())
    second = F.keep_unsaved(folder, _record("a"), _trace())  # never over the first
    assert (first.name, second.name) == ("people.unsaved-a.npz", "people.unsaved-a.1.npz")
    record, trace = F.read_unsaved(second)
    assert record == _record("a") and trace.keys() == _trace().keys()
    assert np.array_equal(trace["belief"], _trace()["belief"])
    trace_file = F.save_trace(tmp_path / "t.npz", _trace())
    with pytest.raises(RecordError, match=rf"{trace_file}: no 'record'"):
        F.read_unsaved(trace_file)

    def full(*args: object, **kwargs: object) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(F.np, "savez_compressed", full)
    with pytest.raises(OSError, match="No space left on device"):
        F.keep_unsaved(folder, _record("b"), _trace())
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([first.name, second.name, "t.npz"])


# ----------------------------------------------------------------------------------------------
# Records: the one check


_LINE = json.loads(_record("x").to_json())


@pytest.mark.parametrize(
    "field, value",
    [
        ("completion_time", "12"),
        ("completion_time", float("nan")),
        ("completion_time", -1.0),
        ("mean_alpha", 1.5),
        ("mean_alpha", float("inf")),
        ("success", "yes"),
        ("task", "juggling"),
        ("interface", "keyboard"),
        ("paradigm", 3),
        ("disambiguation_method", "magic"),
        ("intended_goals", [-1]),
        ("intended_goals", [1.5]),
        ("reached_goals", [-2]),
        ("repetition", True),
        ("duration", float("nan")),
        ("trial_id", "../x"),
        ("trial_id", "x\n"),
        ("subject", "Ünïcødé"),
        ("subject", "٣٣"),
        ("subject", "S" * 65),
        ("assistance_onset", "soon"),
        ("request_times", [float("nan")]),
    ],
)
def test_a_bad_record_value_names_the_file_line_and_field(
    tmp_path: Path, field: str, value: object, capsys: pytest.CaptureFixture[str]
) -> None:
    good = synthetic_records()[:2]
    folder = write_study(tmp_path, good, traces=False)
    bad = dict(_LINE, **{field: value})
    with open(folder / "trials.jsonl", "a") as f:
        f.write(json.dumps(bad) + "\n")  # json writes NaN / Infinity as Python reads them back
    with pytest.raises(RecordError, match=rf"trials.jsonl:3: field {field}: expected"):
        read_records(folder / "trials.jsonl")
    before = digest(folder)
    assert main(["study", "report", str(folder)]) == 2
    err = capsys.readouterr().err
    assert f"trials.jsonl:3: field {field}" in err and "Traceback" not in err
    assert digest(folder) == before and not (folder / "report" / "summary.json").exists()


# ----------------------------------------------------------------------------------------------
# Traces: the one check; a bad one is skipped with a warning


def _trace(n: int = 5) -> dict[str, np.ndarray]:
    return {
        "t": np.arange(n) * 0.1,
        "belief": np.full((n, 2), 0.5),
        "alpha": np.zeros(n),
        "u": np.zeros((n, 6)),
        "u_h": np.zeros((n, 6)),
        "mode": np.zeros(n),
    }


@pytest.mark.parametrize(
    "change, message",
    [
        ({"belief": np.full((5, 2), np.nan)}, "belief: element 0 is nan"),
        ({"alpha": np.array([0, 0, np.inf, 0, 0.0])}, "alpha: element 2 is inf"),
        ({"u": np.zeros((4, 6))}, r"u: expected shape \(5, 6\)"),
        ({"t": np.array([0, 0.2, 0.1, 0.3, 0.4])}, "t: the sample times decrease"),
        ({"mode": np.full(5, 0.5)}, "mode: expected mode indices"),
        ({"t": None}, "missing arrays"),
    ],
)
def test_check_trace_names_the_array(change: dict, message: str) -> None:
    trace = _trace()
    trace.update(change)
    trace = {k: v for k, v in trace.items() if v is not None}
    with pytest.raises(TraceError, match=message):
        check_trace(trace, "T.npz")


@pytest.fixture
def bad_traces(tmp_path: Path) -> Path:
    """A study whose traces are truncated, hold NaN or inf, or are a symlink to nowhere."""
    records = [r for r in synthetic_records() if r.interface == "joystick" and r.task == "reaching"]
    folder = write_study(tmp_path / "s", records)
    first = [r for r in records if r.repetition == 0]
    paths = [folder / "traces" / f"{r.trial_id}.npz" for r in first]
    paths[0].write_bytes(paths[0].read_bytes()[:100])  # truncated: a BadZipFile
    with np.load(paths[1]) as z:
        arrays = dict(z)
    arrays["belief"][3, 0] = np.nan
    np.savez(paths[1], **arrays)
    return folder


def test_report_skips_a_bad_trace_with_a_warning(
    bad_traces: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["study", "report", str(bad_traces), "--no-mixed-model"]) == 0
    err = capsys.readouterr().err
    assert "Traceback" not in err
    warnings = [line for line in err.splitlines() if line.startswith("warning: ")]
    bad = [line for line in warnings if "is missing" not in line]
    assert len(bad) == 2 and "not a readable trace" in err and "belief: element" in err
    # and one for each trace the fixture did not write (the second repetitions')
    without = [r for r in read_records(bad_traces / "trials.jsonl") if r.repetition != 0]
    assert len(warnings) - len(bad) == len(without) > 0


def test_calibrate_skips_a_bad_trace_with_a_warning(
    bad_traces: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    trials = StudyFolder(bad_traces).read_trials()
    err = capsys.readouterr().err
    with_trace = [r for r in read_records(bad_traces / "trials.jsonl") if r.repetition == 0]
    assert len(trials) == len(with_trace) - 2
    assert "not a readable trace" in err and "belief: element" in err and "Traceback" not in err


# ----------------------------------------------------------------------------------------------
# The report writes only into report/


def test_report_never_writes_through_a_planted_symlink(tmp_path: Path) -> None:
    folder = write_study(tmp_path / "s", synthetic_records()[:24])
    outside = tmp_path / "outside"
    outside.mkdir()
    victim = outside / "victim.txt"
    victim.write_text("keep me")
    report = folder / "report"
    report.mkdir()
    for name in ("summary.json", "stats.json", "index.html", "button_presses.png"):
        (report / name).symlink_to(victim)
    (report / "raster.png").symlink_to(outside / "new.png")  # dangling: would create a file outside
    assert main(["study", "report", str(folder), "--no-mixed-model"]) == 0
    assert victim.read_text() == "keep me" and sorted(p.name for p in outside.iterdir()) == ["victim.txt"]
    assert not any(p.is_symlink() for p in report.iterdir())
    assert not list(report.glob(".*.tmp"))


def test_report_refuses_a_report_folder_that_is_a_symlink(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = write_study(tmp_path / "s", synthetic_records()[:24], traces=False)
    (tmp_path / "elsewhere").mkdir()
    (folder / "report").symlink_to(tmp_path / "elsewhere")
    assert main(["study", "report", str(folder)]) == 2
    assert "report: not a folder (a symlink" in capsys.readouterr().err
    assert list((tmp_path / "elsewhere").iterdir()) == []
