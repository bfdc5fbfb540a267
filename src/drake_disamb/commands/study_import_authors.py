"""``drake-disamb study import-authors DATA_DIR --out DIR``: the authors' human logs as trial records."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

HELP = "Import the authors' published human-study logs (4 of the paper's 8 subjects) as trial records."

EPILOG = """\
Appends one record per trial file (source "authors") to DIR/trials.jsonl and writes its trace to
DIR/traces/<trial_id>.npz; trials already in DIR/trials.jsonl are skipped (nothing is overwritten).
A simulated study's folder (with study.yaml or ablation.json) is refused before anything is
written: it takes only its own trials, so that study run can resume it.
See drake_disamb.study.data.authors for how every field is made.

example (from the repository root):
  drake-disamb study import-authors ../shared/data/tnsre2020_human_study --out out/authors
  drake-disamb study report out/authors
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    parser.add_argument("data_dir", type=Path, metavar="DATA_DIR", help="the tnsre2020_human_study folder")
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="study folder to append to")
    parser.add_argument("--quiet", action="store_true", help="no line per imported trial")


def run(args: argparse.Namespace) -> int:
    from drake_disamb.study.data.authors import import_authors

    def progress(trial_id: str) -> None:
        if not args.quiet:
            print(f"imported {trial_id}", flush=True)

    try:
        summary = import_authors(args.data_dir, args.out, progress=progress)
    except ValueError as err:  # RecordError is a ValueError
        print(f"drake-disamb study import-authors: error: {err}", file=sys.stderr)
        return 2
    print(f"{summary.imported} trials imported, {summary.skipped} already there: {summary.records}")
    return 0
