"""A simple, deterministic simulated user of a control interface (pure numpy).

The user knows its goal pose. Every control tick it looks at the interface's current mode, the
end-effector pose, the goal poses and (optionally) the belief, and produces the interface's raw
signal (:data:`drake_disamb.core.interfaces.RAW_LAYOUTS`):

1. **Done**: within the success tolerance of its goal (position *and* orientation) it lets go
   (raw all zeros).
2. **Reacting**: after any button press it waits a reaction time with everything released (so
   presses are single rising edges and it sees the new mode before acting again).
3. **Request**: it presses the disambiguation button at the start of the trial
   (``request_at_start``) and whenever the autonomy has not been helping for
   ``request_when_unhelped_for`` seconds: "not helping" means the belief's argmax is not its goal,
   or the belief is too flat for any assistance (``p(g*) <= rho1``, i.e. alpha = 0). Needs the belief.
4. **Mode switch**: the *remaining error* of a dimension is its absolute error divided by its
   tolerance (``position_tolerance`` for vx..vz, ``orientation_tolerance`` for wx..wz), that of a
   mode the largest over its dimensions (0 for the gripper). When the current mode's remaining error
   is at most 1 (nothing left to do in it) the user picks the arm mode with the largest remaining
   error as its *target* and presses the mode button (joystick ``mode_button``, head array
   ``back``) once per reaction time until the target is active, also through modes on the way that
   would help a little. The target is dropped when it is reached, when it has nothing left to do
   (the autonomy finished it), or after a disambiguation request (the user then re-evaluates the
   mode the disambiguation system chose).
5. **Stall**: when it has been commanding in the current mode for ``stall_time`` seconds and the
   mode's remaining error has not fallen by ``stall_progress`` (tolerance units) -- the arm is held
   up by a joint limit, a singularity or the autonomy pulling elsewhere -- the mode no longer helps:
   the user targets the *other* arm mode with the largest remaining error (if any is above 1) and
   cycles to it as in 4. Any press restarts the count.
6. **Command**: otherwise it drives toward its goal along the current mode's dimensions.
   Joystick: axis k for the mode's k-th dimension, proportional to the error
   (``error / approach_time`` as a share of the interface's full-deflection speed), at least
   ``min_axis`` while the error exceeds the tolerance and 0 once within it. Head array: ``left``
   when the error along the dimension is above its tolerance, ``right`` when below minus it.

Errors are in the world frame: position ``x_goal - x_ee`` (m) and the world-frame rotation vector
``orientation_error(q_ee, q_goal)`` (rad), whose components a world-frame angular velocity along
``wx``, ``wy``, ``wz`` reduces. The success tolerances must be at least ``sqrt(3)`` times the
per-dimension tolerances, so "every dimension within tolerance" implies success and the user never
runs out of useful modes before it is done.

Randomness is optional and seeded: ``reaction_time_jitter`` (uniform, +/- s) and ``axis_noise``
(Gaussian std added to joystick axes). Each draw uses ``default_rng([seed, counter])`` with a
counter kept in the state, so a run is a pure function of the seed.
"""

from __future__ import annotations

import functools
import math
import numbers
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core._validation import all_finite, check_real_fields, is_real
from drake_disamb.core.blending import RHO1_TIMES_N
from drake_disamb.core.geometry import orientation_error
from drake_disamb.core.interfaces import (
    GRIPPER_DIM,
    MODE_BUTTON,
    RAW_SIZE,
    REQUEST_BUTTON,
    InterfaceConfig,
)

NOT_COUNTING = -1.0
"""``unhelped_since`` value meaning "the autonomy is currently helping" (times are >= 0)."""


