"""Live input from the Meshcat page: a person drives the interface from a browser.

:class:`MeshcatLiveInput` adds controls to the Meshcat page (on-page buttons with keyboard
shortcuts, sliders, and the browser's Gamepad API) and turns them into the interface's raw signal
(its ``raw_layout``), the same port a simulated user or a recorded log drives. Every kind lists its
page's buttons, their keys and what each does (its
:class:`~drake_disamb.interfaces.live_controls.LiveControls`, roles
:data:`~drake_disamb.interfaces.LiveRole`) and the raw signals that drive, step the mode and
request (``drive_raw``, ``pulse_raw``); this module knows no kind by name. The mapping from what
the page reports to the raw signal is the pure function :func:`live_raw_step`, tested without a
browser. The same system reads the operator page
(:class:`~drake_disamb.operator_page.server.OperatorPage`, which offers Meshcat's controls API):
:func:`page_live_input` makes one there.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pydrake.systems.framework import Context, DiscreteValues, EventStatus, LeafSystem

from drake_disamb.core.validation import check_real_fields, is_real
from drake_disamb.interfaces import INTERFACES, LIVE_PULSES, RAW_SIZE, InterfaceConfig, check_kind

__all__ = [
    "AXIS_SLIDERS",
    "LIVE_BUTTONS",
    "PAD_BUTTON_OF_KEY",
    "PAD_BUTTON_OF_ROLE",
    "LiveInputConfig",
    "LiveState",
    "MeshcatLiveInput",
    "live_raw_step",
    "pad_buttons",
    "page_live_input",
]

LIVE_BUTTONS = 6
"""Most buttons a kind's live page may have (the length of :attr:`LiveState.clicks`)."""

AXIS_SLIDERS: tuple[tuple[str, str, str], ...] = (
    ("Axis x [KeyA / KeyD]", "KeyA", "KeyD"),
    ("Axis y [KeyS / KeyW]", "KeyS", "KeyW"),
)
"""Axis sliders ``(name, decrement keycode, increment keycode)``, each in ``[-1, 1]``, of a kind with
``live_axes`` (the joystick)."""

PAD_BUTTON_OF_KEY: dict[str, int] = {
    "ArrowUp": 12,
    "ArrowDown": 13,
    "ArrowLeft": 14,
    "ArrowRight": 15,
    "Space": 0,
}
"""A kind without ``live_axes`` (the head array, the sip-and-puff) on a gamepad: the button, in the
browser's standard gamepad mapping, that stands for each key: the D-pad for the arrow keys, the
bottom face button (A on most pads) for the space bar."""

PAD_BUTTON_OF_ROLE: dict[str, int] = {"next": 0, "request": 1}
"""A kind with ``live_axes`` (the joystick) on a gamepad: the left stick is the axes, button 0 the
mode button and button 1 the request."""


def pad_buttons(kind: str) -> tuple[int | None, ...]:
    """The gamepad button that presses each of the kind's ``live_controls``, in their order
    (``None``: none): :data:`PAD_BUTTON_OF_ROLE` by role for a kind with ``live_axes``, else
    :data:`PAD_BUTTON_OF_KEY` by key."""
    variant = INTERFACES[check_kind(kind)]
    if variant.live_axes:
        return tuple(PAD_BUTTON_OF_ROLE.get(c.role) for c in variant.live_controls)
    return tuple(PAD_BUTTON_OF_KEY.get(c.keycode) if c.label else None for c in variant.live_controls)


@dataclass(frozen=True)
class LiveInputConfig:
    """How page events become raw signals.

    Attributes:
        hold_time: Seconds a click (or key press) on a drive button (head-array Left/Right switch)
            keeps it closed; another press extends it. The Meshcat page counts every keydown, the
            browser's auto-repeats of a held key included (checked in Chromium 156), and this is
            longer than the usual auto-repeat delay (about 0.5 s), so a held key drives
            continuously. A press on the other direction opens the first at once.
        slider_step: Step (of the full deflection 1) of the axis sliders and their keys.
        dead_zone: Gamepad stick deflections below this read as 0.
    """

    hold_time: float = 0.6
    slider_step: float = 0.25
    dead_zone: float = 0.1

    def __post_init__(self) -> None:
        check_real_fields(self, ("hold_time", "slider_step"))
        if not (is_real(self.dead_zone) and 0 <= self.dead_zone < 1):
            raise ValueError(
                f"LiveInputConfig.dead_zone: expected a number in [0, 1), got {self.dead_zone!r}"
            )


