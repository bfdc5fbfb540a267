"""``study report DIR --compare OTHER``'s paradigm effect (``report/paradigm_effect.json``, its table in
index.html and on stdout): on small synthetic folders whose answer is known, and on the authors'
logs compared with themselves (skipped where ../shared/data is absent)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from scipy.stats import mannwhitneyu
from support import report_compared
from support import study_trial as trial

from drake_disamb.cli import main
from drake_disamb.study.analysis.effect import paradigm_effect
from drake_disamb.study.data.records import append_record
from drake_disamb.study.report.page import load_study

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "tnsre2020_human_study"


def write(folder: Path, cells: dict[tuple[str, str], tuple[list[int], list[int]]]) -> Path:
    """A study folder: per (interface, task), the Manual and the Disambiguation button presses
    (each Disambiguation trial has one request)."""
    folder.mkdir(parents=True)
    n = 0
    for (interface, task), (manual, disamb) in cells.items():
        for paradigm, presses in (("manual", manual), ("disambiguation", disamb)):
            for p in presses:
                requests = 1 if paradigm == "disambiguation" else 0
                append_record(folder / "trials.jsonl", trial(n, interface, task, paradigm, p, requests))
                n += 1
    # A failed trial: left out, as in every mean and test of the report.
    failed = trial(n, "joystick", "reaching", "disambiguation", 90, 1)
    failed.success = False
    failed.completion_time = None
    append_record(folder / "trials.jsonl", failed)
    return folder


MANUAL, DISAMB = [10, 12, 14], [5, 6, 7]  # relative change -0.5
HERE = {
    ("joystick", "reaching"): (MANUAL, DISAMB),
    ("joystick", "pouring"): (MANUAL, DISAMB),
    ("head_array", "reaching"): (MANUAL, DISAMB),
    ("head_array", "pouring"): (MANUAL, DISAMB),
}
THERE = {
    ("joystick", "reaching"): (MANUAL, [7, 8, 9]),  # -1/3: ratio 1.5, inside the factor of 2
    ("joystick", "pouring"): (MANUAL, [11, 11, 11]),  # -1/12: ratio 6, outside
    ("head_array", "reaching"): (MANUAL, [18, 18, 18]),  # +0.5: the opposite direction
}  # no head-array pouring: "-" and n/a


@pytest.fixture(scope="module")
def compared(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    root = tmp_path_factory.mktemp("effect")
    here, there = write(root / "here", HERE), write(root / "there", THERE)
    return here, report_compared(here, there)


def rows_of(folder: Path) -> dict[tuple[str, str, str], dict]:
    rows = json.loads((folder / "report" / "paradigm_effect.json").read_text())
    return {(r["metric"], r["interface"], r["task"]): r for r in rows}


def test_the_json_has_the_known_effects(compared: tuple[Path, str]) -> None:
    here, _ = compared
    rows = rows_of(here)
    assert len(rows) == 12  # 2 metrics x 2 interfaces x (both tasks, reaching, pouring)
    r = rows[("button_presses", "joystick", "reaching")]
    assert (r["n_manual"], r["n_disambiguation"]) == (3, 3)  # the failed trial left out
    assert r["mean_manual"] == pytest.approx(12.0) and r["mean_disambiguation"] == pytest.approx(6.0)
    assert r["relative_change"] == pytest.approx(-0.5)
    assert r["p_value"] == pytest.approx(mannwhitneyu(MANUAL, DISAMB, alternative="two-sided").pvalue)
    assert r["other_mean_disambiguation"] == pytest.approx(8.0)
    assert r["other_relative_change"] == pytest.approx(-1 / 3)
    assert r["other_p_value"] == pytest.approx(
        mannwhitneyu(MANUAL, [7, 8, 9], alternative="two-sided").pvalue
    )
    assert r["ratio"] == pytest.approx(1.5) and r["check"] is True
    # Mode switches: one of each Disambiguation trial's presses is a request.
    r = rows[("mode_switches", "joystick", "reaching")]
    assert r["mean_disambiguation"] == pytest.approx(5.0) and r["relative_change"] == pytest.approx(-7 / 12)
    assert r["other_relative_change"] == pytest.approx(-5 / 12)
    assert r["ratio"] == pytest.approx(7 / 5) and r["check"] is True
    # Both tasks of an interface: the means over its trials of both tasks.
    r = rows[("button_presses", "joystick", "all")]
    assert r["n_manual"] == 6 and r["relative_change"] == pytest.approx(-0.5)
    assert r["other_mean_disambiguation"] == pytest.approx(9.5)
    assert r["ratio"] == pytest.approx(0.5 / (2.5 / 12)) and r["check"] is False


def test_the_means_and_p_are_the_reports_own(compared: tuple[Path, str]) -> None:
    here, _ = compared
    stats = json.loads((here / "report" / "stats.json").read_text())
    for (metric, interface, task), r in rows_of(here).items():
        (t,) = [
            t
            for t in stats
            if t["test"] == "ranksum"
            and (t["metric"], t["interface"], t["task"], t["a"], t["b"])
            == (metric, interface, task, "manual", "disambiguation")
        ]
        assert (r["mean_manual"], r["mean_disambiguation"], r["p_value"]) == (
            t["mean_a"],
            t["mean_b"],
            t["p_value"],
        )


def test_the_check_column(compared: tuple[Path, str]) -> None:
    rows = rows_of(compared[0])
    assert rows[("button_presses", "joystick", "reaching")]["check"] is True  # ratio 1.5
    outside = rows[("button_presses", "joystick", "pouring")]
    assert outside["ratio"] == pytest.approx(6.0) and outside["check"] is False
    opposite = rows[("button_presses", "head_array", "reaching")]
    assert opposite["ratio"] == pytest.approx(-1.0) and opposite["check"] is False


def test_a_cell_without_trials_on_one_side(compared: tuple[Path, str]) -> None:
    here, stdout = compared
    r = rows_of(here)[("button_presses", "head_array", "pouring")]
    assert r["relative_change"] == pytest.approx(-0.5)
    assert (r["other_n_manual"], r["other_n_disambiguation"]) == (0, 0)
    for key in ("mean_manual", "mean_disambiguation", "relative_change", "p_value"):
        assert r[f"other_{key}"] is None
    assert r["ratio"] is None and r["check"] is None
    (line,) = [x for x in stdout.splitlines() if x.startswith("button presses  head_array  pouring")]
    cells = line.split()
    assert cells[-1] == "n/a" and cells[-2] == "-" and cells.count("-") == 5  # 4 of there + ratio


def test_the_table_is_printed_and_in_the_page(compared: tuple[Path, str]) -> None:
    here, stdout = compared
    lines = stdout.splitlines()
    assert lines[-1].startswith("wrote ") and lines[-1].split()[1].endswith("index.html")
    assert lines[0].startswith("Paradigm effect Manual -> Disambiguation")
    table = [x for x in lines if x.startswith(("button presses", "mode switches"))]
    assert len(table) == 12
    row = next(x for x in table if x.startswith("button presses  joystick    reaching"))
    assert "12.00" in row and "6.00" in row and "-50%" in row and "-33%" in row and "1.50" in row
    assert row.split()[-1] == "yes"
    page = (here / "report" / "index.html").read_text()
    assert "Paradigm effect: this folder beside the other" in page
    assert '<td class="no">no</td>' in page and '<td class="yes">yes</td>' in page


def test_no_table_without_compare(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = write(tmp_path / "alone", HERE)
    assert main(["study", "report", str(folder), "--no-mixed-model"]) == 0
    assert "Paradigm effect" not in capsys.readouterr().out
    assert not (folder / "report" / "paradigm_effect.json").exists()


def test_the_library_makes_its_own_tests(compared: tuple[Path, str]) -> None:
    """Without the tests given, paradigm_effect runs the same rank-sum tests itself."""
    here = compared[0]
    there = here.parent / "there"
    rows = paradigm_effect(load_study(here), load_study(there))
    assert rows == json.loads((here / "report" / "paradigm_effect.json").read_text())


@pytest.mark.skipif(
    not (DATA / "trial_order_testing_8.mat").is_file(),
    reason=f"the authors' human-study logs are not at {DATA} (../shared/data/tnsre2020_human_study)",
)
def test_the_authors_logs_beside_themselves(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "authors"
    assert main(["study", "import-authors", str(DATA), "--out", str(out), "--quiet"]) == 0
    assert main(["study", "report", str(out), "--compare", str(out), "--no-mixed-model"]) == 0
    rows = json.loads((out / "report" / "paradigm_effect.json").read_text())
    assert len(rows) == 12
    for r in rows:
        assert r["ratio"] == 1.0 and r["check"] is True, r
        assert r["n_manual"] > 0 and r["n_disambiguation"] > 0
    stdout = capsys.readouterr().out.splitlines()
    assert stdout[-1].startswith("wrote ")
    assert sum(1 for x in stdout if x.split()[-1:] == ["yes"]) == 12
