"""``study report``: the paper's analysis of a study folder, as a self-contained HTML page.

:func:`write_report` reads ``DIR/trials.jsonl`` (and ``DIR/traces/``) and writes, in
``DIR/report/`` only:

- ``summary.json``: :func:`drake_disamb.study.measures.metrics.summarize` (one object per source,
  interface, task and paradigm);
- ``stats.json``: :func:`drake_disamb.study.analysis.stats.run_tests`;
- the figures as PNG (:mod:`drake_disamb.study.report.figures`): ``button_presses.png``,
  ``switches_requests.png``, ``completion_times.png``, ``raster.png``, ``alpha.png`` and
  ``traces_<interface>_<task>_<paradigm>.png``; with several sources in the folder each figure is
  drawn per source (``<name>_<source>.png``);
- ``survey.json`` (a folder with questionnaires, ``surveys.jsonl``, written by ``study session``):
  :func:`drake_disamb.study.analysis.survey.survey_rows`, the paper's questionnaire summarised as
  its table, beside its values;
- ``index.html``: every table (summary, skewness, tests, "the paper's finding / ours / agree?"
  of :func:`drake_disamb.study.analysis.findings.findings`) and every figure embedded as base64 PNG; no
  network, no script.

``--compare OTHER_DIR`` adds ``compare.json``
(:func:`drake_disamb.study.analysis.findings.compare_summaries`) and a section setting this folder's
means beside the other's per interface, task and paradigm, with their ratio and whether it is within 50 %
(the criterion for simulated versus human users), and ``paradigm_effect.json``
(:func:`drake_disamb.study.analysis.effect.paradigm_effect`, keys in its module) with a table of the
Manual -> Disambiguation effect on button presses and user mode switches per interface and per
interface and task, here and there: the means, the relative change, the rank-sum p, the ratio of the
relative changes and whether it is within a factor of 2, and ``per_goal.json``
(:func:`drake_disamb.study.analysis.per_goal.per_goal`) with a table of the same means per intended
goal of the single-stage tasks, here and there: a cell's mean mixes the goals its trials drew.

On an ablation folder (``DIR/ablation.json``, written by ``study ablate``), :func:`write_report`
writes the combined report instead: for every setting, the paradigm effect on button presses
and completion time with its rank-sum test (``stats.json`` and ``summary.json`` rows carry a
``setting`` field).

Nothing outside ``DIR/report/`` is written: ``report`` must be a real folder (a symlink there is
refused), and every file is written whole into a new temporary file and renamed over its name
(:func:`~drake_disamb.study.data.folder.write_atomic`), so a symlink planted in ``report/`` is replaced,
never written through. Bad records stop the report with
:class:`drake_disamb.study.data.records.RecordError` naming the file, the line and the field; a missing trace
(each one) and a bad trace read for an example figure are left out of the figures with a warning
naming the file.
"""

from __future__ import annotations

import base64
import html
import json
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drake_disamb.interfaces import interfaces_in
from drake_disamb.study.analysis.effect import paradigm_effect
from drake_disamb.study.analysis.findings import (
    COMPARED,
    PAPER_SKEWNESS,
    compare_summaries,
    findings,
    fmt,
    select_trials,
)
from drake_disamb.study.analysis.per_goal import SIDE_KEYS as GOAL_SIDE_KEYS
from drake_disamb.study.analysis.per_goal import per_goal
from drake_disamb.study.analysis.stats import MIXED_METRICS, run_tests
from drake_disamb.study.analysis.survey import survey_rows
from drake_disamb.study.data.folder import StudyFolder, write_atomic
from drake_disamb.study.data.records import RecordError, TrialRecord
from drake_disamb.study.data.surveys import SurveyRecord, read_surveys
from drake_disamb.study.design.survey import PREFERENCES, STATEMENTS
from drake_disamb.study.measures.metrics import TrialMetrics, request_time_skewness, summarize, trial_metrics
from drake_disamb.study.report.effect_table import EFFECT_HEADERS, effect_cells
from drake_disamb.study.report.figures import ablation_figure, save_figure, source_figures, trace_figures

