"""Control interfaces: one module per kind, one registry, one update (pure numpy).

:class:`~drake_disamb.core.interfaces.base.Interface` is the variant every kind derives and
:data:`INTERFACES` the registry; every kind is registered when this package is imported, so a new
kind is one new module. The joystick and the head array are the paper's study's two interfaces.

Its modules, and where this package sits among the others: docs/architecture.md (Layout).
"""

from __future__ import annotations

import importlib
import pkgutil

from drake_disamb.core.interfaces.base import (
    INTERFACES,
    LIVE_PULSES,
    MODE_BUTTON,
    MODE_SELECTIONS,
    RAW_SIZE,
    REQUEST_BUTTON,
    Interface,
    LiveControl,
    LiveRole,
    arm_modes,
    check_kind,
    gripper_mode,
    interface_modes,
    interfaces_in,
    mode_name,
    register,
)
from drake_disamb.core.interfaces.update import (
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

for _module in pkgutil.iter_modules(__path__):
    if _module.name not in ("base", "update"):
        importlib.import_module(f"{__name__}.{_module.name}")

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
    "mode_name",
    "parse_disambiguation_mode",
    "register",
    "sanitize_raw",
]
