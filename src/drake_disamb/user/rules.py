"""The simulated user's rules at a free decision, one function per rule (pure numpy).

:func:`decide` runs them in order on one :class:`Decision` (its inputs, the state so far and the
random-draw counter); each returns the decision's new state, or ``None`` to pass on to the next.
The order, and what each rule does, is the policy of :mod:`drake_disamb.user.policy`:

- :func:`release_rule` (rule 1 with a release): at the goal, change to the gripper mode and open;
- :func:`await_request_rule`: after a request, wait for the mode it chooses;
- :func:`request_rule` (rule 3): the requests at the start and when unhelped;
- :func:`start_delay_rule`: nothing but requests before the start delay ends;
- :func:`aim_rule` (judging where to stop): the error as the user sees it in its mode;
- :func:`judge_request_rule`: keep the mode a request chose, or change away from it;
- :func:`backoff_rule` (rule 5, blocked): no progress in any mode for a while: back off the way
  it came, then route around: over the obstacle (a lift, :func:`_detour`) or in another mode;
- :func:`kept_mode_rule`: a kept (or, proportional interface, any) mode used while assisted;
- :func:`carry_rule`: the mode done while assisted: let the autonomy carry the arm (as a stall
  or a review that wants another mode does while assisted);
- :func:`target_rule` (rule 4): change toward the target mode, or pick one when the mode is done;
- :func:`stall_rule` (rule 5): leave a mode in which commanding stopped paying off;
- :func:`review_rule`: is another mode clearly better now?
- :func:`pause_rule`: pauses;
- :func:`command_rule` (rule 6): drive along the mode's dimensions (or a wrong press).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core.layout import GRIPPER_DIM, is_rotation_mode
from drake_disamb.core.sampling import lognormal, sample_von_mises_fisher
from drake_disamb.interfaces import RAW_SIZE, InterfaceConfig
from drake_disamb.user.config import UserConfig
from drake_disamb.user.judgement import choose_mode, dim_tolerances, draw, mode_remaining
from drake_disamb.user.state import NOT_COUNTING, UserState, evolve

__all__ = ["RULES", "Decision", "decide"]

_Z = 2
"""The world z position's index in the goal error (the dimension a detour lifts)."""


