"""The sip-and-puff: one breath tube read as hard and soft puffs and sips, and a request switch.

The paper names sip-and-puffs beside switch-based head arrays as the interfaces of the people with
the most severe motor impairments (Section I); its study did not use one. A sip-and-puff sends
signals by air pressure: sipping (inhaling) on the tube gives a negative pressure, puffing
(exhaling) a positive one, and the device tells *hard* from *soft* sips and puffs by pressure
levels set for each user in a calibration (the four-command sip-and-puff of powered wheelchairs:
hard puff and hard sip drive forward and backward, soft puffs and sips steer; see the Wikipedia
article "Sip-and-puff", sections "Calibration and setup" and "Motorized wheelchair control").

**Mapping** (the same four commands on the arm's control modes):

- *hard puff* / *hard sip* drive the mode's one dimension positive / negative at a fixed speed,
  for as long as the breath is held (the wheelchair's forward / backward along its one driven
  axis);
- *soft puff* / *soft sip* step to the next / previous mode (the wheelchair's soft commands pick
  the direction, here the dimension).

Why: driving needs a sustained and unmistakable signal, and a hard breath held well past its
threshold is that, while a mode change is a brief discrete event, which a short soft breath is;
puff is positive and forward for both, one sign convention; and stepping back as well as forward
halves the longest mode change (3 steps instead of 6 through the 7 modes). A soft breath is read
when it ends (the pressure back at rest), as the breath's peak: a hard breath passes through the
soft band on its way up and down and so is never also a mode change, and a soft breath changes
the mode once however long it lasts. A breath that turns from puff to sip without rest starts a
new breath. The disambiguation request is a separate switch (every interface of the paper's
system has its own request button), e.g. a chin or head switch.

Modes: ``vx, vy, vz, wx, wy, wz, gripper`` (the default :attr:`SipAndPuff.mode_order`: one
dimension at a time, as on the head array); in the gripper mode a hard puff opens, a hard sip
closes. Speeds: 0.1 m/s and 0.2 rad/s, the head array's (a switched interface at one speed).

Raw signal ``[pressure, unused_1, unused_2, disambiguation_button]``: ``pressure`` in ``[-1, 1]``
of the calibrated full scale (positive puff, negative sip; clipped), hard at
``|pressure| >= hard_threshold``, soft at ``soft_threshold <= |pressure| < hard_threshold``, at rest
below; the request switch 0/1 (``>= button_threshold`` pressed). The sanitised signal holds the
breath's class in its first entry (-2 hard sip, -1 soft sip, 0 rest, 1 soft puff, 2 hard puff).

The simulated user operates it through this raw signal as a person would: a full puff or sip
(``pressure`` +/-1) to drive, a soft breath (between the thresholds) for one decision and then
rest to change mode, the shorter way round the cycle.

Live page: ArrowUp / ArrowDown are the hard puff / hard sip (a key press holds the breath for
``LiveInputConfig.hold_time``, so a held key drives continuously), ArrowRight / ArrowLeft the soft
puff / soft sip (next / previous mode), Space the request switch.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from drake_disamb.core.validation import is_real
from drake_disamb.interfaces.device import RAW_SIZE, REQUEST_BUTTON, sign
from drake_disamb.interfaces.live_controls import LiveControl
from drake_disamb.interfaces.registry import Interface, register


@register
@dataclass(frozen=True)
class SipAndPuff(Interface):
    """The sip-and-puff (module docstring).

    Attributes:
        soft_threshold: The smallest ``|pressure|`` (of full scale) that is a soft breath.
        hard_threshold: The smallest ``|pressure|`` that is a hard breath (above ``soft_threshold``).
    """

    name = "sip_and_puff"
    label = "Sip-and-puff"
    rank = 2
    raw_layout = ("pressure", "unused_1", "unused_2", "disambiguation_button")
    default_speeds = (0.1, 0.2)
    steps_back = True
    live_controls = (
        LiveControl("Hard puff: + [ArrowUp]", "ArrowUp", "drive+"),
        LiveControl("Hard sip: - [ArrowDown]", "ArrowDown", "drive-"),
        LiveControl("Soft puff: next mode [ArrowRight]", "ArrowRight", "next"),
        LiveControl("Soft sip: previous mode [ArrowLeft]", "ArrowLeft", "previous"),
        LiveControl("Request disambiguation [Space]", "Space", "request"),
    )
    live_help = (
        "Live: drive from the operator page (click into it first) or a gamepad (the D-pad as the\n"
        "arrow keys, button A as Space). Hold Up (hard puff, +) or Down\n"
        "(hard sip, -) to drive the mode's dimension (a tap drives it for 0.6 s); Right (soft puff)\n"
        "and Left (soft sip) step to the next and previous mode, Space asks the robot for the\n"
        "disambiguating mode. The trial ends at the goal given by --goal (default 0), after\n"
        "--duration, or when you press Ctrl-C here (the metrics, figure and recording so far are kept)."
    )

    mode_order: tuple[tuple[int, ...], ...] = ((0,), (1,), (2,), (3,), (4,), (5,))
    soft_threshold: float = 0.2
    hard_threshold: float = 0.6

    def __post_init__(self) -> None:
        super().__post_init__()
        soft, hard = self.soft_threshold, self.hard_threshold
        if not (is_real(soft) and is_real(hard) and 0.0 < soft < hard <= 1.0):
            raise ValueError(
                "SipAndPuff.soft_threshold, hard_threshold: expected 0 < soft < hard <= 1, "
                f"got {soft!r} and {hard!r}"
            )

    def breath(self, pressure: float) -> float:
        """The class of a pressure: -2 hard sip, -1 soft sip, 0 rest, 1 soft puff, 2 hard puff."""
        size = abs(pressure)
        if size >= self.hard_threshold:
            return 2.0 * sign(pressure)
        if size >= self.soft_threshold:
            return sign(pressure)
        return 0.0

    def sanitize(self, values: list[float], threshold: float) -> list[float]:
        pressure = min(max(values[0], -1.0), 1.0)
        return [self.breath(pressure), 0.0, 0.0, 1.0 if values[REQUEST_BUTTON] >= threshold else 0.0]

    def mode_event(self, clean: list[float], memory: float) -> tuple[int, float]:
        """The memory is the current breath's peak class; a soft breath steps the mode when it
        ends (rest again), a hard one never does."""
        now = clean[0]
        if now == 0.0:
            return (int(memory) if abs(memory) == 1.0 else 0), 0.0
        if memory == 0.0 or sign(now) != sign(memory):
            return 0, now  # a new breath
        return 0, sign(now) * max(abs(now), abs(memory))

    def drives(self, clean: Sequence[float], n_dims: int) -> list[float]:
        return [sign(clean[0]) if abs(clean[0]) == 2.0 else 0.0] * n_dims

    def drive_raw(self, drives: Sequence[float]) -> list[float]:
        raw = [0.0] * RAW_SIZE
        raw[0] = sign(float(drives[0]))  # a full puff or sip
        return raw

    def is_driving(self, raw: Sequence[float]) -> bool:
        return abs(raw[0]) >= self.hard_threshold

    def step_raw(self, step: int) -> list[float]:
        """A soft puff (forward) or soft sip (back), midway between the thresholds."""
        raw = [0.0] * RAW_SIZE
        raw[0] = sign(step) * 0.5 * (self.soft_threshold + self.hard_threshold)
        return raw


__all__ = ["SipAndPuff"]
