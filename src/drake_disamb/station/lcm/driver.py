"""The simulated driver: the simulated station (:func:`~drake_disamb.station.build.build_station`:
our MultibodyPlant MICO, SAP, joint PD, gravity compensation, its set points integrated from the
commanded velocities) behind the same messages as a Kinova Gen2 arm's LCM driver.

It publishes ``lcmt_jaco_status`` every ``period`` (100 Hz; ``utime`` is its simulated time in us)
and obeys only ``lcmt_jaco_command``, with the real driver's semantics: joint velocities only (the
positions are ignored), on the station's joint-level inputs; when no valid command has arrived for
``command_timeout`` seconds, the arm stops (zero velocity, set points held). It knows nothing of the
controller: Drake's ``hardware_sim`` "no ground truth" regime.

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

from drake_disamb.station.build import Station, build_station
from drake_disamb.station.config import StationConfig
from drake_disamb.station.lcm.loop import prepare_loop
from drake_disamb.station.lcm.messages import make_status, read_command

DEFAULT_STATUS_CHANNEL = "KINOVA_JACO_STATUS"
"""The status channel of Drake's Kinova Gen2 driver."""
DEFAULT_COMMAND_CHANNEL = "KINOVA_JACO_COMMAND"
"""The command channel of Drake's Kinova Gen2 driver."""


class SimulatedDriver:
    """Our simulated MICO behind ``lcmt_jaco_status`` / ``lcmt_jaco_command`` (module docstring).

    Attributes:
        lcm: The bus.
        period: Status period (s); also the plant's control period.
        statuses: Statuses published.
        commands: Valid commands received; ``dropped``: invalid ones (ignored).
        station: The simulated station it runs.
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
        self._status_channel = status_channel
        self._timeout_steps = max(1, int(round(command_timeout / self.period)))
        self.station: Station = build_station(config, (), meshcat)
        self._simulator = Simulator(self.station.diagram)
        self._context = self._simulator.get_mutable_context()
        diagram = self.station.diagram
        self._v_port = diagram.GetInputPort("arm_velocity_command")
        self._fv_port = diagram.GetInputPort("finger_velocity_command")
        self._arm_port = diagram.GetOutputPort("arm_joint_state")
        self._finger_port = diagram.GetOutputPort("finger_state")
        self._command: tuple[np.ndarray, np.ndarray] = (np.zeros(6), np.zeros(2))
        self._steps_since_command = self._timeout_steps + 1
        self._fresh = False
        self.statuses = self.commands = self.dropped = 0
        self._steps = 0  # periods advanced: the time is steps * period (no drift from a running sum)
        self.alive = True
        self._set_velocity(np.zeros(6), np.zeros(2))
        self._simulator.Initialize()
        lcm.Subscribe(command_channel, self._on_command)

    def _on_command(self, data: bytes) -> None:
        command, _ = read_command(bytes(data))
        if command is None:
            self.dropped += 1
            return
        self.commands += 1
        self._command = command
        self._fresh = True

    def _set_velocity(self, v: np.ndarray, fv: np.ndarray) -> None:
        self._v_port.FixValue(self._context, v)
        self._fv_port.FixValue(self._context, fv)

    def publish_status(self) -> None:
        """Publish the arm's state now (``utime`` = simulated time, us)."""
        arm = self._arm_port.Eval(self._context)
        finger = self._finger_port.Eval(self._context)
        utime = int(round(self._context.get_time() * 1e6))
        msg = make_status(utime, arm[:6], arm[6:], finger[:2], finger[2:])
        self.lcm.Publish(self._status_channel, msg.encode())
        self.statuses += 1

    def step(self) -> None:
        """One period: take the latest command (zero after ``command_timeout`` without one),
        advance the plant, publish the status. Does nothing once :meth:`kill` was called."""
        if not self.alive:
            return
        self.lcm.HandleSubscriptions(0)
        if self._fresh:
            self._steps_since_command, self._fresh = 0, False
        else:
            self._steps_since_command += 1
        if self._steps_since_command < self._timeout_steps:
            self._set_velocity(*self._command)
        else:
            self._set_velocity(np.zeros(6), np.zeros(2))
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
        return np.asarray(self._arm_port.Eval(self._context))[:6].copy()


__all__ = [
    "DEFAULT_COMMAND_CHANNEL",
    "DEFAULT_STATUS_CHANNEL",
    "SimulatedDriver",
]
