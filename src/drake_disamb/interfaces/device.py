"""The device model of an interface: what its raw signal means (modes, layout, speeds, sanitising,
mode events, drives).

:class:`Device` is the part of an interface variant (:class:`~drake_disamb.interfaces.registry.Interface`)
that the interface update reads: its control modes (their order is a field of the variant, default
the order the kind's module documents), its raw signal layout, its speeds, the sanitising of its
raw signal and the mapping from a sanitised signal to a mode event and to the drive of each
dimension of the mode. What operating it takes (the raw signals that drive, change the mode and
request) is :mod:`~drake_disamb.interfaces.affordances`, the live page's buttons and keys
:mod:`~drake_disamb.interfaces.live_controls`.

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
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

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
the kind offers it (:attr:`Device.mode_selections`), select one mode with one action
(``"direct"``)."""


def mode_name(mode: Sequence[int]) -> str:
    """Name of a control mode: its dimension names joined by ``_`` (``(0, 1)`` -> ``vx_vy``)."""
    return "_".join(DIM_NAMES[d] for d in mode)


@dataclass(frozen=True)
class Device(ABC):
    """The device model of one kind of control interface (the first part of its variant,
    :class:`~drake_disamb.interfaces.registry.Interface`; subclasses are frozen dataclasses).

    Class attributes (the same for every instance of a kind):
        name: The registry name, the scenario's ``interface`` value (``"head_array"``).
        label: Its name in reports and figures (``"Head array"``).
        rank: Where it is listed in the registry (reports and figures follow this order).
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


def sign(value: float) -> float:
    """-1, 0 or 1."""
    return 0.0 if value == 0 else math.copysign(1.0, value)


__all__ = [
    "MODE_BUTTON",
    "MODE_SELECTIONS",
    "RAW_SIZE",
    "REQUEST_BUTTON",
    "Device",
    "mode_name",
    "sign",
]
