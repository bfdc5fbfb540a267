"""Control interfaces: the variant of each kind (its device model, what operating it takes, its
live page's controls), one registry, one update (numpy), and the Drake systems that run them.

:class:`~drake_disamb.interfaces.registry.Interface` is the variant every kind derives and
:data:`INTERFACES` the registry; every kind (:mod:`drake_disamb.interfaces.kinds`) is registered
when this package is imported, so a new kind is one new module. This package's namespace is the
numpy part; the Drake systems are imported from their modules (:mod:`~drake_disamb.interfaces.system`,
:mod:`~drake_disamb.interfaces.live`, :mod:`~drake_disamb.interfaces.deadman`).

Its modules, and where this package sits among the others: docs/architecture.md (Layout).
"""

from __future__ import annotations

from drake_disamb.interfaces import kinds
from drake_disamb.interfaces.device import MODE_BUTTON, MODE_SELECTIONS, RAW_SIZE, REQUEST_BUTTON, mode_name
from drake_disamb.interfaces.live_controls import LIVE_PULSES, LiveControl, LiveRole
from drake_disamb.interfaces.registry import (
    INTERFACES,
    Interface,
    arm_modes,
    check_kind,
    gripper_mode,
    interface_modes,
    interfaces_in,
    register,
)
from drake_disamb.interfaces.update import (
    Answer,
    EventKind,
    InterfaceConfig,
    InterfaceEvent,
    InterfaceState,
    command_from_raw,
    disambiguation_due,
    initial_state,
    interface_update,
    parse_disambiguation_mode,
    sanitize_raw,
)

__all__ = [
    "INTERFACES",
    "LIVE_PULSES",
    "MODE_BUTTON",
    "MODE_SELECTIONS",
    "RAW_SIZE",
    "REQUEST_BUTTON",
    "Answer",
    "EventKind",
    "Interface",
    "InterfaceConfig",
    "InterfaceEvent",
    "InterfaceState",
    "LiveControl",
    "LiveRole",
    "arm_modes",
    "check_kind",
    "command_from_raw",
    "disambiguation_due",
    "gripper_mode",
    "initial_state",
    "interface_modes",
    "interfaces_in",
    "interface_update",
    "kinds",
    "mode_name",
    "parse_disambiguation_mode",
    "register",
    "sanitize_raw",
]
