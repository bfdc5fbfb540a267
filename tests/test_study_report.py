"""``study report``: metrics, tests, figures and the HTML page, on synthetic records written with the
contract's record and trace layout (the simulated runner's output), and on bad input."""

from __future__ import annotations

import hashlib
import json
import shutil
import tempfile
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.stats import mannwhitneyu, skew
from support import screenshot_script

from drake_disamb.cli import main
from drake_disamb.study.analysis import findings as findings_module
from drake_disamb.study.analysis.findings import compare_summaries, findings
from drake_disamb.study.analysis.stats import rank_biserial, run_tests, stars
from drake_disamb.study.data.records import RecordError, TrialRecord, append_record, assistance_onset
from drake_disamb.study.measures.metrics import (
    clean_mode_switches,
    clean_requests,
    request_time_skewness,
    summarize,
    trial_metrics,
)
from drake_disamb.study.report.page import write_report

JOYSTICK_MODES = ("vx_vy", "vx_vz", "wx_wz", "wy", "gripper")


def synthetic_records(seed: int = 0, scale: float = 1.0, source: str = "simulated") -> list[TrialRecord]:
    """Records of 4 subjects x 2 interfaces x 2 tasks x 3 paradigms x 2 repetitions: Disambiguation
    trials have fewer mode switches, with requests (some less than 3 s apart, some repeated joystick
    presses into one mode within 2 s, so the authors' cleaning changes the counts)."""
    rng = np.random.default_rng(seed)
    records = []
    for s in range(4):
        for interface in ("joystick", "head_array"):
            for task in ("reaching", "pouring"):
                for paradigm in ("manual", "disambiguation", "automatic"):
                    for rep in range(2):
                        base = (3 if interface == "joystick" else 14) * (2.5 if task == "pouring" else 1.0)
                        base *= 0.6 + 0.3 * s  # subjects differ (a random intercept to find)
                        n_sw = int(rng.poisson(base * scale * (1.0 if paradigm == "manual" else 0.6)))
                        duration = float(rng.uniform(20, 80))
                        sw_t = sorted(rng.uniform(0, duration, n_sw).tolist())
                        modes = [JOYSTICK_MODES[int(rng.integers(0, 4))] for _ in sw_t]
                        if interface == "joystick" and n_sw >= 2 and rep == 0:
                            # A repeated press into the same mode 0.5 s later (dropped by the cleaning).
                            sw_t[1] = sw_t[0] + 0.5
                            modes[1] = modes[0]
                            sw_t, modes = map(list, zip(*sorted(zip(sw_t, modes, strict=True)), strict=True))
                        n_rq = int(rng.integers(1, 4)) if paradigm == "disambiguation" else 0
                        rq_t = sorted(rng.uniform(0, duration * 0.6, n_rq).tolist())
                        if n_rq and rep == 1:
                            rq_t.append(rq_t[-1] + 1.0)  # merged with its predecessor
                        n_auto = int(rng.integers(0, 3)) if paradigm == "automatic" else 0
                        success = bool(rng.random() > 0.1)
                        records.append(
                            TrialRecord(
                                trial_id=f"S{s + 1:02d}-{interface}-{task}-{paradigm}-{rep}",
                                subject=f"S{s + 1:02d}",
                                interface=interface,
                                task=task,
                                paradigm=paradigm,
                                disambiguation_method=None if paradigm == "manual" else "algorithm1",
                                repetition=rep,
                                seed=int(rng.integers(0, 2**31)),
                                start_pose=int(rng.integers(0, 3)),
                                initial_mode="vx_vy" if interface == "joystick" else "vx",
                                intended_goals=[1] if task == "reaching" else [0, 1],
                                reached_goals=[1] if task == "reaching" else [0, 1],
                                success=success,
                                done=True,
                                duration=duration,
                                completion_time=duration if success else None,
                                mode_switches=len(sw_t),
                                requests=len(rq_t),
                                automatic_switches=n_auto,
                                button_presses=len(sw_t) + len(rq_t),
                                request_times=rq_t,
                                mode_switch_times=sw_t,
                                mode_switch_modes=modes if interface == "joystick" else ["vy"] * len(sw_t),
                                automatic_switch_times=sorted(rng.uniform(0, duration, n_auto).tolist()),
                                mean_alpha=float(rng.uniform(0.1, 0.4)),
                                assistance_onset=float(rng.uniform(0, duration)),
                                wall_time=1.0,
                                valid=not (s == 3 and rep == 1 and paradigm == "manual"),
                                source=source,
                            )
                        )
    return records


