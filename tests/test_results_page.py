"""``benchmarks/results.py`` writes docs/results.md from the benchmarks' printed figures and a finished
study's report: each figure under the command that measured it. The benchmarks are stubbed here (their
printed text stands in); ``study report`` runs for real on two small synthetic folders whose answer
is known."""

from __future__ import annotations

import contextlib
import io
import json
import shlex
from pathlib import Path

import pytest
import yaml
from support import benchmark_module, study_trial

from drake_disamb.cli import main as cli_main
from drake_disamb.comparison.replay import METHOD_LABELS, PUBLISHED_ACCURACY
from drake_disamb.study.data.records import append_record


@pytest.fixture(scope="module")
def results():  # noqa: ANN201 (the benchmark module)
    with benchmark_module("results") as module:
        yield module


ACCURACY = {"dft": 0.8123, "bayes": 0.8456, "memory": 0.5789}
"""The stubbed inference-benchmark's paper metric per method (the strict one is 0.1 lower)."""


class FakeRunner:
    """Stands in for ``run_command``: the benchmark scripts print ``printed <command>``, the
    inference benchmark writes its ``--json`` from :data:`ACCURACY`, and ``study report`` runs in
    this process. Records every command."""

    def __init__(self) -> None:
        self.commands: list[str] = []

    def __call__(self, command: str) -> str:
        self.commands.append(command)
        argv = shlex.split(command)
        if argv[:2] == ["drake-disamb", "inference-benchmark"]:
            path = Path(argv[argv.index("--json") + 1])
            trials = 100 if "--data" in argv else int(argv[argv.index("--generate") + 1])
            methods = {
                m: {"published_metric": a, "published_std": 0.1, "strict_metric": a - 0.1, "strict_std": 0.1}
                for m, a in ACCURACY.items()
            }
            path.write_text(json.dumps({"methods": methods, "trials": trials, "source": "stub"}))
            return "table\n"
        if argv[:3] == ["drake-disamb", "study", "report"]:
            out = io.StringIO()
            with contextlib.redirect_stdout(out):
                assert cli_main(argv[1:]) == 0
            return out.getvalue()
        return f"printed {command}\n"


