"""What operating an interface takes: the raw signals that drive, change the mode and request.

:class:`Affordances` is the part of an interface variant
(:class:`~drake_disamb.interfaces.registry.Interface`) that the simulated user reads to operate
it as a person would, and that the live page turns a person's clicks into: the inverse of the
device model (:mod:`~drake_disamb.interfaces.device`), from what to do to the raw signal that does
it.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import ClassVar

from drake_disamb.interfaces.device import MODE_BUTTON, RAW_SIZE, REQUEST_BUTTON


class Affordances(ABC):
    """The raw signals that operate one kind of interface: a part of its variant, mixed with its
    :class:`~drake_disamb.interfaces.device.Device` (whose ``name`` and ``mode_steps`` it reads)."""

    name: ClassVar[str]

    @abstractmethod
    def drive_raw(self, drives: Sequence[float]) -> list[float]:
        """A raw signal that drives the mode's dimensions by ``drives`` (in ``[-1, 1]``; a switched
        kind drives at full speed in each drive's direction)."""

    def is_driving(self, raw: Sequence[float]) -> bool:
        """Whether a raw signal drives the arm (default: entry 0 or 1 on, the mode button off)."""
        return bool((raw[0] != 0.0 or raw[1] != 0.0) and raw[MODE_BUTTON] == 0.0)

    def step_raw(self, step: int) -> list[float]:
        """The raw signal of one mode change in direction ``step`` (+1 / -1), held one decision
        and then released (default: the mode button; forward only)."""
        if step < 0:
            raise ValueError(f"{self.name}: mode changes only step forward, got step {step!r}")
        raw = [0.0] * RAW_SIZE
        raw[MODE_BUTTON] = 1.0
        return raw

    def change_raw(self, mode: int, target: int, selection: str = "cycle") -> list[float]:
        """The raw signal of the next mode change from ``mode`` toward ``target`` (the shorter way
        round where the kind steps back)."""
        return self.step_raw(-1 if self.mode_steps(mode, target, selection) < 0 else 1)

    def request_raw(self) -> list[float]:
        """The raw signal of a disambiguation request (the request button)."""
        raw = [0.0] * RAW_SIZE
        raw[REQUEST_BUTTON] = 1.0
        return raw


__all__ = ["Affordances"]