def write_study(
    folder: Path, records: list[TrialRecord], traces: bool = True, all_traces: bool = False
) -> Path:
    """``folder/trials.jsonl`` and (for the first repetitions, or with ``all_traces`` every record)
    ``folder/traces/<id>.npz`` in the contract's layout."""
    (folder / "traces").mkdir(parents=True, exist_ok=True)
    for r in records:
        append_record(folder / "trials.jsonl", r)
        if traces and (all_traces or r.repetition == 0):
            n_goals = 5 if r.task == "reaching" else 2
            t = np.linspace(0, r.duration, 200)
            logits = np.outer(t / r.duration, np.arange(n_goals) == 1) * 3.0
            belief = np.exp(logits) / np.exp(logits).sum(axis=1, keepdims=True)
            u_h = np.zeros((200, 6))
            u_h[50:120, 0] = 0.1
            np.savez(
                folder / "traces" / f"{r.trial_id}.npz",
                t=t,
                belief=belief,
                u_h=u_h,
                u=u_h * 1.2,
                alpha=np.clip(belief[:, 1] - 0.3, 0, 0.7),
                mode=np.zeros(200, dtype=np.int64),
                ee_pose=np.tile([0.1, -0.3, 0.3, 1, 0, 0, 0], (200, 1)),
            )
    return folder


def digest(folder: Path) -> dict[str, str]:
    """sha256 of every file in ``folder`` outside ``report/``."""
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and "report" not in p.relative_to(folder).parts
    }


