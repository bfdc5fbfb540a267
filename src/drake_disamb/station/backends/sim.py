"""The in-process simulated MICO, the default station backend (:func:`drake_disamb.station.build_station`)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import ClassVar

from pydrake.geometry import Meshcat

from drake_disamb.station.build import Station, build_station
from drake_disamb.station.config import SceneObject, StationConfig


@dataclass
class Sim:
    """The station simulated in the same diagram: a MultibodyPlant MICO with joint PD and gravity
    compensation, its set points integrated from the commanded joint and finger velocities (YAML
    ``station: !Sim {}``; no settings of its own: the arm's are the scenario's)."""

    name: ClassVar[str] = "sim"

    def build(
        self, config: StationConfig, scene_objects: Iterable[SceneObject] = (), meshcat: Meshcat | None = None
    ) -> Station:
        """The simulated station (:func:`~drake_disamb.station.build.build_station`)."""
        return build_station(config, scene_objects, meshcat)
