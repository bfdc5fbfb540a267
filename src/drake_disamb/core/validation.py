"""Input checks and input bounds shared by every layer.

Used by the core's config dataclasses, the scenario and station configs and the systems' port checks.

Error messages format values with :func:`bounded_repr`, never with a bare ``repr()``: a value read
from a file can be huge (a long string, a YAML structure expanded from aliases, an integer with
thousands of digits) and its full ``repr`` can take minutes or raise.
"""

from __future__ import annotations

import dataclasses
import math
import numbers

import numpy as np
from numpy.typing import NDArray

from drake_disamb.core._kernels import _all_finite_flat

TIME_STEP_RANGE: tuple[float, float] = (1e-3, 0.1)
"""Accepted range (s) of a control period or a plant time step, bounds included. Below 1 ms a 60 s
trial takes hours of wall time (``control_period: 1e-6`` is sixty million ticks); above 100 ms the
100 Hz velocity interface of the MICO is sampled too coarsely for the joint PD to track it."""

MAX_GOALS: int = 100
"""Most goals a scenario (all stages together) or a disambiguation request may have. The study's
tasks have 4 and 5; the bound only keeps absurd input out (a request's cost grows with the goal
count, a scenario's goals are bodies in the plant)."""


def is_real(value: object) -> bool:
    """True for a finite real number that is not a bool (numpy scalars included).

    An integer too large for a float (``10**400``) is not finite here: it is False, not an error.
    """
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an int beyond the float range
        return False


def check_real_fields(config: object, names: tuple[str, ...], allow_zero: bool = False) -> None:
    """Raise ``ValueError`` naming ``Class.field`` and the value unless each field is a finite real > 0.

    With ``allow_zero`` the bound is ``>= 0``. Used by the ``__post_init__`` of config dataclasses.
    """
    for name in names:
        value = getattr(config, name)
        if not (is_real(value) and (value >= 0 if allow_zero else value > 0)):
            bound = ">= 0" if allow_zero else "> 0"
            raise ValueError(
                f"{type(config).__name__}.{name}: expected a finite number {bound}, got {bounded_repr(value)}"
            )


def all_finite(*arrays: NDArray[np.float64]) -> bool:
    """True if every entry of every array is finite.

    Float64 numpy arrays go through a compiled loop (a control tick checks a few small arrays
    several times, where numpy's ``isfinite(a).all()`` costs more than the check itself);
    anything else (other dtypes, lists, scalars) through ``np.isfinite(a).all()``. Unlike a sum,
    neither overflows, so huge finite values (a command of 1e308) raise no numpy
    ``RuntimeWarning`` at every tick.
    """
    for a in arrays:
        if type(a) is np.ndarray and a.dtype == _FLOAT:
            if not _all_finite_flat(a.ravel()):
                return False
        elif not _isfinite(a).all():
            return False
    return True


_FLOAT = np.dtype(np.float64)
_isfinite = np.isfinite


def check_real_range(value: object, path: str, low: float, high: float, unit: str = "") -> float:
    """Return ``value`` as a float if it is a finite real in ``[low, high]``; else raise ``ValueError``.

    The message names ``path`` and the value, e.g.
    ``scenario.control_period: expected a finite number in [0.001, 0.1] s, got 1e-06``.
    """
    if not (is_real(value) and low <= value <= high):  # type: ignore[operator]
        suffix = f" {unit}" if unit else ""
        raise ValueError(
            f"{path}: expected a finite number in [{low:g}, {high:g}]{suffix}, got {bounded_repr(value)}"
        )
    return float(value)  # type: ignore[arg-type]


class _Full(Exception):
    """Raised inside :func:`bounded_repr` once the text is long enough."""


_MAX_REPR_DEPTH = 32


def bounded_repr(value: object, limit: int = 200) -> str:
    """``repr(value)``, cut to at most ``limit`` characters, at a cost bounded by ``limit``.

    Lists, tuples, dicts, sets, numpy arrays and dataclass instances are walked item by item and the
    walk stops once ``limit`` characters are written, so a structure that shares its parts (a YAML
    alias bomb: billions of leaves from a few kilobytes) or contains itself costs no more than a
    short one. Strings and bytes are cut before ``repr``; an integer with more digits than ``limit``
    is summarised (Python refuses to print one beyond 4300 digits). Nesting deeper than 32 levels
    shows as ``...``. For short values the result equals ``repr(value)``.
    """
    out: list[str] = []
    room = [limit + 1]  # one extra character tells whether the text had to be cut

    def emit(text: str) -> None:
        out.append(text[: room[0]])
        room[0] -= len(text)
        if room[0] <= 0:
            raise _Full

    def walk(v: object, depth: int) -> None:
        if depth > _MAX_REPR_DEPTH:
            emit("...")
        elif isinstance(v, str | bytes | bytearray):
            emit(repr(v[: limit + 1]))
        elif isinstance(v, int) and not isinstance(v, bool) and v.bit_length() > 3.33 * limit:
            digits = int(v.bit_length() * 0.30103) + 1
            emit(f"<{'negative ' if v < 0 else ''}integer of about {digits} digits>")
        elif isinstance(v, np.ndarray) and v.ndim > 0:  # shown like its tolist()
            emit("[")
            for i, item in enumerate(v):
                emit(", " if i else "")
                walk(item.item() if isinstance(item, np.generic) else item, depth + 1)
            emit("]")
        elif isinstance(v, list | tuple | set | frozenset) and type(v) in (list, tuple, set, frozenset):
            if isinstance(v, set | frozenset) and not v:
                emit(f"{type(v).__name__}()")
                return
            opening, closing = {list: "[]", tuple: "()"}.get(type(v), "{}")
            emit(opening if type(v) is not frozenset else "frozenset({")
            for i, item in enumerate(v):
                emit(", " if i else "")
                walk(item, depth + 1)
            emit("," if type(v) is tuple and len(v) == 1 else "")
            emit(closing if type(v) is not frozenset else "})")
        elif type(v) is dict:
            emit("{")
            for i, (key, item) in enumerate(v.items()):
                emit(", " if i else "")
                walk(key, depth + 1)
                emit(": ")
                walk(item, depth + 1)
            emit("}")
        elif dataclasses.is_dataclass(v) and not isinstance(v, type):
            emit(f"{type(v).__name__}(")
            for i, f in enumerate(f for f in dataclasses.fields(v) if f.repr):
                emit(f"{', ' if i else ''}{f.name}=")
                walk(getattr(v, f.name), depth + 1)
            emit(")")
        else:
            emit(repr(v))

    try:
        walk(value, 0)
    except _Full:
        pass
    text = "".join(out)
    return text if len(text) <= limit else text[: max(limit - 3, 0)] + "..."
