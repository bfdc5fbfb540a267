"""Write docs/results.md: today's figures, each with the command that measures it.

Usage::

    python benchmarks/results.py --study DIR --authors DIR [--out docs/results.md] [--only NAME ...]

Runs the quick benchmarks, each as the very command the page names (a subprocess from the
repository root, ``python`` this interpreter, ``drake-disamb`` its ``drake_disamb.cli``), and reads
a finished study: ``--study DIR`` is a folder of the paper's protocol made by
``python benchmarks/bench_study.py --seed 0 --out DIR`` (or ``drake-disamb study run --out DIR``:
the same records), ``--authors DIR`` the people's records made by ``drake-disamb study
import-authors ../shared/data/tnsre2020_human_study --out DIR``. It runs ``drake-disamb study report
DIR --compare AUTHORS --no-mixed-model`` (which writes only ``DIR/report/``) and reads its JSON; it
never runs the study itself (15 to 25 minutes on two cores). About ten minutes on the 2-core
development machine, most of it the closed-loop and safety sweeps.

``--only NAME`` (repeatable; the names are :data:`BENCHMARKS`' keys and ``study``) writes the page
with those sections only, to try the script. Exit status: 0 the page was written; 1 a command it
runs failed (named, with the end of its error output); 2 bad input (a folder that is not what it
should be, an unknown ``--only``), one line naming it. Nothing is written unless every section was
made.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import subprocess
import sys
import tempfile
import textwrap
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from drake_disamb.config.schema import PARADIGMS

REPO = Path(__file__).resolve().parents[1]
PUBLISHED = "../shared/data/tnsre2018_simulated_trajectories"
"""The authors' published trials, relative to the repository root (as the page writes them)."""

STUDY_SHOWN, AUTHORS_SHOWN = "out/study", "out/authors"
"""The folder names the page's commands use (the folders given on the command line may be others)."""


class CommandFailed(RuntimeError):
    """A command the page names exited with a non-zero status."""


def command_argv(command: str) -> list[str]:
    """``command`` as the page writes it, as an argument list: ``python`` is this interpreter and
    ``drake-disamb`` this interpreter's ``-m drake_disamb.cli``."""
    argv = shlex.split(command)
    if argv[0] == "python":
        return [sys.executable, *argv[1:]]
    if argv[0] == "drake-disamb":
        return [sys.executable, "-m", "drake_disamb.cli", *argv[1:]]
    raise ValueError(f"command: expected one starting with python or drake-disamb, got {command!r}")


def run_command(command: str) -> str:
    """Run ``command`` from the repository root with this checkout's ``src`` first on the path;
    its standard output. Raises :class:`CommandFailed` on a non-zero exit."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO / "src"), env.get("PYTHONPATH")) if p)
    env["MPLBACKEND"] = "Agg"
    print(f"running: {command}", file=sys.stderr, flush=True)
    proc = subprocess.run(
        command_argv(command), cwd=REPO, env=env, stdin=subprocess.DEVNULL, capture_output=True, text=True
    )
    if proc.returncode != 0:
        tail = (proc.stderr.strip().splitlines() or ["(no error output)"])[-1]
        raise CommandFailed(f"{command}: exit status {proc.returncode}: {tail}")
    return proc.stdout


Runner = Callable[[str], str]

WIDTH = 100
"""The page's prose is wrapped at this width."""


def wrap(text: str) -> str:
    """A paragraph of the page, wrapped at :data:`WIDTH` (code spans and links kept whole)."""
    return textwrap.fill(text, WIDTH, break_long_words=False, break_on_hyphens=False)


@dataclass(frozen=True)
class Benchmark:
    """A section of the page made from one benchmark script's printed figures."""

    key: str
    title: str
    command: str
    about: str

    def section(self, run: Runner) -> str:
        """The section: title, what it measures, the command and what it printed."""
        printed = run(self.command).rstrip()
        return f"## {self.title}\n\n{wrap(self.about)}\n\n```text\n$ {self.command}\n{printed}\n```\n"


