"""Faults of a study run, injected through fixtures: a lost Dask scheduler, a dead worker, a full
disk, a stop request, a folder that holds another study. Each ends with one line saying what
happened and that a rerun resumes, its documented exit status, no traceback, and nothing printed
that claims a file that was not written."""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import dataclasses
import errno
import json
import os
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest
from test_records import _record
from test_study_runner import tiny_protocol_data, write_yaml

from drake_disamb.cli import main
from drake_disamb.commands import study_run
from drake_disamb.study.data.records import read_records
from drake_disamb.study.design import protocol as P
from drake_disamb.study.run.runner import StudyMismatch, TrialOutput, plan_study, run_study


def _output(spec) -> TrialOutput:  # noqa: ANN001 (TrialSpec)
    """A made-up result for ``spec`` (nothing is simulated)."""
    record = dataclasses.replace(
        _record(spec.trial_id),
        subject=spec.subject,
        interface=spec.interface,
        task=spec.task,
        paradigm=spec.paradigm,
        repetition=spec.repetition,
        seed=spec.seed,
        start_pose=spec.start_pose,
    )
    n = 4
    trace = {"t": np.arange(n) * 0.1, "belief": np.full((n, 2), 0.5), "alpha": np.zeros(n)}
    trace |= {"u": np.zeros((n, 6)), "u_h": np.zeros((n, 6)), "mode": np.zeros(n)}
    return TrialOutput(record=record, trace=trace)


class FakeExecutor(cf.Executor):
    """Trials answered by ``outcome(k, spec)`` (the k-th submission): a ``TrialOutput`` or an
    exception the future raises, as the executor would."""

    def __init__(self, outcome: Callable[[int, object], object]) -> None:
        self.outcome = outcome
        self.k = 0

    def submit(self, fn, spec, *args, **kwargs):  # type: ignore[no-untyped-def, override]
        future: cf.Future = cf.Future()
        value = self.outcome(self.k, spec)
        self.k += 1
        if isinstance(value, BaseException):
            future.set_exception(value)
        else:
            future.set_result(value)
        return future


@pytest.fixture
def fake_executor(monkeypatch: pytest.MonkeyPatch):
    """Install a :class:`FakeExecutor` with the given outcome in place of ``study run``'s pool."""

    def install(outcome: Callable[[int, object], object]) -> None:
        @contextlib.contextmanager
        def fake(workers, scheduler) -> Iterator[tuple[cf.Executor, str]]:  # type: ignore[no-untyped-def]
            yield FakeExecutor(outcome), "a fake executor"

        monkeypatch.setattr(study_run, "open_executor", fake)

    return install


@pytest.fixture
def protocol(tmp_path: Path) -> Path:
    return write_yaml(tmp_path / "protocol.yaml", tiny_protocol_data())


