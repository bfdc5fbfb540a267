"""The live page's controls of an interface: its buttons, their keys and what each does.

:class:`LiveControls` is the part of an interface variant
(:class:`~drake_disamb.interfaces.registry.Interface`) that the live page
(:class:`~drake_disamb.interfaces.live.MeshcatLiveInput`) reads: the buttons it adds (each with its
key and role), whether it adds axis sliders, the help ``demo --live`` prints, and the raw signal of
a one-period pulse (a mode step or a request, the :mod:`~drake_disamb.interfaces.affordances`
signals).
"""

from __future__ import annotations

from abc import ABC
from dataclasses import dataclass
from typing import ClassVar, Literal

LiveRole = Literal["drive+", "drive-", "center", "next", "previous", "request", ""]
"""What a live-page button does: hold the mode's dimension driven positive / negative (switched
kinds), re-centre the axis sliders (proportional kinds), one step to the next / previous mode, a
disambiguation request, or nothing (a placeholder that adds no button)."""

LIVE_PULSES: tuple[LiveRole, ...] = ("next", "previous", "request")
"""The live roles that are one-period pulses (a press, then a release)."""


@dataclass(frozen=True)
class LiveControl:
    """One button of the live page.

    Attributes:
        label: The button's text on the page (its key in brackets).
        keycode: The browser ``KeyboardEvent.code`` that clicks it.
        role: What a click does (:data:`LiveRole`).
    """

    label: str
    keycode: str
    role: LiveRole


class LiveControls(ABC):
    """The live page's controls of one kind of interface: a part of its variant, mixed with its
    :class:`~drake_disamb.interfaces.affordances.Affordances` (whose ``step_raw`` and
    ``request_raw`` make its pulses).

    Class attributes (the same for every instance of a kind):
        live_controls: The live page's buttons, one per raw entry where one applies.
        live_axes: Whether the live page adds axis sliders (and reads a gamepad's stick).
        live_help: What ``demo --live`` prints before the trial.
    """

    live_controls: ClassVar[tuple[LiveControl, ...]]
    live_axes: ClassVar[bool] = False
    live_help: ClassVar[str]

    def pulse_raw(self, role: LiveRole) -> list[float]:
        """The raw signal of a live pulse (:data:`LIVE_PULSES`)."""
        if role == "request":
            return self.request_raw()
        return self.step_raw(1 if role == "next" else -1)


__all__ = ["LIVE_PULSES", "LiveControl", "LiveControls", "LiveRole"]
