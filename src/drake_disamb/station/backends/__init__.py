"""The station's backends, one module each, and the one entry point that builds a station from a
backend choice (Drake's ``MakeHardwareStation(scenario, meshcat, hardware=...)`` pattern).

A backend is a small dataclass (its settings) with a ``name`` and a ``build(config, scene_objects,
meshcat) -> Station`` method; it is the scenario's ``station`` field (:class:`StationBackend`), in
YAML chosen by its tag, ``station: !Sim {}`` or ``station: !Lcm {lcm_url: ...}``. Every backend's
station offers the ports of :mod:`drake_disamb.station.ports` (joint-level commands in, the
measurement out); code dispatches on the backend's type (by calling its ``build``), never on its
name.
"""

import typing
from collections.abc import Iterable

from pydrake.geometry import Meshcat

from drake_disamb.station.backends.lcm import InProcessLcm, Lcm
from drake_disamb.station.backends.sim import Sim
from drake_disamb.station.build import Station
from drake_disamb.station.config import SceneObject, StationConfig

BACKENDS: dict[str, type] = {cls.name: cls for cls in (Sim, Lcm)}
"""Every registered backend by name (``--station NAME``)."""

StationBackend = typing.Union[tuple(BACKENDS.values())]  # noqa: UP007 (built from the registry)
"""Any registered backend's settings (a YAML tag picks one; the first, :class:`Sim`, without a tag)."""


def make_station(
    backend: StationBackend | None,  # type: ignore[valid-type]
    config: StationConfig,
    scene_objects: Iterable[SceneObject] = (),
    meshcat: Meshcat | None = None,
) -> Station:
    """Build the station of ``backend`` (``None``: :class:`Sim`) with ``config`` and the scene."""
    return (backend if backend is not None else Sim()).build(config, scene_objects, meshcat)


__all__ = [
    "BACKENDS",
    "InProcessLcm",
    "Lcm",
    "Sim",
    "StationBackend",
    "make_station",
]