@dataclass(frozen=True)
class UserConfig:
    """Behaviour of the simulated user.

    Attributes:
        position_tolerance: Per-dimension position tolerance (m): a translational dimension is done
            when its error is at most this.
        orientation_tolerance: Per-dimension orientation tolerance (rad).
        success_position_tolerance: Goal reached when the position error norm is at most this (m);
            at least ``sqrt(3) * position_tolerance``.
        success_orientation_tolerance: ... and the orientation error angle at most this (rad); at
            least ``sqrt(3) * orientation_tolerance``.
        use_orientation: If False the user ignores orientation (reaching by position only).
        reaction_time: Wait (s) after a button press before the next action, everything released.
        reaction_time_jitter: Each wait is ``reaction_time + U(-jitter, +jitter)`` (s); 0 = exact.
        approach_time: Joystick gain: the user asks for ``error / approach_time`` (m/s or rad/s).
        min_axis: Smallest joystick deflection used while a dimension is not done, in (0, 1].
        axis_noise: Standard deviation of Gaussian noise added to joystick axes (0 = none).
        stall_time: Seconds of commanding in one mode without progress after which the user
            switches to another mode (rule 5); ``None`` disables.
        stall_progress: The progress that counts, as a fall of the mode's remaining error in
            tolerance units (1 = one ``position_tolerance`` or ``orientation_tolerance``).
        request_at_start: Press the disambiguation button once at the start of the trial.
        request_when_unhelped_for: Press it when the autonomy has not been helping for this long
            (s); the timer restarts after every request. ``None`` disables (manual paradigm: set
            this to ``None`` and ``request_at_start`` to False).
        rho1: Belief threshold below which the autonomy gives no assistance (as in the blender);
            ``None`` = the paper's ``1.2 / n_goals``.
        seed: Seed of the optional randomness.
    """

    position_tolerance: float = 0.01
    orientation_tolerance: float = 0.05
    success_position_tolerance: float = 0.02
    success_orientation_tolerance: float = 0.1
    use_orientation: bool = True
    reaction_time: float = 0.3
    reaction_time_jitter: float = 0.0
    approach_time: float = 0.5
    min_axis: float = 0.2
    axis_noise: float = 0.0
    stall_time: float | None = 2.0
    stall_progress: float = 1.0
    request_at_start: bool = True
    request_when_unhelped_for: float | None = 3.0
    rho1: float | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        check_real_fields(
            self,
            (
                "position_tolerance",
                "orientation_tolerance",
                "success_position_tolerance",
                "success_orientation_tolerance",
                "reaction_time",
                "approach_time",
            ),
        )
        check_real_fields(self, ("reaction_time_jitter", "axis_noise"), allow_zero=True)
        if self.reaction_time_jitter >= self.reaction_time:
            raise ValueError(
                f"UserConfig.reaction_time_jitter: expected less than reaction_time={self.reaction_time}, "
                f"got {self.reaction_time_jitter!r}"
            )
        if not (is_real(self.min_axis) and 0 < self.min_axis <= 1):
            raise ValueError(f"UserConfig.min_axis: expected a number in (0, 1], got {self.min_axis!r}")
        for succ, per_dim in (
            ("success_position_tolerance", "position_tolerance"),
            ("success_orientation_tolerance", "orientation_tolerance"),
        ):
            need = math.sqrt(3.0) * getattr(self, per_dim)
            if getattr(self, succ) < need:
                raise ValueError(
                    f"UserConfig.{succ}: expected at least sqrt(3) * {per_dim} = {need:.4g}, "
                    f"got {getattr(self, succ)!r}"
                )
        if self.stall_time is not None and not (is_real(self.stall_time) and self.stall_time > 0):
            raise ValueError(f"UserConfig.stall_time: expected None or a number > 0, got {self.stall_time!r}")
        if not (is_real(self.stall_progress) and self.stall_progress > 0):
            raise ValueError(
                f"UserConfig.stall_progress: expected a finite number > 0, got {self.stall_progress!r}"
            )
        t = self.request_when_unhelped_for
        if t is not None and not (is_real(t) and t > 0):
            raise ValueError(
                f"UserConfig.request_when_unhelped_for: expected None or a number > 0, got {t!r}"
            )
        if self.rho1 is not None and not (is_real(self.rho1) and 0 <= self.rho1 <= 1):
            raise ValueError(f"UserConfig.rho1: expected None or a number in [0, 1], got {self.rho1!r}")
        if not (isinstance(self.seed, numbers.Integral) and self.seed >= 0):
            raise ValueError(f"UserConfig.seed: expected an integer >= 0, got {self.seed!r}")

    @property
    def min_reaction_time(self) -> float:
        """The shortest possible wait after a press (s)."""
        return self.reaction_time - self.reaction_time_jitter

    def dim_tolerances(self) -> NDArray[np.float64]:
        """Tolerance of each dimension 0..5 (3 positions in m, 3 orientations in rad)."""
        return np.array([self.position_tolerance] * 3 + [self.orientation_tolerance] * 3)