@pytest.fixture(scope="module")
def study(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = write_study(tmp_path_factory.mktemp("study"), synthetic_records())
    before = digest(folder)
    assert main(["study", "report", str(folder)]) == 0
    assert digest(folder) == before  # only report/ was written
    return folder


# ----------------------------------------------------------------------------------------------
# Metrics


def test_request_merging_follows_the_authors_consecutive_gaps() -> None:
    assert clean_requests([0.0, 1.0, 2.5, 6.0]) == [0.0, 6.0]
    # Each request is compared with the one before it in the raw list (loadData.m: diff(t) < 3).
    assert clean_requests([0.0, 2.9, 5.8, 8.9]) == [0.0, 8.9]
    assert clean_requests([5.0, 0.0]) == [0.0, 5.0]
    # Not merged into the last kept request: 4.1 is 3.1 s after 1.0 but 1.6 s after 2.5.
    assert clean_requests([1.0, 2.5, 4.1, 10.0]) == [1.0, 10.0]
    assert clean_requests([]) == []


def test_repeated_joystick_presses_into_one_mode_within_2_s_are_dropped() -> None:
    times, modes = [1.0, 1.5, 3.0, 6.0, 6.5], ["wy", "wy", "wy", "vx_vy", "vx_vz"]
    # 1.5 repeats wy within 0.5 s: dropped; 3.0 repeats wy 1.5 s after 1.5: dropped too.
    assert clean_mode_switches(times, modes, "joystick") == [1.0, 6.0, 6.5]
    assert clean_mode_switches([1.0, 3.5], ["wy", "wy"], "joystick") == [1.0, 3.5]
    assert clean_mode_switches(times, modes, "head_array") == times
    with pytest.raises(ValueError, match="2 times but 1 modes"):
        clean_mode_switches([1.0, 2.0], ["wy"], "joystick")


def test_skewness_is_the_biased_estimator_of_pooled_normalised_times() -> None:
    records = [r for r in synthetic_records() if r.paradigm == "disambiguation" and r.interface == "joystick"]
    trials = [trial_metrics(r) for r in records]
    pooled = np.array([t / r.duration for r in records if r.valid for t in clean_requests(r.request_times)])
    m = pooled - pooled.mean()
    expected = np.mean(m**3) / np.mean(m**2) ** 1.5
    assert request_time_skewness(trials) == pytest.approx(expected, rel=1e-12)
    assert request_time_skewness(trials) == pytest.approx(skew(pooled))
    assert request_time_skewness([t for t in trials if t.requests == 0]) is None


def test_assistance_onset_is_the_start_of_the_last_correct_stretch() -> None:
    t = np.arange(6.0)
    belief = np.array([[0.6, 0.4], [0.4, 0.6], [0.6, 0.4], [0.3, 0.7], [0.2, 0.8], [0.2, 0.8]])
    alpha = np.array([0.0, 0.2, 0.2, 0.0, 0.3, 0.3])
    assert assistance_onset(t, belief, alpha, 1) == 4.0
    assert assistance_onset(t, belief, alpha, 0) is None
    assert assistance_onset(t, belief, np.full(6, 0.5), 1) == 3.0
    with pytest.raises(ValueError, match="goal 2"):
        assistance_onset(t, belief, alpha, 2)


def test_stars_and_rank_biserial() -> None:
    assert [stars(p) for p in (0.0005, 0.005, 0.03, 0.2, None)] == ["***", "**", "*", "n.s.", ""]
    assert rank_biserial([3, 4, 5], [0, 1, 2]) == 1.0
    assert rank_biserial([0, 1, 2], [3, 4, 5]) == -1.0
    assert rank_biserial([1, 2], [1, 2]) == 0.0


def test_summary_excludes_invalid_and_failed_trials_from_means_and_counts_failures() -> None:
    records = synthetic_records()
    rows = {(r["interface"], r["task"], r["paradigm"]): r for r in summarize(records)}
    row = rows[("head_array", "pouring", "manual")]
    group = [r for r in records if (r.interface, r.task, r.paradigm) == ("head_array", "pouring", "manual")]
    # The means leave out the invalid trials and the failed ones, as the authors left out theirs.
    valid = [r for r in group if r.valid and r.success is not False]
    assert row["n_trials"] == len(group) == 8 and row["n_valid"] == sum(r.valid for r in group) == 7
    assert row["n_analysed"] == len(valid) < 7
    assert row["mean_mode_switches_raw"] == pytest.approx(np.mean([r.mode_switches for r in valid]))
    assert row["mean_completion_time"] == pytest.approx(
        np.mean([r.completion_time for r in valid if r.completion_time is not None])
    )
    assert row["success_rate"] == pytest.approx(np.mean([r.success for r in group]))
    assert row["request_time_skewness"] is None  # Manual: no requests
    assert rows[("joystick", "reaching", "disambiguation")]["request_time_skewness"] is not None


# ----------------------------------------------------------------------------------------------
# The report


def test_a_finding_is_one_function_and_one_row_of_the_table(monkeypatch: pytest.MonkeyPatch) -> None:
    records = synthetic_records()
    tests = run_tests(records, mixed_metrics=())
    trials = [trial_metrics(r) for r in records]
    rows = findings(trials, tests, "simulated")
    # 12 findings: the skewness and the manual switches each a row per interface and task
    assert len(findings_module.FINDINGS) == 12 and len(rows) == 18
    assert rows[0]["paper"].startswith("Head array: significantly fewer button presses")
    assert {r["agree"] for r in rows} <= {"yes", "no", "n/a"}

    def count(evidence) -> list[dict[str, str]]:  # noqa: ANN001
        return [
            {"paper": "a new finding", "ours": str(len(evidence.trials)), "agree": "n/a", "criterion": "-"}
        ]

    monkeypatch.setattr(findings_module, "FINDINGS", (*findings_module.FINDINGS, count))
    assert findings(trials, tests, "simulated") == [*rows, *count(SimpleNamespace(trials=trials))]


def test_report_writes_its_files(study: Path) -> None:
    out = study / "report"
    for name in (
        "index.html",
        "summary.json",
        "stats.json",
        "button_presses.png",
        "switches_requests.png",
        "completion_times.png",
        "raster.png",
        "alpha.png",
    ):
        assert (out / name).is_file() and (out / name).stat().st_size > 1000, name
    traces = sorted(out.glob("traces_*.png"))
    assert len(traces) == 12  # 2 interfaces x 2 tasks x 3 paradigms
    page = (out / "index.html").read_text()
    assert page.count('src="data:image/png;base64,') == 5 + len(traces)
    assert "http://" not in page and "https://" not in page and "<script" not in page
    assert "the paper&#x27;s finding" in page and "agree?" in page
    summary = json.loads((out / "summary.json").read_text())
    assert len(summary) == 12
    for row in summary:
        for key in (
            "interface",
            "task",
            "paradigm",
            "n_trials",
            "n_valid",
            "mean_mode_switches",
            "mean_requests",
            "mean_button_presses",
            "mean_completion_time",
            "success_rate",
            "request_time_skewness",
            "mean_mode_switches_raw",
            "mean_requests_raw",
            "mean_button_presses_raw",
        ):
            assert key in row, key
    # The cleaning removed something in the synthetic data (merged requests, repeated presses).
    assert any(r["mean_requests"] < r["mean_requests_raw"] for r in summary)
    assert any(
        r["mean_mode_switches"] < r["mean_mode_switches_raw"] for r in summary if r["interface"] == "joystick"
    )


def _clean_independently(row: dict) -> int:
    """Button presses after the authors' cleaning, written here from the definitions alone."""
    rq = sorted(row["request_times"])
    n_rq = sum(1 for i in range(len(rq)) if i == 0 or rq[i] - rq[i - 1] >= 3.0)
    t, m = row["mode_switch_times"], row["mode_switch_modes"]
    n_sw = len(t)
    if row["interface"] == "joystick":
        n_sw -= sum(1 for i in range(1, len(t)) if m[i] == m[i - 1] and t[i] - t[i - 1] < 2.0)
    return n_sw + n_rq


def test_a_p_value_of_stats_json_is_recomputed_from_trials_jsonl(study: Path) -> None:
    stats = json.loads((study / "report" / "stats.json").read_text())
    for key in ("metric", "interface", "task", "a", "b", "test", "statistic", "p_value", "n_a", "n_b"):
        assert all(key in row for row in stats), key
    lines = [json.loads(line) for line in (study / "trials.jsonl").read_text().splitlines()]

    def values(paradigm: str, interface: str, field: str) -> list[float]:
        rows = [  # the analysed trials: valid, and not failed (as the authors left theirs out)
            r
            for r in lines
            if r["valid"] and r["success"] is not False
            if r["paradigm"] == paradigm and r["interface"] == interface
        ]
        return [_clean_independently(r) if field == "clean" else r[field] for r in rows]

    for metric, field in (("button_presses", "clean"), ("button_presses_raw", "button_presses")):
        row = next(
            r
            for r in stats
            if r["test"] == "ranksum"
            and r["metric"] == metric
            and r["interface"] == "head_array"
            and r["task"] == "all"
            and r["a"] == "manual"
            and r["b"] == "disambiguation"
        )
        a, b = values("manual", "head_array", field), values("disambiguation", "head_array", field)
        expected = mannwhitneyu(a, b, alternative="two-sided")
        assert (row["n_a"], row["n_b"]) == (len(a), len(b))
        assert row["statistic"] == expected.statistic
        assert row["p_value"] == pytest.approx(expected.pvalue, rel=1e-12)
        assert row["ci_low"] <= row["effect_size"] <= row["ci_high"]
    tests = {r["test"] for r in stats}
    assert tests == {"ranksum", "signed_rank_subject_means", "mixedlm"}
    assert {r["metric"] for r in stats if r["test"] == "mixedlm"} == {"button_presses", "completion_time"}
    pairs = {(r["a"], r["b"]) for r in stats}
    assert pairs == {("manual", "disambiguation"), ("manual", "automatic"), ("disambiguation", "automatic")}


def test_stats_are_reproducible(study: Path) -> None:
    records = synthetic_records()
    first = run_tests(records, ("button_presses",), per_subject=False)
    assert first == run_tests(records, ("button_presses",), per_subject=False)
    saved = [
        r
        for r in json.loads((study / "report" / "stats.json").read_text())
        if r["metric"] == "button_presses" and r["test"] == "ranksum"
    ]
    assert [r["ci_low"] for r in saved] == [r["ci_low"] for r in first]


def test_mixed_sources_are_reported_per_source(tmp_path: Path) -> None:
    records = synthetic_records()[:48] + synthetic_records(seed=1, source="human")[:48]
    for r in records[48:]:
        r.trial_id = "human-" + r.trial_id
    write_study(tmp_path, records, traces=False)
    files = write_report(tmp_path, mixed_model=False)
    assert (tmp_path / "report" / "button_presses_simulated.png").is_file()
    assert (tmp_path / "report" / "button_presses_human.png").is_file()
    assert {r["source"] for r in json.loads(files.summary.read_text())} == {"simulated", "human"}
    assert "a mix" in files.index.read_text()


def test_compare_sets_two_folders_side_by_side(tmp_path: Path) -> None:
    sim = write_study(tmp_path / "sim", synthetic_records(seed=2, scale=2.0), traces=False)
    human = write_study(tmp_path / "human", synthetic_records(seed=3, source="human"), traces=False)
    assert main(["study", "report", str(sim), "--compare", str(human), "--no-mixed-model"]) == 0
    stats = json.loads((sim / "report" / "stats.json").read_text())
    assert "mixedlm" not in {r["test"] for r in stats} and "signed_rank_subject_means" in {
        r["test"] for r in stats
    }
    rows = json.loads((sim / "report" / "compare.json").read_text())
    assert len(rows) == 12
    ours = {
        (r["interface"], r["task"], r["paradigm"]): r for r in summarize(synthetic_records(seed=2, scale=2.0))
    }
    for row in rows:
        mine = ours[(row["interface"], row["task"], row["paradigm"])]["mean_mode_switches"]
        assert row["mean_mode_switches"] == pytest.approx(mine)
        assert row["ratio_mean_mode_switches"] == pytest.approx(mine / row["other_mean_mode_switches"])
        assert row["within_mean_mode_switches"] == (abs(row["ratio_mean_mode_switches"] - 1) <= 0.5)
    assert any(not r["within_mean_mode_switches"] for r in rows if r["interface"] == "head_array")
    assert "Compared with" in (sim / "report" / "index.html").read_text()
    assert compare_summaries([], rows) == []


def test_ablation_folder_gets_the_combined_report(tmp_path: Path) -> None:
    settings = []
    for i, value in enumerate(("dot", "cosine")):
        name = f"inference.agreement={value}"
        write_study(tmp_path / name, synthetic_records(seed=10 + i, scale=1.0 + i), traces=False)
        settings.append({"name": name, "dir": name, "overrides": {"inference.agreement": value}})
    (tmp_path / "ablation.json").write_text(json.dumps({"format": 1, "settings": settings}))
    before = digest(tmp_path)
    assert main(["study", "report", str(tmp_path)]) == 0
    assert digest(tmp_path) == before
    stats = json.loads((tmp_path / "report" / "stats.json").read_text())
    assert {r["setting"] for r in stats} == {s["name"] for s in settings}
    assert {r["metric"] for r in stats} == {"button_presses", "completion_time"}
    page = (tmp_path / "report" / "index.html").read_text()
    assert "Paradigm effect per setting" in page and page.count("data:image/png;base64,") == 1
    # A setting's folder without records: the message names its trials.jsonl.
    (tmp_path / settings[1]["name"] / "trials.jsonl").unlink()
    with pytest.raises(RecordError, match="cosine/trials.jsonl: no records"):
        write_report(tmp_path)
    (tmp_path / "ablation.json").write_text(
        json.dumps({"format": 1, "settings": [{"name": "x", "dir": "../x"}]})
    )
    with pytest.raises(RecordError, match=r"settings\[0\].dir"):
        write_report(tmp_path)


# ----------------------------------------------------------------------------------------------
# Bad input


def _report_fails(folder: Path, capsys: pytest.CaptureFixture[str]) -> str:
    before = digest(folder) if folder.exists() else None
    assert main(["study", "report", str(folder)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("drake-disamb study report: error: ") and "Traceback" not in err
    if before is not None:
        assert digest(folder) == before
    return err


def test_bad_input_names_the_file_and_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert "no such study folder" in _report_fails(tmp_path / "missing", capsys)
    (tmp_path / "empty").mkdir()
    assert "empty/trials.jsonl: no records" in _report_fails(tmp_path / "empty", capsys)
    (tmp_path / "empty" / "trials.jsonl").write_text("")
    assert "empty/trials.jsonl: no records (the file is empty)" in _report_fails(tmp_path / "empty", capsys)

    good = synthetic_records()[:3]
    corrupt = write_study(tmp_path / "corrupt", good, traces=False)
    lines = (corrupt / "trials.jsonl").read_text().splitlines()
    lines[1] = lines[1][: len(lines[1]) // 2]
    (corrupt / "trials.jsonl").write_text("\n".join(lines) + "\n")
    assert "corrupt/trials.jsonl:2: not a JSON record" in _report_fails(corrupt, capsys)

    old = write_study(tmp_path / "old", good, traces=False)
    rows = [json.loads(line) for line in (old / "trials.jsonl").read_text().splitlines()]
    rows[2]["format"] = 0
    (old / "trials.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    err = _report_fails(old, capsys)
    assert "old/trials.jsonl:3: record format 0" in err and "older" in err

    cut = write_study(tmp_path / "cut", good, traces=False)
    (cut / "trials.jsonl").write_bytes((cut / "trials.jsonl").read_bytes()[:-10])
    assert "cut/trials.jsonl:3: the last line is incomplete" in _report_fails(cut, capsys)
    assert not (cut / "report").exists()


def test_a_record_whose_goal_is_not_one_of_its_tasks_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Goal 99 of the five-goal reaching task: not summarised (nor set per goal beside another folder)."""
    records = [r for r in synthetic_records() if r.task == "reaching"][:4]
    folder = write_study(tmp_path / "here", records)
    rows = [json.loads(line) for line in (folder / "trials.jsonl").read_text().splitlines()]
    rows[2]["intended_goals"] = [99]
    (folder / "trials.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    err = _report_fails(folder, capsys)
    assert err.count("\n") == 1, err
    assert (
        "here/trials.jsonl:3: field intended_goals: expected indices of the reaching task's goals "
        "(5 goals: 0 to 4), got [99]" in err
    )
    other = write_study(tmp_path / "other", records)
    assert main(["study", "report", str(other), "--compare", str(folder), "--no-mixed-model"]) == 2
    assert "here/trials.jsonl:3: field intended_goals" in capsys.readouterr().err
    assert not (other / "report" / "per_goal.json").exists()


def test_each_missing_trace_is_named_and_the_figures_are_drawn_without_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The traces of two Manual trials deleted: the first of its condition (its figure is drawn from
    the next trial) and another; one warning line each, naming the file."""
    records = [r for r in synthetic_records() if r.interface == "joystick" and r.task == "reaching"]
    write_study(tmp_path, records, all_traces=True)
    manual = sorted(r.trial_id for r in records if r.paradigm == "manual" and r.valid)
    for trial_id in manual[:2]:
        (tmp_path / "traces" / f"{trial_id}.npz").unlink()
    capsys.readouterr()
    assert main(["study", "report", str(tmp_path), "--no-mixed-model"]) == 0
    warnings = [line for line in capsys.readouterr().err.splitlines() if line.startswith("warning:")]
    assert warnings == [
        f"warning: {tmp_path}/traces/{t}.npz: the trace of record {t!r} is missing; left out of the figures"
        for t in manual[:2]
    ]
    assert (tmp_path / "report" / "traces_joystick_reaching_manual.png").is_file()


def test_an_unreadable_trace_is_left_out(tmp_path: Path) -> None:
    records = [r for r in synthetic_records() if r.interface == "joystick" and r.task == "reaching"]
    write_study(tmp_path, records)
    for r in records:
        if r.paradigm == "manual" and r.repetition == 0:
            (tmp_path / "traces" / f"{r.trial_id}.npz").write_bytes(b"not an npz")
    files = write_report(tmp_path, mixed_model=False)
    names = sorted(p.name for p in files.figures if p.name.startswith("traces_"))
    assert names == ["traces_joystick_reaching_automatic.png", "traces_joystick_reaching_disambiguation.png"]


# ----------------------------------------------------------------------------------------------
# In a browser


@pytest.mark.skipif(
    (shutil.which("chromium") or shutil.which("chromium-browser")) is None
    or shutil.which("chromedriver") is None,
    reason="needs chromium and chromedriver (Debian: apt-get install chromium chromium-driver)",
)
def test_the_report_shows_its_figures_in_headless_chromium(study: Path, tmp_path: Path) -> None:
    pytest.importorskip("selenium", reason="needs the selenium package")
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service

    chromium, driver_path = screenshot_script().chromium_paths()
    with tempfile.TemporaryDirectory(prefix="chromium-profile-") as profile:
        options = Options()
        # The repository's Chromium flags (no background network) plus no proxy: nothing to reach.
        for flag in (
            *screenshot_script().CHROMIUM_FLAGS,
            f"--user-data-dir={profile}",
            "--proxy-server=127.0.0.1:9",
            "--proxy-bypass-list=<-loopback>",
        ):
            options.add_argument(flag)
        options.binary_location = chromium
        driver = webdriver.Chrome(service=Service(driver_path), options=options)
        try:
            driver.get((study / "report" / "index.html").resolve().as_uri())
            shown = driver.execute_script(
                "return Array.from(document.images).map(i => [i.complete, i.naturalWidth, i.naturalHeight, "
                "i.src.slice(0, 22)]);"
            )
            driver.set_window_size(1280, 900)
            driver.save_screenshot(str(tmp_path / "screenshot.png"))
        finally:
            driver.quit()
    assert len(shown) == 17
    for complete, width, height, src in shown:
        assert complete and width > 300 and height > 200
        assert src == "data:image/png;base64,"
    assert (tmp_path / "screenshot.png").stat().st_size > 10_000


def test_a_single_human_trial_is_reported(tmp_path: Path) -> None:
    """One trial of one person (``demo --live --record``): every figure and table still comes out."""
    records = [r for r in synthetic_records(source="human") if r.subject == "S01" and r.repetition == 0]
    records = [r for r in records if r.interface == "joystick" and r.task == "reaching"][:2]
    records[1].mean_alpha = records[0].mean_alpha  # no spread: no density to draw
    records[1].paradigm = records[0].paradigm
    write_study(tmp_path, records)
    files = write_report(tmp_path)
    assert files.index.is_file() and len(files.figures) == 6
    assert json.loads(files.stats.read_text()) == []  # one paradigm: nothing to compare
    (row,) = json.loads(files.summary.read_text())
    assert row["source"] == "human" and row["n_trials"] == 2