class Decision:
    """One free decision in progress.

    Attributes:
        state: The user's state so far (rules replace it as they go).
        time, mode, err, interface, config, belief, assisted, releasing, misled: The decision's
            inputs (``misled``: the autonomy assists another goal)
            (``err`` becomes the error as the user judges it, :func:`aim_rule`).
        draws: The random-draw counter so far.
        remaining, arm_remaining: Every mode's (the arm modes') remaining error, set by
            :func:`aim_rule` (and raised for a kept mode by :func:`kept_mode_rule`).
        target: The mode the user is changing toward, or -1.
        keep: A kept mode is carried by the assistance (:func:`kept_mode_rule`).
        use_requests: The user may ask for disambiguation instead of changing mode.
        after_carry: The wait that just ended was a carry (:func:`carry_rule`).
    """

    def __init__(
        self,
        state: UserState,
        time: float,
        mode: int,
        err: NDArray[np.float64],
        interface: InterfaceConfig,
        config: UserConfig,
        belief: ArrayLike | None,
        assisted: bool,
        releasing: bool,
        misled: bool = False,
    ) -> None:
        self.state = state
        self.misled = misled
        self.time = time
        self.mode = mode
        self.err = err
        self.interface = interface
        self.variant = interface.variant
        self.config = config
        self.belief = belief
        self.assisted = assisted
        self.releasing = releasing
        self.modes = interface.modes
        self.n_modes = len(self.modes)
        self.selection = interface.mode_selection
        self.direct = self.selection == "direct"
        self.zero = np.zeros(RAW_SIZE)
        self.period = config.period(interface)
        self.draws = state.draws
        self.remaining: NDArray[np.float64] = np.zeros(0)
        self.arm_remaining: NDArray[np.float64] = np.zeros(0)
        self.target = -1
        self.keep = False
        self.use_requests = belief is not None and config.requests.request_instead_prob > 0
        self.after_carry = state.carrying  # the wait that just ended was a carry
        if state.carrying:
            self.state = evolve(state, carrying=False)
        if state.detour_mode >= 0:  # routing around over the obstacle (:func:`_detour`)
            if mode_remaining(err, (self.modes[state.detour_mode],), config)[0] <= 1.0:
                self.state = evolve(self.state, detour_mode=-1, detour_offset=0.0)  # past it
            else:
                self.err = err = err.copy()
                err[_Z] -= state.detour_offset  # it keeps the hand lifted

    def rng(self) -> np.random.Generator:
        """The next random draw's generator (advances the counter)."""
        g = draw(self.config, self.draws)
        self.draws += 1
        return g

    def request_chance(self, p: float) -> bool:
        """Whether a request of probability ``p`` (scaled by the decay over time) is made."""
        decay = self.config.requests.request_decay_time
        if decay is not None:
            p *= math.exp(-self.time / decay)
        return p >= 1.0 or (p > 0 and self.rng().random() < p)

    def press(self, signal: list[float], **changes: object) -> UserState:
        """Produce ``signal`` (a mode change or a request) and react to it: everything released
        for a reaction time after."""
        timing = self.config.timing
        wait = timing.reaction_time
        if timing.reaction_time_jitter > 0 or timing.reaction_log_sd > 0:
            g = self.rng()
            if timing.reaction_time_jitter > 0:
                wait += g.uniform(-timing.reaction_time_jitter, timing.reaction_time_jitter)
            wait = lognormal(wait, timing.reaction_log_sd, g)
        return evolve(
            self.state,
            raw=np.array(signal, dtype=float),
            busy_until=self.time + max(wait, 2.0 * self.period),
            draws=self.draws,
            presses=self.state.presses + 1,
            progress_mode=-1,  # every press restarts the stall watch (rule 5)
            **changes,
        )

    def change(self, target: int, **changes: object) -> UserState:
        """The next mode change toward ``target`` (the kind's action for it), aiming at it."""
        signal = self.variant.change_raw(self.mode, target, self.selection)
        return self.press(signal, target_mode=target, **changes)

    def request(self, **changes: object) -> UserState:
        """A disambiguation request: restarts the "unhelped" timer and drops a change's target."""
        return self.press(
            self.variant.request_raw(),
            target_mode=-1,
            request_mode=self.mode,
            request_since=self.time,
            **changes,
        )

    def settle(self, **changes: object) -> UserState | None:
        """The settle wait after a finished mode change, or ``None`` when there is none."""
        timing = self.config.timing
        if timing.settle_time <= 0 or (
            timing.settle_prob < 1.0 and self.rng().random() >= timing.settle_prob
        ):
            return None
        g = self.rng() if timing.settle_log_sd > 0 else None
        wait = lognormal(timing.settle_time, timing.settle_log_sd, g)
        return evolve(
            self.state,
            raw=self.zero,
            busy_until=self.time + max(wait, self.period),
            draws=self.draws,
            **changes,
        )

    def choose(self, exclude_current: bool | None = False) -> int:
        """The arm mode to go for next (:func:`~drake_disamb.user.judgement.choose_mode`);
        ``exclude_current=None``: leave the current mode out only when the choice is random."""
        g = self.rng() if self.config.mode_choice.mode_temperature > 0 else None
        exclude = g is not None if exclude_current is None else exclude_current
        return choose_mode(
            self._weighed_remaining(),
            self.mode,
            self.n_modes,
            self.config,
            g,
            exclude_current=exclude,
            direct=self.direct,
            back=self.variant.steps_back,
        )

    def _weighed_remaining(self) -> NDArray[np.float64]:
        """The arm modes' remaining errors as the mode choice weighs them: while the autonomy does
        not assist the goal and a translation mode has work left, a rotation mode's times
        ``unsure_rotation_weight`` (the user translates first)."""
        weight = self.config.mode_choice.unsure_rotation_weight
        remaining = self.arm_remaining
        if weight >= 1.0 or self.assisted:
            return remaining
        rotation = _rotation_modes(self.modes)[: remaining.size]
        if not np.any(remaining[~rotation] > 1.0):
            return remaining  # nothing left to translate: the rotations are what is left
        return np.where(rotation, weight * remaining, remaining)


