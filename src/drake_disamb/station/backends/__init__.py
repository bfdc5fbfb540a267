"""The station's backends, one module each, and the one entry point that builds a station from a
backend choice (Drake's ``MakeHardwareStation(scenario, meshcat, hardware=...)`` pattern).

A backend is a small dataclass (its settings) with a ``name`` and a ``build(config, scene_objects,
meshcat) -> Station`` method; in YAML it is chosen by its tag, ``station: !Sim {}``. Every backend's
station offers the ports of :mod:`drake_disamb.station.ports` (joint-level commands in, the
measurement out); code dispatches on the backend's type (by calling its ``build``), never on its
name.
"""

import typing
from collections.abc import Iterable
from dataclasses import dataclass, field

from pydrake.geometry import Meshcat

from drake_disamb.station.backends.lcm import InProcessLcm, Lcm
from drake_disamb.station.backends.sim import Sim
from drake_disamb.station.build import Station
from drake_disamb.station.config import SceneObject, StationConfig

BACKENDS: dict[str, type] = {cls.name: cls for cls in (Sim, Lcm)}
"""Every registered backend by name (``--station NAME``)."""

StationBackend = typing.Union[tuple(BACKENDS.values())]  # noqa: UP007 (built from the registry)
"""Any registered backend's settings (a YAML tag picks one)."""


@dataclass  # (no postponed annotations in this module: Drake's YAML loader reads the field type)
class StationChoice:
    """A station choice as a YAML document: ``station: !Sim {}`` (the tag is the backend's class)."""

    station: StationBackend = field(default_factory=Sim)  # type: ignore[valid-type]


def backend_named(name: str) -> StationBackend:  # type: ignore[valid-type]
    """The backend registered as ``name`` with its default settings.

    Raises:
        ValueError: an unknown name; the message lists the registered ones.
    """
    if name not in BACKENDS:
        raise ValueError(f"station: unknown backend {name!r}; registered: {', '.join(BACKENDS)}")
    return BACKENDS[name]()


def load_station_choice(text: str) -> StationBackend:  # type: ignore[valid-type]
    """The backend of a YAML document ``station: !Tag {settings}``.

    Raises:
        ValueError: an unknown tag (listing the registered backends' tags) or a bad setting.
    """
    from pydrake.common.yaml import yaml_load_typed

    try:
        return yaml_load_typed(schema=StationChoice, data=text).station
    except RuntimeError as exc:
        tags = ", ".join(f"!{cls.__name__}" for cls in BACKENDS.values())
        raise ValueError(f"station: {exc} (registered backends: {tags})") from None


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
    "StationChoice",
    "backend_named",
    "load_station_choice",
    "make_station",
]
