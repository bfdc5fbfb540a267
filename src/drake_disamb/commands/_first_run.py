"""Telling people about the one-time compilation of the numerical kernels.

The core's hot loops are numba kernels compiled on first use and cached on disk
(``numba.njit(cache=True)``, see ``drake_disamb/core/_kernels.py``). On a first run, or after a
kernel changed, compiling them takes several seconds of silence. :func:`announce_kernel_compilation`
listens to numba's ``numba:compile`` events, which numba raises only when a kernel is really
compiled (a kernel loaded from the cache raises none), and says so once, before the first one
compiles, and how long it took at the end.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator
from typing import Any

COMPILING = "compiling the numerical kernels (first run only, cached afterwards; about 10 s) ..."
"""The line written before the first kernel compiles."""


class KernelCompilation:
    """What :func:`announce_kernel_compilation` saw: ``count`` top-level compilations, ``seconds``."""

    def __init__(self, write: Callable[[str], None]) -> None:
        self.write = write
        self.count = 0
        self.seconds = 0.0
        self._depth = 0
        self._start = 0.0

    def on_start(self, event: Any) -> None:
        if self._depth == 0:
            if self.count == 0:
                self.write(COMPILING)
            self._start = time.perf_counter()
            self.count += 1
        self._depth += 1

    def on_end(self, event: Any) -> None:
        self._depth = max(0, self._depth - 1)
        if self._depth == 0:
            self.seconds += time.perf_counter() - self._start


@contextlib.contextmanager
def announce_kernel_compilation(write: Callable[[str], None]) -> Iterator[KernelCompilation]:
    """While active, write :data:`COMPILING` before the first numba kernel compiles (nothing when
    every kernel comes from the cache); on leaving, write how long the compilation took.

    Args:
        write: Writes one line (e.g. ``print`` with ``flush=True``); it may be replaced on the yielded
            object (e.g. by a progress display's ``write`` while one is shown).
    """
    from numba.core import event

    class _Listener(event.Listener):
        def on_start(self, ev: Any) -> None:
            seen.on_start(ev)

        def on_end(self, ev: Any) -> None:
            seen.on_end(ev)

    seen = KernelCompilation(write)
    with event.install_listener("numba:compile", _Listener()):
        yield seen
    if seen.count:
        seen.write(f"compiled the kernels in {seen.seconds:.1f} s (cached for the next runs)")