@functools.lru_cache(maxsize=16)
def _rotation_modes(modes: tuple[tuple[int, ...], ...]) -> NDArray[np.bool_]:
    """Per mode, whether it is a rotation mode (:func:`~drake_disamb.core.layout.is_rotation_mode`)
    (read-only)."""
    out = np.array([is_rotation_mode(dims) for dims in modes])
    out.setflags(write=False)
    return out


def release_rule(d: Decision) -> UserState | None:
    """Rule 1 with a release: at the goal, change to the gripper mode (the changes, with the waits
    after them, as any mode change), settle into it, and open the gripper until the stage ends."""
    if not d.releasing:
        return None
    grip = d.n_modes - 1
    d.state = evolve(d.state, request_mode=-1, judge=False, kept_mode=-1)
    if d.mode != grip:
        return d.change(grip, overshot=False)
    if d.state.target_mode == grip:
        d.state = evolve(d.state, target_mode=-1)
        out = d.settle()
        if out is not None:
            return out
    raw = np.array(d.variant.drive_raw([1.0]))  # the gripper mode's one dimension: opens
    return evolve(d.state, raw=raw, target_mode=-1, draws=d.draws)


def await_request_rule(d: Decision) -> UserState | None:
    """A request was made: wait for the mode it chooses, then settle into it and judge it."""
    state = d.state
    if state.request_mode < 0:
        return None
    if d.mode == state.request_mode and d.time - state.request_since < d.config.requests.request_wait - 1e-9:
        return evolve(state, raw=d.zero)
    changed = d.mode != state.request_mode
    d.state = evolve(state, request_mode=-1, judge=True)
    return d.settle() if changed else None


def request_rule(d: Decision) -> UserState | None:
    """Rule 3: the request at the start of the trial, and when the autonomy has not been helping
    for ``request_when_unhelped_for`` (each made with ``request_prob``)."""
    requests = d.config.requests
    restart = NOT_COUNTING if d.state.unhelped_since == NOT_COUNTING else d.time
    if requests.request_at_start and not d.state.requested_at_start:
        if d.request_chance(requests.request_prob):
            return d.request(requested_at_start=True, unhelped_since=restart)
        d.state = evolve(d.state, requested_at_start=True, draws=d.draws)
    if (
        requests.request_when_unhelped_for is not None
        and d.state.unhelped_since != NOT_COUNTING
        and d.time - d.state.unhelped_since >= requests.request_when_unhelped_for - 1e-9
    ):
        if d.request_chance(requests.request_prob):
            return d.request(unhelped_since=d.time)
        d.state = evolve(d.state, unhelped_since=d.time, draws=d.draws)  # let it pass; look again later
    return None


def start_delay_rule(d: Decision) -> UserState | None:
    """Before the start delay ends, nothing but requests."""
    if d.time < d.state.start_until - 1e-9:
        return evolve(d.state, raw=d.zero, draws=d.draws)
    return None


def aim_rule(d: Decision) -> UserState | None:
    """Every mode's remaining error, as the user judges it: with ``aim_error``, where to stop along
    the current mode's dimensions is judged by eye on entering it, and when the movement ends short
    it is corrected at once (``correction_prob``, or when nothing else is left: aimed anew)."""
    config, mode, modes, n_modes = d.config, d.mode, d.modes, d.n_modes
    remaining = mode_remaining(d.err, modes, config)
    if config.command.aim_error > 0 and mode < n_modes - 1:
        if d.state.aim_mode != mode:
            d.state = _aim(d.state, mode, d.err, modes, config, d.rng())
        seen = _seen_error(d.state, d.err, modes[mode])
        seen_remaining = float(mode_remaining(seen, (modes[mode],), config)[0])
        if seen_remaining <= 1.0 < remaining[mode]:
            # The primary movement ended short: correct it now, in this mode (a corrective
            # submovement, with probability correction_prob, or when nothing else is left).
            others = np.delete(remaining[: n_modes - 1], mode)
            p = config.command.correction_prob
            if d.variant.proportional and config.command.stick_correction_prob is not None:
                p = config.command.stick_correction_prob
            if others.size == 0 or float(np.max(others)) <= 1.0 or (p > 0 and d.rng().random() < p):
                d.state = _aim(d.state, mode, d.err, modes, config, d.rng())
                seen = _seen_error(d.state, d.err, modes[mode])
                seen_remaining = float(mode_remaining(seen, (modes[mode],), config)[0])
        d.err = seen
        remaining = remaining.copy()
        remaining[mode] = seen_remaining
    d.remaining = remaining
    d.arm_remaining = remaining[: n_modes - 1]
    d.target = d.state.target_mode
    return None


