"""``benchmarks/bench_study.py``'s ``--only``: a protocol's trials of some conditions, with the seeds
and draws they have in the whole protocol (the trials themselves are not run here)."""

from __future__ import annotations

from pathlib import Path

import pytest
from support import benchmark_module

from drake_disamb.study.design import protocol as P


@pytest.fixture(scope="module")
def bench():  # noqa: ANN201 (the benchmark module)
    with benchmark_module("bench_study") as module:
        yield module


def test_only_parses_fields_and_values(bench) -> None:  # noqa: ANN001
    only = bench.parse_only(["task=reaching", "interface=joystick,head_array", "task=pouring"])
    assert only == {"task": {"reaching", "pouring"}, "interface": {"joystick", "head_array"}}


@pytest.mark.parametrize("bad", ["color=red", "task=", "task"])
def test_only_refuses_a_bad_option_by_name(bench, bad: str) -> None:  # noqa: ANN001
    with pytest.raises(SystemExit, match="--only: expected FIELD=V1"):
        bench.parse_only([bad])


def test_only_keeps_the_whole_protocols_trials(bench, tmp_path: Path, monkeypatch) -> None:  # noqa: ANN001
    """The selected trials are those of the whole protocol, seeds included; nothing else runs."""
    protocol = P.quick_protocol(P.default_protocol())
    ran = {}

    def fake_run_study(plan, pool):  # noqa: ANN001, ANN202
        ran["pending"] = list(plan.pending)
        raise SystemExit("stop before running")

    monkeypatch.setattr(bench, "run_study", fake_run_study)
    with pytest.raises(SystemExit, match="stop before running"):
        bench.run_once(protocol, tmp_path / "study", 1, 0, {"interface": {"joystick"}})
    whole = P.expand_trials(protocol, 0)
    chosen = ran["pending"]
    assert chosen and all(s.interface == "joystick" for s in chosen)
    by_id = {s.trial_id: s for s in whole}
    assert all(by_id[s.trial_id].seed == s.seed for s in chosen)
    assert len(chosen) == sum(s.interface == "joystick" for s in whole)