@dataclass(frozen=True)
class LiveState:
    """What the live input remembers between control ticks.

    Attributes:
        clicks: Button click counts already seen, in the kind's ``live_controls`` order
            (:data:`LIVE_BUTTONS`, zeros past the kind's buttons).
        pending: Pulses not yet passed on, per :data:`~drake_disamb.interfaces.LIVE_PULSES`
            (next mode, previous mode, request): a pulse lasts one control period and is followed
            by a release, so clicks closer than two periods queue.
        hold_until: Time (s) until which the positive and negative drive buttons stay closed (2).
        pad_buttons: Whether the gamepad button of each live control (:func:`pad_buttons`) was
            pressed at the last tick (:data:`LIVE_BUTTONS`; rising edges count).
        raw: The raw signal of the last tick (4).
    """

    clicks: NDArray[np.float64] = field(default_factory=lambda: np.zeros(LIVE_BUTTONS))
    pending: NDArray[np.float64] = field(default_factory=lambda: np.zeros(len(LIVE_PULSES)))
    hold_until: NDArray[np.float64] = field(default_factory=lambda: np.full(2, -np.inf))
    pad_buttons: NDArray[np.float64] = field(default_factory=lambda: np.zeros(LIVE_BUTTONS))
    raw: NDArray[np.float64] = field(default_factory=lambda: np.zeros(RAW_SIZE))

    VECTOR_SIZE = LIVE_BUTTONS + len(LIVE_PULSES) + 2 + LIVE_BUTTONS + RAW_SIZE

    def to_vector(self) -> NDArray[np.float64]:
        """Flat ``[clicks (6), pending (3), hold_until (2), pad_buttons (6), raw (4)]``."""
        return np.concatenate([self.clicks, self.pending, self.hold_until, self.pad_buttons, self.raw])

    @classmethod
    def from_vector(cls, x: NDArray[np.float64]) -> LiveState:
        """Inverse of :meth:`to_vector`."""
        v = np.asarray(x, dtype=float)
        if v.shape != (cls.VECTOR_SIZE,):
            raise ValueError(f"LiveState vector: expected {cls.VECTOR_SIZE} numbers, got {v.shape}")
        b, p = LIVE_BUTTONS, LIVE_BUTTONS + len(LIVE_PULSES)
        q = p + 2 + LIVE_BUTTONS
        return cls(v[:b].copy(), v[b:p].copy(), v[p : p + 2].copy(), v[p + 2 : q].copy(), v[q:].copy())


def _dead_zone(value: float, dead_zone: float) -> float:
    if not math.isfinite(value) or abs(value) < dead_zone:
        return 0.0
    return max(-1.0, min(1.0, value))


def live_raw_step(
    state: LiveState,
    time: float,
    kind: str,
    clicks: NDArray[np.float64],
    axes: tuple[float, float] = (0.0, 0.0),
    pad: Sequence[float] | NDArray[np.float64] = (),
    config: LiveInputConfig | None = None,
) -> LiveState:
    """One control tick: the page's click counts, the gamepad's buttons (and, for a kind with
    ``live_axes``, the axes) to the next state, whose ``raw`` is the interface's raw signal.

    Drive buttons (roles ``drive+`` / ``drive-``) stay closed for ``config.hold_time`` after a
    click (a click on the other direction opens the first at once); their gamepad buttons drive
    while pressed and no longer (both directions pressed: neither); the axes drive a kind with
    ``live_axes``. A pulse (next / previous mode, request) is the kind's ``pulse_raw`` for one
    period, made only while its raw entries were and are otherwise at rest, and followed by a
    period with them at rest, so each click, and each press of its gamepad button, is one mode
    event or request.

    Args:
        state: The state after the previous tick.
        time: Current time (s).
        kind: A registered interface name.
        clicks: Cumulative click counts of the kind's ``live_controls`` buttons, in their order.
        axes: ``(axis_x, axis_y)`` in ``[-1, 1]`` (non-finite reads as 0).
        pad: The level in ``[0, 1]`` of each live control's gamepad button (:func:`pad_buttons`),
            in the same order (pressed at ``>= 0.5``; missing entries: released).
        config: Timing and dead zone.
    """
    cfg = LiveInputConfig() if config is None else config
    variant = INTERFACES[check_kind(kind)]
    controls = variant.live_controls
    counts = _per_control(clicks, "clicks", kind, len(controls))
    levels = (_per_control(pad, "pad", kind, len(controls)) >= 0.5).astype(float)
    new = np.maximum(counts - state.clicks, 0.0)  # a count never decreases; guard anyway
    rising = levels > state.pad_buttons
    pending = state.pending.copy()
    hold = state.hold_until.copy()
    pad_drive = [0.0, 0.0]
    for i, control in enumerate(controls):
        if control.role in LIVE_PULSES:
            pending[LIVE_PULSES.index(control.role)] += new[i] + float(rising[i])
        elif control.role in ("drive+", "drive-"):
            j = 0 if control.role == "drive+" else 1
            if new[i] > 0:
                hold[j] = time + cfg.hold_time
            if new[i] > 0 or rising[i]:
                hold[1 - j] = -np.inf
            pad_drive[j] = levels[i]
    if variant.live_axes:
        drives = [_dead_zone(float(axes[0]), 0.0), _dead_zone(float(axes[1]), 0.0)]
    else:
        closed = [float(time < hold[j] or pad_drive[j] > 0) for j in (0, 1)]
        drives = [closed[0] - closed[1]]
    raw = _with_pulses(variant, np.array(variant.drive_raw(drives), dtype=float), state.raw, pending)
    return LiveState(clicks=counts, pending=pending, hold_until=hold, pad_buttons=levels, raw=raw)