def judge_request_rule(d: Decision) -> UserState | None:
    """The mode a request chose: keep it (``accept_prob``), or change away to one of its own
    choice."""
    if not d.state.judge:
        return None
    requests = d.config.requests
    d.state = evolve(d.state, judge=False, kept_mode=d.mode if requests.keep_assisted_mode else -1)
    if requests.accept_prob < 1.0 and d.rng().random() >= requests.accept_prob:
        d.target = d.choose(exclude_current=True)
        if d.target != d.mode and d.arm_remaining[d.target] > 1.0:
            return d.change(d.target, overshot=False, kept_mode=-1)
        d.target = -1
    return None


def kept_mode_rule(d: Decision) -> UserState | None:
    """The kept mode: while the assistance helps, the arm approaches the goal in it whatever is left
    along the mode's own dimensions, so the user keeps using it until the whole goal's remaining
    error stops falling (rule 5 watches it) or the assistance stops helping. A counter-steer
    (:func:`_counter`) pushes so while the assistance pulls elsewhere."""
    stay = d.config.mode_choice.stay_while_assisted and d.variant.proportional
    countering = d.misled and d.time < d.state.counter_until - 1e-9
    if d.state.counter_until > 0.0 and not countering:
        d.state = evolve(d.state, counter_until=0.0)
    arm_mode = d.mode < d.n_modes - 1
    d.keep = arm_mode and (((d.state.kept_mode == d.mode or stay) and d.assisted) or countering)
    if d.state.kept_mode >= 0 and not d.keep:
        d.state = evolve(d.state, kept_mode=-1)
    if d.keep:
        _push_in_mode(d)
    return None


def _push_in_mode(d: Decision) -> None:
    """The current mode carries the whole goal's remaining error: the user pushes in it."""
    d.remaining = d.remaining.copy()
    d.remaining[d.mode] = max(float(d.remaining[d.mode]), float(np.max(d.arm_remaining)))
    d.arm_remaining = d.remaining[: d.n_modes - 1]


def carry_rule(d: Decision) -> UserState | None:
    """Letting the autonomy carry the arm: the current mode has nothing left to do while the
    autonomy assists the goal (:func:`_carry`), or counter-steering while it assists another
    (:func:`_counter`)."""
    if d.target >= 0 or d.remaining[d.mode] > 1.0:
        return None
    return _carry(d) or _counter(d)


def _counter(d: Decision) -> UserState | None:
    """A change is wanted while the autonomy assists another goal: with ``counter_prob`` the user
    counter-steers instead, pushing toward its goal in its mode (as in a kept mode) for a
    lognormal ``carry_duration``. Returns the push, or ``None``: the change goes ahead."""
    pauses = d.config.pauses
    if pauses.counter_prob <= 0 or not d.misled or d.mode >= d.n_modes - 1:
        return None
    if d.time < d.state.counter_until - 1e-9:
        return None  # a counter-steer has stalled (rule 5): the change goes ahead
    if not (pauses.counter_prob >= 1.0 or d.rng().random() < pauses.counter_prob):
        return None
    g = d.rng() if pauses.pause_log_sd > 0 else None
    until = d.time + max(lognormal(pauses.carry_duration, pauses.pause_log_sd, g), d.period)
    d.state = evolve(d.state, counter_until=until, draws=d.draws, progress_mode=-1)
    d.keep = True
    _push_in_mode(d)
    return command_rule(d)