BENCHMARKS = {
    b.key: b
    for b in (
        Benchmark(
            "disambiguation",
            "Disambiguation latency",
            "python benchmarks/bench_disambiguation.py",
            "One disambiguation request (validation, the forward projection of every probe, the "
            "features, the scores, the mode) with the `mico` preset, 6 dimensions and the head array's "
            "6 arm modes; the rows run interleaved, so they share the machine's good and slow moments. "
            "The paper's system needed 2 to 2.5 s per request; the target is a median under 1 ms for the "
            "MICO configuration (5 goals).",
        ),
        Benchmark(
            "station",
            "The station",
            "python benchmarks/bench_station.py --time-step 0.01",
            "The MICO station behind its controllers under the station-demo's commanded Cartesian "
            "pattern, one 10 ms SAP step per 100 Hz control tick: simulated seconds per wall second.",
        ),
        Benchmark(
            "safety",
            "Safety: motion off the command",
            "python benchmarks/bench_safety.py",
            "Every single-axis command (translations at +/-0.1 m/s, rotations at +/-0.2 and +/-0.67 "
            "rad/s) held 10 s from five postures on the simulated station: per posture the worst "
            "motion outside the commanded direction in all, its fastest speed, the worst rotation "
            "outside it, and how often each `ik_status` came. The limits are 2 cm and 1 cm/s "
            "([real_arm.md](real_arm.md#safety-the-arm-moves-only-where-it-is-commanded)).",
        ),
        Benchmark(
            "tasks",
            "Closed loop: every goal of both tasks",
            "python benchmarks/bench_tasks.py",
            "Every goal of the reaching task (5 objects) and every (container, location) pair of the "
            "pouring task with both interfaces, one trial each with the embedded deterministic "
            "simulated user on the `mico` system, Disambiguation paradigm, 60 s limit: success, stage "
            "times, mode switches, requests and mean alpha, then per task and interface the success "
            "count and the mean and worst completion time. `tests/test_closed_loop.py` checks the same.",
        ),
        Benchmark(
            "tasks-study",
            "Closed loop on the study's system",
            "python benchmarks/bench_tasks.py --system tnsre2020_study",
            "The same trials on the `tnsre2020_study` system (the study's system as its logs show it, "
            "which the study protocol runs): its DFT constants, the paper's dot-product agreement term, "
            "assistance without input, one belief per task, the loop paused while a request is "
            "computed (here with no request latency).",
        ),
        Benchmark(
            "page",
            "The operator page's latency",
            "python benchmarks/bench_page_latency.py",
            "A simulated head-array user reaching at real time with the operator page open in headless "
            "Chromium (the scene drawn in software): how long a panel state takes from the diagram's "
            "publish to the page's drawing it, and the bound from the change itself (one 20 ms publish "
            "period more). The target is under 100 ms at the 99th percentile "
            "([operator_page.md](operator_page.md#latency)).",
        ),
    )
}


def inference_section(run: Runner) -> str:
    """The paper's inference comparison on the published trials and on 500 generated ones."""
    from drake_disamb.comparison.replay import METHOD_LABELS, PUBLISHED_ACCURACY

    commands = (
        f"drake-disamb inference-benchmark --data {PUBLISHED}",
        "drake-disamb inference-benchmark --generate 500 --seed 0",
    )
    results = []
    with tempfile.TemporaryDirectory(prefix="results_") as tmp:
        for k, command in enumerate(commands):
            path = Path(tmp) / f"inference{k}.json"
            run(f"{command} --quiet --json {shlex.quote(str(path))}")
            results.append(json.loads(path.read_text()))
    published, generated = results
    lines = [
        "## Intent inference: the paper's comparison",
        "",
        wrap(
            "The accuracy is the fraction of samples at which `argmax p` is the true goal, averaged "
            "over trials. The paper's metric counts the zero-input stretch at a trial's end as "
            "correct; the strict metric leaves it out. The paper's figures are its 500 trials. On "
            "the authors' published files the replay gives the numbers of the authors' own code to two "
            "decimals (`tests/test_trials.py` holds them)."
        ),
        "",
        "```bash",
        *commands,
        "```",
        "",
        f"| method | paper | published trials ({published['trials']}) | strict "
        f"| generated trials ({generated['trials']}, seed 0) | strict |",
        "|---|---|---|---|---|---|",
    ]
    for method, label in METHOD_LABELS.items():
        a, b = published["methods"][method], generated["methods"][method]
        lines.append(
            f"| {label} | {100 * PUBLISHED_ACCURACY[method]:.2f} % "
            f"| {100 * a['published_metric']:.2f} % | {100 * a['strict_metric']:.2f} % "
            f"| {100 * b['published_metric']:.2f} % | {100 * b['strict_metric']:.2f} % |"
        )
    return "\n".join(lines) + "\n"


def _rank(order: Sequence[Any], name: str) -> tuple[int, str]:
    """Sort key: ``name``'s place in ``order`` (unknown names last, by name)."""
    return (list(order).index(name), "") if name in order else (len(order), name)


def _number(value: Any, digits: int = 1) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def _interface(name: str) -> str:
    return name.replace("_", " ")


def _load_json(path: Path) -> Any:
    return json.loads(path.read_text(encoding="utf-8"))


