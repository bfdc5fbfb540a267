"""The interface update: settings, state and one control period of any registered kind (numpy).

The update (:func:`interface_update`) is what the Drake system runs every control period: it
sanitises the raw signal (the kind's :meth:`~drake_disamb.interfaces.device.Device.sanitize`;
non-finite entries never reach the arm: they are read as 0 and counted), reads the kind's mode
event (a mode-button press, or what the kind uses) and changes or selects the mode, detects the
request button's rising edge (a held button counts once), starts a disambiguation at a request (or
an automatic trigger) and applies the disambiguation system's answer to it ``request_latency``
later (the answer is a value the update is given, :class:`Answer`; the update calls nothing),
holds the sanitised raw signal, and returns the events it logged. The commands
(:func:`command_from_raw`) are the kind's drives of the current mode's dimensions times their
speeds.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core.layout import GRIPPER_DIM
from drake_disamb.core.validation import check_real_fields, is_real
from drake_disamb.interfaces.device import MODE_SELECTIONS, RAW_SIZE, REQUEST_BUTTON
from drake_disamb.interfaces.registry import INTERFACES, Interface, check_kind

EventKind = Literal["mode_switch", "disambiguation_request", "disambiguation_switch", "automatic_switch"]

_DUE_TOLERANCE = 1e-6
"""A pending mode switch is served by the first update at least ``request_latency - 1 us`` after it
started (update times are sums of control periods, off by rounding)."""


def disambiguation_due(pending_due: float, time: float) -> bool:
    """Whether a disambiguation pending since ``pending_due`` (:attr:`InterfaceState.pending_due`,
    -1 if none) may be served by the update at ``time``."""
    return pending_due >= 0 and time >= pending_due - _DUE_TOLERANCE


@dataclass(frozen=True)
class InterfaceConfig:
    """Settings of one interface.

    Attributes:
        kind: A registered interface name (:data:`~drake_disamb.interfaces.registry.INTERFACES`).
        max_linear_speed: Speed (m/s) of a translational dimension at full drive; ``None`` takes
            the kind's default (:attr:`~drake_disamb.interfaces.device.Device.default_speeds`).
        max_angular_speed: Same for rotational dimensions (rad/s).
        gripper_speed: Finger opening speed (m/s) at full deflection / switch on (positive opens).
        button_threshold: A button or switch level ``>=`` this counts as pressed.
        control_period: Period (s) of the interface update.
        initial_mode: Mode index at the start of a trial (the study randomised it).
        request_latency: Time (s, finite, >= 0) from a request press (or an automatic trigger) to
            the mode switch it causes: the paper's system took 2 to 2.5 s to compute the mode. The
            switch is made by the first update at least this long after the press that has the
            disambiguation system's answer to that request (the mode chosen for the belief, pose,
            goals and mode of the press). 0 (default): the first update that has the answer.
        serve_requests: Whether a request press starts a disambiguation (default). False: presses
            are logged and counted but never switch the mode (the Automatic paradigm without its
            request button).
        mode_selection: ``"cycle"`` (default): a mode change steps through the cycle.
            ``"direct"`` (a kind that offers it, the joystick): a press with the stick deflected
            selects the mode of the stick's sector, a press with it centred cycles
            (:mod:`drake_disamb.interfaces.kinds.joystick`).
        variant: The kind's variant (its settings, e.g. the mode order); ``None`` (default): the
            registered default of ``kind``.
    """

    kind: str = "joystick"
    max_linear_speed: float | None = None
    max_angular_speed: float | None = None
    gripper_speed: float = 0.02
    button_threshold: float = 0.5
    control_period: float = 0.01
    initial_mode: int = 0
    request_latency: float = 0.0
    serve_requests: bool = True
    mode_selection: str = "cycle"
    variant: Interface | None = None
    speed_tuple: tuple[float, ...] = field(init=False, default=(), compare=False, repr=False)
    """:meth:`dim_speeds` as a tuple (set from the fields; the update reads it every tick)."""

    def __post_init__(self) -> None:
        check_kind(self.kind)
        if self.variant is None:
            object.__setattr__(self, "variant", INTERFACES[self.kind])
        elif not (isinstance(self.variant, Interface) and self.variant.name == self.kind):
            raise ValueError(f"InterfaceConfig.variant: expected a {self.kind} variant, got {self.variant!r}")
        lin, ang = self.variant.default_speeds
        if self.max_linear_speed is None:
            object.__setattr__(self, "max_linear_speed", lin)
        if self.max_angular_speed is None:
            object.__setattr__(self, "max_angular_speed", ang)
        check_real_fields(self, ("max_linear_speed", "max_angular_speed", "gripper_speed", "control_period"))
        object.__setattr__(self, "speed_tuple", tuple(self.dim_speeds().tolist()))
        if not (is_real(self.button_threshold) and 0.0 < self.button_threshold <= 1.0):
            raise ValueError(
                "InterfaceConfig.button_threshold: expected a number in (0, 1], "
                f"got {self.button_threshold!r}"
            )
        n = len(self.variant.modes)
        if not (isinstance(self.initial_mode, numbers.Integral) and 0 <= self.initial_mode < n):
            raise ValueError(
                f"InterfaceConfig.initial_mode: expected an integer in [0, {n - 1}] for {self.kind}, "
                f"got {self.initial_mode!r}"
            )
        check_real_fields(self, ("request_latency",), allow_zero=True)
        if not isinstance(self.serve_requests, bool):
            raise ValueError(
                f"InterfaceConfig.serve_requests: expected true or false, got {self.serve_requests!r}"
            )
        if self.mode_selection not in MODE_SELECTIONS:
            raise ValueError(
                f"InterfaceConfig.mode_selection: expected one of {MODE_SELECTIONS}, "
                f"got {self.mode_selection!r}"
            )
        if self.mode_selection not in self.variant.mode_selections:
            raise ValueError(
                f"InterfaceConfig.mode_selection: the {self.kind} offers "
                f"{', '.join(self.variant.mode_selections)}, got {self.mode_selection!r}"
            )

    @property
    def modes(self) -> tuple[tuple[int, ...], ...]:
        """All control modes (gripper mode last)."""
        return self.variant.modes

    @property
    def arm_modes(self) -> tuple[tuple[int, ...], ...]:
        """The arm modes (all but the gripper mode)."""
        return self.variant.mode_order

    @property
    def raw_layout(self) -> tuple[str, ...]:
        """Names of the raw entries."""
        return self.variant.raw_layout

    def dim_speeds(self) -> NDArray[np.float64]:
        """Speed of each dimension 0..6 at full deflection: 3 linear, 3 angular, gripper."""
        return np.array([self.max_linear_speed] * 3 + [self.max_angular_speed] * 3 + [self.gripper_speed])


@dataclass(frozen=True)
class InterfaceEvent:
    """One logged interface event.

    Attributes:
        time: Simulation time (s) of the update that saw it.
        kind: ``"mode_switch"`` (manual press), ``"disambiguation_request"`` (request press, at the
            press), ``"disambiguation_switch"`` (the mode change a request caused, at the switch:
            ``request_latency`` after the press) or ``"automatic_switch"`` (the mode change an
            automatic trigger caused, Automatic paradigm).
        from_mode: Mode index before the event.
        to_mode: Mode index after it (equal to ``from_mode`` for a request).
    """

    time: float
    kind: EventKind
    from_mode: int
    to_mode: int


@dataclass(frozen=True)
class InterfaceState:
    """Everything the interface remembers between updates.

    Attributes:
        mode: Current mode index.
        prev_mode_button: What the kind's mode event remembered at the last update (the
            mode-button level, 0/1, for the button kinds).
        prev_request_button: Request-button level (0/1) seen at the last update.
        mode_switch_count: Manual mode switches so far (mode-button presses).
        request_count: Disambiguation requests so far (request-button presses).
        nonfinite_count: Updates whose raw signal held a NaN or infinity.
        held_raw: The sanitised raw signal of the last update; the commands are computed from it.
        pending_due: Time (s) from which the pending disambiguation may switch the mode (its start
            plus ``request_latency``); -1 if none (a number, not NaN: an unchanged state vector
            compares equal and is not rewritten). The pending disambiguation's request id is
            :attr:`started_count`.
        pending_automatic: The pending disambiguation was started by an automatic trigger (1) or by
            a request press (0).
        served_count: Disambiguations served so far (their answer applied, or, with no
            disambiguation system, their wait over: requests and automatic triggers).
        automatic_seen: The automatic trigger's request count seen at the last update.
    """

    mode: int = 0
    prev_mode_button: float = 0.0
    prev_request_button: float = 0.0
    mode_switch_count: int = 0
    request_count: int = 0
    nonfinite_count: int = 0
    held_raw: NDArray[np.float64] = field(default_factory=lambda: np.zeros(RAW_SIZE), compare=False)
    pending_due: float = -1.0
    pending_automatic: int = 0
    served_count: int = 0
    automatic_seen: int = 0

    VECTOR_SIZE = 10 + RAW_SIZE
    PENDING_DUE_INDEX = 6 + RAW_SIZE
    """Where ``pending_due`` is in :meth:`to_vector` (read without building the state)."""

    @property
    def started_count(self) -> int:
        """Disambiguations started so far (served ones and the pending one): the pending one's
        request id, the one the disambiguation system's :class:`Answer` must carry."""
        return self.served_count + (1 if self.pending_due >= 0 else 0)

    def to_vector(self) -> NDArray[np.float64]:
        """Flat vector ``[mode, prev_mode, prev_req, n_switch, n_req, n_bad, raw (4), pending_due,
        pending_automatic, n_served, automatic_seen]`` (Drake state)."""
        head = [
            self.mode,
            self.prev_mode_button,
            self.prev_request_button,
            self.mode_switch_count,
            self.request_count,
            self.nonfinite_count,
        ]
        tail = [self.pending_due, self.pending_automatic, self.served_count, self.automatic_seen]
        return np.array([*head, *np.asarray(self.held_raw, dtype=float).tolist(), *tail])

    @classmethod
    def from_vector(cls, x: ArrayLike) -> InterfaceState:
        """Inverse of :meth:`to_vector`."""
        v = np.asarray(x, dtype=float)
        if v.shape != (cls.VECTOR_SIZE,):
            raise ValueError(f"InterfaceState vector: expected {cls.VECTOR_SIZE} numbers, got {v.shape}")
        mode, prev_mode, prev_request, switches, requests, nonfinite = v[:6].tolist()
        return cls(
            mode=int(round(mode)),
            prev_mode_button=prev_mode,
            prev_request_button=prev_request,
            mode_switch_count=int(round(switches)),
            request_count=int(round(requests)),
            nonfinite_count=int(round(nonfinite)),
            held_raw=v[6 : 6 + RAW_SIZE].copy(),
            pending_due=float(v[6 + RAW_SIZE]),
            pending_automatic=int(round(v[7 + RAW_SIZE])),
            served_count=int(round(v[8 + RAW_SIZE])),
            automatic_seen=int(round(v[9 + RAW_SIZE])),
        )