def _carry(d: Decision) -> UserState | None:
    """A change is wanted (the mode is done, stalled or a review prefers another) while the
    autonomy assists the goal: with ``carry_prob`` the user lets go and watches for a lognormal
    ``carry_duration`` instead. After a carry, another one only if it brought the goal's remaining
    error down by ``stall_progress`` or by a quarter (the attractor slows as the arm closes in;
    else the autonomy is not getting there: the user changes mode). ``None``: no carry, the change
    goes ahead."""
    pauses = d.config.pauses
    if pauses.carry_prob <= 0 or not d.assisted:
        return None
    left = float(np.max(d.arm_remaining))
    best = d.state.carry_best
    progress = min(d.config.mode_choice.stall_progress, 0.25 * best)
    if d.after_carry and best >= 0 and left > best - progress:
        return None
    if not (pauses.carry_prob >= 1.0 or d.rng().random() < pauses.carry_prob):
        return None
    g = d.rng() if pauses.pause_log_sd > 0 else None
    wait = lognormal(pauses.carry_duration, pauses.pause_log_sd, g)
    return evolve(
        d.state,
        raw=d.zero,
        busy_until=d.time + max(wait, d.period),
        draws=d.draws,
        carrying=True,
        carry_best=left,
        progress_mode=-1,
    )


def target_rule(d: Decision) -> UserState | None:
    """Rule 4: on reaching the target (possibly one change too many, ``overshoot_prob``) settle;
    when the mode has nothing left to do, pick a target (or ask for disambiguation instead) and
    change toward it, one change per reaction time."""
    mode, target = d.mode, d.target
    if target >= 0 and target == mode:
        p = d.config.mode_choice.overshoot_prob
        if p > 0 and not d.direct and not d.state.overshot and d.rng().random() < p:
            # One too many (one step on): cycling goes round again to the target. Direct selection
            # is one deliberate press per change: nothing to overshoot.
            return d.press(d.variant.step_raw(1), overshot=True)
        d.state = evolve(d.state, target_mode=-1, overshot=False)
        out = d.settle()
        if out is not None:
            return out
        target = -1
    if target >= 0 and d.remaining[target] <= 1.0:
        target = -1  # nothing left to do there
    if target < 0 and d.remaining[mode] <= 1.0:
        if d.use_requests and d.request_chance(d.config.requests.request_instead_prob):
            return d.request()
        # A Boltzmann user never "chooses" the exhausted mode it is in (the oracle cannot: it is the least).
        target = d.choose(exclude_current=None)
        if target == mode:  # unreachable with validated tolerances: nothing left anywhere
            return evolve(d.state, raw=d.zero, target_mode=-1, draws=d.draws)
        return d.change(target, overshot=False)
    if target >= 0:
        return d.change(target)
    d.state = evolve(d.state, target_mode=-1)
    return None


def stall_rule(d: Decision) -> UserState | None:
    """Rule 5: a mode in which commanding has stopped paying off (``stall_time`` without a fall of
    ``stall_progress``) is left for another one, or the user asks for help."""
    choice, mode = d.config.mode_choice, d.mode
    if choice.stall_time is None:
        return None
    now_remaining = float(d.remaining[mode])
    state = d.state
    if state.progress_mode != mode or now_remaining <= state.progress_best - choice.stall_progress:
        d.state = evolve(state, progress_mode=mode, progress_since=d.time, progress_best=now_remaining)
    elif d.time - state.progress_since >= choice.stall_time - 1e-9:
        carried = _carry(d) or _counter(d)  # let the autonomy carry the arm, or push against it
        if carried is not None:
            return carried
        if _others_left(d):
            if d.use_requests and d.request_chance(d.config.requests.request_instead_prob):
                return d.request()
            changed = _change_away(d)
            if changed is not None:
                return changed
        # Nothing else to do: the arm does not follow (the autonomy holds it at another goal,
        # or a limit): ask the system for help if it can, else keep at it and watch again.
        if d.use_requests:
            return d.request()
        d.state = evolve(d.state, progress_since=d.time, progress_best=now_remaining)
    return None


