"""The compact text tables ``study report --compare`` prints: columns aligned, in groups."""

from __future__ import annotations

import math
from collections.abc import Sequence

__all__ = ["MISSING", "grouped_table", "number"]

MISSING = "-"
"""A table's cell without a value."""


def number(v: float | None, digits: int = 2) -> str:
    """``v`` with ``digits`` decimals, or :data:`MISSING` for None, NaN or an infinity."""
    return MISSING if v is None or not math.isfinite(v) else f"{v:.{digits}f}"


def grouped_table(header: Sequence[str], body: Sequence[Sequence[str]], groups: Sequence[int]) -> list[str]:
    """``header`` and ``body`` as aligned lines: the columns in groups of the given sizes (which
    add up to the number of columns), the first group's left-aligned (the labels) and the others'
    right-aligned, two spaces between columns and `` | `` between groups."""
    if sum(groups) != len(header):
        raise ValueError(
            f"groups: {list(groups)} add up to {sum(groups)}, the header has {len(header)} columns"
        )
    width = [max(len(x) for x in col) for col in zip(header, *body, strict=True)]
    bounds = [sum(groups[:k]) for k in range(len(groups) + 1)]

    def line(values: Sequence[str]) -> str:
        parts = [
            v.ljust(w) if i < groups[0] else v.rjust(w)
            for i, (v, w) in enumerate(zip(values, width, strict=True))
        ]
        return " | ".join("  ".join(parts[a:b]) for a, b in zip(bounds, bounds[1:], strict=False))

    return [line(header), *(line(b) for b in body)]
