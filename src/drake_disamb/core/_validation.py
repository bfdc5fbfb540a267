"""Small checks shared by the core's config dataclasses."""

from __future__ import annotations

import math
import numbers

import numpy as np
from numpy.typing import NDArray


def is_real(value: object) -> bool:
    """True for a finite real number that is not a bool (numpy scalars included)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool) and math.isfinite(value)


def check_real_fields(config: object, names: tuple[str, ...], allow_zero: bool = False) -> None:
    """Raise ``ValueError`` naming ``Class.field`` and the value unless each field is a finite real > 0.

    With ``allow_zero`` the bound is ``>= 0``. Used by the ``__post_init__`` of config dataclasses.
    """
    for name in names:
        value = getattr(config, name)
        if not (is_real(value) and (value >= 0 if allow_zero else value > 0)):
            bound = ">= 0" if allow_zero else "> 0"
            raise ValueError(
                f"{type(config).__name__}.{name}: expected a finite number {bound}, got {value!r}"
            )


def all_finite(*arrays: NDArray[np.float64]) -> bool:
    """True if every entry of every array is finite.

    One reduction per array decides the common all-finite case: a finite sum of the entries means
    none is NaN or infinite; only a sum that is not finite (a bad entry, or finite entries whose
    sum overflows) takes the exact per-entry check.
    """
    if math.isfinite(sum(float(np.add.reduce(a, axis=None)) for a in arrays)):
        return True
    return all(bool(np.isfinite(a).all()) for a in arrays)
