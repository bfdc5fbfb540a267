"""A first run as a newcomer sees it: the kernel compilation is announced, progress shows simulated
time without a false total (a line per second off a terminal), the Meshcat URL is printed once and,
from a terminal, the demo waits for a browser to open it."""

from __future__ import annotations

import io
import logging
import re
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from drake_disamb.cli import main
from drake_disamb.commands import demo
from drake_disamb.commands._first_run import COMPILING, announce_kernel_compilation
from drake_disamb.commands._meshcat import wait_for_browser
from drake_disamb.operator_page.server import OperatorPage
from drake_disamb.progress import SimulationProgress, TrialProgress


def test_compilation_is_announced_once_before_it_happens_and_not_when_cached() -> None:
    import numba

    @numba.njit(cache=False)
    def add(a: float, b: float) -> float:  # pragma: no cover - compiled
        return a + b

    @numba.njit(cache=False)
    def twice(a: float) -> float:  # pragma: no cover - compiled
        return add(a, a)

    lines: list[str] = []
    seen_before: list[bool] = []

    def write(line: str) -> None:
        lines.append(line)
        seen_before.append(len(twice.signatures) == 0)  # written before the compiled code exists

    with announce_kernel_compilation(write) as compiling:
        assert twice(1.5) == 3.0
        assert add(1, 2) == 3  # a second, nested-free compilation: no second announcement
    assert lines[0] == COMPILING and seen_before[0]
    assert len(lines) == 2 and lines[1].startswith("compiled the kernels in ")
    assert compiling.count == 2 and compiling.seconds > 0
    lines.clear()
    with announce_kernel_compilation(lines.append):
        assert twice(2.0) == 4.0  # already compiled: silent
    assert lines == []


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_off_a_terminal_writes_a_line_per_interval() -> None:
    out = io.StringIO()
    progress = SimulationProgress(60.0, stream=out, interval=0.05)
    assert not progress.interactive
    for k in range(1, 13):
        progress.update(0.1 * k)
        time.sleep(0.01)
    progress.close()
    lines = out.getvalue().splitlines()
    assert 1 <= len(lines) <= 4, lines
    assert all(line.startswith("simulated ") and "(limit 60 s)" in line for line in lines)


def test_trial_progress_counts_and_writes_a_last_line() -> None:
    from types import SimpleNamespace

    out = io.StringIO()
    progress = TrialProgress(3, stream=out, interval=3600.0)
    progress.update(SimpleNamespace(success=True), None)
    progress.update(SimpleNamespace(success=False), None)
    assert out.getvalue() == ""  # no line due yet
    progress.update(None, "S01-joystick-reaching-manual-r0: boom")
    progress.close()
    lines = out.getvalue().splitlines()
    assert lines == [
        "error: S01-joystick-reaching-manual-r0: boom",
        lines[1],
    ] and lines[1].startswith("trials 3/3, 1 unsuccessful, 1 errors, ")
    quiet = io.StringIO()
    progress = TrialProgress(1, stream=quiet, quiet=True)
    progress.update(None, "boom")
    assert quiet.getvalue() == "error: boom\n"  # quiet shows errors only
    with pytest.raises(ValueError, match="interval"):
        TrialProgress(1, interval=0.0)


def test_progress_on_a_terminal_has_no_false_total() -> None:
    out = _Terminal()
    progress = SimulationProgress(60.0, stream=out)
    assert progress.interactive
    for k in range(1, 30):
        progress.update(0.25 * k)
    progress.write("a message")
    progress.close()
    text = out.getvalue()
    assert "limit 60 s" in text and "a message" in text
    assert "/60" not in text and "%" not in text  # neither a total nor a percentage


def test_run_trial_shows_progress_off_a_terminal(capsys: pytest.CaptureFixture[str]) -> None:
    import dataclasses

    from drake_disamb.config import load_scenario
    from drake_disamb.trial import run_trial

    scenario = dataclasses.replace(load_scenario("reaching"), duration=1.5)
    run_trial(scenario, progress=SimulationProgress(scenario.duration, interval=0.2), realtime_rate=1.0)
    err = capsys.readouterr().err
    assert err.count("simulated ") >= 3 and "(limit 1.5 s)" in err


class _FakeMeshcat:
    def __init__(self, connect_after: int | None) -> None:
        self.calls = 0
        self.connect_after = connect_after

    def GetNumActiveConnections(self) -> int:
        self.calls += 1
        return int(self.connect_after is not None and self.calls > self.connect_after)


def test_wait_for_browser() -> None:
    start = time.monotonic()
    assert wait_for_browser(_FakeMeshcat(connect_after=3), timeout=5.0, settle=0.0)
    assert time.monotonic() - start < 2.0
    start = time.monotonic()
    assert not wait_for_browser(_FakeMeshcat(connect_after=None), timeout=0.3)
    assert 0.3 <= time.monotonic() - start < 1.5
    start = time.monotonic()
    assert not wait_for_browser(_FakeMeshcat(connect_after=None), timeout=30.0, stop=lambda: True)
    assert time.monotonic() - start < 0.5


