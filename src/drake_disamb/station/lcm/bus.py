"""The ends of the wire: the station on LCM holds the status inbox (every status received, with its
wall-clock receipt time) and the command link (publishing commands, and the zero command sent
several times when the controller stops); the simulated driver holds the command inbox (the valid
commands received) and the status link (publishing statuses).

These hold I/O, not simulation state: like Drake's ``LcmSubscriberSystem``, an inbox buffers what
arrives between two control ticks; the receiving LeafSystem
(:class:`~drake_disamb.station.lcm.systems.JacoStatusReceiver`,
:class:`~drake_disamb.station.lcm.systems.JacoCommandReceiver`) moves it into its context's
discrete state at each tick.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable

import numpy as np
from pydrake.lcm import DrakeLcm

from drake_disamb.station.lcm.messages import make_command, read_command

Pump = Callable[[], None]
"""Called before each poll of the bus (the in-process driver steps there; ``None`` on a real wire)."""


class StatusInbox:
    """Subscribes to the status channel and buffers ``(message bytes, receipt time)``.

    A message's receipt time is when a poll handed it over: what arrived while the process was
    not polling (paused, or busy elsewhere) is stamped when it is finally handled, so
    :meth:`poll` also says how long the bus went unwatched.

    Attributes:
        last_good: ``time.monotonic()`` of the receipt of the last status the receiver used (the
            watchdog counts from it); set when the first status is taken.
        last_look: ``time.monotonic()`` at the end of the last poll.
    """

    def __init__(self, lcm: DrakeLcm, channel: str, pump: Pump | None = None) -> None:
        self._lcm = lcm
        self._pump = pump
        self._pending: list[tuple[bytes, float]] = []
        self.channel = channel
        self.last_good = self.last_look = time.monotonic()
        lcm.Subscribe(channel, self._on_message)

    def _on_message(self, data: bytes) -> None:
        self._pending.append((bytes(data), time.monotonic()))

    def poll(self, timeout: float) -> float:
        """Receive what arrives within ``timeout`` seconds, then everything already queued (LCM
        hands over one message per call: a backlog is drained, never left to overflow).

        Returns:
            The longest time (s, wall clock) the bus went unwatched up to this poll's end: since
            the end of the previous poll, or within this one beyond ``timeout`` (the in-process
            driver's step counts too).
        """
        start = time.monotonic()
        if self._pump is not None:
            self._pump()
        if self._lcm.HandleSubscriptions(max(0, int(timeout * 1000))) > 0:
            while self._lcm.HandleSubscriptions(0) > 0:
                pass
        end = time.monotonic()
        unwatched = max(start - self.last_look, end - start - timeout)
        self.last_look = end
        return unwatched

    def take(self) -> list[tuple[bytes, float]]:
        """Every message received since the last take, oldest first."""
        out, self._pending = self._pending, []
        return out


KEPT_LATENCIES = 360_000
"""Latencies a :class:`CommandLink` keeps (an hour at 100 Hz)."""


class CommandLink:
    """Publishes commands on the command channel, and zero commands when the controller stops.

    Attributes:
        latencies: Wall-clock seconds from the receipt of the status a command answers to its
            publication, one per command, the last :data:`KEPT_LATENCIES` (the hardware-loop
            benchmark reads them).
        sent: Commands published.
    """

    def __init__(self, lcm: DrakeLcm, channel: str, period: float, zero_repeats: int) -> None:
        self._lcm = lcm
        self.channel = channel
        self._period = float(period)
        self._zero_repeats = int(zero_repeats)
        self.latencies: deque[float] = deque(maxlen=KEPT_LATENCIES)
        self.sent = 0
        self._stopped = False
        self._answered: float | None = None

    def publish(self, msg: object, answered_at: float | None = None) -> None:
        """Publish one command; ``answered_at`` is the receipt time of the status it answers (a
        latency is recorded for the first command after each status)."""
        self._lcm.Publish(self.channel, msg.encode())  # type: ignore[attr-defined]
        self.sent += 1
        if answered_at is not None and answered_at != self._answered:
            if self._answered is not None:
                self.latencies.append(time.monotonic() - answered_at)
            self._answered = answered_at

    def stop_arm(self, utime: int = 0) -> None:
        """Send the zero command ``zero_repeats`` times, one period apart (idempotent: only the
        first call sends; called on exit, Ctrl-C, SIGTERM and exceptions)."""
        if self._stopped:
            return
        self._stopped = True
        zero6, zero2 = np.zeros(6), np.zeros(2)
        for k in range(self._zero_repeats):
            self._lcm.Publish(self.channel, make_command(utime, zero6, zero6, zero2, zero2).encode())
            if k + 1 < self._zero_repeats:
                time.sleep(self._period)


class CommandInbox:
    """Subscribes to the command channel and keeps each valid command (decoded and checked by
    :func:`~drake_disamb.station.lcm.messages.read_command`: DH joint velocities, rad/s, and finger
    slide speeds, m/s) until it is taken; an invalid one is dropped.

    Attributes:
        received: Valid commands received.
        dropped: Commands dropped (undecodable, wrong sizes, not finite).
    """

    def __init__(self, lcm: DrakeLcm, channel: str) -> None:
        self._pending: list[tuple[np.ndarray, np.ndarray]] = []
        self.channel = channel
        self.received = self.dropped = 0
        lcm.Subscribe(channel, self._on_message)

    def _on_message(self, data: bytes) -> None:
        command, _ = read_command(bytes(data))
        if command is None:
            self.dropped += 1
            return
        self.received += 1
        self._pending.append(command)

    def take(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Every valid command received since the last take, oldest first."""
        out, self._pending = self._pending, []
        return out


class StatusLink:
    """Publishes statuses on the status channel.

    Attributes:
        sent: Statuses published.
    """

    def __init__(self, lcm: DrakeLcm, channel: str) -> None:
        self._lcm = lcm
        self.channel = channel
        self.sent = 0

    def publish(self, msg: object) -> None:
        """Publish one status."""
        self._lcm.Publish(self.channel, msg.encode())  # type: ignore[attr-defined]
        self.sent += 1


class DriverEnds:
    """The two ends of the wire a driver holds (the simulated one and the SDK's): the command
    inbox and the status link on ``lcm``, and their counts."""

    def __init__(self, lcm: DrakeLcm, status_channel: str, command_channel: str) -> None:
        self._inbox = CommandInbox(lcm, command_channel)
        self._link = StatusLink(lcm, status_channel)

    @property
    def statuses(self) -> int:
        """Statuses published."""
        return self._link.sent

    @property
    def commands(self) -> int:
        """Valid commands received."""
        return self._inbox.received

    @property
    def dropped(self) -> int:
        """Invalid commands received (dropped)."""
        return self._inbox.dropped
