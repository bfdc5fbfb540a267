"""The faults a station on a wire latches (its ``fault`` output port) and what each one means."""

from __future__ import annotations

import enum


class Fault(enum.IntEnum):
    """A latched fault of a station on a wire; once set it stays until the station is rebuilt, and
    every command sent from then on is zero."""

    NONE = 0
    STATUS_TIMEOUT = 1
    """No fresh, valid status within the status timeout (the driver or the arm stopped talking)."""
    JOINT_LIMIT = 2
    """A status put a joint outside our model's limits (the model and the arm disagree)."""
    TWO_SOURCES = 3
    """Statuses out of sequence, several within a second (a ``utime`` that goes back or repeats, a
    posture that jumps further than an arm moves): a second driver publishes on the status
    channel, and every driver on the bus obeys the commands."""
    CONTROLLER_STALLED = 4
    """The controller did not watch the bus for longer than the status timeout (its process was
    paused or starved): the watchdog was blind for longer than it allows."""

    @property
    def reason(self) -> str:
        """One line for the terminal and ``metrics.json``."""
        return _REASONS[self]


_REASONS = {
    Fault.NONE: "",
    Fault.STATUS_TIMEOUT: "no fresh arm status within the status timeout: the arm was commanded to stop",
    Fault.JOINT_LIMIT: "an arm status put a joint outside the model's limits: the arm was commanded to stop",
    Fault.TWO_SOURCES: (
        "arm statuses from two sources on the status channel (two drivers publishing on one bus?): "
        "the arm was commanded to stop"
    ),
    Fault.CONTROLLER_STALLED: (
        "the controller missed its periods for longer than the status timeout (paused or starved): "
        "the arm was commanded to stop"
    ),
}