def check_study_folders(study: Path | None, authors: Path | None) -> None:
    """Raise ``ValueError`` naming the folder unless ``study`` is a simulated study's folder (its
    ``study.yaml`` and ``trials.jsonl``) and ``authors`` holds records."""
    if study is None or not (study / "study.yaml").is_file() or not (study / "trials.jsonl").is_file():
        raise ValueError(
            f"--study: expected a study folder with study.yaml and trials.jsonl (python "
            f"benchmarks/bench_study.py --seed 0 --out DIR makes one), got {study}"
        )
    if authors is None or not (authors / "trials.jsonl").is_file():
        raise ValueError(
            f"--authors: expected a folder with trials.jsonl (drake-disamb study import-authors "
            f"../shared/data/tnsre2020_human_study --out DIR makes one), got {authors}"
        )


def study_section(study: Path | None, authors: Path | None, run: Runner) -> str:
    """The user study: the means per condition beside the people's, how trials ended, the
    paradigm effect beside the people's; from ``study report``'s JSON."""
    check_study_folders(study, authors)
    run(
        f"drake-disamb study report {shlex.quote(str(study))} --compare {shlex.quote(str(authors))} "
        "--no-mixed-model"
    )
    meta = yaml.safe_load((study / "study.yaml").read_text(encoding="utf-8"))
    protocol = meta.get("protocol") or {}
    report = study / "report"
    tasks = [t.get("task") for t in protocol.get("tasks", [])] if isinstance(protocol, dict) else []
    summary = sorted(
        (r for r in _load_json(report / "summary.json") if r["source"] == "simulated"),
        key=lambda r: (r["interface"], _rank(tasks, r["task"]), _rank(PARADIGMS, r["paradigm"])),
    )
    people = {(r["interface"], r["task"], r["paradigm"]): r for r in _load_json(report / "compare.json")}
    effect = [r for r in _load_json(report / "paradigm_effect.json") if r["task"] == "all"]
    records = [json.loads(line) for line in (study / "trials.jsonl").read_text().splitlines() if line.strip()]
    simulated = sum(r["duration"] for r in records)
    lines = [
        "## The user study",
        "",
        wrap(
            f"The protocol of `study.yaml` (system `{protocol.get('system', '?')}`, "
            f"{len(meta.get('subjects', []))} subjects, seed {meta.get('seed')}, drake-disamb "
            f"{meta.get('version')}): {len(records)} trials, {simulated:.0f} simulated seconds, "
            f"{sum(r['wall_time'] for r in records):.0f} s of the trials' own simulation wall time on "
            "the workers. The people are the 4 published subjects. Made by:"
        ),
        "",
        "```bash",
        f"python benchmarks/bench_study.py --seed 0 --out {STUDY_SHOWN}   "
        f"# or: drake-disamb study run --out {STUDY_SHOWN}",
        f"drake-disamb study import-authors ../shared/data/tnsre2020_human_study --out {AUTHORS_SHOWN}",
        f"drake-disamb study report {STUDY_SHOWN} --compare {AUTHORS_SHOWN} --no-mixed-model",
        "```",
        "",
        wrap(
            "Means per trial over the trials that did not fail (the authors left their failed trials "
            "out of every mean; failures count in the success rate), after the authors' cleaning "
            "(`report/summary.json`), the people's in brackets (`report/compare.json`):"
        ),
        "",
        "| interface, task | paradigm | trials (not failed) | user mode switches | requests "
        "| button presses | completion (s) | success |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in summary:
        key = (r["interface"], r["task"], r["paradigm"])
        other = people.get(key, {})

        def cell(name: str, digits: int = 1, other: dict = other, r: dict = r) -> str:
            mine = _number(r.get(f"mean_{name}"), digits)
            theirs = other.get(f"other_mean_{name}")
            return mine if theirs is None else f"{mine} ({_number(theirs, digits)})"

        success = "-" if r["success_rate"] is None else f"{100 * r['success_rate']:.0f} %"
        lines.append(
            f"| {_interface(r['interface'])}, {r['task']} | {r['paradigm']} | {r['n_trials']} "
            f"({r['n_analysed']}) | {cell('mode_switches')} | {cell('requests')} | "
            f"{cell('button_presses')} | {cell('completion_time')} | {success} |"
        )
    lines += ["", wrap(_success_line(summary)), "", *_effect_table(effect)]
    return "\n".join(lines) + "\n"


def _success_line(summary: Sequence[dict[str, Any]]) -> str:
    """Success per paradigm and how the trials ended, over every condition."""
    known: dict[str, list[float]] = {}
    ends: dict[str, int] = {}
    for r in summary:
        if r["success_rate"] is not None:
            n = known.setdefault(r["paradigm"], [0.0, 0.0])
            n[0] += r["success_rate"] * r["n_success_known"]
            n[1] += r["n_success_known"]
        for reason, count in r["end_reasons"].items():
            ends[reason] = ends.get(reason, 0) + count
    order = sorted(known, key=lambda p: _rank(PARADIGMS, p))
    rates = ", ".join(f"{p} {100 * known[p][0] / known[p][1]:.1f} %" for p in order if known[p][1])
    ended = ", ".join(f"{reason} {count}" for reason, count in sorted(ends.items()))
    return f"Success: {rates}. How the trials ended: {ended}."


METRIC_NAMES = {"button_presses": "button presses", "mode_switches": "user mode switches"}
"""The paradigm effect's metrics as the page names them."""


def _effect_table(effect: Sequence[dict[str, Any]]) -> list[str]:
    """The paradigm effect, both tasks, per interface and metric, beside the people's."""

    def side(r: dict[str, Any], prefix: str) -> str:
        man, dis = r[f"{prefix}mean_manual"], r[f"{prefix}mean_disambiguation"]
        change, p = r[f"{prefix}relative_change"], r[f"{prefix}p_value"]
        if man is None or dis is None:
            return "-"
        text = f"{man:.1f} → {dis:.1f}"
        if change is not None:
            text += f" ({100 * change:+.0f} %"
            text += ")" if p is None else f", p = {p:.2g})"
        return text

    lines = [
        wrap(
            "The paradigm effect, Manual → Disambiguation, both tasks, failed trials left out, "
            "two-sided rank-sum (`report/paradigm_effect.json`); the check: the same direction as the "
            "people's and within a factor of 2:"
        ),
        "",
        "| interface | metric | population | people | check (ratio) |",
        "|---|---|---|---|---|",
    ]
    for r in sorted(effect, key=lambda r: (r["interface"], r["metric"])):
        check = "n/a" if r["check"] is None else ("yes" if r["check"] else "no")
        ratio = "" if r["ratio"] is None else f" ({r['ratio']:.2f})"
        lines.append(
            f"| {_interface(r['interface'])} | {METRIC_NAMES.get(r['metric'], r['metric'])} | {side(r, '')} "
            f"| {side(r, 'other_')} | {check}{ratio} |"
        )
    return lines


HEADER = """# Results

Today's figures, each under the command that measures it; speed figures are the machine's of the
day (each benchmark prints its host's load, steal and speed gauge). This page is written by
`python benchmarks/results.py --study {study} --authors {authors}` (the study folder is an input:
the study section says how it was made); edit the script, not the page. Commit measured:
`{commit}`.

Other benchmarks print figures this page does not carry: `bench_belief_integrator.py` (the belief's
integrator against a fine reference), `bench_loop.py` and `bench_loop_profile.py` (the full loop's
real-time rate and its cost per system), `bench_ik.py` (one IK step), `bench_framework.py` (Drake's
cost per Python system), `bench_inference.py` and `bench_inference_memory.py` (the inference
comparison's time and memory), `bench_hardware_loop.py` (the loop on LCM against `mico-driver`),
`bench_population.py` and `study_spread.py` (the population beside the people; several seeds).
Each script's docstring says how to run it.
"""


def _commit() -> str:
    proc = subprocess.run(
        ["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True, text=True, check=False
    )
    return proc.stdout.strip() or "unknown"


SECTIONS = ("inference", *BENCHMARKS, "study")
"""The page's sections, in order."""


def write_page(
    study: Path | None,
    authors: Path | None,
    out: Path,
    only: Sequence[str] = (),
    run: Runner = run_command,
) -> Path:
    """Make every section (or ``only`` those) and write the page to ``out``; nothing is written if a
    section fails."""
    unknown = sorted(set(only) - set(SECTIONS))
    if unknown:
        raise ValueError(f"--only: expected names among {', '.join(SECTIONS)}, got {', '.join(unknown)}")
    if "study" in (only or SECTIONS):
        check_study_folders(study, authors)
    parts = [HEADER.format(study=STUDY_SHOWN, authors=AUTHORS_SHOWN, commit=_commit())]
    for name in SECTIONS:
        if only and name not in only:
            continue
        if name == "inference":
            parts.append(inference_section(run))
        elif name == "study":
            parts.append(study_section(study, authors, run))
        else:
            parts.append(BENCHMARKS[name].section(run))
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(parts), encoding="utf-8")
    return out


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", type=Path, help="a finished study folder of the protocol")
    parser.add_argument("--authors", type=Path, help="the people's records (study import-authors)")
    parser.add_argument("--out", type=Path, default=REPO / "docs" / "results.md", help="the page to write")
    parser.add_argument(
        "--only", action="append", default=[], metavar="NAME", help=f"sections: {', '.join(SECTIONS)}"
    )
    args = parser.parse_args(argv)
    try:
        path = write_page(args.study, args.authors, args.out, args.only)
    except ValueError as exc:
        print(f"results: {exc}", file=sys.stderr)
        return 2
    except CommandFailed as exc:
        print(f"results: {exc}", file=sys.stderr)
        return 1
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