def initial_state(config: InterfaceConfig) -> InterfaceState:
    """The state at the start of a trial: ``config.initial_mode``, nothing pressed, zero counts."""
    return InterfaceState(mode=int(config.initial_mode))


def sanitize_raw(raw: ArrayLike, config: InterfaceConfig) -> tuple[NDArray[np.float64], bool]:
    """Clean a raw signal: non-finite entries -> 0, then the kind's
    :meth:`~drake_disamb.interfaces.device.Device.sanitize` (the joystick clips its axes to
    ``[-1, 1]``, switches and buttons become 0/1).

    Returns ``(clean, had_nonfinite)``. A raw signal of the wrong length is a ``ValueError``.
    """
    clean, bad = _sanitized(raw, config)
    return np.array(clean), bad


def _sanitized(raw: ArrayLike, config: InterfaceConfig) -> tuple[list[float], bool]:
    """:func:`sanitize_raw` as a list of Python floats (cheaper than numpy for four numbers)."""
    r = np.asarray(raw, dtype=float).reshape(-1)
    if r.shape != (RAW_SIZE,):
        raise ValueError(
            f"raw ({config.kind} {list(config.raw_layout)}): expected {RAW_SIZE} numbers, got {r.tolist()}"
        )
    values = r.tolist()
    finite = [math.isfinite(v) for v in values]
    values = [v if ok else 0.0 for v, ok in zip(values, finite, strict=True)]
    return config.variant.sanitize(values, config.button_threshold), not all(finite)