@dataclass(frozen=True)
class UserState:
    """What the simulated user remembers between ticks.

    Attributes:
        busy_until: No action before this time (s): reacting to its last press.
        requested_at_start: Whether the start-of-trial request was made.
        unhelped_since: Time (s) since which the autonomy has not been helping, or
            :data:`NOT_COUNTING`.
        draws: Counter of random draws (keys the seeded generator).
        presses: Buttons pressed so far (mode + request).
        target_mode: The mode it is cycling toward, or -1.
        progress_mode: The mode whose progress it is watching (rule 5), or -1.
        progress_since: When the watch (re)started (s).
        progress_best: The mode's remaining error then (tolerance units).
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
    raw: NDArray[np.float64] = field(default_factory=lambda: np.zeros(RAW_SIZE), compare=False)

    VECTOR_SIZE = 9 + RAW_SIZE

    def to_vector(self) -> NDArray[np.float64]:
        """Flat ``[busy_until, requested_at_start, unhelped_since, draws, presses, target_mode,
        progress_mode, progress_since, progress_best, raw (4)]``."""
        head = [
            self.busy_until,
            float(self.requested_at_start),
            self.unhelped_since,
            self.draws,
            self.presses,
            self.target_mode,
            self.progress_mode,
            self.progress_since,
            self.progress_best,
        ]
        return np.array([*head, *np.asarray(self.raw, dtype=float).tolist()], dtype=float)

    @classmethod
    def from_vector(cls, x: ArrayLike) -> UserState:
        """Inverse of :meth:`to_vector`."""
        v = np.asarray(x, dtype=float)
        if v.shape != (cls.VECTOR_SIZE,):
            raise ValueError(f"UserState vector: expected {cls.VECTOR_SIZE} numbers, got {v.shape}")
        busy_until, requested, unhelped_since, draws, presses, target, watched, since, best = v[:9].tolist()
        return cls(
            busy_until=busy_until,
            requested_at_start=requested > 0.5,
            unhelped_since=unhelped_since,
            draws=int(round(draws)),
            presses=int(round(presses)),
            target_mode=int(round(target)),
            progress_mode=int(round(watched)),
            progress_since=since,
            progress_best=best,
            raw=v[9:].copy(),
        )


def _evolve(state: UserState, **changes: object) -> UserState:
    """``dataclasses.replace(state, **changes)`` without its per-call field inspection (the user
    steps every control tick). ``UserState`` has no ``__post_init__`` and no slots, so a copy of
    the instance dictionary with the changes is exactly what ``replace`` builds."""
    new = object.__new__(UserState)
    new.__dict__.update(state.__dict__)
    new.__dict__.update(changes)
    return new


@functools.lru_cache(maxsize=64)
def _dim_tolerances(config: UserConfig) -> NDArray[np.float64]:
    """``config.dim_tolerances()``, once per (frozen) configuration (read-only)."""
    t = config.dim_tolerances()
    t.setflags(write=False)
    return t


def goal_error(ee_pose: ArrayLike, goal_pose: ArrayLike, use_orientation: bool = True) -> NDArray[np.float64]:
    """World-frame 6-D error ``[x_g - x_ee, orientation_error(q_ee, q_g)]`` (m, rad).

    Poses are ``[x, y, z, qw, qx, qy, qz]``. With ``use_orientation=False`` the last 3 are 0.
    """
    ee = np.asarray(ee_pose, dtype=float)
    g = np.asarray(goal_pose, dtype=float)
    if ee.shape != (7,) or g.shape != (7,):
        raise ValueError(f"ee_pose/goal_pose: expected 7 numbers each, got shapes {ee.shape} and {g.shape}")
    err = np.zeros(6)
    err[:3] = g[:3] - ee[:3]
    if use_orientation:
        err[3:] = orientation_error(ee[3:], g[3:])
    return err


def goal_reached(error: ArrayLike, config: UserConfig) -> bool:
    """True when a 6-D goal error is within the success tolerances."""
    e = np.asarray(error, dtype=float)
    ok = np.linalg.norm(e[:3]) <= config.success_position_tolerance
    if config.use_orientation:
        ok = ok and np.linalg.norm(e[3:]) <= config.success_orientation_tolerance
    return bool(ok)


def mode_remaining(
    error: ArrayLike, modes: tuple[tuple[int, ...], ...] | list[list[int]], config: UserConfig
) -> NDArray[np.float64]:
    """Remaining error of every mode: ``max_{d in mode} |error_d| / tolerance_d`` (gripper dims 0)."""
    ratio = np.abs(np.asarray(error, dtype=float)) / _dim_tolerances(config)
    ratio7 = [*ratio.tolist(), 0.0]
    return np.array([max(ratio7[d] for d in mode) for mode in modes])


def helped(belief: ArrayLike, goal_index: int, rho1: float) -> bool:
    """True when the autonomy assists toward the user's goal: argmax is it and ``p(g*) > rho1``."""
    p = np.asarray(belief, dtype=float)
    if not all_finite(p):
        return False
    g = int(np.argmax(p))
    return g == goal_index and p[g] > rho1


