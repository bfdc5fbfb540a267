"""The interface variant and the registry of kinds.

Every kind of interface is one small frozen dataclass deriving :class:`Interface`, in its own
module of :mod:`drake_disamb.interfaces.kinds`, registered with :func:`register` under the name a
scenario's ``interface`` field uses (the YAML tag). A variant has three parts, each in its own
module: the device model (:class:`~drake_disamb.interfaces.device.Device`: modes, raw layout,
speeds, sanitising, mode events, drives), what operating it takes
(:class:`~drake_disamb.interfaces.affordances.Affordances`: the raw signals the simulated user and
the live page send) and the live page's controls
(:class:`~drake_disamb.interfaces.live_controls.LiveControls`: buttons, keys, help). Everything
else (the interface update, the simulated user, the study, the report) reads :data:`INTERFACES`
and the variant's properties, never the kind's name.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import TypeVar

from drake_disamb.interfaces.affordances import Affordances
from drake_disamb.interfaces.device import Device
from drake_disamb.interfaces.live_controls import LiveControls


@dataclass(frozen=True)
class Interface(Device, Affordances, LiveControls):
    """One kind of control interface (a variant; subclasses are frozen dataclasses): its device
    model, what operating it takes and its live page's controls (the attributes and methods of
    the three parts)."""


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


__all__ = [
    "INTERFACES",
    "Interface",
    "arm_modes",
    "check_kind",
    "gripper_mode",
    "interface_modes",
    "interfaces_in",
    "register",
]