def command_from_raw(
    clean_raw: ArrayLike, mode: int, config: InterfaceConfig
) -> tuple[NDArray[np.float64], float]:
    """The 6-D arm command and the gripper command of a sanitised raw signal in mode ``mode``.

    Returns ``(u_h, gripper)``: ``u_h`` is ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s, world frame;
    zero in the gripper mode), ``gripper`` the finger opening speed (m/s; nonzero only in the
    gripper mode).
    """
    r = np.asarray(clean_raw, dtype=float).tolist()
    dims = config.modes[mode]
    drives = config.variant.drives(r, len(dims))
    speeds = config.speed_tuple
    u7 = [0.0] * 7
    for dim, drive in zip(dims, drives, strict=True):
        u7[dim] = drive * speeds[dim]
    return np.array(u7[:6]), u7[GRIPPER_DIM]


@dataclass(frozen=True)
class Answer:
    """The disambiguation system's answer to one request, the value :func:`interface_update` reads.

    Attributes:
        request: The id of the request answered: the :attr:`InterfaceState.started_count` the
            request was started with (1 for the first); 0 before any answer.
        mode: The arm-mode index chosen for it, or -1 to keep the current mode (ties, unusable
            inputs). Any other value is invalid: warned about, the mode kept.
    """

    request: float
    mode: float