def backoff_rule(d: Decision) -> UserState | None:
    """Backing off: after ``backoff_after`` seconds of commanding (in any modes, across presses
    and requests) without the goal's remaining error (summed over the arm modes) falling by
    ``stall_progress``, the arm is blocked (a joint limit, the floor, the IK stopping): the user
    drives away from the goal in its mode for ``backoff_time``, then routes around: it changes to
    the best other mode with something left to do (or goes on in this one when there is none), or,
    as for any change of its own, asks for disambiguation instead (``request_instead_prob``).
    A back-off ends early if the mode changes meanwhile."""
    choice, state = d.config.mode_choice, d.state
    if choice.backoff_time <= 0:
        return None
    if state.backoff_mode >= 0:
        if d.mode != state.backoff_mode:
            d.state = evolve(state, backoff_mode=-1, backoff_until=0.0)
            return None
        if d.time < state.backoff_until - 1e-9:
            return _reverse(d)
        d.state = evolve(state, backoff_mode=-1, backoff_until=0.0, progress_mode=-1)
        if d.use_requests and d.request_chance(d.config.requests.request_instead_prob):
            return d.request()  # routing around is a change of its own: it may ask for it instead
        detour = _detour(d, state.backoff_mode)
        if detour is not None:
            return detour
        return _change_away(d) if _others_left(d) else None
    left = float(np.sum(d.arm_remaining))
    if state.blocked_time <= 0.0 or left < state.blocked_best - choice.stall_progress:
        d.state = evolve(state, blocked_best=left, blocked_time=d.period)
        return None
    if not d.variant.is_driving(state.raw):
        return None  # the watch counts commanding time only
    blocked = state.blocked_time + d.period
    if blocked < choice.backoff_after - 1e-9 or d.mode >= d.n_modes - 1 or d.arm_remaining[d.mode] <= 1.0:
        d.state = evolve(state, blocked_time=blocked)
        return None
    d.state = evolve(
        state,
        blocked_time=0.0,
        backoff_mode=d.mode,
        backoff_until=d.time + choice.backoff_time,
        progress_mode=-1,
        kept_mode=-1,
        detour_mode=-1,  # blocked on a detour too: it drops it (and routes around by mode)
        detour_offset=0.0,
    )
    return _reverse(d)


def _detour(d: Decision, blocked: int) -> UserState | None:
    """After a back-off in ``blocked``, a mode that does not move the hand vertically, route over
    the obstacle (``detour_lift``): see the goal ``detour_lift`` higher until ``blocked`` is done
    (:class:`Decision` applies it) and change to the mode that lifts. ``None``: no detour."""
    lift = d.config.mode_choice.detour_lift
    if lift <= 0 or d.state.detour_mode >= 0 or _Z in d.modes[blocked]:
        return None
    lifting = next((m for m, dims in enumerate(d.modes[:-1]) if _Z in dims), -1)
    if lifting < 0:
        return None
    d.state = evolve(d.state, detour_mode=blocked, detour_offset=float(d.err[_Z]) - lift)
    return d.change(lifting, overshot=False)


def _others_left(d: Decision) -> bool:
    """Another arm mode than the current one has something left to do."""
    others = d.arm_remaining.copy()
    if d.mode < others.size:
        others[d.mode] = -np.inf
    return bool(np.max(others) > 1.0)


def _change_away(d: Decision) -> UserState | None:
    """Change toward the best other arm mode (the user's choice), if it has something left to do."""
    best = d.choose(exclude_current=True)
    if best != d.mode and d.arm_remaining[best] > 1.0:
        return d.change(best, overshot=False)
    return None


def _reverse(d: Decision) -> UserState:
    """The command of rule 6 with the mode's errors reversed: back the way it came."""
    err = d.err.copy()
    for dim in d.modes[d.mode]:
        if dim != GRIPPER_DIM:
            err[dim] = -err[dim]
    d.err, d.keep = err, False
    return command_rule(d)


