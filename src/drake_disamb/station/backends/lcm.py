"""The station on LCM: a Kinova Gen2 arm (or the simulated driver) behind ``lcmt_jaco_status`` /
``lcmt_jaco_command`` (:func:`~drake_disamb.station.lcm.station.build_lcm_station`)."""

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import ClassVar

from pydrake.geometry import Meshcat

from drake_disamb.station.build import Station
from drake_disamb.station.config import SceneObject, StationConfig
from drake_disamb.station.lcm.driver import DEFAULT_COMMAND_CHANNEL, DEFAULT_STATUS_CHANNEL, SimulatedDriver

DEFAULT_LCM_URL = "udpm://239.255.76.67:7667?ttl=0"
"""LCM's default bus: UDP multicast that never leaves the machine (``ttl=0``)."""


@dataclass  # (no postponed annotations in this module: Drake's YAML loader reads the field types)
class Lcm:
    """A station whose arm is on an LCM bus (YAML ``station: !Lcm {lcm_url: ..., ...}``).

    Attributes:
        lcm_url: The bus (``udpm://GROUP:PORT?ttl=0`` on one machine, ``memq://`` in one process).
        status_channel, command_channel: The driver's channels (Drake's Kinova Gen2 driver's by
            default).
        status_timeout: The watchdog (s, wall clock): no fresh, valid status for this long latches
            a fault and commands zero, and so does a controller that left the bus unwatched for
            this long (its process paused or starved). 0.03 s is 3 status periods at 100 Hz; a
            driver that announces a longer period (the spacing of its statuses' ``utime``: a
            slow link) scales it alike (3 of its periods by default).
        max_status_period: The longest status period (s) the watchdog follows: a driver whose
            statuses come further apart at the start is refused, and later trips the watchdog.
            0.05 s is 20 Hz (a driver whose SDK calls take 5 ms each holds about 43 Hz).
        start_timeout: How long (s) the start waits for the first status.
        zero_command_repeats: Zero commands sent on exit, Ctrl-C, SIGTERM or an exception.
        finger_speed_limit: Largest finger slide speed sent (m/s).
    """

    name: ClassVar[str] = "lcm"

    lcm_url: str = DEFAULT_LCM_URL
    status_channel: str = DEFAULT_STATUS_CHANNEL
    command_channel: str = DEFAULT_COMMAND_CHANNEL
    status_timeout: float = 0.03
    max_status_period: float = 0.05
    start_timeout: float = 5.0
    zero_command_repeats: int = 5
    finger_speed_limit: float = 0.1

    def check(self) -> None:
        """Raise ``ValueError`` naming the field and the value unless every setting is usable."""
        if not isinstance(self.lcm_url, str) or "://" not in self.lcm_url:
            raise ValueError(
                f"station.lcm_url: expected a URL such as {DEFAULT_LCM_URL}, got {self.lcm_url!r}"
            )
        for name in ("status_channel", "command_channel"):
            if not isinstance(getattr(self, name), str) or not getattr(self, name):
                raise ValueError(f"station.{name}: expected a channel name, got {getattr(self, name)!r}")
        for name, low, high in (
            ("status_timeout", 0.005, 1.0),
            ("max_status_period", 0.005, 1.0),
            ("start_timeout", 0.01, 600.0),
            ("finger_speed_limit", 0.0, 1.0),
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and low < v <= high):
                raise ValueError(f"station.{name}: expected a number in ({low:g}, {high:g}], got {v!r}")
        if not (isinstance(self.zero_command_repeats, int) and 1 <= self.zero_command_repeats <= 100):
            raise ValueError(
                "station.zero_command_repeats: expected an integer in [1, 100], "
                f"got {self.zero_command_repeats!r}"
            )

    def build(
        self, config: StationConfig, scene_objects: Iterable[SceneObject] = (), meshcat: Meshcat | None = None
    ) -> Station:
        """The station on the bus ``lcm_url`` (waits for the arm's first status)."""
        from drake_disamb.station.lcm.station import build_lcm_station

        self.check()
        return build_lcm_station(self, config, scene_objects, meshcat)


@dataclass
class InProcessLcm(Lcm):
    """The LCM station and the simulated driver in one process, on one ``memq://`` bus: the
    station steps the driver before each poll, so a trial is deterministic (for tests; not a
    YAML choice). ``driver`` is made on first build when not given."""

    driver: SimulatedDriver | None = None

    def build(
        self, config: StationConfig, scene_objects: Iterable[SceneObject] = (), meshcat: Meshcat | None = None
    ) -> Station:
        """The station and, when needed, its driver on a new ``memq://`` bus."""
        from pydrake.lcm import DrakeLcm

        from drake_disamb.station.lcm.station import build_lcm_station

        self.check()
        if self.driver is None:
            self.driver = SimulatedDriver(
                DrakeLcm("memq://"), config, self.status_channel, self.command_channel
            )
        return build_lcm_station(self, config, scene_objects, meshcat, self.driver.lcm, self.driver.step)