def _folder(path: Path, trials: list[tuple[str, str, int, bool]], study_yaml: bool) -> Path:
    """A folder of (interface, paradigm, presses, success) joystick or head-array reaching trials."""
    path.mkdir(parents=True)
    for n, (interface, paradigm, presses, success) in enumerate(trials):
        record = study_trial(n, interface, "reaching", paradigm, presses, requests=presses // 3)
        if not success:
            record.success, record.completion_time = False, None
        record.extra = {"end_reason": "done" if success else "given up"}
        append_record(path / "trials.jsonl", record)
    if study_yaml:
        meta = {"seed": 0, "version": "0.1.0", "subjects": [{"name": "S01"}, {"name": "S02"}]}
        meta["protocol"] = {"system": "tnsre2020_study", "tasks": [{"task": "reaching"}]}
        (path / "study.yaml").write_text(yaml.safe_dump(meta))
    return path


# Joystick Manual presses 2 and 4 (mean 3), Disambiguation 3 and 6 (mean 4.5) and one failed trial.
HERE = [("joystick", "manual", 2, True), ("joystick", "manual", 4, True)]
HERE += [("joystick", "disambiguation", 3, True), ("joystick", "disambiguation", 6, True)]
HERE += [("joystick", "disambiguation", 30, False)]
# The people: Manual 6 and 8 (mean 7), Disambiguation 3 and 3 (mean 3).
THERE = [("joystick", "manual", 6, True), ("joystick", "manual", 8, True)]
THERE += [("joystick", "disambiguation", 3, True), ("joystick", "disambiguation", 3, True)]


@pytest.fixture(scope="module")
def page(results, tmp_path_factory: pytest.TempPathFactory) -> tuple[str, FakeRunner]:  # noqa: ANN001
    root = tmp_path_factory.mktemp("results")
    study = _folder(root / "study", HERE, study_yaml=True)
    authors = _folder(root / "authors", THERE, study_yaml=False)
    runner = FakeRunner()
    out = results.write_page(study, authors, root / "docs" / "results.md", run=runner)
    return out.read_text(), runner


def test_every_benchmark_runs_as_the_page_names_it(results, page: tuple[str, FakeRunner]) -> None:  # noqa: ANN001
    text, runner = page
    for benchmark in results.BENCHMARKS.values():
        assert benchmark.command in runner.commands
        # The printed figures stand under their command, in the page's order.
        assert f"$ {benchmark.command}\nprinted {benchmark.command}\n" in text
    titles = [line for line in text.splitlines() if line.startswith("## ")]
    assert titles == [
        "## Intent inference: the paper's comparison",
        *(f"## {b.title}" for b in results.BENCHMARKS.values()),
        "## The user study",
    ]


def test_the_inference_table_comes_from_the_commands_json(page: tuple[str, FakeRunner]) -> None:
    text, runner = page
    assert "drake-disamb inference-benchmark --data ../shared/data/tnsre2018_simulated_trajectories\n" in text
    assert "drake-disamb inference-benchmark --generate 500 --seed 0\n" in text
    assert any(
        c.startswith("drake-disamb inference-benchmark --generate 500 --seed 0 --quiet --json")
        for c in runner.commands
    )
    assert (
        "| method | paper | published trials (100) | strict | generated trials (500, seed 0) | strict |"
        in text
    )
    for method, accuracy in ACCURACY.items():
        paper = 100 * PUBLISHED_ACCURACY[method]
        mine = f"{100 * accuracy:.2f} % | {100 * accuracy - 10:.2f} %"
        assert f"| {METHOD_LABELS[method]} | {paper:.2f} % | {mine} |" in text


def test_the_study_figures_are_the_reports(page: tuple[str, FakeRunner]) -> None:
    text, runner = page
    prose = " ".join(text.split())  # the page's paragraphs are wrapped
    assert any(
        c.startswith("drake-disamb study report ") and c.endswith("--no-mixed-model") for c in runner.commands
    )
    # The page names the commands with the reader's folder names, not the temporary ones.
    assert "drake-disamb study report out/study --compare out/authors --no-mixed-model" in text
    assert (
        "(system `tnsre2020_study`, 2 subjects, seed 0, drake-disamb 0.1.0): 5 trials, 1000 simulated"
        in prose
    )
    # Means over the analysed trials, the people's in brackets; the failed trial counts in success.
    assert "| joystick, reaching | manual | 2 (2) |" in text
    manual = next(line for line in text.splitlines() if line.startswith("| joystick, reaching | manual |"))
    assert "| 3.0 (7.0) |" in manual and "| 100 % |" in manual
    dis = next(
        line for line in text.splitlines() if line.startswith("| joystick, reaching | disambiguation |")
    )
    assert dis.startswith("| joystick, reaching | disambiguation | 3 (2) |")
    assert "| 4.5 (3.0) |" in dis and "| 67 % |" in dis
    assert (
        "Success: manual 100.0 %, disambiguation 66.7 %. How the trials ended: done 4, given up 1." in prose
    )
    # The effect: +50 % here against -57 % for the people: the other direction.
    effect = next(line for line in text.splitlines() if line.startswith("| joystick | button presses |"))
    assert "3.0 → 4.5 (+50 %" in effect and "7.0 → 3.0 (-57 %" in effect and effect.endswith("| no (-0.88) |")


def test_a_failed_command_writes_nothing(results, tmp_path: Path) -> None:  # noqa: ANN001
    study = _folder(tmp_path / "study", HERE, study_yaml=True)
    authors = _folder(tmp_path / "authors", THERE, study_yaml=False)
    out = tmp_path / "results.md"

    def failing(command: str) -> str:
        if command.startswith("python benchmarks/bench_safety.py"):
            raise results.CommandFailed(f"{command}: exit status 1: boom")
        return FakeRunner()(command)

    with pytest.raises(results.CommandFailed, match="bench_safety.py: exit status 1: boom"):
        results.write_page(study, authors, out, run=failing)
    assert not out.exists()


def test_bad_input_is_one_line_and_status_2(results, tmp_path: Path, capsys) -> None:  # noqa: ANN001
    authors = _folder(tmp_path / "authors", THERE, study_yaml=False)
    out = tmp_path / "results.md"
    # A folder without study.yaml is not a study of the protocol (the people's records are not).
    assert results.main(["--study", str(authors), "--authors", str(authors), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("results: --study: expected a study folder with study.yaml") and "\n" not in err
    assert results.main(["--only", "nothing", "--out", str(out)]) == 2
    assert "--only: expected names among inference, disambiguation" in capsys.readouterr().err
    assert not out.exists()


def test_commands_run_this_interpreter(results) -> None:  # noqa: ANN001
    import sys

    assert results.command_argv("python benchmarks/bench_ik.py --calls 3") == [
        sys.executable,
        "benchmarks/bench_ik.py",
        "--calls",
        "3",
    ]
    assert results.command_argv("drake-disamb demo --no-meshcat")[:3] == [
        sys.executable,
        "-m",
        "drake_disamb.cli",
    ]
    with pytest.raises(ValueError, match="python or drake-disamb"):
        results.command_argv("rm -rf /")
