"""``study import-authors`` on the authors' published logs, then ``study report``: the summary
matches an independent computation of the same definitions written here straight from the .mat
files, in the style of the authors' ``loadData.m``. Skipped where ../shared/data is absent."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat
from scipy.stats import skew

from drake_disamb.cli import main
from drake_disamb.study.data.authors import load_trial_order, parse_trial_name, read_trial, read_trials
from drake_disamb.study.data.records import read_records

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "tnsre2020_human_study"
pytestmark = pytest.mark.skipif(
    not (DATA / "trial_order_testing_8.mat").is_file(),
    reason=f"the authors' human-study logs are not at {DATA} (../shared/data/tnsre2020_human_study)",
)

EXCLUDED = {
    ("H3", 2, 12),
    ("H4", 2, 9),
    ("H4", 2, 12),
    ("H5", 1, 3),
    ("H5", 1, 4),
    ("H5", 1, 11),
    ("H5", 1, 14),
    ("H5", 1, 16),
}  # the README's failed trials among H2..H5


def independent_summary() -> dict[tuple[str, str, str], dict[str, float]]:
    """Per (interface, task, paradigm), straight from the files: the README's definitions with the
    request switch taken as in loadData.m (the first switch at or after each request)."""
    order = loadmat(str(DATA / "trial_order_testing_8.mat"))
    groups: dict[tuple[str, str, str], list[dict]] = {}
    for path in sorted(DATA.glob("H*/H*.mat")):
        m = re.match(r"H(\d)PH(\d)(RE|PO)(J2|HA)T(\d+)\.mat", path.name)
        s, block, task, iface, n = int(m[1]), int(m[2]), m[3], m[4], int(m[5])
        paradigm = str(order[f"ph{block}_trial_mat"][n - 1, 2, s - 2][0])
        d = loadmat(str(path))
        start, total = d["start_time"][0, 0], d["total_time"][0, 0]
        ms = d["mode_switches"][2:]  # without the placeholder and the initial mode
        cm = d["current_mode"][2:]
        ar = d["assistance_requested"][1:, 1] - start
        ms_t = ms[:, 1] - start
        own = []
        for r in ar:
            diff = ms_t - r
            diff[diff < 0] = -999
            own.append(int(np.argmin(np.abs(diff))))
        user = [k for k in range(len(ms_t)) if k not in own]
        switches_raw = len(ms) - len(ar)
        switches = switches_raw
        if iface == "J2":  # joystick: consecutive user switches into one mode within 2 s
            cm_user, t_user = cm[user, 0], ms_t[user]
            switches -= int(np.sum((np.diff(cm_user) == 0) & (np.diff(t_user) < 2)))
        keep = np.ones(len(ar), dtype=bool)
        keep[1:] = np.diff(ar) >= 3
        alpha = d["alpha"][1:]
        during = (alpha[:, 1] - start >= 0) & (alpha[:, 1] - start <= total)
        groups.setdefault(
            (
                "joystick" if iface == "J2" else "head_array",
                "reaching" if task == "RE" else "pouring",
                "disambiguation" if paradigm == "on" else "manual",
            ),
            [],
        ).append(
            {
                "valid": (f"H{s}", block, n) not in EXCLUDED,
                "switches": switches,
                "switches_raw": switches_raw,
                "requests": int(keep.sum()),
                "requests_raw": len(ar),
                "time": total,
                "norm": list(ar[keep] / total),
                "alpha": alpha[during, 0].mean(),
            }
        )
    out = {}
    for key, trials in groups.items():
        v = [t for t in trials if t["valid"]]
        pooled = [x for t in v for x in t["norm"]]
        out[key] = {
            "n_trials": len(trials),
            "n_valid": len(v),
            "mean_mode_switches": np.mean([t["switches"] for t in v]),
            "mean_requests": np.mean([t["requests"] for t in v]),
            "mean_button_presses": np.mean([t["switches"] + t["requests"] for t in v]),
            "mean_mode_switches_raw": np.mean([t["switches_raw"] for t in v]),
            "mean_requests_raw": np.mean([t["requests_raw"] for t in v]),
            "mean_button_presses_raw": np.mean([t["switches_raw"] + t["requests_raw"] for t in v]),
            "mean_completion_time": np.mean([t["time"] for t in v]),
            "success_rate": len(v) / len(trials),
            "request_time_skewness": float(skew(pooled)) if pooled else None,
            "mean_alpha": np.mean([t["alpha"] for t in v]),
        }
    return out


@pytest.fixture(scope="module")
def imported(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("authors")
    assert main(["study", "import-authors", str(DATA), "--out", str(out), "--quiet"]) == 0
    assert main(["study", "report", str(out)]) == 0
    return out


def test_summary_matches_an_independent_computation(imported: Path) -> None:
    summary = json.loads((imported / "report" / "summary.json").read_text())
    expected = independent_summary()
    assert {(r["interface"], r["task"], r["paradigm"]) for r in summary} == set(expected)
    assert sum(r["n_trials"] for r in summary) == 127 and sum(r["n_valid"] for r in summary) == 119
    for row in summary:
        exp = expected[(row["interface"], row["task"], row["paradigm"])]
        assert row["source"] == "authors"
        for key, value in exp.items():
            if value is None:
                assert row[key] is None, key
            else:
                assert row[key] == pytest.approx(value, rel=1e-9), (row["interface"], row["task"], key)
    # The cleaning matters on these logs (joystick repeated presses, merged requests).
    assert any(r["mean_mode_switches"] < r["mean_mode_switches_raw"] for r in summary)
    assert any(r["mean_requests"] < r["mean_requests_raw"] for r in summary)


def test_read_trials_gives_the_imported_records(imported: Path) -> None:
    # The one reader of the logs: import-authors writes what read_trials returns (study calibrate
    # reads the logs with it too).
    trials = read_trials(DATA)
    assert [t.record for t in trials] == read_records(imported / "trials.jsonl")


def test_report_on_the_authors_data(imported: Path) -> None:
    out = imported / "report"
    page = (out / "index.html").read_text()
    assert page.count('src="data:image/png;base64,') == 5 + 8  # 5 figures + one trace per condition
    stats = json.loads((out / "stats.json").read_text())
    assert {r["a"] for r in stats} == {"manual"} and {r["b"] for r in stats} == {"disambiguation"}
    # Every p-value of stats.json is a two-sided rank-sum p recomputed from the records.
    from scipy.stats import mannwhitneyu

    lines = [json.loads(x) for x in (imported / "trials.jsonl").read_text().splitlines()]
    row = next(
        r
        for r in stats
        if r["test"] == "ranksum"
        and r["metric"] == "completion_time"
        and r["interface"] == "head_array"
        and r["task"] == "pouring"
    )
    a = [
        x["completion_time"]
        for x in lines
        if x["valid"]
        and x["interface"] == "head_array"
        and x["task"] == "pouring"
        and x["paradigm"] == "manual"
    ]
    b = [
        x["completion_time"]
        for x in lines
        if x["valid"]
        and x["interface"] == "head_array"
        and x["task"] == "pouring"
        and x["paradigm"] == "disambiguation"
    ]
    assert row["p_value"] == pytest.approx(mannwhitneyu(a, b, alternative="two-sided").pvalue, rel=1e-12)


def test_one_trial_field_by_field() -> None:
    order = load_trial_order(DATA / "trial_order_testing_8.mat")
    trial = read_trial(DATA / "H2" / "H2PH1POHAT1.mat", order)
    r = trial.record
    assert (r.subject, r.interface, r.task, r.paradigm) == ("H2", "head_array", "pouring", "disambiguation")
    assert r.intended_goals == [1] and r.start_pose == 1 and r.initial_mode == "gripper"
    assert r.request_times == pytest.approx([1.645, 36.945], abs=2e-3)
    # 15 rows - placeholder - initial mode - 2 request switches (at 4.21 s and 39.49 s).
    assert r.mode_switches == 11 and r.button_presses == 13
    assert r.mode_switch_times[0] == pytest.approx(18.01, abs=0.01) and r.mode_switch_modes[0] == "vy"
    assert all(abs(t - 4.21) > 0.01 and abs(t - 39.49) > 0.01 for t in r.mode_switch_times)
    assert trial.request_switch_times == pytest.approx([4.21, 39.49], abs=0.01)
    assert len(trial.switch_times) == 13 and np.all(np.diff(trial.switch_times) >= 0)
    assert r.duration == r.completion_time == pytest.approx(67.708, abs=1e-3)
    assert r.success is None and r.reached_goals is None and r.valid and r.source == "authors"
    assert r.assistance_onset is None  # pouring: the stage goals are not logged
    assert 0.0 < r.mean_alpha < 0.7
    assert set(trial.trace) == {
        "t", "belief", "alpha", "u", "mode", "u_h", "t_u_h",
        "request_mode_scores", "request_dim_scores", "request_mode_ids",
    }  # fmt: skip
    k = r.requests
    assert trial.trace["request_mode_scores"].shape == (k, 6)  # the head array's arm modes
    assert trial.trace["request_dim_scores"].shape == (k, 6) and len(trial.trace["request_mode_ids"]) == k
    n = len(trial.trace["t"])
    assert trial.trace["belief"].shape == (n, 4) and trial.trace["u"].shape == (n, 6)
    assert trial.trace["u_h"].shape[1] == 6 and len(trial.trace["t_u_h"]) == len(trial.trace["u_h"])
    # Joystick ids map to the cycle's names; the authors' trial-order corrections are applied.
    assert read_trial(DATA / "H2" / "H2PH1POJ2T12.mat", order).record.initial_mode == "wx_wz"
    assert read_trial(DATA / "H2" / "H2PH1POHAT2.mat", order).record.start_pose == 2
    failed = read_trial(DATA / "H5" / "H5PH1POJ2T3.mat", order).record
    assert not failed.valid and parse_trial_name("H5PH1POJ2T3.mat") == ("H5", 1, "pouring", "joystick", 3)
    onset = read_trial(DATA / "H2" / "H2PH2REJ2T10.mat", order).record.assistance_onset
    assert onset is None or 0.0 <= onset <= 12.9


def test_import_resumes_and_never_overwrites(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["study", "import-authors", str(DATA), "--out", str(tmp_path), "--quiet"]) == 0
    path = tmp_path / "trials.jsonl"
    lines = path.read_text().splitlines(keepends=True)
    assert len(lines) == 127
    assert main(["study", "import-authors", str(DATA), "--out", str(tmp_path), "--quiet"]) == 0
    assert path.read_text() == "".join(lines)
    assert "0 trials imported, 127 already there" in capsys.readouterr().out
    path.write_text("".join(lines[:100]))
    assert main(["study", "import-authors", str(DATA), "--out", str(tmp_path), "--quiet"]) == 0
    records = read_records(path)
    assert len(records) == 127 and {r.trial_id for r in records} == {json.loads(x)["trial_id"] for x in lines}
    assert path.read_text().startswith("".join(lines[:100]))
    assert len(list((tmp_path / "traces").glob("*.npz"))) == 127
    reps = {}
    for r in records:
        reps.setdefault((r.subject, r.interface, r.task, r.paradigm), []).append(r.repetition)
    assert all(sorted(v) == list(range(len(v))) for v in reps.values())


def test_bad_data_folders(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["study", "import-authors", str(tmp_path), "--out", str(tmp_path / "o")]) == 2
    assert "trial_order_testing_8.mat: the trial-order file is missing" in capsys.readouterr().err
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "trial_order_testing_8.mat").write_bytes(
        (DATA / "trial_order_testing_8.mat").read_bytes()
    )
    assert main(["study", "import-authors", str(tmp_path / "d"), "--out", str(tmp_path / "o")]) == 2
    assert "no trial files" in capsys.readouterr().err
    (tmp_path / "d" / "H2").mkdir()
    (tmp_path / "d" / "H2" / "H2PH1POHAT1.mat").write_bytes(b"garbage")
    assert main(["study", "import-authors", str(tmp_path / "d"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "H2PH1POHAT1.mat: cannot read the MATLAB file" in err and "Traceback" not in err
    assert not (tmp_path / "o" / "trials.jsonl").exists()
    # A corrupt trials.jsonl in --out is reported with its line, and left as it is.
    (tmp_path / "o").mkdir(exist_ok=True)
    (tmp_path / "o" / "trials.jsonl").write_text("{not json}\n")
    assert main(["study", "import-authors", str(DATA), "--out", str(tmp_path / "o")]) == 2
    assert "o/trials.jsonl:1: not a JSON record" in capsys.readouterr().err
    assert (tmp_path / "o" / "trials.jsonl").read_text() == "{not json}\n"
    with pytest.raises(ValueError, match="trial file name"):
        parse_trial_name("H2PH3POHAT1.mat")


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"drop": "alpha"}, "no variable 'alpha'"),
        ({"drop": "blended_vel"}, "no variable 'blended_vel'"),
        ({"alpha": np.zeros((4, 3))}, "alpha has shape (4, 3), expected (k, 2)"),
        ({"goal_probabilities": np.zeros((0, 4))}, "goal_probabilities has shape (0, 4)"),
    ],
    ids=["no-alpha", "no-blended-vel", "flat-alpha", "empty-belief"],
)
def test_a_trial_file_missing_or_misshaping_a_series_is_named(
    change: dict, message: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A trial file without one of its time series, or with one of the wrong shape: a ValueError
    naming the file and the variable (``study import-authors``: one line, status 2), not a
    ``KeyError`` or ``IndexError`` traceback."""
    from scipy.io import savemat

    data = {k: v for k, v in loadmat(str(DATA / "H2" / "H2PH1POHAT1.mat")).items() if not k.startswith("__")}
    data.pop(change.pop("drop", None), None)
    data.update(change)
    folder = tmp_path / "d"
    (folder / "H2").mkdir(parents=True)
    (folder / "trial_order_testing_8.mat").write_bytes((DATA / "trial_order_testing_8.mat").read_bytes())
    savemat(str(folder / "H2" / "H2PH1POHAT1.mat"), data)
    order = load_trial_order(folder / "trial_order_testing_8.mat")
    with pytest.raises(ValueError, match=re.escape(message)):
        read_trial(folder / "H2" / "H2PH1POHAT1.mat", order)
    assert main(["study", "import-authors", str(folder), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert message in err and "H2PH1POHAT1.mat" in err and "Traceback" not in err