def _draw(config: UserConfig, counter: int) -> np.random.Generator:
    return np.random.default_rng([int(config.seed), int(counter)])


def user_step(
    state: UserState,
    time: float,
    mode: int,
    ee_pose: ArrayLike,
    goal_poses: ArrayLike,
    goal_index: int,
    interface: InterfaceConfig,
    config: UserConfig,
    belief: ArrayLike | None = None,
) -> UserState:
    """One control tick of the simulated user. Returns the new state; its ``raw`` is the output.

    Args:
        state: The state after the previous tick.
        time: Current time (s).
        mode: The interface's current mode index.
        ee_pose: End-effector pose ``[x, y, z, qw, qx, qy, qz]``.
        goal_poses: ``(n, 7)`` (or flat ``n * 7``) goal poses.
        goal_index: The user's goal.
        interface: The interface it operates (modes, raw layout, speeds).
        config: The user's behaviour.
        belief: The current belief over goals (``n``), or ``None`` if unavailable (then no
            "unhelped" requests are made).
    """
    goals = np.asarray(goal_poses, dtype=float).reshape(-1, 7)
    n = goals.shape[0]
    if not (0 <= goal_index < n):
        raise ValueError(f"goal_index: expected an integer in [0, {n - 1}], got {goal_index!r}")
    modes = interface.modes
    if not (0 <= mode < len(modes)):
        raise ValueError(
            f"mode: expected an integer in [0, {len(modes) - 1}] for {interface.kind}, got {mode!r}"
        )
    zero = np.zeros(RAW_SIZE)
    err = goal_error(ee_pose, goals[goal_index], config.use_orientation)

    if goal_reached(err, config):
        return _evolve(state, raw=zero, unhelped_since=NOT_COUNTING, target_mode=-1)

    # The "unhelped" timer runs whenever the belief is known, also while reacting.
    unhelped_since = NOT_COUNTING
    if belief is not None and config.request_when_unhelped_for is not None:
        rho1 = RHO1_TIMES_N / n if config.rho1 is None else config.rho1
        if not helped(belief, goal_index, rho1):
            unhelped_since = time if state.unhelped_since == NOT_COUNTING else state.unhelped_since
    state = _evolve(state, unhelped_since=unhelped_since)

    if time < state.busy_until - 1e-9:
        return _evolve(state, raw=zero)

    def press(button: int, **changes: object) -> UserState:
        wait = config.reaction_time
        draws = state.draws
        if config.reaction_time_jitter > 0:
            wait += _draw(config, draws).uniform(-config.reaction_time_jitter, config.reaction_time_jitter)
            draws += 1
        raw = zero.copy()
        raw[button] = 1.0
        return _evolve(
            state,
            raw=raw,
            busy_until=time + wait,
            draws=draws,
            presses=state.presses + 1,
            progress_mode=-1,  # every press restarts the stall watch (rule 5)
            **changes,
        )

    # Every request restarts the "unhelped" timer and drops a mode-cycling target.
    restart = NOT_COUNTING if state.unhelped_since == NOT_COUNTING else time
    if config.request_at_start and not state.requested_at_start:
        return press(REQUEST_BUTTON, requested_at_start=True, unhelped_since=restart, target_mode=-1)
    if (
        config.request_when_unhelped_for is not None
        and state.unhelped_since != NOT_COUNTING
        and time - state.unhelped_since >= config.request_when_unhelped_for - 1e-9
    ):
        return press(REQUEST_BUTTON, unhelped_since=time, target_mode=-1)

    remaining = mode_remaining(err, modes, config)
    target = state.target_mode
    if target >= 0 and (target == mode or remaining[target] <= 1.0):
        target = -1  # reached, or nothing left to do there
    if target < 0 and remaining[mode] <= 1.0:
        target = int(np.argmax(remaining[: len(modes) - 1]))
        if target == mode:  # unreachable with validated tolerances: nothing left anywhere
            return _evolve(state, raw=zero, target_mode=-1)
    if target >= 0:
        return press(MODE_BUTTON, target_mode=target)
    state = _evolve(state, target_mode=-1)

    # Rule 5: a mode in which commanding has stopped paying off is left for another one.
    if config.stall_time is not None:
        now_remaining = float(remaining[mode])
        if state.progress_mode != mode or now_remaining <= state.progress_best - config.stall_progress:
            state = _evolve(state, progress_mode=mode, progress_since=time, progress_best=now_remaining)
        elif time - state.progress_since >= config.stall_time - 1e-9:
            others = remaining[: len(modes) - 1].copy()  # arm modes (the gripper mode is last)
            if mode < others.size:
                others[mode] = -np.inf
            best = int(np.argmax(others))
            if others[best] > 1.0:
                return press(MODE_BUTTON, target_mode=best)
            # Nothing else to do: keep at it, and watch again from here.
            state = _evolve(state, progress_since=time, progress_best=now_remaining)

    dims = modes[mode]
    tol = _dim_tolerances(config)
    speeds = interface.dim_speeds()
    raw = zero.copy()
    draws = state.draws
    if interface.kind == "joystick":
        for k, d in enumerate(dims):
            if d == GRIPPER_DIM or abs(err[d]) <= tol[d]:
                continue
            axis = float(np.clip(err[d] / config.approach_time / speeds[d], -1.0, 1.0))
            if abs(axis) < config.min_axis:
                axis = math.copysign(config.min_axis, err[d])
            if config.axis_noise > 0:
                axis += float(_draw(config, draws).normal(0.0, config.axis_noise))
                draws += 1
            raw[k] = float(np.clip(axis, -1.0, 1.0))
    else:
        d = dims[0]
        if d != GRIPPER_DIM:
            if err[d] > tol[d]:
                raw[0] = 1.0
            elif err[d] < -tol[d]:
                raw[1] = 1.0
    return _evolve(state, raw=raw, draws=draws)
