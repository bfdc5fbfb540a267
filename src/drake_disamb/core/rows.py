"""The row layout of the compiled kernels (``core/_kernels.py``), shared by every core module.

A public array function of the core broadcasts its inputs over leading batch axes, lays each one
out as a C-ordered ``(B, *tail)`` array of rows with these helpers, and calls a kernel that loops
over the rows by index. An input without batch axes may stay a single shared row that the kernel
reads for every row (:func:`shared_rows`).
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

__all__ = ["as_rows", "batch_shape", "shared_rows"]


@functools.lru_cache(maxsize=256)
def batch_shape(*shapes: tuple[int, ...]) -> tuple[int, ...]:
    """``np.broadcast_shapes`` (pure Python, slow next to a small step), memoised on the shapes."""
    return np.broadcast_shapes(*shapes)


def as_rows(a: NDArray[np.float64], batch: tuple[int, ...], tail: tuple[int, ...]) -> NDArray[np.float64]:
    """``a`` broadcast to ``batch + tail`` as a C-ordered ``(B, *tail)`` array (the layout of the
    compiled row kernels; no copy when ``a`` already is one)."""
    full = (*batch, *tail)
    if a.shape != full:
        a = np.broadcast_to(a, full)
    return np.ascontiguousarray(a.reshape(-1, *tail))


def shared_rows(a: NDArray[np.float64], batch: tuple[int, ...], tail: tuple[int, ...]) -> NDArray[np.float64]:
    """As :func:`as_rows`, but an ``a`` without batch axes stays one row ``(1, *tail)`` that a
    kernel reads for every row (row index ``r if a.shape[0] > 1 else 0``)."""
    if a.ndim == len(tail):
        return np.ascontiguousarray(a[None])
    return as_rows(a, batch, tail)