__all__ = ["ReportFiles", "compare_summaries", "load_study", "write_report"]


def load_study(folder: str | Path) -> list[TrialRecord]:
    """The records of ``folder/trials.jsonl``.

    Raises:
        RecordError: The folder or file is missing, empty, or has a bad line (file and line named).
    """
    folder = Path(folder)
    path = folder / "trials.jsonl"
    if not folder.is_dir():
        raise RecordError(f"{folder}: no such study folder")
    if not path.is_file():
        raise RecordError(f"{path}: no records (the study folder has no trials.jsonl)")
    records = StudyFolder(folder).read_records()
    if not records:
        raise RecordError(f"{path}: no records (the file is empty)")
    return records


@dataclass
class ReportFiles:
    """What :func:`write_report` wrote."""

    index: Path
    figures: list[Path]
    stats: Path
    summary: Path
    paradigm_effect: Path | None = None
    """``paradigm_effect.json`` (with ``compare`` only)."""
    survey: Path | None = None
    """``survey.json`` (a folder with questionnaires, ``surveys.jsonl``, only)."""
    per_goal: Path | None = None
    """``per_goal.json`` (with ``compare`` only)."""


# HTML

_CSS = """
body { font-family: sans-serif; max-width: 1200px; margin: 1em auto; padding: 0 1em; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1.5em; font-size: 0.85em; }
th, td { border: 1px solid #bbb; padding: 3px 6px; text-align: left; vertical-align: top; }
th { background: #eee; }
td.yes { background: #dff0d8; } td.no { background: #f2dede; }
img { max-width: 100%; border: 1px solid #ddd; margin: 0.3em 0; }
.note { color: #555; font-size: 0.9em; }
div.wide { overflow-x: auto; }
"""


def _table(
    rows: Sequence[dict[str, Any]], columns: Sequence[str], headers: Sequence[str] | None = None
) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in (headers or columns))
    body = []
    for r in rows:
        cells = []
        for c in columns:
            v = r.get(c)
            text = fmt(v, 3) if isinstance(v, float) else ("n/a" if v is None else str(v))
            cls = f' class="{v}"' if c in ("agree", "check") and v in ("yes", "no") else ""
            if isinstance(v, bool):
                cls = f' class="{"yes" if v else "no"}"'
            cells.append(f"<td{cls}>{html.escape(text)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f'<div class="wide"><table><tr>{head}</tr>{"".join(body)}</table></div>'


def _img(path: Path, alt: str) -> str:
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    return f'<p><img src="data:image/png;base64,{data}" alt="{html.escape(alt)}"></p>'


def _page(title: str, sections: Sequence[str]) -> str:
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>"
        f"<h1>{html.escape(title)}</h1>" + "\n".join(sections) + "</body></html>\n"
    )


def _write_page(out: Path, title: str, sections: Sequence[str], figures: list[Path]) -> ReportFiles:
    """Write ``out/index.html`` (``title`` and ``sections``) beside the JSON files already there."""
    index = out / "index.html"
    page = _page(title, sections).encode("utf-8")
    write_atomic(index, lambda f: f.write(page))
    return ReportFiles(index=index, figures=figures, stats=out / "stats.json", summary=out / "summary.json")


def _write_json(path: Path, data: Any) -> None:
    text = (json.dumps(data, indent=1, allow_nan=False) + "\n").encode("utf-8")
    write_atomic(path, lambda f: f.write(text))


def _report_dir(folder: Path) -> Path:
    out = folder / "report"
    if out.is_symlink() or (out.exists() and not out.is_dir()):
        raise RecordError(
            f"{out}: not a folder (a symlink or a file); the report writes only into a real folder"
        )
    try:
        out.mkdir(exist_ok=True)
    except OSError as err:
        raise RecordError(f"{out}: cannot create the report folder: {err.strerror or err}") from None
    return out


def _warn(message: str) -> None:
    print(f"warning: {message}", file=sys.stderr, flush=True)