def _run(out: Path, protocol: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    from drake_disamb.study.data.folder import StudyFolder

    try:
        status = main(
            ["study", "run", "--out", str(out), "--protocol", str(protocol), "--seed", "3", "--quiet"]
        )
    finally:
        StudyFolder(out).release()  # as the end of the process would
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err + captured.out
    return status, captured.out, captured.err


def _half(k: int, spec: object, fault: BaseException) -> object:
    return _output(spec) if k < 2 else fault


@pytest.mark.parametrize(
    "fault, status, says",
    [
        (cf.CancelledError(), 3, "the Dask scheduler was lost"),
        (cf.process.BrokenProcessPool("terminated abruptly"), 3, "a worker process died"),
        (OSError(errno.ECONNRESET, "connection reset"), 3, "the executor failed"),
    ],
    ids=["lost-scheduler", "dead-worker", "executor-error"],
)
def test_a_failing_executor_gives_one_line_and_keeps_the_records(
    fake_executor, protocol: Path, tmp_path: Path, capsys, fault: BaseException, status: int, says: str
) -> None:
    fake_executor(lambda k, spec: _half(k, spec, fault))
    code, out, err = _run(tmp_path / "s", protocol, capsys)
    assert code == status
    assert err.count("\n") == 1 and says in err and "rerun the same command to resume" in err
    assert "2 records in" in err and "wrote" not in out + err
    assert len(read_records(tmp_path / "s" / "trials.jsonl")) == 2
    fake_executor(lambda k, spec: _output(spec))  # the rerun resumes
    code, out, _ = _run(tmp_path / "s", protocol, capsys)
    assert code == 0 and "(2 already done)" in out


def test_a_full_disk_gives_one_line_naming_the_file(
    fake_executor, protocol: Path, tmp_path: Path, capsys, monkeypatch: pytest.MonkeyPatch
) -> None:
    import drake_disamb.study.data.folder as F

    real = F.append_record
    calls = []

    def fills_up(path, record):  # type: ignore[no-untyped-def]
        calls.append(record.trial_id)
        if len(calls) > 1:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real(path, record)

    monkeypatch.setattr(F, "append_record", fills_up)
    fake_executor(lambda k, spec: _output(spec))
    code, out, err = _run(tmp_path / "s", protocol, capsys)
    assert code == 4
    assert err.count("\n") == 1 and "trials.jsonl: No space left on device" in err
    assert "1 records in" in err and "rerun the same command to resume" in err and "wrote" not in out + err
    assert len(read_records(tmp_path / "s" / "trials.jsonl")) == 1


def test_a_trial_that_raises_is_reported_and_retried(
    fake_executor, protocol: Path, tmp_path: Path, capsys
) -> None:
    fake_executor(lambda k, spec: TrialOutput(None, {}, "ValueError: boom") if k == 0 else _output(spec))
    code, out, err = _run(tmp_path / "s", protocol, capsys)
    assert code == 1 and "ValueError: boom" in err and "1 trials raised" in out


def test_a_stop_request_writes_no_further_result(protocol: Path, tmp_path: Path) -> None:
    plan = plan_study(tmp_path / "s", P.load_protocol(protocol), 3)
    answered: list[str] = []

    def stop() -> bool:
        return len(answered) >= 1

    class Slow(FakeExecutor):
        def submit(self, fn, spec, *args, **kwargs):  # type: ignore[no-untyped-def, override]
            future: cf.Future = cf.Future()
            if self.k == 0:
                future.set_result(_output(spec))
            self.k += 1
            return future  # the others never finish

    result = run_study(
        plan, Slow(lambda k, s: None), on_result=lambda r, e: answered.append(r.trial_id), stop=stop
    )
    assert result.stopped and len(result.ran) == 1
    assert len(read_records(plan.records_path)) == 1


# ----------------------------------------------------------------------------------------------
# A folder that holds another study


def test_records_without_study_yaml_are_refused(
    fake_executor, protocol: Path, tmp_path: Path, capsys
) -> None:
    fake_executor(lambda k, spec: _output(spec))
    assert _run(tmp_path / "s", protocol, capsys)[0] == 0
    (tmp_path / "s" / "study.yaml").unlink()
    code, _, err = _run(tmp_path / "s", protocol, capsys)
    assert code == 2 and "records without study.yaml" in err


@pytest.mark.parametrize("field, value", [("seed", 12345), ("paradigm", "automatic"), ("trial_id", "S09-x")])
def test_a_record_of_another_study_is_refused(
    fake_executor, protocol: Path, tmp_path: Path, capsys, field: str, value: object
) -> None:
    fake_executor(lambda k, spec: _output(spec) if k == 0 else TrialOutput(None, {}, "RuntimeError: later"))
    assert _run(tmp_path / "s", protocol, capsys)[0] == 1
    path = tmp_path / "s" / "trials.jsonl"
    row = json.loads(path.read_text())
    row[field] = value if row[field] != value else "manual"
    path.write_text(json.dumps(row) + "\n")
    code, _, err = _run(tmp_path / "s", protocol, capsys)
    assert code == 2 and "trials.jsonl:1" in err and "another study's records" in err
    with pytest.raises(StudyMismatch):
        plan_study(tmp_path / "s", P.load_protocol(protocol), 3)


def test_an_out_of_limit_joint_offset_is_named_by_the_protocols_field(tmp_path: Path) -> None:
    data = tiny_protocol_data()
    data["tasks"][0]["start_poses"][1]["joint_offsets"] = [0.0, 0.0, 0.0, 0.0, 0.0, 40.0]
    with pytest.raises(ValueError, match=r"^protocol.tasks\[0\].start_poses\[1\].joint_offsets: "):
        plan_study(tmp_path / "s", P.protocol_from_dict(data), 3)
