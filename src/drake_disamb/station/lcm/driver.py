"""The simulated driver: the simulated station (:func:`~drake_disamb.station.build.build_station`:
our MultibodyPlant MICO, SAP, joint PD, gravity compensation, its set points integrated from the
commanded velocities) behind the same messages as a Kinova Gen2 arm's LCM driver, in one diagram::

    lcmt_jaco_command ─▶ "command_receiver" ─ arm_velocity_command, finger_velocity_command ─▶ "station"
    "station" ─ arm_joint_state, finger_state ─▶ "status_sender" ─▶ lcmt_jaco_status

It publishes ``lcmt_jaco_status`` every ``period`` (100 Hz; ``utime`` is its simulated time in us)
and obeys only ``lcmt_jaco_command``, with the real driver's semantics: joint velocities only (the
positions are ignored), integrated into the PD's set points by the simulated station; when no valid
command has arrived for ``command_timeout`` seconds, the arm stops (zero velocity, set points
held). It knows nothing of the controller: Drake's ``hardware_sim`` "no ground truth" regime.

Two forms: :meth:`SimulatedDriver.run` paces itself at real time (the ``mico-driver`` process);
:meth:`SimulatedDriver.step` advances one period on demand, so a station on the same ``memq://``
bus can step it in its own loop (the in-process, deterministic form).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
from pydrake.geometry import Meshcat
from pydrake.lcm import DrakeLcm
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import Diagram, DiagramBuilder

from drake_disamb.station.build import Station, build_station
from drake_disamb.station.config import StationConfig
from drake_disamb.station.lcm.bus import DriverEnds
from drake_disamb.station.lcm.loop import prepare_loop
from drake_disamb.station.lcm.systems import JacoCommandReceiver, JacoStatusSender
from drake_disamb.station.ports import SHARED_INPUTS

DEFAULT_STATUS_CHANNEL = "KINOVA_JACO_STATUS"
"""The status channel of Drake's Kinova Gen2 driver."""
DEFAULT_COMMAND_CHANNEL = "KINOVA_JACO_COMMAND"
"""The command channel of Drake's Kinova Gen2 driver."""


class SimulatedDriver(DriverEnds):
    """Our simulated MICO behind ``lcmt_jaco_status`` / ``lcmt_jaco_command`` (module docstring).

    Attributes:
        lcm: The bus.
        period: Status period (s); also the station's control period.
        station: The simulated station (subsystem ``"station"`` of ``diagram``).
        diagram: The driver's one diagram (named ``"mico_driver"``): the station, the command
            receiver and the status sender.
    """

    def __init__(
        self,
        lcm: DrakeLcm,
        config: StationConfig | None = None,
        status_channel: str = DEFAULT_STATUS_CHANNEL,
        command_channel: str = DEFAULT_COMMAND_CHANNEL,
        command_timeout: float = 0.03,
        meshcat: Meshcat | None = None,
    ) -> None:
        config = config or StationConfig()
        self.lcm = lcm
        self.period = float(config.control_period)
        builder = DiagramBuilder()
        self.station: Station = build_station(config, (), meshcat)
        builder.AddSystem(self.station.diagram)
        DriverEnds.__init__(self, lcm, status_channel, command_channel)
        timeout_ticks = max(1, int(round(command_timeout / self.period)))
        receiver = builder.AddNamedSystem(
            "command_receiver", JacoCommandReceiver(self._inbox, self.period, timeout_ticks)
        )
        self._sender = builder.AddNamedSystem("status_sender", JacoStatusSender(self._link))
        for name in SHARED_INPUTS:
            builder.Connect(receiver.GetOutputPort(name), self.station.diagram.GetInputPort(name))
        for name in ("arm_joint_state", "finger_state"):
            builder.Connect(self.station.diagram.GetOutputPort(name), self._sender.GetInputPort(name))
        self.diagram: Diagram = builder.Build()
        self.diagram.set_name("mico_driver")
        self._simulator = Simulator(self.diagram)
        self._context = self._simulator.get_mutable_context()
        self._steps = 0  # periods advanced: the time is steps * period (no drift from a running sum)
        self.alive = True
        self._simulator.Initialize()

    def publish_status(self) -> None:
        """Publish the arm's state now (``utime`` = simulated time, us)."""
        self._sender.ForcedPublish(self._sender.GetMyContextFromRoot(self._context))

    def step(self) -> None:
        """One period: receive what is on the bus, advance the diagram (the receiver takes the
        latest command, zero after ``command_timeout`` without one; the station integrates it and
        steps the plant), publish the status. Does nothing once :meth:`kill` was called."""
        if not self.alive:
            return
        self.lcm.HandleSubscriptions(0)
        self._steps += 1
        self._simulator.AdvanceTo(self._steps * self.period)
        self.publish_status()

    def kill(self) -> None:
        """Stop publishing, as a driver that died would (the in-process tests' fault)."""
        self.alive = False

    def run(
        self,
        stop: Callable[[], bool],
        duration: float | None = None,
        on_start: Callable[[], None] | None = None,
    ) -> int:
        """Step at real time (one status every ``period`` of wall time) until ``stop()`` or
        ``duration`` seconds of simulated time; returns the periods that started late. The steps
        keep to a grid of ``period``; one that starts late is caught up over the next ones, with
        never two statuses less than half a period apart (as even a stream as a real driver's).
        ``on_start`` is called once the process is ready, just before the first status (with no
        numba cache, readying it compiles the kernels: several seconds)."""
        prepare_loop()  # no kernel load, no full collection of the plant, BLAS on one thread
        if on_start is not None:
            on_start()
        late = 0
        next_tick = time.monotonic()
        while not stop() and (duration is None or self._steps * self.period < duration):
            self.step()
            published = time.monotonic()
            next_tick += self.period
            if next_tick <= published:
                late += 1
            next_tick = max(next_tick, published + self.period / 2)
            self.lcm.HandleSubscriptions(0)
            time.sleep(max(0.0, next_tick - time.monotonic()))
        return late

    def joint_positions(self) -> np.ndarray:
        """The arm's DH angles now (rad)."""
        station = self.station.diagram
        arm = station.GetOutputPort("arm_joint_state").Eval(station.GetMyContextFromRoot(self._context))
        return np.asarray(arm)[:6].copy()


__all__ = [
    "DEFAULT_COMMAND_CHANNEL",
    "DEFAULT_STATUS_CHANNEL",
    "SimulatedDriver",
]
