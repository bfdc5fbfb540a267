"""What the simulated user remembers between decisions: :class:`UserState` and its flat vector."""

from __future__ import annotations

import operator
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.interfaces import RAW_SIZE

__all__ = ["NOT_COUNTING", "UserState", "evolve"]

NOT_COUNTING = -1.0
"""``unhelped_since`` value meaning "the autonomy is currently helping" (times are >= 0)."""


@dataclass(frozen=True)
class UserState:
    """What the simulated user remembers between ticks.

    Attributes:
        busy_until: No action before this time (s): reacting to its last press, settling into a new
            mode, or pausing.
        requested_at_start: Whether the start-of-trial request was made (or passed up).
        unhelped_since: Time (s) since which the autonomy has not been helping, or
            :data:`NOT_COUNTING`.
        draws: Counter of random draws (keys the seeded generator).
        presses: Buttons pressed so far (mode + request).
        target_mode: The mode it is cycling toward, or -1.
        progress_mode: The mode whose progress it is watching (rule 5), or -1.
        progress_since: When the watch (re)started (s).
        progress_best: The mode's remaining error then (tolerance units).
        started: Whether the start delay was drawn.
        start_until: No mode switch or command before this time (s): the start delay.
        hold_until: A late release in progress: the raw signal is held until this time (s); 0 = none.
        request_mode: The mode when its last request was made while it waits for the switch, or -1.
        request_since: When that request was made (s).
        judge: The mode a request chose is to be accepted or left at the next free decision.
        overshot: It has pressed once too many toward the current target.
        aim_mode: The mode whose stopping points it has judged (``aim_error``), or -1.
        aim_0, aim_1: Its misjudgement of the goal along the mode's first and second dimension
            (m or rad): it drives until the error along the dimension is this.
        kept_mode: The mode a request chose and the user kept, while it keeps using it (the
            assistance helps), or -1.
        carrying: The wait in progress (``busy_until``) is a carry: the user lets the autonomy
            move the arm, and stops waiting as soon as the assistance stops helping.
        carry_best: The goal's remaining error (tolerance units) when the carry in progress, or
            the one just ended, began; -1 when none.
        counter_until: It counter-steers (pushes toward its goal in its mode while the autonomy
            assists another goal) until this time (s); 0 = not.
        blocked_best: The goal's remaining error summed over the arm modes (tolerance units) when
            the back-off watch began (it last fell by ``stall_progress``).
        blocked_time: The time spent commanding since then (s); 0 = the watch is not running.
        backoff_mode: The mode it backs off in (drives away from the goal), or -1.
        backoff_until: ... until this time (s).
        detour_mode: Routing around over the obstacle (``detour_lift``): the blocked mode, until
            its dimensions are done, or -1.
        detour_offset: Meanwhile the user sees the z error less this (m): it keeps the end
            effector lifted.
        push_mode: Pushing in a kept mode whose own dimensions are done (rule 6 while the
            assistance carries the arm): the mode, or -1 when not pushing.
        push_axis: ... the mode's dimension it pushes along (its index in the mode).
        push_sign: ... and the direction (+1 or -1), held for the whole push.
        raw: The raw signal produced at the last tick (what the user is holding).
    """

    busy_until: float = 0.0
    requested_at_start: bool = False
    unhelped_since: float = NOT_COUNTING
    draws: int = 0
    presses: int = 0
    target_mode: int = -1
    progress_mode: int = -1
    progress_since: float = 0.0
    progress_best: float = 0.0
    started: bool = False
    start_until: float = 0.0
    hold_until: float = 0.0
    request_mode: int = -1
    request_since: float = 0.0
    judge: bool = False
    overshot: bool = False
    aim_mode: int = -1
    aim_0: float = 0.0
    aim_1: float = 0.0
    kept_mode: int = -1
    carrying: bool = False
    carry_best: float = -1.0
    counter_until: float = 0.0
    blocked_best: float = 0.0
    blocked_time: float = 0.0
    backoff_mode: int = -1
    backoff_until: float = 0.0
    detour_mode: int = -1
    detour_offset: float = 0.0
    push_mode: int = -1
    push_axis: int = -1
    push_sign: float = 0.0
    raw: NDArray[np.float64] = field(default_factory=lambda: np.zeros(RAW_SIZE), compare=False)

    _INT = (
        "draws",
        "presses",
        "target_mode",
        "progress_mode",
        "request_mode",
        "aim_mode",
        "kept_mode",
        "backoff_mode",
        "detour_mode",
        "push_mode",
        "push_axis",
    )
    _BOOL = ("requested_at_start", "started", "judge", "overshot", "carrying")
    _FIELDS = (
        "busy_until",
        "requested_at_start",
        "unhelped_since",
        "draws",
        "presses",
        "target_mode",
        "progress_mode",
        "progress_since",
        "progress_best",
        "started",
        "start_until",
        "hold_until",
        "request_mode",
        "request_since",
        "judge",
        "overshot",
        "aim_mode",
        "aim_0",
        "aim_1",
        "kept_mode",
        "carrying",
        "carry_best",
        "counter_until",
        "blocked_best",
        "blocked_time",
        "backoff_mode",
        "backoff_until",
        "detour_mode",
        "detour_offset",
        "push_mode",
        "push_axis",
        "push_sign",
    )
    VECTOR_SIZE = 32 + RAW_SIZE

    def to_vector(self) -> NDArray[np.float64]:
        """Flat ``[busy_until, requested_at_start, unhelped_since, draws, presses, target_mode,
        progress_mode, progress_since, progress_best, started, start_until, hold_until, request_mode,
        request_since, judge, overshot, aim_mode, aim_0, aim_1, kept_mode, carrying, carry_best,
        counter_until, blocked_best, blocked_time, backoff_mode, backoff_until, detour_mode,
        detour_offset, push_mode, push_axis, push_sign, raw (4)]``."""
        head = map(float, _STATE_FIELDS(self))  # (one C-level read of the fields: a user decides every tick)
        return np.array([*head, *np.asarray(self.raw, dtype=float).tolist()], dtype=float)

    @classmethod
    def from_vector(cls, x: ArrayLike) -> UserState:
        """Inverse of :meth:`to_vector`."""
        v = np.asarray(x, dtype=float)
        if v.shape != (cls.VECTOR_SIZE,):
            raise ValueError(f"UserState vector: expected {cls.VECTOR_SIZE} numbers, got {v.shape}")
        values: dict[str, object] = dict(zip(cls._FIELDS, v[: len(cls._FIELDS)].tolist(), strict=True))
        for name in cls._INT:
            values[name] = int(round(values[name]))
        for name in cls._BOOL:
            values[name] = values[name] > 0.5
        return cls(**values, raw=v[len(cls._FIELDS) :].copy())


_STATE_FIELDS = operator.attrgetter(*UserState._FIELDS)
"""The fields of :meth:`UserState.to_vector`, in its order, as one tuple."""


def evolve(state: UserState, **changes: object) -> UserState:
    """``dataclasses.replace(state, **changes)`` without its per-call field inspection (the user
    steps every control tick). ``UserState`` has no ``__post_init__`` and no slots, so a copy of
    the instance dictionary with the changes is exactly what ``replace`` builds."""
    new = object.__new__(UserState)
    new.__dict__.update(state.__dict__)
    new.__dict__.update(changes)
    return new
