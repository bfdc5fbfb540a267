"""Small checks shared by the core's config dataclasses."""

from __future__ import annotations

import math
import numbers


def is_real(value: object) -> bool:
    """True for a finite real number that is not a bool (numpy scalars included)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)
