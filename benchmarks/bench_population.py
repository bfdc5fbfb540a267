"""The simulated population beside the people: mean user mode switches, requests and completion time
per interface, task and paradigm (a check of the calibration, not a fit). Means over the trials
that succeeded (the authors left their failed trials out of every mean); success over all.

Runs ``--trials`` trials per condition (interface x task x paradigm) with subjects drawn by
:func:`drake_disamb.user.population.draw_subjects`, each with a random intended goal and initial
mode, through :func:`drake_disamb.trial.run_trial` (the embedded reaching and pouring scenarios,
``duration`` raised to ``--duration``, the joystick's mode selection the study protocol's
``interface_mode_selection``), and prints their means beside the means of the authors'
logs (:func:`drake_disamb.study.measures.metrics.summarize` of
:func:`drake_disamb.study.data.authors.read_trials`, the authors' metric definitions) and the ratio
simulated / human; the last column adds the people's median tail (last command to the end of the
trial, which the experimenter stopped) to the simulated time. A simulated population is accepted when
every ratio is within 0.5..1.5.

    python benchmarks/bench_population.py [--trials 2] [--duration 180] [--seed 0] [--jsonl FILE]

Results stream to ``--jsonl`` (one line per trial) so a long run can be read while it goes.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from drake_disamb.config import load_scenario
from drake_disamb.interfaces import interface_modes
from drake_disamb.study.data.authors import read_trials
from drake_disamb.study.design.protocol import default_protocol
from drake_disamb.study.measures.calibration import estimate_behaviour
from drake_disamb.study.measures.metrics import summarize
from drake_disamb.trial import run_trial
from drake_disamb.user.population import draw_subjects

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "tnsre2020_human_study"
CONDITIONS = [
    (itf, task, par)
    for itf in ("joystick", "head_array")
    for task in ("reaching", "pouring")
    for par in ("manual", "disambiguation")
]


def run_one(itf: str, task: str, par: str, subject, seed: int) -> dict:
    rng = np.random.default_rng([seed, 7])
    base = load_scenario(task)
    goals = [int(rng.integers(len(base.stage_goals(k)))) for k in range(base.n_stages)]
    n_modes = len(interface_modes(itf))
    s = load_scenario(
        task,
        {
            "interface": itf,
            "paradigm": par,
            "seed": seed,
            "user": {"goals": goals, "config": dict(subject.user)},
            "interface_mode_selection": default_protocol().interface_mode_selection,
            "duration": ARGS.duration,
            "initial_mode": int(rng.integers(n_modes)),
        },
    )
    r = run_trial(s, progress=False)
    return {
        "interface": itf,
        "task": task,
        "paradigm": par,
        "subject": subject.name,
        "seed": seed,
        "success": r.success,
        "done": r.done,
        "completion_time": r.time,
        "mode_switches": r.mode_switches,
        "requests": r.requests,
        "wall_time": r.wall_time,
    }


def main() -> int:
    global ARGS
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=2, help="trials per condition")
    p.add_argument("--duration", type=float, default=180.0, help="trial duration limit (s)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--subjects", type=int, default=8)
    p.add_argument("--jsonl", type=Path, default=None, help="append each trial's result here")
    p.add_argument("--from-jsonl", type=Path, default=None, help="only print the table of a finished run")
    ARGS = p.parse_args()
    rows = []
    if ARGS.from_jsonl is not None:
        rows = [json.loads(line) for line in ARGS.from_jsonl.read_text().splitlines() if line.strip()]
    else:
        subjects = draw_subjects(ARGS.subjects, ARGS.seed)
        k = 0
        start = time.perf_counter()
        for r in range(ARGS.trials):
            for c, (itf, task, par) in enumerate(CONDITIONS):
                subject = subjects[(c + 3 * r) % len(subjects)]  # each condition meets other subjects
                row = run_one(itf, task, par, subject, ARGS.seed * 1000 + k)
                k += 1
                rows.append(row)
                print(json.dumps(row), flush=True)
                if ARGS.jsonl is not None:
                    with ARGS.jsonl.open("a") as f:
                        f.write(json.dumps(row) + "\n")
        print(f"{len(rows)} trials in {time.perf_counter() - start:.0f} s wall", file=sys.stderr)
    human, tail = {}, 0.0
    if DATA.is_dir():
        trials = read_trials(DATA)
        human = {(r["interface"], r["task"], r["paradigm"]): r for r in summarize([t.record for t in trials])}
        tail = estimate_behaviour(trials).tail.median
    else:
        print(f"(no human logs at {DATA}: simulated means only)")
    print(
        f"{'interface':<11} {'task':<9} {'paradigm':<15} {'n':>3} {'succ':>5} | "
        f"{'switches sim/hum':>17} {'requests sim/hum':>17} {'time sim/hum':>17} {'time+tail':>9}"
    )
    for itf, task, par in CONDITIONS:
        rs = [r for r in rows if (r["interface"], r["task"], r["paradigm"]) == (itf, task, par)]
        if not rs:
            continue
        h = human.get((itf, task, par), {})
        ok = [r for r in rs if r["success"]]  # the means leave failed trials out, as the authors did
        cells = []
        for key in ("mode_switches", "requests", "completion_time"):
            sim = float(np.mean([r[key] for r in ok])) if ok else float("nan")
            hum = h.get(f"mean_{key}", float("nan"))
            ratio = sim / hum if hum else float("nan")
            cells.append(f"{sim:6.1f}/{hum:5.1f} ({ratio:4.2f})")
        succ = np.mean([r["success"] for r in rs])
        hum_time = h.get("mean_completion_time", float("nan"))
        with_tail = (np.mean([r["completion_time"] for r in ok]) + tail) / hum_time if ok else float("nan")
        print(
            f"{itf:<11} {task:<9} {par:<15} {len(rs):>3} {succ:>5.2f} | "
            + " ".join(cells)
            + f" ({with_tail:4.2f})"
        )
    if tail:
        print(
            f"time+tail: the simulated time plus the people's median {tail:.1f} s from their last command "
            "to the end of the trial (the experimenter's stop; a simulated trial ends on success)"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
