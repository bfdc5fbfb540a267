"""``drake-disamb inference-benchmark``: the paper's inference comparison (DFT, Bayes, memory)."""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

from drake_disamb.commands._outputs import check_output_file
from drake_disamb.commands._signals import EXIT_INTERRUPTED

MAX_GENERATED = 1_000_000
"""Largest ``--generate``: about 1.5 h of work and 48 MB of per-trial scores (more is refused)."""

HELP = "Compare DFT, recursive Bayes and memory-based intent inference on simulated trials."

DESCRIPTION = """\
Replays simulated teleoperation trials (docs/facts.md section 3) through the three inference methods and
prints, per method, the paper's accuracy metric (the zeroed-input stretch counts as correct) and
the strict metric (that stretch excluded), mean and standard deviation over trials.

Trials come either from the authors' published files (--data DIR, one trajectory_N.mat per trial)
or from our seeded generator with the same protocol (--generate N --seed S). The replay uses the
authors' discretisation (explicit Euler at each file's delta_t, clip and renormalise) and
parameters (tau1 = tau2 = 10 s, lambda = 200 I, each trial's transition matrix P).

Trials are streamed in chunks of 500 (generate or load, replay, score, drop), so memory does not
grow with N; generated trial i depends only on the seed and i (--generate 100 gives the first 100
trials of --generate 500). --generate takes at most 1000000 trials. MATLAB v7.3 (HDF5) files are
not supported: re-save them as v7. --json and --plot are checked before any work.

Exit status: 0 on success, 2 on bad input (missing/malformed files, bad options, unusable output
paths), 1 out of memory, 130 stopped by Ctrl-C.
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the sub-command's options."""
    parser.description = HELP + "\n\n" + DESCRIPTION
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    source = parser.add_mutually_exclusive_group()
    source.add_argument("--data", metavar="DIR", help="Folder of the authors' trajectory_N.mat files.")
    source.add_argument(
        "--generate", metavar="N", type=int, help="Generate N trials with our seeded generator (default 500)."
    )
    parser.add_argument("--seed", type=int, default=0, help="Generator seed (default 0).")
    parser.add_argument("--limit", type=int, default=None, help="Use at most this many files from --data.")
    parser.add_argument("--json", metavar="PATH", help="Write the summary as JSON to PATH.")
    parser.add_argument(
        "--plot",
        metavar="PATH",
        help="Draw the accuracy distributions and one example trial's goal probabilities to PATH.",
    )
    parser.add_argument(
        "--example", type=int, default=0, help="Index of the trial drawn in --plot (default 0)."
    )
    parser.add_argument("--quiet", action="store_true", help="No progress bars.")


def _summary(scores: dict[str, dict[str, Any]]) -> dict[str, dict[str, float]]:
    import numpy as np

    out = {}
    for m, s in scores.items():
        pub, strict = np.asarray(s["published"]), np.asarray(s["strict"])
        strict_ok = strict[np.isfinite(strict)]
        out[m] = {
            "published_metric": float(pub.mean()),
            "published_std": float(pub.std()),
            "strict_metric": float(strict_ok.mean()) if strict_ok.size else math.nan,
            "strict_std": float(strict_ok.std()) if strict_ok.size else math.nan,
        }
    return out


def format_table(summary: dict[str, dict[str, float]], n_trials: int, source: str) -> str:
    """The printed comparison table (percent, mean +/- standard deviation over trials)."""
    from drake_disamb.comparison.replay import METHOD_LABELS, PUBLISHED_ACCURACY

    lines = [
        f"Intent inference accuracy over {n_trials} trials ({source})",
        f"{'method':<18}{'paper metric %':>22}{'strict metric %':>22}{'paper reports %':>18}",
    ]
    for m, s in summary.items():
        lines.append(
            f"{METHOD_LABELS[m]:<18}"
            f"{100 * s['published_metric']:>13.2f} +/- {100 * s['published_std']:5.2f}"
            f"{100 * s['strict_metric']:>13.2f} +/- {100 * s['strict_std']:5.2f}"
            f"{100 * PUBLISHED_ACCURACY[m]:>18.2f}"
        )
    lines.append(
        "paper metric: zeroed-input stretch counted as correct (authors' sentinel); strict: excluded."
    )
    lines.append("paper reports: the paper's 500 trials, paper metric.")
    return "\n".join(lines)


