"""One job per function: no function of the package is longer than :data:`MAX_LINES` lines (from its
``def`` to its last line, docstring and comments included)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from support import SRC

MAX_LINES = 120
"""The longest a function may be."""

NOT_YET: dict[str, set[str]] = {
    # The station on LCM's assembly: its start checks, systems and wiring in one function.
    "drake_disamb/station/lcm/station.py": {"build_lcm_station"},
}
"""The functions still longer than :data:`MAX_LINES`, by module (relative to ``src``); a test fails
once one of them is short enough, so that it leaves this list."""

MODULES = sorted(str(p.relative_to(SRC)) for p in (SRC / "drake_disamb").rglob("*.py"))
"""Every module of the package, relative to ``src``."""


def function_lengths(path: Path) -> list[tuple[str, int]]:
    """``(qualified name, lines)`` of every function and method in the Python file ``path``."""
    found: list[tuple[str, int]] = []

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                name = f"{prefix}{child.name}"
                if not isinstance(child, ast.ClassDef):
                    assert child.end_lineno is not None
                    found.append((name, child.end_lineno - child.lineno + 1))
                visit(child, f"{name}.")
            else:
                visit(child, prefix)

    visit(ast.parse(path.read_text(encoding="utf-8")), "")
    return found


@pytest.mark.parametrize("module", MODULES)
def test_no_function_is_longer_than_the_limit(module: str) -> None:
    allowed = NOT_YET.get(module, set())
    long = [(name, n) for name, n in function_lengths(SRC / module) if n > MAX_LINES and name not in allowed]
    assert not long, f"{module}: functions over {MAX_LINES} lines: {long}"


@pytest.mark.parametrize("module", sorted(NOT_YET))
def test_a_function_not_yet_split_is_still_long(module: str) -> None:
    lengths = dict(function_lengths(SRC / module))
    short = sorted(name for name in NOT_YET[module] if lengths.get(name, 0) <= MAX_LINES)
    assert not short, f"{module}: {short} are at most {MAX_LINES} lines (or gone): take them out of NOT_YET"


def test_the_length_counts_every_line_of_a_nested_function(tmp_path: Path) -> None:
    path = tmp_path / "m.py"
    lines = ["def outer():", "    def inner():", "        pass", "", "    return inner", "", ""]
    lines += ["class C:", "    def m(self):", "        return 1", ""]
    path.write_text("\n".join(lines))
    assert function_lengths(path) == [("outer", 5), ("outer.inner", 2), ("C.m", 2)]
