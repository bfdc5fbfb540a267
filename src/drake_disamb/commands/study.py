"""``drake-disamb study``: the user study, one sub-command per module (``study run``, ...).

Each module in :data:`STUDY_COMMANDS` defines ``HELP``, ``add_arguments(parser)`` and
``run(args) -> int``, like the top-level commands, and imports pydrake lazily.

The study needs the ``study`` extra (:mod:`drake_disamb.extras`): without it every ``study``
sub-command but those of :data:`WITHOUT_EXTRA` prints one line naming the extra and exits with
status 2 before it reads or makes anything (``--help`` still works).
"""

from __future__ import annotations

import argparse
import importlib

from drake_disamb.commands.study_run import error
from drake_disamb.extras import MissingExtra, require

HELP = (
    "Run the user study with simulated users or with people (sessions at the operator page), import the "
    "authors' human logs, and report on them."
)

# ``study`` sub-command name -> module in drake_disamb.commands.
STUDY_COMMANDS: dict[str, str] = {
    "run": "study_run",
    "ablate": "study_ablate",
    "rerun": "study_rerun",
    "session": "study_session",
    "report": "study_report",
    "import-authors": "study_import_authors",
    "calibrate": "study_calibrate",
    "identify": "study_identify",
}

WITHOUT_EXTRA = frozenset({"session"})
"""Sub-commands that run without the ``study`` extra: a session with a person is the operator page
with a schedule and a questionnaire (neither Dask nor statsmodels), so a lab's machine at the arm
needs only the base install; the report on its records needs the extra."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="study_command", metavar="STUDY_COMMAND", required=True)
    for name, module_name in STUDY_COMMANDS.items():
        module = importlib.import_module(f"drake_disamb.commands.{module_name}")
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.set_defaults(_study_run=module.run)


def run(args: argparse.Namespace) -> int:
    if args.study_command not in WITHOUT_EXTRA:
        try:
            require("study")
        except MissingExtra as exc:
            return error(args.study_command, exc)
    return int(args._study_run(args) or 0)