def review_rule(d: Decision) -> UserState | None:
    """Reviews (``mode_review_rate``): while the mode still helps, is another one better now?
    (People interleave modes.) Not while a kept mode carries the user with the assistance."""
    rate = d.config.mode_choice.mode_review_rate
    if rate > 0 and not d.keep and d.rng().random() < -math.expm1(-rate * d.period):
        choice = d.choose()
        if choice != d.mode and d.arm_remaining[choice] > 1.0:
            carried = _carry(d) or _counter(d)
            if carried is not None:
                return carried
            if d.use_requests and d.request_chance(d.config.requests.request_instead_prob):
                return d.request()  # a change is wanted: ask for it instead, as in rules 4 and 5
            return d.change(choice, overshot=False)
    return None


def pause_rule(d: Decision) -> UserState | None:
    """Pauses (fatigue, thinking): started at rate ``pause_rate``, of lognormal duration."""
    pauses = d.config.pauses
    if pauses.pause_rate > 0 and d.rng().random() < -math.expm1(-pauses.pause_rate * d.period):
        g = d.rng() if pauses.pause_log_sd > 0 else None
        wait = lognormal(pauses.pause_duration, pauses.pause_log_sd, g)
        # The stall watch (rule 5) counts commanding time: it starts again after the pause.
        return evolve(
            d.state, raw=d.zero, busy_until=d.time + max(wait, d.period), draws=d.draws, progress_mode=-1
        )
    return None


def command_rule(d: Decision) -> UserState:
    """Rule 6: drive toward the goal along the mode's dimensions. A proportional interface: each
    axis proportional to its dimension's error (at least ``min_axis``), with the stick's noise; a
    switched one: full drive in the error's direction. Starting to drive, a wrong press
    (``wrong_press_prob``) makes a mode change instead."""
    config, variant, err = d.config, d.variant, d.err
    command = config.command
    dims = d.modes[d.mode]
    tol = dim_tolerances(config)
    speeds = d.interface.dim_speeds()
    raw = d.zero
    push_k, push_sign = _push(d, err, dims, tol)
    if variant.proportional:
        axes = [0.0, 0.0]
        active = []
        for k, dim in enumerate(dims):
            if k == push_k:
                axes[k] = push_sign * command.min_axis
                active.append(k)
                continue
            if dim == GRIPPER_DIM or abs(err[dim]) <= tol[dim]:
                continue
            axis = float(np.clip(err[dim] / command.approach_time / speeds[dim], -1.0, 1.0))
            if abs(axis) < command.min_axis:
                axis = math.copysign(command.min_axis, err[dim])
            axes[k] = axis
            active.append(k)
        if active and (command.direction_kappa is not None or command.deflection_log_sd > 0):
            g = d.rng()
            stick = np.array(axes)
            size = float(np.linalg.norm(stick))
            if command.direction_kappa is not None:
                stick = sample_von_mises_fisher(stick, command.direction_kappa, g)
            stick = stick * lognormal(size, command.deflection_log_sd, g)
            axes = stick.tolist()
        for k in range(2):
            if command.axis_noise > 0 and k in active:
                axes[k] += float(d.rng().normal(0.0, command.axis_noise))
        raw = np.array(variant.drive_raw(axes))
    else:
        dim = dims[0]
        if push_k == 0:
            raw = np.array(variant.drive_raw([push_sign]))
        elif dim != GRIPPER_DIM:
            if err[dim] > tol[dim]:
                raw = np.array(variant.drive_raw([1.0]))
            elif err[dim] < -tol[dim]:
                raw = np.array(variant.drive_raw([-1.0]))
    p = config.mode_choice.wrong_press_prob
    if p > 0 and variant.is_driving(raw) and not variant.is_driving(d.state.raw) and d.rng().random() < p:
        return d.press(variant.step_raw(1))  # meant to drive, made a mode change
    return evolve(d.state, raw=raw, draws=d.draws)


RULES: tuple[Callable[[Decision], UserState | None], ...] = (
    release_rule,
    await_request_rule,
    request_rule,
    start_delay_rule,
    aim_rule,
    judge_request_rule,
    backoff_rule,
    kept_mode_rule,
    carry_rule,
    target_rule,
    stall_rule,
    review_rule,
    pause_rule,
)
"""The rules before the command, in order (:func:`command_rule` is the last, always deciding)."""


