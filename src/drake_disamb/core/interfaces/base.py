"""The interface variant: what one kind of control interface owns, and the registry of kinds.

Every kind of interface is one small frozen dataclass deriving :class:`Interface`, in its own
module of this package, registered with :func:`register` under the name a scenario's
``interface`` field uses (the YAML tag). It owns its control modes (their order is a field of the
variant, default the order the kind's module documents), its raw signal layout, its speeds, the
sanitising of its raw signal, the mapping from a sanitised signal to the drive of each dimension
of the mode, the live page's controls and key map, and the properties the simulated user needs to
operate it. Everything else (the interface update, the simulated user, the study, the report)
reads :data:`INTERFACES` and the variant's properties, never the kind's name.

Control modes are tuples of dimension indices (0 = vx ... 5 = wz, :data:`GRIPPER_DIM` = 6 for
the gripper); arm modes come first, the gripper mode last, and the disambiguation system's mode
indices index that same list. Spatial velocities are ``[vx, vy, vz, wx, wy, wz]`` in the world
frame (m/s, rad/s).

Every kind's raw signal is a :data:`RAW_SIZE`-vector whose last entry
(:data:`REQUEST_BUTTON`) is the disambiguation-request button, so a simulated user, a recorded
log or a live browser drives every kind through the same port.
"""

from __future__ import annotations

import math
import numbers
from abc import ABC, abstractmethod
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import ClassVar, Literal, TypeVar

from drake_disamb.core.layout import DIM_NAMES, GRIPPER_DIM

RAW_SIZE = 4
"""Length of the raw signal vector of every interface."""

MODE_BUTTON = 2
"""Raw index of the mode-switch button of the button-based kinds (joystick ``mode_button``, head
array ``back``)."""

REQUEST_BUTTON = 3
"""Raw index of the disambiguation-request button (every kind)."""

MODE_SELECTIONS: tuple[str, ...] = ("cycle", "direct")
"""How a mode change chooses the mode: step through the cycle (``"cycle"``, every kind) or, where
the kind offers it (:attr:`Interface.mode_selections`), select one mode with one action
(``"direct"``)."""

LiveRole = Literal["drive+", "drive-", "center", "next", "previous", "request", ""]
"""What a live-page button does: hold the mode's dimension driven positive / negative (switched
kinds), re-centre the axis sliders (proportional kinds), one step to the next / previous mode, a
disambiguation request, or nothing (a placeholder that adds no button)."""

LIVE_PULSES: tuple[LiveRole, ...] = ("next", "previous", "request")
"""The live roles that are one-period pulses (a press, then a release)."""


def mode_name(mode: Sequence[int]) -> str:
    """Name of a control mode: its dimension names joined by ``_`` (``(0, 1)`` -> ``vx_vy``)."""
    return "_".join(DIM_NAMES[d] for d in mode)


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