def _demo(tmp_path: Path, *extra: str) -> int:
    argv = ["demo", "--quiet", "--hold", "0", "--realtime-rate", "0", "--duration", "0.3"]
    return main([*argv, "--out", str(tmp_path), *extra])


class _Script(io.StringIO):
    def isatty(self) -> bool:
        return False


def test_the_url_is_printed_once(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    caplog: pytest.LogCaptureFixture,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    caplog.set_level(logging.INFO)
    monkeypatch.setattr("sys.stdin", _Script())
    assert _demo(tmp_path) == 1  # 0.3 s is too short to succeed
    out, err = capsys.readouterr()
    # Meshcat's address and the operator page's, each once, the page's on a line of its own
    assert out.count("http://localhost:") == 2 and "http://localhost:" not in err
    assert out.count("Meshcat: http://localhost:") == 1
    lines = out.splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("operator page"))
    assert re.fullmatch(r"http://localhost:\d+/", lines[at + 1])
    assert not [r for r in caplog.records if "listening for connections" in r.getMessage()]
    assert "open it in a browser to watch" in out  # not a terminal: no waiting
    for name in ("goal_probabilities.png", "recording.html", "metrics.json"):
        assert f"wrote {tmp_path / name}" in out


@pytest.mark.parametrize("no_wait", [False, True])
def test_from_a_terminal_the_demo_waits_for_a_browser(
    no_wait: bool, tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    waited: list[float] = []
    warm_ups: list[float] = []
    real_run_trial = __import__("drake_disamb.trial", fromlist=["run_trial"]).run_trial

    started: list[Any] = []
    real_start_meshcat = demo.start_meshcat

    def recorded_start_meshcat(args):  # noqa: ANN001, ANN202
        started.append(real_start_meshcat(args))
        return started[-1]

    def fake_wait(page, timeout, stop, settle=1.0):  # noqa: ANN001, ANN202
        assert isinstance(page, OperatorPage)  # the operator page is what the demo waits for
        assert started[0].HasPath("/shared_control/goals/g0")  # the scene is drawn before anyone looks
        waited.append(timeout)
        return True

    def counting_run_trial(handles, *args, **kwargs):  # noqa: ANN001, ANN202
        if not hasattr(handles, "diagram"):
            warm_ups.append(handles.duration)
        return real_run_trial(handles, *args, **kwargs)

    monkeypatch.setattr(demo, "wait_for_browser", fake_wait)
    monkeypatch.setattr(demo, "start_meshcat", recorded_start_meshcat)
    monkeypatch.setattr("drake_disamb.trial.run_trial", counting_run_trial)
    monkeypatch.setattr("sys.stdin", _Terminal())
    assert _demo(tmp_path, *(["--no-wait"] if no_wait else [])) == 1
    out = capsys.readouterr().out
    assert out.count("http://localhost:") == 2
    if no_wait:
        assert waited == [] and warm_ups == []
    else:
        assert waited == [demo.WAIT_FOR_BROWSER] and warm_ups == [pytest.approx(demo.WARM_UP)]
        assert "the trial starts when the page is open" in out and "the page is open" in out
        assert out.index("the page is open") < out.index("running the trial")


def test_no_browser_within_the_timeout_starts_anyway(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(demo, "WAIT_FOR_BROWSER", 0.2)
    monkeypatch.setattr("sys.stdin", _Terminal())
    assert _demo(tmp_path) == 1
    out = capsys.readouterr().out
    assert "no browser opened the page within 0.2 s: starting anyway" in out
    assert np.isfinite(float(out.split("completion time (s)")[1].split("stopped at ")[1].split(")")[0]))


def test_from_a_script_the_demo_runs_straight_through(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """No --hold or --realtime-rate given: no waiting, no holding, as fast as possible."""
    from drake_disamb import trial

    rates: list[float] = []
    real_run_trial = trial.run_trial

    def recording_run_trial(handles, *args, **kwargs):  # noqa: ANN001, ANN202
        rates.append(kwargs["realtime_rate"])
        return real_run_trial(handles, *args, **kwargs)

    monkeypatch.setattr(trial, "run_trial", recording_run_trial)
    monkeypatch.setattr("sys.stdin", _Script())
    assert main(["demo", "--quiet", "--duration", "0.5", "--out", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert rates == [0.0] and "stays up" not in out and "waiting" not in out
    monkeypatch.setattr("sys.stdin", _Terminal())
    assert (
        main(["demo", "--quiet", "--duration", "0.5", "--no-wait", "--hold", "0", "--out", str(tmp_path)])
        == 1
    )
    assert rates[-1] == 1.0  # from a terminal, with Meshcat: real time
