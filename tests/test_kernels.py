"""House rules for the compiled kernels (see CONTRIBUTING: Compiled kernels)."""

from __future__ import annotations

import ast
from pathlib import Path

import drake_disamb

PACKAGE = Path(drake_disamb.__file__).parent


def _njit_functions(path: Path) -> list[tuple[str, bool]]:
    """``(name, cached)`` of every function decorated with numba's ``njit`` in ``path``."""
    found = []
    for node in ast.walk(ast.parse(path.read_text())):
        if not isinstance(node, ast.FunctionDef):
            continue
        for d in node.decorator_list:
            func = d.func if isinstance(d, ast.Call) else d
            if isinstance(func, ast.Name) and func.id == "njit":
                cached = isinstance(d, ast.Call) and any(
                    k.arg == "cache" and isinstance(k.value, ast.Constant) and k.value.value is True
                    for k in d.keywords
                )
                found.append((node.name, cached))
    return found


def test_every_kernel_lives_in_the_kernels_module_and_is_cached() -> None:
    """numba's cache is keyed on a kernel's own file: kernels calling kernels of another file could
    run a stale copy after an edit, so all of them live in core/_kernels.py."""
    kernels = PACKAGE / "core" / "_kernels.py"
    outside = {
        str(p.relative_to(PACKAGE)): _njit_functions(p)
        for p in PACKAGE.rglob("*.py")
        if p != kernels and _njit_functions(p)
    }
    assert outside == {}
    inside = _njit_functions(kernels)
    assert len(inside) >= 20
    assert [name for name, cached in inside if not cached] == []
