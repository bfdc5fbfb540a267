"""Named systems: scenario settings that make the shared-control system one particular system.

Each preset is a YAML fragment of scenario fields in :mod:`drake_disamb.config.systems`
(``<name>.yaml``), a layer of the scenario (:func:`system_layer`) loaded over the task by the one
loader (:func:`~drake_disamb.config.yaml_io.load_layers`), so its fields merge as every layer's do
and the scenario's own checks apply to it:

- ``mico``: the schema's defaults (our choices where the paper is silent); nothing changes.
- ``tnsre2020_study``: the system the paper's study ran, as its logs show it (``drake-disamb study
  identify``; the file says which value comes from the logs and which is ours).

The study protocol names one (``Protocol.system``).
"""

from __future__ import annotations

import functools
from importlib import resources

from drake_disamb.config.yaml_io import Layer, text_layer

__all__ = ["SYSTEM_PRESETS", "system_layer"]

SYSTEM_PRESETS: tuple[str, ...] = ("mico", "tnsre2020_study")
"""The names of the presets (one YAML file each in :mod:`drake_disamb.config.systems`)."""


@functools.cache
def system_layer(name: str) -> Layer:
    """The preset's layer (read once per process).

    Raises:
        ValueError: ``name`` is not one of :data:`SYSTEM_PRESETS` (the message lists them).
    """
    if name not in SYSTEM_PRESETS:
        raise ValueError(f"system: expected one of {', '.join(SYSTEM_PRESETS)}, got {name!r}")
    text = resources.files("drake_disamb.config.systems").joinpath(f"{name}.yaml").read_text(encoding="utf-8")
    return text_layer(text, f"<system {name}.yaml>")