def _per_control(values: Any, name: str, kind: str, n_controls: int) -> NDArray[np.float64]:
    """``values`` (one per live control, at most ``n_controls``) padded with zeros to
    :data:`LIVE_BUTTONS`; non-finite reads as 0."""
    given = np.nan_to_num(np.asarray(values, dtype=float).reshape(-1), nan=0.0, posinf=0.0, neginf=0.0)
    if given.size > n_controls:
        raise ValueError(f"{name}: expected at most {n_controls} values for {kind}, got {given.tolist()}")
    out = np.zeros(LIVE_BUTTONS)
    out[: given.size] = given
    return out


def _with_pulses(
    variant: Any, raw: NDArray[np.float64], before: NDArray[np.float64], pending: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``raw`` with the pending pulses made (``pending`` counts down) and the period after a pulse
    at rest (:func:`live_raw_step`)."""
    for k, role in enumerate(LIVE_PULSES):
        if pending[k] <= 0:
            continue
        pulse = np.asarray(variant.pulse_raw(role), dtype=float)
        entries = pulse != 0.0
        if np.all(before[entries] == 0.0) and np.all(raw[entries] == 0.0):
            raw[entries] = pulse[entries]
            pending[k] -= 1
    for role in LIVE_PULSES:  # the period after a pulse: its entries at rest (a release)
        if role == "previous" and not any(c.role == "previous" for c in variant.live_controls):
            continue
        pulse = np.asarray(variant.pulse_raw(role), dtype=float)
        entries = pulse != 0.0
        if np.all(before[entries] == pulse[entries]):
            raw[entries] = 0.0
    return raw


class MeshcatLiveInput(LeafSystem):
    """The interface's raw signal from a person at the Meshcat page (buttons, keys, sliders, gamepad).

    .. pydrake_system::

        name: MeshcatLiveInput
        output_ports:
        - raw

    Output ports:
        raw (4): the interface's raw signal (in its ``raw_layout``), computed at the last update
            and held (no direct feedthrough).

    Controls it adds to the page: the kind's ``live_controls`` buttons and, for a kind with
    ``live_axes``, :data:`AXIS_SLIDERS`. Every kind also takes a browser gamepad
    (:func:`pad_buttons`). The study's two kinds:

    - head array: buttons Left, Right (drive the mode's dimension +/-; each click or key press
      keeps the switch closed for ``config.hold_time``, so a held key drives continuously), Back
      (next mode) and Request, on the arrow keys and the space bar; on a gamepad the D-pad is the
      arrow keys (a D-pad direction drives while held) and button 0 (A) the space bar
      (:data:`PAD_BUTTON_OF_KEY`; the sip-and-puff alike);
    - joystick: two axis sliders in ``[-1, 1]`` (keys A/D and S/W step them), a button that
      re-centres them (C), Mode (M) and Request (space). A browser gamepad, when one is connected,
      takes over: left stick for the axes (up is +y), buttons 0 and 1 for mode and request.
      The axes go out with the Mode press, so with ``interface.mode_selection == "direct"`` a
      person sets the sliders (or the stick) into a mode's sector and presses Mode to select it,
      and re-centres them (C) to cycle (:mod:`drake_disamb.interfaces.kinds.joystick`); no extra control.

    State: discrete :class:`LiveState` vector, updated every ``interface.control_period`` from
    t = 0; the page is read in that update. Run the simulator at real time (rate 1) so the person
    sees what they drive. :meth:`remove_controls` takes the controls off the page.

    Args:
        meshcat: The Meshcat instance whose page the person uses.
        interface: The interface being driven (its kind and control period).
        config: Timing and dead zone.
    """

    def __init__(
        self, meshcat: Any, interface: InterfaceConfig, config: LiveInputConfig | None = None
    ) -> None:
        super().__init__()
        if not isinstance(interface, InterfaceConfig):
            raise ValueError(f"interface: expected an InterfaceConfig, got {interface!r}")
        self.meshcat = meshcat
        self.interface = interface
        self.config = LiveInputConfig() if config is None else config
        self._variant = INTERFACES[interface.kind]
        self._buttons = [control.label for control in self._variant.live_controls]
        self._centre = [k for k, c in enumerate(self._variant.live_controls) if c.role == "center"]
        self._pad = pad_buttons(interface.kind)
        for control in self._variant.live_controls:
            if control.label:
                meshcat.AddButton(control.label, control.keycode)
        self._sliders: list[str] = []
        if self._variant.live_axes:
            for name, down, up in AXIS_SLIDERS:
                meshcat.AddSlider(name, -1.0, 1.0, self.config.slider_step, 0.0, down, up)
                self._sliders.append(name)
        self._state_index = self.DeclareDiscreteState(LiveState().to_vector())
        self._raw_index = self.DeclareDiscreteState(np.zeros(RAW_SIZE))
        self.DeclarePeriodicDiscreteUpdateEvent(interface.control_period, 0.0, self._update)
        self.DeclareStateOutputPort("raw", self._raw_index)

    def remove_controls(self) -> None:
        """Delete the buttons and sliders this system added to the page."""
        for name in self._buttons:
            if name:
                self.meshcat.DeleteButton(name, strict=False)
        for name in self._sliders:
            self.meshcat.DeleteSlider(name, strict=False)

    def _read_page(self) -> tuple[NDArray[np.float64], tuple[float, float], NDArray[np.float64]]:
        """``(clicks, axes, pad)``: the buttons' click counts, the axes (the gamepad's stick when one
        is connected, else the sliders; a kind with ``live_axes`` only) and each live control's
        gamepad button level (:func:`pad_buttons`; zeros without a gamepad)."""
        m = self.meshcat
        clicks = np.array([float(m.GetButtonClicks(name)) if name else 0.0 for name in self._buttons])
        axes = (0.0, 0.0)
        pad = np.zeros(len(self._buttons))
        gamepad = m.GetGamepad()
        connected = gamepad.index is not None
        if connected:
            values = list(gamepad.button_values)
            pad = np.array([values[b] if b is not None and b < len(values) else 0.0 for b in self._pad])
        if self._variant.live_axes:
            if connected and len(gamepad.axes) >= 2:
                dz = self.config.dead_zone
                axes = (_dead_zone(gamepad.axes[0], dz), _dead_zone(-gamepad.axes[1], dz))  # up is +y
            else:
                axes = (m.GetSliderValue(self._sliders[0]), m.GetSliderValue(self._sliders[1]))
        return clicks, axes, pad

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        before = LiveState.from_vector(context.get_discrete_state(self._state_index).get_value())
        clicks, axes, pad = self._read_page()
        after = live_raw_step(before, context.get_time(), self.interface.kind, clicks, axes, pad, self.config)
        if any(clicks[k] > before.clicks[k] for k in self._centre):  # re-centre the sliders
            for name in self._sliders:
                self.meshcat.SetSliderValue(name, 0.0)
        discrete_state.get_mutable_vector(self._state_index).SetFromVector(after.to_vector())
        discrete_state.get_mutable_vector(self._raw_index).SetFromVector(after.raw)
        return EventStatus.Succeeded()


def page_live_input(
    page: Any, interface: InterfaceConfig, config: LiveInputConfig | None = None
) -> MeshcatLiveInput:
    """A :class:`MeshcatLiveInput` reading the operator page ``page`` instead of Meshcat's: the
    kind's drive keys (roles ``drive+`` / ``drive-``) repeat while held there
    (:meth:`~drake_disamb.operator_page.server.OperatorPage.repeat_while_held`), so a held key drives
    for as long as it is held, with no browser's auto-repeat."""
    source = MeshcatLiveInput(page, interface, config)
    controls = INTERFACES[interface.kind].live_controls
    page.repeat_while_held(c.keycode for c in controls if c.role in ("drive+", "drive-"))
    return source