def decide(
    state: UserState,
    time: float,
    mode: int,
    err: NDArray[np.float64],
    interface: InterfaceConfig,
    config: UserConfig,
    belief: ArrayLike | None,
    assisted: bool,
    releasing: bool = False,
    misled: bool = False,
) -> UserState:
    """Rules 3 to 6 (and rule 1 with a release) at a free decision (not reacting, not letting go
    late); ``assisted``: the autonomy assists the user's goal
    (:func:`~drake_disamb.user.judgement.helped`); ``releasing``: at the goal of a stage that
    ends by letting go of the held object; ``misled``: the autonomy assists another goal."""
    d = Decision(state, time, mode, err, interface, config, belief, assisted, releasing, misled)
    for rule in RULES:
        out = rule(d)
        if out is not None:
            return out
    return command_rule(d)


def _aim(
    state: UserState,
    mode: int,
    err: NDArray[np.float64],
    modes: tuple[tuple[int, ...], ...],
    config: UserConfig,
    rng: np.random.Generator,
) -> UserState:
    """Judge where to stop along ``mode``'s dimensions: ``aim_k = eps_k * err_d`` (``eps_k``
    half-normal of scale ``config.command.aim_error``, truncated at 2: it stops short)."""
    aims = [0.0, 0.0]
    for k, d in enumerate(modes[mode][:2]):
        if d != GRIPPER_DIM:
            eps = min(abs(rng.standard_normal()), 2.0) * config.command.aim_error
            aims[k] = float(eps * err[d])
    return evolve(state, aim_mode=mode, aim_0=aims[0], aim_1=aims[1])


def _seen_error(state: UserState, err: NDArray[np.float64], dims: tuple[int, ...]) -> NDArray[np.float64]:
    """The error as the user judges it in its current mode: less its aim along the mode's dims."""
    seen = err.copy()
    for k, d in enumerate(dims[:2]):
        if d != GRIPPER_DIM:
            seen[d] -= state.aim_0 if k == 0 else state.aim_1
    return seen


def _push(
    d: Decision, err: NDArray[np.float64], dims: tuple[int, ...], tol: NDArray[np.float64]
) -> tuple[int, float]:
    """The push in a kept mode whose own dimensions are done (:func:`_pushed`): the dimension (its
    index in ``dims``) and direction (+1 / -1) the user pushes along, or ``(-1, 0.0)`` for none.

    A push keeps the dimension and direction it began with (toward the goal then) for as long as it
    lasts, as a person pushes on the way it was going: re-aiming at every decision at an error
    inside the tolerance turned the stick back and forth as the assistance moved the arm across
    it (reversals per dwell 0.83 / 0.48 against people's 0.37 / 0.14, ``study calibrate``). The
    push ends when the mode is no longer kept or a dimension is no longer done; the next one aims
    anew."""
    k = _pushed(err, dims, tol) if d.keep else -1
    state = d.state
    if k < 0:
        if state.push_mode >= 0:
            d.state = evolve(state, push_mode=-1, push_axis=-1, push_sign=0.0)
        return -1, 0.0
    if state.push_mode == d.mode and 0 <= state.push_axis < len(dims):
        return state.push_axis, state.push_sign  # (the axis _pushed chose in this mode: an arm one)
    sign = 1.0 if err[dims[k]] >= 0.0 else -1.0
    d.state = evolve(state, push_mode=d.mode, push_axis=k, push_sign=sign)
    return k, sign


def _pushed(err: NDArray[np.float64], dims: tuple[int, ...], tol: NDArray[np.float64]) -> int:
    """In a kept mode (``UserState.kept_mode``) whose dimensions are all within tolerance, the one
    the user pushes along (the largest error in tolerance units; toward the goal): its index in
    ``dims``, or -1 when a dimension is not within tolerance (it drives that one as usual)."""
    arm = [k for k, d in enumerate(dims) if d != GRIPPER_DIM]
    if not arm or any(abs(err[dims[k]]) > tol[dims[k]] for k in arm):
        return -1
    return max(arm, key=lambda k: abs(err[dims[k]]) / tol[dims[k]])