SUMMARY_COLUMNS = (
    "source",
    "interface",
    "task",
    "paradigm",
    "n_trials",
    "n_valid",
    "n_analysed",
    "n_subjects",
    "mean_mode_switches",
    "mean_requests",
    "mean_button_presses",
    "mean_completion_time",
    "success_rate",
    "request_time_skewness",
    "mean_alpha",
    "mean_assistance_onset",
    "mean_automatic_switches",
    "mean_mode_switches_raw",
    "mean_requests_raw",
    "mean_button_presses_raw",
)
TEST_KEY = ("metric", "interface", "task", "a", "b")
"""The columns naming a test: the metric, the trials' interface and task, the paradigms a and b."""
TEST_COLUMNS = (
    "source",
    *TEST_KEY,
    "n_a",
    "n_b",
    "mean_a",
    "mean_b",
    "statistic",
    "p_value",
    "stars",
    "effect_size",
    "ci_low",
    "ci_high",
)
MAIN_METRICS = ("button_presses", "mode_switches", "requests", "completion_time", "mean_alpha")


def _json_clean(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """NaN / inf -> None, so the JSON is strict."""
    return [
        {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()}
        for r in rows
    ]


def _intro(
    folder: Path, records: Sequence[TrialRecord], sources: Sequence[str], summary: list[dict[str, Any]]
) -> list[str]:
    """The note on what the report reads and how it counts, and the summary table."""
    return [
        f'<p class="note">{len(records)} trials from '
        f"<code>{html.escape(str(folder / 'trials.jsonl'))}</code>; "
        f"sources: {', '.join(sources)}"
        + (" (a mix: every table and figure is per source)" if len(sources) > 1 else "")
        + ". Means over the analysed trials (valid and not failed: failed trials are left out, as the "
        "authors did; they count in the success rate), after the authors' cleaning (requests less "
        "than 3 s apart merged, "
        "repeated joystick presses into the same mode within 2 s dropped); raw means in the *_raw columns. "
        "Tests: two-sided Wilcoxon rank-sum over trials (scipy mannwhitneyu); "
        "*** p &lt; 0.001, ** p &lt; 0.01, "
        "* p &lt; 0.05.</p>",
        "<h2>Summary</h2>",
        _table(summary, SUMMARY_COLUMNS),
    ]


def _findings_section(mine: Sequence[TrialMetrics], tests: list[dict[str, Any]], source: str) -> list[str]:
    """The table "the paper's finding / ours / agree?" of one source."""
    return [
        f"<h2>The paper's findings: the paper / ours ({html.escape(source)}) / agree?</h2>",
        _table(
            findings(mine, tests, source),
            ("paper", "ours", "agree", "criterion"),
            ("the paper's finding", "ours", "agree?", "criterion"),
        ),
    ]


def _skewness_rows(mine: Sequence[TrialMetrics]) -> list[dict[str, Any]]:
    """Per interface, task and paradigm with requests (Disambiguation, Automatic): the request-time
    skewness beside the paper's."""
    rows = []
    for interface in interfaces_in(m.record.interface for m in mine):
        for task in ("reaching", "pouring"):
            for paradigm in ("disambiguation", "automatic"):
                sel = [m for m in select_trials(mine, interface, task) if m.record.paradigm == paradigm]
                if not sel:
                    continue
                rows.append(
                    {
                        "interface": interface,
                        "task": task,
                        "paradigm": paradigm,
                        "requests": sum(len(m.normalized_request_times) for m in sel),
                        "skewness": request_time_skewness(sel),
                        "paper": PAPER_SKEWNESS.get((interface, task))
                        if paradigm == "disambiguation"
                        else None,
                    }
                )
    return rows


def _skewness_section(mine: Sequence[TrialMetrics], source: str) -> list[str]:
    """The request-time skewness table of one source."""
    return [
        f"<h2>Skewness of request times ({html.escape(source)})</h2>",
        '<p class="note">Cleaned request times divided by the trial\'s duration, pooled over the '
        "analysed trials of a condition; biased sample skewness (MATLAB skewness, scipy.stats.skew).</p>",
        _table(_skewness_rows(mine), ("interface", "task", "paradigm", "requests", "skewness", "paper")),
    ]


def _source_sections(
    folder: Path,
    out: Path,
    mine: Sequence[TrialMetrics],
    tests: list[dict[str, Any]],
    source: str,
    suffix: str,
) -> tuple[list[str], list[Path]]:
    """The sections of one source (its findings, skewness, figures and example traces) and the
    figures written for them (named with ``suffix``)."""
    sections = _findings_section(mine, tests, source) + _skewness_section(mine, source)
    figures: list[Path] = []
    for path, caption in source_figures(mine, tests, source, out, suffix):
        figures.append(path)
        sections.append(f"<h2>{html.escape(caption)} ({html.escape(source)})</h2>")
        sections.append(_img(path, caption))
    traces = trace_figures(folder, mine, out, suffix, warn=_warn)
    figures += traces
    sections.append(f"<h2>Example goal-probability traces ({html.escape(source)})</h2>")
    if not traces:
        sections.append('<p class="note">No traces in traces/ for these trials.</p>')
    for path in traces:
        sections.append(_img(path, path.stem))
    return sections, figures


def _tests_sections(tests: list[dict[str, Any]]) -> list[str]:
    """The rank-sum tests of the main metrics and the per-subject checks."""
    per_subject = [
        t
        for t in tests
        if t["test"] != "ranksum"
        and t["metric"] in ("button_presses", "completion_time")
        and t["interface"] != "all"
        and t["task"] == "all"
    ]
    return [
        "<h2>Rank-sum tests (main metrics)</h2>",
        '<p class="note">effect_size: rank-biserial correlation (positive: a larger), '
        "95 % bootstrap interval; every test, the raw counts and the per-subject checks "
        "(signed-rank on subject means, mixed model with a "
        "random intercept per subject) are in stats.json.</p>",
        _table([t for t in tests if t["test"] == "ranksum" and t["metric"] in MAIN_METRICS], TEST_COLUMNS),
        "<h2>Per-subject checks (button presses, completion time)</h2>",
        _table(
            per_subject,
            ("source", *TEST_KEY, "test", "n_a", "n_b", "statistic", "p_value", "stars", "note"),
        ),
    ]


def _means_section(
    out: Path, compare: str | Path, summary: list[dict[str, Any]], other: Sequence[TrialRecord]
) -> list[str]:
    """``compare.json`` written, and its section: the means here beside the other folder's."""
    rows = _json_clean(compare_summaries(summary, _json_clean(summarize(other))))
    _write_json(out / "compare.json", rows)
    cols = ["interface", "task", "paradigm", "source", "other_source"]
    for name in COMPARED:
        cols += [name, f"other_{name}", f"ratio_{name}", f"within_{name}"]
    return [
        f"<h2>Compared with {html.escape(str(compare))}</h2>",
        '<p class="note">Ratio = this folder / the other; flagged (red) outside 50 % '
        "(the criterion for a simulated population: "
        "its means within 50 % of the people's).</p>",
        _table(rows, cols),
    ]


def _effect_section(
    out: Path, records: Sequence[TrialRecord], other: Sequence[TrialRecord], tests: list[dict[str, Any]]
) -> list[str]:
    """``paradigm_effect.json`` written, and its section: the paradigm effect here and there."""
    effect = _json_clean(paradigm_effect(records, other, tests))
    _write_json(out / "paradigm_effect.json", effect)
    headers = ("source", "other source", *EFFECT_HEADERS)
    cells = [{"source": r["source"], "other source": r["other_source"], **effect_cells(r)} for r in effect]
    return [
        "<h2>Paradigm effect: this folder beside the other</h2>",
        '<p class="note">The Manual -&gt; Disambiguation effect on button presses and user mode '
        "switches, per interface (both tasks) and per interface and task, here ("
        + html.escape(", ".join(sorted({r.source for r in records})))
        + ") and in the other folder ("
        + html.escape(", ".join(sorted({r.source for r in other})))
        + "): n (Manual/Disambiguation trials), the two means and the two-sided rank-sum p, "
        "as the summary and the tests above compute them (analysed trials: failed ones left out, "
        "after the authors' cleaning), the relative change (Dis - Man) / Man, the ratio of the "
        "relative changes (here / there) and the check: same direction and within a factor of 2 "
        "(ratio in [0.5, 2]). - : no test for the cell on that side (no analysed trials of a "
        "paradigm); n/a: no ratio. The numbers are in paradigm_effect.json.</p>",
        _table(cells, headers),
    ]


def _per_goal_section(out: Path, records: Sequence[TrialRecord], other: Sequence[TrialRecord]) -> list[str]:
    """``per_goal.json`` written, and its section: the means per intended goal here and there."""
    goals = _json_clean(per_goal(records, other))
    _write_json(out / "per_goal.json", goals)
    goal_cols = ["interface", "task", "paradigm", "goal"]
    goal_cols += [f"{p}{k}" for p in ("", "other_") for k in GOAL_SIDE_KEYS]
    return [
        "<h2>Per intended goal: this folder beside the other</h2>",
        '<p class="note">The tasks whose records name one intended goal (reaching), per interface, '
        "paradigm and goal (0-based): trials, failed trials, and the means over the analysed ones "
        "(user mode switches, requests, completion time in s), here and in the other folder. A "
        "condition's mean above mixes the goals its trials drew. The numbers are in "
        "per_goal.json.</p>",
        _table(goals, goal_cols),
    ]


def _survey_section(out: Path, surveys: Sequence[SurveyRecord]) -> list[str]:
    """``survey.json`` written, and its section: the questionnaire's table beside the paper's."""
    rows = survey_rows(surveys)
    _write_json(out / "survey.json", rows)
    cells = []
    for r in rows:
        if "answer" in r:
            counts = ", ".join(f"{k} {v}" for k, v in r["counts"].items())
            cells.append(
                {
                    "question": r["question"],
                    "group": r["label"],
                    "n": r["n"],
                    "ours": f"{r['answer'] or 'n/a'} ({counts})",
                    "paper": r["paper"],
                }
            )
        else:
            cells.append(
                {
                    "question": r["question"],
                    "group": r["label"],
                    "n": r["n"],
                    "ours": _mean_sd_text(r["mean"], r["sd"]),
                    "paper": _mean_sd_text(r["paper_mean"], r["paper_sd"]),
                }
            )
    questions = [*STATEMENTS, *((q, t) for q, t, _ in PREFERENCES)]
    statements = "".join(f"<li>{html.escape(q)}: {html.escape(t)}</li>" for q, t in questions)
    return [
        f"<h2>Questionnaire ({len(surveys)} subjects)</h2>",
        '<p class="note">The paper\'s questionnaire: Q1-Q3 rated from 1 (strongly disagree) to 7 '
        "(strongly agree) for each interface and task a subject did, mean &plusmn; standard deviation "
        "over the ratings, overall, per interface and per task; Q4-Q7 the most frequent answer (ties "
        "joined by /) and every answer's count. The paper's values (Table \"Subjective Survey "
        'Results") are across tasks and per task. The numbers are in survey.json.</p>',
        f"<ul>{statements}</ul>",
        _table(cells, ("question", "group", "n", "ours", "paper")),
    ]


def _mean_sd_text(mean: float | None, sd: float | None) -> str:
    if mean is None:
        return "n/a"
    return f"{mean:.2f} \u00b1 {sd:.2f}" if sd is not None else f"{mean:.2f}"


def write_report(
    folder: str | Path, compare: str | Path | None = None, mixed_model: bool = True
) -> ReportFiles:
    """Write the report of ``folder`` (or the combined ablation report) into ``folder/report/``.

    Args:
        folder: A study folder (``trials.jsonl``, ``traces/``) or an ablation folder
            (``ablation.json``).
        compare: Another study folder whose means are set beside this one's.
        mixed_model: Fit the per-subject mixed model (:data:`stats.MIXED_METRICS`; about half a
            second per test); the signed-rank check on subject means is always made.

    Raises:
        RecordError: No records, a bad line or an unreadable folder (file and line named).
    """
    folder = Path(folder)
    if (folder / "ablation.json").is_file():
        return _write_ablation_report(folder)
    records = load_study(folder)
    other = load_study(compare) if compare is not None else None
    out = _report_dir(folder)
    trials = [trial_metrics(r) for r in records]
    summary = _json_clean(summarize(records))
    tests = _json_clean(run_tests(records, mixed_metrics=MIXED_METRICS if mixed_model else ()))
    _write_json(out / "summary.json", summary)
    _write_json(out / "stats.json", tests)
    sources = sorted({r.source for r in records})
    sections = _intro(folder, records, sources, summary)
    figures: list[Path] = []
    for source in sources:
        mine = [m for m in trials if m.record.source == source]
        suffix = "" if len(sources) == 1 else f"_{source}"
        part, drawn = _source_sections(folder, out, mine, tests, source, suffix)
        sections += part
        figures += drawn
    sections += _tests_sections(tests)
    surveys = read_surveys(folder)
    if surveys:
        sections += _survey_section(out, surveys)
    if compare is not None and other is not None:
        sections += _means_section(out, compare, summary, other)
        sections += _effect_section(out, records, other, tests)
        sections += _per_goal_section(out, records, other)
    files = _write_page(out, f"Study report: {folder.name}", sections, figures)
    if surveys:
        files.survey = out / "survey.json"
    if other is not None:
        files.paradigm_effect = out / "paradigm_effect.json"
        files.per_goal = out / "per_goal.json"
    return files


# ----------------------------------------------------------------------------------------------
# Ablations


def _read_ablation(folder: Path) -> list[dict[str, Any]]:
    path = folder / "ablation.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise RecordError(f"{path}: not a readable ablation file: {err}") from None
    if not isinstance(data, dict) or data.get("format") != 1 or not isinstance(data.get("settings"), list):
        raise RecordError(f'{path}: expected {{"format": 1, "settings": [...]}}')
    for i, s in enumerate(data["settings"]):
        if not isinstance(s, dict) or not isinstance(s.get("name"), str) or not isinstance(s.get("dir"), str):
            raise RecordError(
                f"{path}: settings[{i}]: expected an object with string name and dir, got {s!r}"
            )
        if Path(s["dir"]).is_absolute() or ".." in Path(s["dir"]).parts:
            raise RecordError(
                f"{path}: settings[{i}].dir: expected a folder inside {folder}, got {s['dir']!r}"
            )
    return data["settings"]


def _write_ablation_report(folder: Path) -> ReportFiles:
    settings = _read_ablation(folder)
    loaded = [(s, load_study(folder / s["dir"])) for s in settings]
    out = _report_dir(folder)
    tests: list[dict[str, Any]] = []
    summary: list[dict[str, Any]] = []
    for s, records in loaded:
        tag = {"setting": s["name"], "overrides": s.get("overrides", {})}
        summary += [{**tag, **r} for r in _json_clean(summarize(records))]
        tests += [
            {**tag, **t}
            for t in _json_clean(run_tests(records, ("button_presses", "completion_time"), per_subject=False))
        ]
    _write_json(out / "summary.json", summary)
    _write_json(out / "stats.json", tests)
    effect = []
    for t in tests:
        if t["task"] != "all" and t["interface"] != "all":
            continue
        effect.append({**t, "difference": t["mean_b"] - t["mean_a"]})
    figures = [save_figure(ablation_figure(effect), out / "ablation_effects.png")]
    sections = [
        f'<p class="note">{len(settings)} settings from '
        f"<code>{html.escape(str(folder / 'ablation.json'))}</code>. "
        "Per setting, the paradigm effect (b minus a, means over the analysed trials after the authors' "
        "cleaning) on "
        "button presses and completion time, with the two-sided rank-sum test.</p>",
        _img(figures[0], "paradigm effect per setting"),
        "<h2>Paradigm effect per setting</h2>",
        _table(
            effect,
            (
                "setting",
                *TEST_KEY,
                "n_a",
                "n_b",
                "mean_a",
                "mean_b",
                "difference",
                "p_value",
                "stars",
                "effect_size",
            ),
        ),
        "<h2>Summary per setting</h2>",
        _table(summary, ("setting", *SUMMARY_COLUMNS)),
    ]
    return _write_page(out, f"Ablation report: {folder.name}", sections, figures)
