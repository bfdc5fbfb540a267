"""The layers contract (``[tool.importlinter]`` in pyproject.toml): the package keeps it, and an
upward import (the controller side importing the study among them), Drake in the core, the
inference comparison, the simulated user's policy or an interface's model, a private module
imported from another package or an import circle between sibling packages each break it."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from support import REPO, SRC

LINT = "import sys; from importlinter.cli import lint_imports_command; sys.exit(lint_imports_command())"


def _lint(root: Path, src: Path) -> subprocess.CompletedProcess[str]:
    """``lint-imports`` run in ``root`` (its pyproject.toml) on the package found in ``src``."""
    env = dict(os.environ, PYTHONPATH=str(src))
    return subprocess.run(
        [sys.executable, "-c", LINT, "--no-cache"],
        cwd=root,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_the_package_keeps_its_layers() -> None:
    run = _lint(REPO, SRC)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "broken" not in run.stdout.lower().replace("0 broken", "")


def test_the_numpy_parts_load_without_drake() -> None:
    """What the forbidden contracts check statically, at run time: importing the core, the inference
    comparison, the interfaces' and the simulated user's namespaces (every kind registered) and the
    population loads no pydrake."""
    code = (
        "import sys\n"
        "import drake_disamb.core.disambiguation, drake_disamb.core.inference\n"
        "import drake_disamb.comparison.replay, drake_disamb.comparison.trial_files\n"
        "import drake_disamb.interfaces, drake_disamb.user, drake_disamb.user.population\n"
        "assert len(drake_disamb.interfaces.INTERFACES) == 3, drake_disamb.interfaces.INTERFACES\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('pydrake', 'drake')))\n"
    )
    env = dict(os.environ, PYTHONPATH=str(SRC))
    run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0 and run.stdout.strip() == "[]", run.stdout + run.stderr


@pytest.fixture(scope="module")
def package_copy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the repository's pyproject.toml and of the package's Python files."""
    root = tmp_path_factory.mktemp("layers")
    shutil.copy(REPO / "pyproject.toml", root / "pyproject.toml")
    shutil.copytree(
        SRC / "drake_disamb", root / "src" / "drake_disamb", ignore=shutil.ignore_patterns("__pycache__")
    )
    return root


@pytest.mark.parametrize(
    ("module", "line", "contract", "shown"),
    [
        # The core reaching up to the study (an upward import, and a circle core <-> study).
        (
            "core/layout.py",
            "import drake_disamb.study.data.records",
            "Layers import one way",
            "core.layout -> ",
        ),
        # The builder reaching up to the study (the controller side never imports it).
        (
            "builder.py",
            "import drake_disamb.study.run.outcome",
            "Nothing below the study imports it",
            "study",
        ),
        # The station reaching up to the builder.
        ("station/config.py", "from drake_disamb import builder", "Layers import one way", "builder"),
        # Drake in the numpy core.
        ("core/layout.py", "import pydrake.math", "The core is numpy", "pydrake"),
        ("comparison/replay.py", "import pydrake.math", "The inference comparison is numpy", "pydrake"),
        # Drake in the simulated user's policy, directly and through the package it is read from.
        ("user/policy.py", "import pydrake.math", "The simulated user's policy is numpy", "pydrake"),
        ("user/__init__.py", "from drake_disamb.user import system", "The simulated user's policy", "system"),
        # Drake in an interface's model (a kind's module).
        ("interfaces/kinds/joystick.py", "import pydrake.math", "An interface's model is numpy", "pydrake"),
        # A private module of another package.
        ("builder.py", "from drake_disamb.core import _kernels", "A private module", "_kernels"),
        # Two siblings of one layer (independent) importing each other.
        ("display.py", "import drake_disamb.paths", "Layers import one way", "drake_disamb.paths"),
    ],
)
def test_a_forbidden_import_breaks_the_contract(
    package_copy: Path, module: str, line: str, contract: str, shown: str
) -> None:
    path = package_copy / "src" / "drake_disamb" / module
    original = path.read_text()
    path.write_text(original + f"\n{line}  # injected by tests/test_layers.py\n")
    try:
        run = _lint(package_copy, package_copy / "src")
    finally:
        path.write_text(original)
    assert run.returncode != 0, run.stdout
    broken = run.stdout.split("Broken contracts", 1)[-1]
    assert contract in broken and shown in broken, run.stdout