def plot_comparison(trial, beliefs, scores, example: int, path: str | Path) -> None:  # noqa: ANN001
    """The paper's inference-comparison figure: accuracy distributions and one example trial.

    Args:
        trial: The example :class:`~drake_disamb.comparison.trials.Trial` (number ``example``).
        beliefs: Its beliefs, ``{method: (L + 1, n)}``.
        scores: Every trial's scores, ``{method: {"published": (N,), "strict": (N,)}}``.
        example: The example's index (for the title).
        path: The image file to write.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from drake_disamb.comparison.replay import METHOD_LABELS, METHODS
    from drake_disamb.plotting import GOAL_COLORS

    n_trials = len(next(iter(scores.values()))["published"])
    tr = trial
    fig = plt.figure(figsize=(13, 7.5))
    grid = fig.add_gridspec(2, 3, height_ratios=[1.0, 1.0])
    ax = fig.add_subplot(grid[0, :])
    data, labels, positions = [], [], []
    for k, m in enumerate(METHODS):
        for j, metric in enumerate(("published", "strict")):
            values = np.asarray(scores[m][metric])
            data.append(100 * values[np.isfinite(values)])
            labels.append(f"{METHOD_LABELS[m]}\n{'paper' if metric == 'published' else 'strict'}")
            positions.append(3 * k + j)
    parts = ax.boxplot(data, positions=positions, widths=0.7, patch_artist=True, showmeans=True)
    for j, box in enumerate(parts["boxes"]):
        box.set_facecolor("#9ecae1" if j % 2 == 0 else "#fdd0a2")
    ax.set_xticks(positions, labels, fontsize=8)
    ax.set_ylabel("inference accuracy (%)")
    ax.set_ylim(0, 105)
    ax.grid(axis="y", alpha=0.3)
    ax.set_title(f"Goal inference accuracy over {n_trials} trials (paper metric and strict metric)")

    t = np.arange(tr.n_steps + 1)
    for k, m in enumerate(METHODS):
        axk = fig.add_subplot(grid[1, k])
        b = beliefs[m]
        for g in range(tr.n_goals):
            axk.plot(t, b[:, g], color=GOAL_COLORS[g % len(GOAL_COLORS)], lw=1.5, label=f"goal {g + 1}")
        axk.axvspan(tr.zeroed_start, tr.zeroed_stop - 1, color="0.85", zorder=0, label="zero input")
        truth = tr.true_goal
        axk.scatter(
            t, np.full_like(t, -0.04, dtype=float), c=[GOAL_COLORS[g] for g in truth], s=2, marker="s"
        )
        axk.set_ylim(-0.08, 1.02)
        axk.set_xlabel("time step")
        axk.set_title(f"{METHOD_LABELS[m]}", fontsize=10)
        if k == 0:
            axk.set_ylabel("goal probability (true goal: strip)")
            axk.legend(fontsize=7, loc="upper right")
    fig.suptitle(f"Example trial {example} ({Path(tr.source).name if tr.source else ''})", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _check_plot_path(path: str) -> None:
    """``--plot`` must be writable and name an image format matplotlib can write."""
    check_output_file(path, "--plot")
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.backend_bases import FigureCanvasBase

    formats = FigureCanvasBase.get_supported_filetypes()
    suffix = Path(path).suffix.lower().lstrip(".")
    if suffix not in formats:
        got = f".{suffix}" if suffix else "no extension"
        raise ValueError(
            f"--plot: {path}: expected a file name ending in one of "
            f"{', '.join('.' + f for f in sorted(formats))}, got {got}"
        )


def run(args: argparse.Namespace) -> int:
    """Load or generate the trials, replay, print the table, write --json and --plot.

    0 on success, 2 on bad input, 1 out of memory, 130 on Ctrl-C.
    """
    try:
        return _run(args)
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except MemoryError:
        print("error: out of memory (fewer trials with --generate or --limit need less)", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def _run(args: argparse.Namespace) -> int:
    from drake_disamb.comparison.replay import score_trial_stream
    from drake_disamb.comparison.trial_files import iter_loaded_chunks, trial_paths
    from drake_disamb.comparison.trials import chunk_seed, iter_generated_chunks

    progress = not args.quiet and sys.stderr.isatty()
    if args.generate is not None and not 1 <= args.generate <= MAX_GENERATED:
        raise ValueError(
            f"--generate: expected a number of trials in [1, {MAX_GENERATED}], got {args.generate}"
        )
    if args.limit is not None and args.limit < 1:
        raise ValueError(f"--limit: expected a positive number of trials, got {args.limit}")
    if args.json:
        check_output_file(args.json, "--json")
    if args.plot:
        _check_plot_path(args.plot)
    start = time.perf_counter()
    if args.data is not None:
        files = trial_paths(args.data, limit=args.limit)
        n = len(files)
        chunks = iter_loaded_chunks(files, progress=progress)
        source = f"published files in {args.data}"
    else:
        n = 500 if args.generate is None else args.generate
        try:
            chunk_seed(args.seed, 0)  # a bad seed is an error before any work
        except ValueError:
            raise ValueError(f"--seed: expected an integer >= 0, got {args.seed}") from None
        chunks = iter_generated_chunks(n, seed=args.seed, progress=progress)
        source = f"generated, seed {args.seed}"
    if args.plot and not 0 <= args.example < n:
        raise ValueError(f"--example: expected a trial index in [0, {n - 1}], got {args.example}")
    streamed = score_trial_stream(chunks, keep=args.example if args.plot else None, progress=progress)
    scores, n_trials = streamed.scores, streamed.n_trials
    elapsed = time.perf_counter() - start
    summary = _summary(scores)
    print(format_table(summary, n_trials, source))
    print(f"(loading/generating and replaying took {elapsed:.2f} s)")
    if args.json:
        payload = {
            "methods": summary,
            "trials": n_trials,
            "source": source,
            "per_trial": {m: {k: v.tolist() for k, v in s.items()} for m, s in scores.items()},
        }
        Path(args.json).write_text(json.dumps(payload, indent=2, allow_nan=True))
        print(f"wrote {args.json}")
    if args.plot:
        plot_comparison(streamed.example, streamed.example_beliefs, scores, args.example, args.plot)
        print(f"wrote {args.plot}")
    return 0
