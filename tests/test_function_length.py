"""One job per function: no function of the package is longer than :data:`MAX_LINES` lines (from its
``def`` to its last line, docstring and comments included)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from support import SRC

MAX_LINES = 120
"""The longest a function may be."""

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
    long = [(name, n) for name, n in function_lengths(SRC / module) if n > MAX_LINES]
    assert not long, f"{module}: functions over {MAX_LINES} lines: {long}"


def test_the_length_counts_every_line_of_a_nested_function(tmp_path: Path) -> None:
    path = tmp_path / "m.py"
    lines = ["def outer():", "    def inner():", "        pass", "", "    return inner", "", ""]
    lines += ["class C:", "    def m(self):", "        return 1", ""]
    path.write_text("\n".join(lines))
    assert function_lengths(path) == [("outer", 5), ("outer.inner", 2), ("C.m", 2)]
