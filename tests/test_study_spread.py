"""``benchmarks/study_spread.py``: several study folders beside the people, on synthetic folders
whose answer is known."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from support import benchmark_module, study_trial

from drake_disamb.study.data.records import append_record


@pytest.fixture(scope="module")
def spread():  # noqa: ANN201 (the benchmark module)
    with benchmark_module("study_spread") as module:
        yield module


def _folder(path: Path, manual: list[int], disamb: list[int], fail_pouring: bool = False) -> Path:
    """Joystick reaching trials with these button presses (Disambiguation: one request each)."""
    path.mkdir(parents=True)
    n = 0
    for paradigm, presses in (("manual", manual), ("disambiguation", disamb)):
        for p in presses:
            requests = 1 if paradigm == "disambiguation" else 0
            append_record(
                path / "trials.jsonl", study_trial(n, "joystick", "reaching", paradigm, p, requests)
            )
            n += 1
    if fail_pouring:
        failed = study_trial(n, "joystick", "pouring", "manual", 4)
        failed.success, failed.completion_time = False, None
        append_record(path / "trials.jsonl", failed)
    return path


def test_each_folder_and_the_spread(spread, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: ANN001
    people = _folder(tmp_path / "people", [10, 12, 14], [5, 6, 7])  # presses -50 %
    a = _folder(tmp_path / "a", [10, 12, 14], [6, 7, 8], fail_pouring=True)  # -42 %: within 2x
    b = _folder(tmp_path / "b", [10, 12, 14], [18, 18, 18])  # +50 %: the wrong direction
    sys.argv = ["study_spread.py", str(a), str(b), "--compare", str(people)]
    assert spread.main() == 0
    out = capsys.readouterr().out
    assert "conditions off by more than 35%: 0" in out  # a: switches 6/5, time and requests equal
    assert "joystick reaching disambiguation switches 3.40" in out  # b: 17 switches against 5
    assert "Manual and Disambiguation failures in pouring: 1 of 1" in out
    assert "effect joystick button presses: -42 % (people -50 %), ratio 0.83 ok" in out
    assert "effect joystick button presses: +50 % (people -50 %), ratio -1.00 OUT" in out
    assert "joystick button presses: -42 % to +50 %; within a factor of 2: 1 of 2" in out


def test_a_bad_folder_is_named(spread, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: ANN001
    sys.argv = ["study_spread.py", str(tmp_path / "missing"), "--compare", str(tmp_path / "missing")]
    assert spread.main() == 2
    assert "missing" in capsys.readouterr().err