def parse_disambiguation_mode(value: float | None, n_arm_modes: int) -> int | None:
    """Read the disambiguation system's choice: an arm-mode index, or ``None`` to keep the mode.

    ``None`` (no disambiguation system), -1, and invalid values (non-finite, non-integer, out of
    range) all keep the mode; the caller warns about invalid ones (see :func:`interface_update`).
    """
    if value is None:
        return None
    v = float(value)
    if not math.isfinite(v) or v != round(v):
        return None
    m = int(round(v))
    if 0 <= m < n_arm_modes:
        return m
    return None


def interface_update(
    state: InterfaceState,
    raw: ArrayLike,
    time: float,
    config: InterfaceConfig,
    answer: Answer | None = None,
    warn: Callable[[str], None] | None = None,
    automatic_requests: float | None = None,
) -> tuple[InterfaceState, list[InterfaceEvent]]:
    """One control-period update of an interface.

    Args:
        state: The state before the update.
        raw: The raw signal now (any values; sanitised here).
        time: Current time (s), stamped on the events.
        config: The interface.
        answer: The disambiguation system's latest answer (:class:`Answer`), or ``None`` when there
            is no disambiguation system (manual paradigm: a request is logged and waited for, and
            the mode kept). Read only when a pending disambiguation is due.
        warn: Called with a message on the first non-finite raw signal and on an invalid
            disambiguation choice.
        automatic_requests: The automatic trigger's running count of triggers (Automatic
            paradigm), or ``None`` without one. A count larger than ``state.automatic_seen``
            starts a disambiguation like a request press does, with no press.

    Returns:
        ``(new_state, events)``. A mode event of the kind (a mode-button rising edge, or what the
        kind uses: :meth:`~drake_disamb.interfaces.device.Device.mode_event`) steps the mode
        or selects one (:meth:`~drake_disamb.interfaces.device.Device.select`), logged as
        one ``mode_switch`` per event (also when a direct selection keeps the mode). A
        request-button rising edge logs ``disambiguation_request`` (at the press) and, with
        ``config.serve_requests``, starts a disambiguation; so does a new automatic trigger. A
        started disambiguation is request number ``new_state.started_count``: the caller latches
        what the disambiguation system solves (the belief, pose and goals of this update, and the
        mode after this update's manual switch, if any), and the system answers it. It is served
        by the first update at least ``config.request_latency`` after it started that has the
        answer to it (``answer.request`` equal to its id; with no disambiguation system, the first
        update at least that late): if the answer is an arm mode different from the current one
        the mode switches to it, logged as ``disambiguation_switch`` (a request's) or
        ``automatic_switch`` (a trigger's) at the switch time. One disambiguation at a time: a
        press during the wait is logged and counted as a request but starts nothing, and a
        trigger during the wait is dropped; manual mode switches during the wait work as usual
        (and an answer equal to the mode they reached keeps it). When the mode button and a
        served disambiguation fall in the same update the manual switch is applied first and the
        answer last. Only manual switches count in ``mode_switch_count``; requests count in
        ``request_count`` (the paper's "button presses" is their sum), served disambiguations in
        ``served_count``.
    """
    variant = config.variant
    values, bad = _sanitized(raw, config)
    events: list[InterfaceEvent] = []
    mode = int(state.mode)
    switches = state.mode_switch_count
    requests = state.request_count
    nonfinite = state.nonfinite_count
    if bad:
        if nonfinite == 0 and warn is not None:
            warn(
                f"raw signal {np.asarray(raw, dtype=float).tolist()} has non-finite entries "
                f"({config.kind} layout {list(config.raw_layout)}); they are read as 0"
            )
        nonfinite += 1

    step, memory = variant.mode_event(values, state.prev_mode_button)
    if step:
        new = variant.select(mode, step, values, config.mode_selection)
        events.append(InterfaceEvent(float(time), "mode_switch", mode, new))
        mode = new
        switches += 1

    clean = np.array(variant.held(values, memory, config.mode_selection))
    due, automatic = state.pending_due, state.pending_automatic
    request_level = clean[REQUEST_BUTTON]
    if request_level > 0.5 and state.prev_request_button <= 0.5:
        requests += 1
        events.append(InterfaceEvent(float(time), "disambiguation_request", mode, mode))
        if config.serve_requests and due < 0:
            due, automatic = float(time) + config.request_latency, 0
    seen = state.automatic_seen
    if automatic_requests is not None and math.isfinite(automatic_requests) and automatic_requests > seen:
        seen = int(round(automatic_requests))
        if due < 0:  # a trigger while a disambiguation is pending is dropped
            due, automatic = float(time) + config.request_latency, 1
    served = state.served_count
    pending_id = served + 1
    answered = answer is None or answer.request == pending_id
    if disambiguation_due(due, time) and answered:
        served += 1
        value = None if answer is None else answer.mode
        choice = parse_disambiguation_mode(value, len(config.arm_modes))
        if value is not None and choice is None and float(value) != -1.0 and warn is not None:
            warn(
                f"disambiguation_mode: expected -1 or an arm-mode index in [0, {len(config.arm_modes) - 1}] "
                f"for {config.kind}, got {value!r}; keeping mode {mode}"
            )
        if choice is not None and choice != mode:
            kind: EventKind = "automatic_switch" if automatic else "disambiguation_switch"
            events.append(InterfaceEvent(float(time), kind, mode, choice))
            mode = choice
        due, automatic = -1.0, 0

    new_state = InterfaceState(
        mode=mode,
        prev_mode_button=float(memory),
        prev_request_button=float(request_level),
        mode_switch_count=switches,
        request_count=requests,
        nonfinite_count=nonfinite,
        held_raw=clean,
        pending_due=due,
        pending_automatic=automatic,
        served_count=served,
        automatic_seen=seen,
    )
    return new_state, events
