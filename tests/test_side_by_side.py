"""``benchmarks/side_by_side.py``: it reads the figures the two benchmark scripts print today (a
change of their format would otherwise leave it reading nothing), and refuses a folder that is
not a checkout."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from support import benchmark_module

REPO = Path(__file__).resolve().parents[1]


def _script(name: str, *argv: str) -> str:
    proc = subprocess.run(
        [sys.executable, f"benchmarks/{name}.py", *argv], cwd=REPO, capture_output=True, text=True, check=True
    )
    return proc.stdout


def test_it_reads_the_figures_the_benchmarks_print() -> None:
    with benchmark_module("side_by_side") as side:
        m = side.MICO_ROW.search(_script("bench_disambiguation", "--rounds", "5"))
        assert m is not None and 0 < float(m[1]) < 1000
        m = side.LOOP_LINE.search(
            _script("bench_loop", "--seconds", "0.3", "--repeats", "1", "--time-step", "0.01")
        )
        assert m is not None and float(m[1]) > 0 and float(m[2]) > 0


def test_it_refuses_a_folder_that_is_not_a_checkout(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with benchmark_module("side_by_side") as side, pytest.raises(SystemExit) as stop:
        side.main([str(tmp_path), str(REPO)])
    assert stop.value.code == 2
    assert "before: " in capsys.readouterr().err