@dataclass(frozen=True)
class Interface(ABC):
    """One kind of control interface (a variant; subclasses are frozen dataclasses).

    Class attributes (the same for every instance of a kind):
        name: The registry name, the scenario's ``interface`` value (``"head_array"``).
        label: Its name in reports and figures (``"Head array"``).
        rank: Where it is listed in :data:`INTERFACES` (reports and figures follow this order).
        raw_layout: The meaning of each of the :data:`RAW_SIZE` raw entries.
        default_speeds: ``(max linear m/s, max angular rad/s)`` of a dimension at full drive.
        axes: How many dimensions one mode drives at once (a mode has at most this many).
        proportional: Whether a dimension's drive is graded (a stick) rather than switched
            (on/off at full speed).
        mode_selections: The :data:`MODE_SELECTIONS` the kind offers (``"cycle"`` first).
        steps_back: Whether a mode change can also step back through the cycle (else forward
            only).
        clean_repeated_switches: Whether the study's authors dropped quick repeats of the same
            mode switch from this kind's logs (the metrics' cleaning).
        live_controls: The live page's buttons, one per raw entry where one applies.
        live_axes: Whether the live page adds axis sliders (and reads a gamepad's stick).
        live_help: What ``demo --live`` prints before the trial.

    Field:
        mode_order: The arm modes in the order a mode change steps through them; the gripper mode
            follows them (:attr:`modes`).
    """

    name: ClassVar[str]
    label: ClassVar[str]
    rank: ClassVar[int]
    raw_layout: ClassVar[tuple[str, ...]]
    default_speeds: ClassVar[tuple[float, float]]
    axes: ClassVar[int] = 1
    proportional: ClassVar[bool] = False
    mode_selections: ClassVar[tuple[str, ...]] = ("cycle",)
    steps_back: ClassVar[bool] = False
    clean_repeated_switches: ClassVar[bool] = False
    live_controls: ClassVar[tuple[LiveControl, ...]]
    live_axes: ClassVar[bool] = False
    live_help: ClassVar[str]

    mode_order: tuple[tuple[int, ...], ...] = ()

    def __post_init__(self) -> None:
        where = f"{type(self).__name__}.mode_order"
        order = self.mode_order
        ok = isinstance(order, tuple) and len(order) > 0
        for mode in order if ok else ():
            ok = ok and isinstance(mode, tuple) and 1 <= len(mode) <= self.axes
            ok = ok and all(isinstance(d, numbers.Integral) and 0 <= d < GRIPPER_DIM for d in mode)
        dims = [d for mode in order for d in mode] if ok else []
        if not ok or len(set(map(tuple, order))) != len(order):
            raise ValueError(
                f"{where}: expected distinct modes of 1 to {self.axes} arm dimension indices in [0, 5], "
                f"got {order!r}"
            )
        if sorted(set(dims)) != list(range(GRIPPER_DIM)):
            raise ValueError(f"{where}: expected modes that cover every arm dimension 0..5, got {order!r}")

    # -- modes -------------------------------------------------------------------------------------

    @property
    def modes(self) -> tuple[tuple[int, ...], ...]:
        """All control modes: :attr:`mode_order`, then the gripper mode."""
        return (*self.mode_order, (GRIPPER_DIM,))

    @property
    def gripper_mode(self) -> int:
        """The index of the gripper mode (the last one)."""
        return len(self.mode_order)

    def mode_name(self, mode: int) -> str:
        """Name of mode index ``mode`` (:func:`mode_name` of its dimensions)."""
        return mode_name(self.modes[int(mode)])

    def mode_steps(self, mode: int, target: int, selection: str = "cycle") -> int:
        """The mode changes from ``mode`` to ``target``, signed (positive forward, negative back):
        forward through the cycle, the shorter way round when the kind :attr:`steps_back` (ties
        forward), or one for any other mode with ``"direct"`` selection."""
        n = len(self.modes)
        if selection == "direct":
            return int(target != mode)
        forward = (int(target) - int(mode)) % n
        if self.steps_back and n - forward < forward:
            return forward - n
        return forward

    # -- the raw signal ----------------------------------------------------------------------------

    @abstractmethod
    def sanitize(self, values: list[float], threshold: float) -> list[float]:
        """The sanitised signal of :data:`RAW_SIZE` finite raw values (non-finite ones are already
        0); levels ``>= threshold`` count as pressed. The request entry is 0 or 1."""

    def mode_event(self, clean: list[float], memory: float) -> tuple[int, float]:
        """``(step, memory)``: the mode change the sanitised signal ``clean`` makes (+1 forward, -1
        back, 0 none) given what the previous update remembered, and what to remember now.

        The default is the mode button's rising edge (the memory is its level)."""
        level = clean[MODE_BUTTON]
        return (1 if level > 0.5 and memory <= 0.5 else 0), level

    def select(self, mode: int, step: int, clean: list[float], selection: str) -> int:
        """The mode a mode change ``step`` selects from ``mode`` with the interface's
        ``mode_selection`` (default: the next / previous one, cycling)."""
        return (int(mode) + step) % len(self.modes)

    def held(self, clean: list[float], memory: float, selection: str) -> list[float]:
        """The sanitised signal the commands are computed from, after the mode events (default:
        ``clean``)."""
        return clean

    @abstractmethod
    def drives(self, clean: Sequence[float], n_dims: int) -> list[float]:
        """The drive in ``[-1, 1]`` (of full speed) of each of a mode's ``n_dims`` dimensions."""

    # -- operating it (the simulated user, the live page) ---------------------------------------

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

    def pulse_raw(self, role: LiveRole) -> list[float]:
        """The raw signal of a live pulse (:data:`LIVE_PULSES`)."""
        if role == "request":
            return self.request_raw()
        return self.step_raw(1 if role == "next" else -1)


_Kind = TypeVar("_Kind", bound=type[Interface])

INTERFACES: dict[str, Interface] = {}
"""The registry: interface name -> its default variant, in :attr:`Interface.rank` order."""


def register(cls: _Kind) -> _Kind:
    """Class decorator: register an :class:`Interface` kind under ``cls.name`` (its default
    instance); the registry stays in rank order."""
    if cls.name in INTERFACES:
        raise ValueError(f"interface {cls.name!r} is registered twice")
    items = [*INTERFACES.items(), (cls.name, cls())]
    INTERFACES.clear()
    INTERFACES.update(sorted(items, key=lambda item: item[1].rank))
    return cls


def interfaces_in(names: Iterable[str]) -> list[str]:
    """The registered interfaces among ``names`` (e.g. the trials' interfaces), in the registry's
    order."""
    present = set(names)
    return [name for name in INTERFACES if name in present]


def check_kind(kind: str) -> str:
    """Return ``kind`` if it names a registered interface, else raise ``ValueError`` listing them."""
    if not isinstance(kind, str) or kind not in INTERFACES:
        raise ValueError(f"interface kind: expected one of {tuple(INTERFACES)}, got {kind!r}")
    return kind


def interface_modes(kind: str) -> tuple[tuple[int, ...], ...]:
    """All control modes of a registered interface's default variant (gripper mode last)."""
    return INTERFACES[check_kind(kind)].modes


def arm_modes(kind: str) -> tuple[tuple[int, ...], ...]:
    """The arm modes of an interface (every mode but the gripper mode)."""
    return interface_modes(kind)[:-1]


def gripper_mode(kind: str) -> int:
    """The index of an interface's gripper mode (its last mode)."""
    return INTERFACES[check_kind(kind)].gripper_mode


def sign(value: float) -> float:
    """-1, 0 or 1."""
    return 0.0 if value == 0 else math.copysign(1.0, value)


__all__ = [
    "INTERFACES",
    "LIVE_PULSES",
    "MODE_BUTTON",
    "MODE_SELECTIONS",
    "RAW_SIZE",
    "REQUEST_BUTTON",
    "Interface",
    "LiveControl",
    "LiveRole",
    "arm_modes",
    "check_kind",
    "gripper_mode",
    "interface_modes",
    "interfaces_in",
    "mode_name",
    "register",
    "sign",
]
