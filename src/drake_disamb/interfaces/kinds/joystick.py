"""The 2-axis joystick: two proportional axes, a mode button and a request button.

The study's joystick (paper Section "Study Methods"): continuous axes in ``[-1, 1]``, a mode button
that cycles through 5 control modes ``{vx, vy}, {vx, vz}, {wx, wz}, {wy}, gripper`` (the default
:attr:`Joystick.mode_order`), or, with ``InterfaceConfig.mode_selection = "direct"``, selects one
directly. Speeds at full deflection: 0.13 m/s and 0.4 rad/s (the study's logs, docs/facts.md
section 6).

Raw signal ``[axis_x, axis_y, mode_button, disambiguation_button]``: axes clipped to ``[-1, 1]``,
buttons 0/1 (a level ``>= button_threshold`` counts as pressed). The k-th dimension of the current
mode is driven by the k-th axis (a one-dimensional mode and the gripper mode use ``axis_x``).

**Direct selection** (``"direct"``): the study's joystick selected a mode with one action
(consecutive logged modes step forward, back, two or three places about equally, and some repeat
the mode: docs/facts.md section 6), so here a press *with the stick deflected* (``|(axis_x, axis_y)| >=``
:data:`DIRECT_SELECT_DEFLECTION`) selects the mode of the stick direction's sector, and a press
with the stick centred cycles as before. The ``n`` modes have equal sectors of ``360 / n``
degrees, clockwise like a clock face from straight up (``+axis_y``): mode ``k``'s sector is
centred on the compass bearing ``k * 360 / n`` (:func:`sector_mode`, :func:`sector_stick`). For
the 5 default modes, 72 degrees each: ``{vx, vy}`` up (bearing 0), ``{vx, vz}`` up-right (72),
``{wx, wz}`` down-right (144), ``{wy}`` down-left (216), gripper up-left (288). Every press is
one logged ``mode_switch``, also a press that selects the current mode (the mode is kept: the
study's logs hold such repeats). While the mode button is held the stick selects and does not
drive: the held signal's axes are 0 then.

Live page: two axis sliders (keys A/D and S/W), C re-centres them, M is the mode button, Space the
request; a browser gamepad's left stick and buttons 0 / 1 take over when connected.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from drake_disamb.interfaces.device import RAW_SIZE
from drake_disamb.interfaces.live_controls import LiveControl
from drake_disamb.interfaces.registry import Interface, register

DIRECT_SELECT_DEFLECTION = 0.5
"""Stick deflection (norm of ``(axis_x, axis_y)``, of full deflection 1) from which a mode-button
press selects the sector's mode (``mode_selection = "direct"``); below it the press cycles."""


def sector_mode(axis_x: float, axis_y: float, n_modes: int) -> int | None:
    """The mode whose stick sector ``(axis_x, axis_y)`` points into, or ``None`` when the stick is
    centred (deflection below :data:`DIRECT_SELECT_DEFLECTION`).

    ``n_modes`` equal sectors, clockwise from straight up (``+axis_y``): mode ``k`` is centred on
    the bearing ``k * 360 / n_modes`` degrees (a boundary goes to the next mode clockwise).
    """
    if math.hypot(axis_x, axis_y) < DIRECT_SELECT_DEFLECTION:
        return None
    bearing = math.atan2(axis_x, axis_y) % (2.0 * math.pi)  # clockwise from +axis_y
    width = 2.0 * math.pi / int(n_modes)
    return int(math.floor(bearing / width + 0.5)) % int(n_modes)


def sector_stick(mode: int, n_modes: int) -> tuple[float, float]:
    """The full-deflection stick ``(axis_x, axis_y)`` at the centre of mode ``mode``'s sector (the
    inverse of :func:`sector_mode`)."""
    bearing = 2.0 * math.pi * int(mode) / int(n_modes)
    return math.sin(bearing), math.cos(bearing)


@register
@dataclass(frozen=True)
class Joystick(Interface):
    """The 2-axis joystick (module docstring)."""

    name = "joystick"
    label = "Joystick"
    rank = 0
    raw_layout = ("axis_x", "axis_y", "mode_button", "disambiguation_button")
    default_speeds = (0.13, 0.4)
    axes = 2
    proportional = True
    mode_selections = ("cycle", "direct")
    clean_repeated_switches = True
    live_controls = (
        LiveControl("Center the axes [KeyC]", "KeyC", "center"),
        LiveControl("", "", ""),
        LiveControl("Mode button [KeyM]", "KeyM", "next"),
        LiveControl("Request disambiguation [Space]", "Space", "request"),
    )
    live_axes = True
    live_help = (
        "Live: drive from the operator page (click into it first) or plug in a gamepad. A/D and S/W\n"
        "step the two axes, C centres them, M switches mode, Space asks the robot for the\n"
        "disambiguating mode. The trial ends at the goal given by --goal (default 0), after --duration,\n"
        "or when you press Ctrl-C here (the metrics, figure and recording so far are kept)."
    )

    mode_order: tuple[tuple[int, ...], ...] = ((0, 1), (0, 2), (3, 5), (4,))

    def sanitize(self, values: list[float], threshold: float) -> list[float]:
        a, b, c, d = values
        return [
            min(max(a, -1.0), 1.0),
            min(max(b, -1.0), 1.0),
            1.0 if c >= threshold else 0.0,
            1.0 if d >= threshold else 0.0,
        ]

    def select(self, mode: int, step: int, clean: list[float], selection: str) -> int:
        """The next mode (``"cycle"``, or a centred stick), or the stick sector's mode (``"direct"``,
        the stick deflected; possibly ``mode`` itself)."""
        n = len(self.modes)
        if selection == "direct":
            chosen = sector_mode(clean[0], clean[1], n)
            if chosen is not None:
                return chosen
        return (int(mode) + step) % n

    def held(self, clean: list[float], memory: float, selection: str) -> list[float]:
        if selection == "direct" and memory > 0.5:
            clean[0] = clean[1] = 0.0  # a held mode button: the stick selects, it does not drive
        return clean

    def drives(self, clean: Sequence[float], n_dims: int) -> list[float]:
        return list(clean[:n_dims])

    def drive_raw(self, drives: Sequence[float]) -> list[float]:
        raw = [0.0] * RAW_SIZE
        for k, drive in enumerate(drives[:2]):
            raw[k] = min(max(float(drive), -1.0), 1.0)
        return raw

    def change_raw(self, mode: int, target: int, selection: str = "cycle") -> list[float]:
        raw = self.step_raw(1)
        if selection == "direct":  # the stick into the target's sector, then the press
            raw[0], raw[1] = sector_stick(target, len(self.modes))
        return raw


__all__ = ["DIRECT_SELECT_DEFLECTION", "Joystick", "sector_mode", "sector_stick"]
