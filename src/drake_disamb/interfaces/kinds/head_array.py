"""The switch-based head array: three switches in a headrest and a request button.

The study's head array (paper Section "Study Methods"): the *back* switch cycles through 7 modes
``vx, vy, vz, wx, wy, wz, gripper`` (the default :attr:`HeadArray.mode_order`); *left* / *right*
drive the selected dimension in the positive / negative direction at a fixed speed, 0.1 m/s or
0.2 rad/s (the study's logs, docs/facts.md section 6).

Raw signal ``[left, right, back, disambiguation_button]``, every entry a 0/1 switch level (a level
``>= button_threshold`` counts as closed). ``left - right`` drives the selected dimension (both
closed cancel).

Live page: the Left / Right arrow keys close the left / right switch (a key press keeps it closed
for ``LiveInputConfig.hold_time``, so a held key drives continuously), Down is the back switch,
Space the request.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from drake_disamb.interfaces.device import RAW_SIZE
from drake_disamb.interfaces.live_controls import LiveControl
from drake_disamb.interfaces.registry import Interface, register


@register
@dataclass(frozen=True)
class HeadArray(Interface):
    """The 3-switch head array (module docstring)."""

    name = "head_array"
    label = "Head array"
    rank = 1
    raw_layout = ("left", "right", "back", "disambiguation_button")
    default_speeds = (0.1, 0.2)
    live_controls = (
        LiveControl("Left switch: + [ArrowLeft]", "ArrowLeft", "drive+"),
        LiveControl("Right switch: - [ArrowRight]", "ArrowRight", "drive-"),
        LiveControl("Back switch: next mode [ArrowDown]", "ArrowDown", "next"),
        LiveControl("Request disambiguation [Space]", "Space", "request"),
    )
    live_help = (
        "Live: drive from the operator page (click into it first) or a gamepad (the D-pad as the\n"
        "arrow keys, button A as Space). Hold the Left (+) or Right (-)\n"
        "arrow key to drive the mode's dimension (a tap drives it for 0.6 s); Down switches to the\n"
        "next mode, Space asks the robot for the disambiguating mode. The trial ends at the goal\n"
        "given by --goal (default 0), after --duration, or when you press Ctrl-C here (the metrics,\n"
        "figure and recording so far are kept)."
    )

    mode_order: tuple[tuple[int, ...], ...] = ((0,), (1,), (2,), (3,), (4,), (5,))

    def sanitize(self, values: list[float], threshold: float) -> list[float]:
        return [1.0 if v >= threshold else 0.0 for v in values]

    def drives(self, clean: Sequence[float], n_dims: int) -> list[float]:
        return [clean[0] - clean[1]] * n_dims

    def drive_raw(self, drives: Sequence[float]) -> list[float]:
        raw = [0.0] * RAW_SIZE
        if drives[0] > 0:
            raw[0] = 1.0
        elif drives[0] < 0:
            raw[1] = 1.0
        return raw


__all__ = ["HeadArray"]
