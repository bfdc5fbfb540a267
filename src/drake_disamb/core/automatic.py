"""The Automatic paradigm's trigger: when the system switches to the disambiguating mode by itself.

The paper's stated future work (its Discussion: "automated mode switching schemes that eliminate
the need for manual button presses altogether") without a design; this is ours. The trigger fires
when, **since the last mode change, the user has been commanding the arm for** ``dwell_time``
**seconds (accumulated) while the belief's largest probability stayed below**
``confidence_threshold``, and **at least** ``min_interval`` **seconds have passed since the last
automatic switch** (the last trigger plus the system's ``request_latency``). A fired trigger
starts the same disambiguation a request press starts (the interface serves it
``request_latency`` later, :func:`drake_disamb.interfaces.interface_update`).

Why each part:

- *Low confidence* (``max p < rho1`` by default): below ``rho1`` the blender gives no assistance
  (alpha = 0), so the user drives alone; that is exactly when the paper's request helps, and
  above it a switch would interrupt assistance that already works.
- *While the user commands*: the belief only moves while the user moves the arm (the DFT relaxes
  towards uniform at rest), so low confidence after a pause says nothing about the mode; and a
  person who is not moving (thinking, resting, at the goal) should not have the mode changed under
  them. Pauses neither count nor reset the clock.
- *Dwell since the last mode change* (1 s by default, the projection's short horizon ``t_b``): a
  mode the user just chose (or the system just gave) deserves a second of motion before it is
  judged uninformative; this is also what keeps the trigger from firing right after the user's own
  mode switch, which would override the user's plan. The clock restarts at every mode change
  (manual, requested or automatic) and whenever the belief's maximum reaches the threshold.
- *At most once per* ``min_interval`` (4 s by default): after a switch the user needs a reaction
  time (about 0.5 to 1 s) and then about the projection's long horizon (``t_c`` = 2 s) of motion
  for the new mode to move the belief; and the paper's system needed 2 to 2.5 s to compute a mode.
  A shorter interval would let the system switch modes faster than a person can use them. The
  interval counts from the switch, not from the trigger: with a latency (the study's system took
  2.5-3.4 s, and paused its loop meanwhile) an interval from the trigger would leave the user
  about a second of control between two automatic switches.

The trigger is pure numpy (:func:`automatic_trigger_update`); the Drake system
:class:`drake_disamb.systems.disambiguation.AutomaticTrigger` holds its state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from drake_disamb.core.validation import bounded_repr, check_real_fields, is_real

COMMAND_THRESHOLD = 1e-9
"""A command counts as given when some entry of ``u_h`` exceeds this (m/s or rad/s), as in the trial's
``mean_alpha``."""

_TOLERANCE = 1e-9
"""Slack (s) on the dwell and interval comparisons: sums of control periods are off by rounding."""


@dataclass(frozen=True)
class AutomaticConfig:
    """The Automatic paradigm's trigger (see the module docstring for why).

    Attributes:
        confidence_threshold: The trigger waits while ``max p`` stays below this (a probability in
            ``(0, 1]``); ``None`` takes the blending threshold ``rho1`` (the scenario's resolver
            writes it out), so the system steps in exactly while the user gets no assistance.
        dwell_time: Seconds (> 0) of the user's commanding, accumulated since the last mode change
            with ``max p`` below the threshold, before the trigger fires.
        min_interval: Seconds (>= 0) from one automatic switch (a trigger plus the request
            latency) to the next trigger at the earliest.
        request_button: Whether the request button keeps working in the Automatic paradigm
            (default true: the user can still ask, and a press is served as in the Disambiguation
            paradigm). False: presses are logged and counted as requests but switch nothing.
    """

    confidence_threshold: float | None = None
    dwell_time: float = 1.0
    min_interval: float = 4.0
    request_button: bool = True

    def __post_init__(self) -> None:
        c = self.confidence_threshold
        if c is not None and not (is_real(c) and 0.0 < c <= 1.0):
            raise ValueError(
                "AutomaticConfig.confidence_threshold: expected a probability in (0, 1], "
                f"got {bounded_repr(c)}"
            )
        check_real_fields(self, ("dwell_time",))
        check_real_fields(self, ("min_interval",), allow_zero=True)
        if not isinstance(self.request_button, bool):
            raise ValueError(
                "AutomaticConfig.request_button: expected true or false, "
                f"got {bounded_repr(self.request_button)}"
            )


@dataclass(frozen=True)
class TriggerState:
    """What the trigger remembers between control ticks.

    Attributes:
        count: Triggers so far.
        dwell: Seconds of commanding with low confidence since the last mode change (or since the
            belief last reached the threshold).
        mode: The mode seen at the last tick (-1 before the first).
        last_trigger: Time (s) of the last trigger (``-inf`` before the first).
    """

    count: int = 0
    dwell: float = 0.0
    mode: int = -1
    last_trigger: float = -math.inf


def automatic_trigger_update(
    state: TriggerState,
    belief: ArrayLike,
    u_h: ArrayLike,
    mode: float,
    time: float,
    period: float,
    config: AutomaticConfig,
    latency: float = 0.0,
) -> tuple[TriggerState, bool]:
    """One control tick of the trigger: ``(new state, fired)``.

    Args:
        state: The state before the tick.
        belief: The belief now (a non-finite belief counts as confident: no trigger on bad data).
        u_h: The user's command now, ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s).
        mode: The interface's mode index now.
        time: The tick's time (s).
        period: The control period (s): what one commanding tick adds to the dwell.
        config: The trigger's settings; ``confidence_threshold`` must be written out (not None).
        latency: Seconds (>= 0) from a trigger to its switch (the interface's ``request_latency``):
            the next trigger comes ``min_interval`` after the switch at the earliest.
    """
    if config.confidence_threshold is None:
        raise ValueError(
            "AutomaticConfig.confidence_threshold: expected a number (resolve it from rho1), got None"
        )
    p = np.asarray(belief, dtype=float)
    m = int(round(mode)) if math.isfinite(mode) else state.mode
    dwell = 0.0 if m != state.mode else state.dwell
    confident = not np.isfinite(p).all() or float(p.max()) >= config.confidence_threshold
    if confident:
        dwell = 0.0
    elif float(np.max(np.abs(u_h))) > COMMAND_THRESHOLD:
        dwell += period
    fired = dwell >= config.dwell_time - _TOLERANCE and time - state.last_trigger >= (
        latency + config.min_interval - _TOLERANCE
    )
    if fired:
        return TriggerState(count=state.count + 1, dwell=0.0, mode=m, last_trigger=float(time)), True
    return TriggerState(count=state.count, dwell=dwell, mode=m, last_trigger=state.last_trigger), False
