"""Named systems: scenario settings that make the shared-control system one particular system.

Each preset is a YAML fragment of scenario fields in :mod:`drake_disamb.config.systems`
(``<name>.yaml``), merged into a scenario's plain data before it is loaded, so the scenario's own
checks apply to it:

- ``mico``: the schema's defaults (our choices where the paper is silent); nothing changes.
- ``tnsre2020_study``: the system the paper's study ran, as its logs show it (``drake-disamb study
  identify``; the file says which value comes from the logs and which is ours).

The study protocol names one (``Protocol.system``).
"""

from __future__ import annotations

import copy
from importlib import resources
from typing import Any

from drake_disamb.yaml_safety import load_yaml_document

__all__ = ["SYSTEM_PRESETS", "apply_system_preset", "system_preset"]

SYSTEM_PRESETS: tuple[str, ...] = ("mico", "tnsre2020_study")
"""The names of the presets (one YAML file each in :mod:`drake_disamb.config.systems`)."""


def system_preset(name: str) -> dict[str, Any]:
    """The preset's scenario fields (plain nested data).

    Raises:
        ValueError: ``name`` is not one of :data:`SYSTEM_PRESETS` (the message lists them).
    """
    if name not in SYSTEM_PRESETS:
        raise ValueError(f"system: expected one of {', '.join(SYSTEM_PRESETS)}, got {name!r}")
    text = resources.files("drake_disamb.config.systems").joinpath(f"{name}.yaml").read_text(encoding="utf-8")
    data = load_yaml_document(text, f"<system {name}.yaml>", root="system")
    if not isinstance(data, dict):
        raise ValueError(f"<system {name}.yaml>: expected a mapping of scenario fields, got {data!r}")
    return data


def _merge(into: dict[str, Any], fields: dict[str, Any]) -> None:
    for key, value in fields.items():
        if isinstance(value, dict) and isinstance(into.get(key), dict):
            _merge(into[key], value)
        else:
            into[key] = copy.deepcopy(value)


def apply_system_preset(plain: dict[str, Any], name: str) -> dict[str, Any]:
    """Merge the preset ``name`` into plain scenario data (in place; also returned): its fields
    replace the scenario's, nested mappings merged field by field."""
    _merge(plain, system_preset(name))
    return plain
