"""The simulated user of a control interface (pure numpy): deterministic by default, human-like
(reaction times, noise, Boltzmann mode choice, pauses, requests) with the fields listed under
"Human behaviour" below.

The module is longer than the project's ~500 lines because it is one policy: its rules, its state
and each human behaviour act on the same decision, and splitting them would scatter one algorithm.

The user knows its goal pose. Every control tick it looks at the interface's current mode, the
end-effector pose, the goal poses and (optionally) the belief, and produces the interface's raw
signal (:data:`drake_disamb.core.interfaces.RAW_LAYOUTS`):

1. **Done**: within the success tolerance of its goal (position *and* orientation) it lets go
   (raw all zeros). At the goal of a stage that ends by letting go of the held object
   (``release``: the pouring task's cup, set down at its place) it instead changes to the gripper
   mode (pressing as in rule 4, then its settle) and opens the gripper until the stage ends.
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
   would help a little. With a joystick that selects modes directly
   (``InterfaceConfig.mode_selection == "direct"``) it instead deflects the stick into the
   target's sector and presses once (:func:`~drake_disamb.core.interfaces.sector_stick`): one
   press per change. The target is dropped when it is reached, when it has nothing left to do
   (the autonomy finished it), or after a disambiguation request (the user then re-evaluates the
   mode the disambiguation system chose).
5. **Stall**: when it has been commanding in the current mode for ``stall_time`` seconds and the
   mode's remaining error has not fallen by ``stall_progress`` (tolerance units) -- the arm is held
   up by a joint limit, a singularity or the autonomy pulling elsewhere -- the mode no longer helps:
   the user targets the *other* arm mode with the largest remaining error (if any is above 1) and
   cycles to it as in 4. Any press restarts the count. With no other mode left, a user who can ask
   for disambiguation (a belief and ``request_instead_prob > 0``) does so: the autonomy is holding
   the arm at another goal, or a limit holds it; otherwise it keeps trying.
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

**Human behaviour** (every field off by default, which is the deterministic user above; the
population of :mod:`drake_disamb.study.population` turns them on, docs/population.md gives the
values and where they come from):

- *Decision rate*: ``decision_period`` (s) is how often the user decides (the
  :class:`~drake_disamb.systems.user.SimulatedUser` ticks at it; the raw signal is held between
  decisions). Every wait is at least two decision periods, so a press is one rising edge.
- *Reaction times*: the wait after a press is lognormal with median ``reaction_time`` and log-sd
  ``reaction_log_sd``; after a mode change is finished (the target reached, or the mode a request
  chose) the user waits a further lognormal ``settle_time`` (with probability ``settle_prob``)
  before commanding; at the start of the
  trial it does nothing but an optional request for a lognormal ``start_delay``.
- *Command noise*: the joystick's stick vector (``[axis_x, axis_y]``, the intended deflection of
  rule 6) gets a direction drawn from a von Mises-Fisher distribution of concentration
  ``direction_kappa`` about the intended one and a magnitude scaled by a lognormal factor of
  log-sd ``deflection_log_sd``, once per decision. *Switch timing*: when the user stops driving
  (either interface), it lets go late by an exponential ``release_lag`` (mean, s). *Wrong
  presses*: when it starts to drive it hits the mode button instead with probability
  ``wrong_press_prob``.
- *Mode choice*: a new mode is drawn by softmax over the modes' usefulness
  (:func:`mode_usefulness`: remaining error as a share of the largest, less ``press_cost`` per
  press it takes to get there) with temperature ``mode_temperature`` (0 = the best mode, rule 4);
  the presses are made one by one, and on reaching its target the user presses once more with
  probability ``overshoot_prob`` (and must go round again). With direct selection every other mode
  is one press away (``press_cost`` once) and there is nothing to overshoot: a change is one
  deliberate press with the stick in the target's sector (the joystick logs' consecutive button
  events less than 1 s apart are 3-4 % of them; an overshoot, a centred press and a second
  selection, made 11-17 % with ``overshoot_prob`` from the head array, 4-5 % without); a wrong
  press, made with the stick centred, cycles on either interface. With ``mode_review_rate`` it also
  reviews its mode while it still helps (the same choice, the current mode in it at no press cost)
  and leaves it for a clearly better one, as people interleave modes (not while a kept mode, below,
  carries it).
- *Judging where to stop*: on entering an arm mode the user judges by eye where to stop along
  its dimensions and stops short by a half-normal share (scale ``aim_error``) of the distance it
  sees; the mode then looks done. With probability ``correction_prob`` (or when nothing else is
  left) it sees the shortfall and corrects it at once in the same mode, aiming anew (a corrective
  submovement, Meyer et al. 1988); else it moves on and comes back later.
- *Pauses*: at a decision where it would command, it starts a pause with rate ``pause_rate``
  (per second), of lognormal duration (median ``pause_duration``, log-sd ``pause_log_sd``).
- *Requests*: a request the policy calls for (at the start, when unhelped) is made with
  probability ``request_prob``; when a new mode is needed (its mode done, a stall, or a review that
  wants another) the user asks for disambiguation instead of cycling with probability
  ``request_instead_prob``; both scaled by ``exp(-t / request_decay_time)`` (requests concentrate
  early). After a request it waits up to
  ``request_wait`` seconds for the mode to change, then keeps the mode the system chose with
  probability ``accept_prob`` or cycles away from it to a mode of its own choice. With
  ``keep_assisted_mode`` it keeps using a kept mode while the autonomy assists its goal, also once
  the mode's own dimensions are done (pushing toward the goal in it), until the whole goal's
  remaining error stops falling (rule 5) or the assistance stops. With ``stay_while_assisted`` a
  joystick user uses any arm mode so (win-stay while assisted).
"""

from __future__ import annotations

import functools
import math
import numbers
import operator
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core._validation import all_finite, check_real_fields, is_real
from drake_disamb.core.blending import RHO1_TIMES_N
from drake_disamb.core.geometry import orientation_error
from drake_disamb.core.interfaces import GRIPPER_DIM, RAW_SIZE, InterfaceConfig
from drake_disamb.core.sampling import lognormal, sample_von_mises_fisher

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
        decision_period: Seconds between the user's decisions (``None`` = every control period).
        reaction_log_sd: Log-sd of the lognormal wait after a press (median ``reaction_time``).
        settle_time: Median extra wait (s) after a finished mode change before commanding.
        settle_log_sd: Its log-sd.
        settle_prob: Probability that a finished mode change is followed by the settle wait (else
            the user commands right after its reaction wait).
        start_delay: Median time (s) before the first mode switch or command of the trial.
        start_delay_log_sd: Its log-sd.
        direction_kappa: Von Mises-Fisher concentration of the joystick's stick direction about the
            intended one (``None`` = exact).
        deflection_log_sd: Log-sd of the lognormal factor on the stick's deflection (0 = exact).
        release_lag: Mean (s) of the exponential delay with which a drive is released.
        wrong_press_prob: Probability that starting to drive presses the mode button instead.
        mode_temperature: Softmax temperature of the mode choice, in usefulness units (0 = the best).
        press_cost: Usefulness a mode loses per press needed to reach it.
        overshoot_prob: Probability of one press too many on reaching the target mode by cycling
            (not with direct selection: one deliberate press per change).
        mode_review_rate: Reviews per second of commanding time of whether another mode would be
            better (a Boltzmann choice with the current mode in it, at no press cost); 0 = only
            when the mode is done or stalled.
        pause_rate: Pauses per second of the time it would command (0 = none).
        pause_duration: Median pause (s).
        pause_log_sd: Its log-sd.
        request_prob: Probability of making a request the policy calls for (start, unhelped).
        request_instead_prob: Probability of asking for disambiguation instead of cycling when a
            new mode is needed (needs the belief, i.e. the disambiguation paradigm).
        request_decay_time: Request probabilities are scaled by ``exp(-t / this)`` (``None`` = 1).
        request_wait: After a request, wait up to this (s) for the mode to change.
        accept_prob: Probability of keeping the mode a request chose (else cycle away from it).
        aim_error: Relative error of the user's judgement of where to stop (0 = exact): on entering
            a mode it aims each of the mode's dimensions at ``goal - eps * error`` with ``eps``
            half-normal of scale this (truncated at 2), i.e. the primary movement stops short by a
            share of the distance it sees, and the user corrects later.
        correction_prob: With ``aim_error``: probability that, when a movement in a mode ends
            short of the goal (the aim reached, the mode not done), the user corrects it at once
            in the same mode (a corrective submovement, aimed anew) rather than moving on to
            another mode and coming back later (0 = it always moves on while others are left).
        keep_assisted_mode: Keep using the mode a request chose and the user kept (``accept_prob``)
            while the autonomy assists its goal (:func:`helped`), also when the mode's own
            dimensions are done: it pushes toward the goal in it (the blended command moves the arm
            toward the goal) until the whole goal's remaining error stops falling (rule 5) or the
            assistance stops. False: a kept mode whose dimensions are done is left at once.
        stay_while_assisted: With a proportional interface (the joystick), keep using *any* arm
            mode the user is in, not only a kept request mode, while the autonomy assists its goal,
            the same way (win-stay): a small push in the mode (``min_axis``) is blended with the
            autonomy's command, which carries the arm home. Not with the head array, whose
            full-speed switches along a done dimension drive the arm away from the goal (there
            only a kept request mode is used so, with ``keep_assisted_mode``).
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
    decision_period: float | None = None
    reaction_log_sd: float = 0.0
    settle_time: float = 0.0
    settle_log_sd: float = 0.0
    settle_prob: float = 1.0
    start_delay: float = 0.0
    start_delay_log_sd: float = 0.0
    direction_kappa: float | None = None
    deflection_log_sd: float = 0.0
    release_lag: float = 0.0
    wrong_press_prob: float = 0.0
    mode_temperature: float = 0.0
    press_cost: float = 0.0
    overshoot_prob: float = 0.0
    mode_review_rate: float = 0.0
    pause_rate: float = 0.0
    pause_duration: float = 1.0
    pause_log_sd: float = 0.0
    request_prob: float = 1.0
    request_instead_prob: float = 0.0
    request_decay_time: float | None = None
    request_wait: float = 0.0
    accept_prob: float = 1.0
    aim_error: float = 0.0
    correction_prob: float = 0.0
    keep_assisted_mode: bool = False
    stay_while_assisted: bool = False

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
        for name in ("keep_assisted_mode", "stay_while_assisted"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"UserConfig.{name}: expected true or false, got {getattr(self, name)!r}")
        check_real_fields(self, ("pause_duration",))
        check_real_fields(
            self,
            (
                "reaction_log_sd",
                "settle_time",
                "settle_log_sd",
                "start_delay",
                "start_delay_log_sd",
                "deflection_log_sd",
                "release_lag",
                "mode_temperature",
                "press_cost",
                "pause_rate",
                "mode_review_rate",
                "pause_log_sd",
                "request_wait",
                "aim_error",
            ),
            allow_zero=True,
        )
        for name in ("decision_period", "direction_kappa", "request_decay_time"):
            value = getattr(self, name)
            if value is not None and not (is_real(value) and value > 0):
                raise ValueError(f"UserConfig.{name}: expected None or a number > 0, got {value!r}")
        for name in (
            "settle_prob",
            "wrong_press_prob",
            "overshoot_prob",
            "request_prob",
            "request_instead_prob",
            "accept_prob",
            "correction_prob",
        ):
            value = getattr(self, name)
            if not (is_real(value) and 0 <= value <= 1):
                raise ValueError(f"UserConfig.{name}: expected a probability in [0, 1], got {value!r}")

    def without_requests(self) -> UserConfig:
        """This user with every disambiguation request off (the manual paradigm)."""
        return replace(self, request_at_start=False, request_when_unhelped_for=None, request_instead_prob=0.0)

    def period(self, interface: InterfaceConfig) -> float:
        """Seconds between decisions with ``interface``: ``decision_period`` or its control period."""
        return interface.control_period if self.decision_period is None else self.decision_period

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
    raw: NDArray[np.float64] = field(default_factory=lambda: np.zeros(RAW_SIZE), compare=False)

    _INT = ("draws", "presses", "target_mode", "progress_mode", "request_mode", "aim_mode", "kept_mode")
    _BOOL = ("requested_at_start", "started", "judge", "overshot")
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
    )
    VECTOR_SIZE = 20 + RAW_SIZE

    def to_vector(self) -> NDArray[np.float64]:
        """Flat ``[busy_until, requested_at_start, unhelped_since, draws, presses, target_mode,
        progress_mode, progress_since, progress_best, started, start_until, hold_until, request_mode,
        request_since, judge, overshot, aim_mode, aim_0, aim_1, kept_mode, raw (4)]``."""
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


def presses_to(
    mode: int, target: np.ndarray | int, n_modes: int, direct: bool = False, back: bool = False
) -> np.ndarray | int:
    """Mode changes (presses) from ``mode`` to ``target``: forward cycling, the shorter way round
    with ``back`` (an interface that also steps back, ``Interface.steps_back``), or with ``direct``
    selection (``InterfaceConfig.mode_selection == "direct"``) one for any other mode."""
    if direct:
        return (
            (np.asarray(target) != mode).astype(int)
            if isinstance(target, np.ndarray)
            else int(target != mode)
        )
    forward = (
        (np.asarray(target) - mode) % n_modes if isinstance(target, np.ndarray) else (target - mode) % n_modes
    )
    return np.minimum(forward, n_modes - forward) if back else forward


def mode_usefulness(
    remaining: ArrayLike, mode: int, n_modes: int, press_cost: float, direct: bool = False, back: bool = False
) -> NDArray[np.float64]:
    """Expected usefulness of each arm mode: its remaining error as a share of the largest (0..1),
    minus ``press_cost`` per press it takes to reach it from ``mode`` (:func:`presses_to`; arm modes
    only: the gripper mode, last, is left out of ``remaining``)."""
    r = np.asarray(remaining, dtype=float)
    top = float(np.max(r)) if r.size else 0.0
    share = r / top if top > 0 else np.zeros_like(r)
    return share - press_cost * presses_to(mode, np.arange(r.size), n_modes, direct, back)


def choose_mode(
    remaining: ArrayLike,
    mode: int,
    n_modes: int,
    config: UserConfig,
    rng: np.random.Generator | None,
    exclude_current: bool = False,
    direct: bool = False,
    back: bool = False,
) -> int:
    """The arm mode the user goes for next: Boltzmann choice over :func:`mode_usefulness`.

    ``remaining`` holds the arm modes' remaining errors (:func:`mode_remaining` without the gripper
    mode). With ``config.mode_temperature == 0`` (or no ``rng``) it is the mode with the most
    remaining error (ties to the lowest index); else mode ``m`` has probability proportional to
    ``exp(usefulness_m / temperature)``. ``exclude_current`` leaves ``mode`` out. ``direct``: the
    interface selects modes directly (every other mode one press away, :func:`presses_to`);
    ``back``: it also steps back (the shorter way round).
    """
    r = np.asarray(remaining, dtype=float).copy()
    if exclude_current and mode < r.size:
        r[mode] = -np.inf
    if config.mode_temperature == 0 or rng is None:
        return int(np.argmax(r))
    ok = np.isfinite(r)
    u = mode_usefulness(np.where(ok, r, 0.0), mode, n_modes, config.press_cost, direct, back)
    logits = np.where(ok, u / config.mode_temperature, -np.inf)
    w = np.exp(logits - np.max(logits))
    return int(rng.choice(r.size, p=w / w.sum()))


def _aim(
    state: UserState,
    mode: int,
    err: NDArray[np.float64],
    modes: tuple[tuple[int, ...], ...],
    config: UserConfig,
    rng: np.random.Generator,
) -> UserState:
    """Judge where to stop along ``mode``'s dimensions: ``aim_k = eps_k * err_d`` (``eps_k``
    half-normal of scale ``config.aim_error``, truncated at 2: it stops short)."""
    aims = [0.0, 0.0]
    for k, d in enumerate(modes[mode][:2]):
        if d != GRIPPER_DIM:
            eps = min(abs(rng.standard_normal()), 2.0) * config.aim_error
            aims[k] = float(eps * err[d])
    return _evolve(state, aim_mode=mode, aim_0=aims[0], aim_1=aims[1])


def _seen_error(state: UserState, err: NDArray[np.float64], dims: tuple[int, ...]) -> NDArray[np.float64]:
    """The error as the user judges it in its current mode: less its aim along the mode's dims."""
    seen = err.copy()
    for k, d in enumerate(dims[:2]):
        if d != GRIPPER_DIM:
            seen[d] -= state.aim_0 if k == 0 else state.aim_1
    return seen


def _pushed(err: NDArray[np.float64], dims: tuple[int, ...], tol: NDArray[np.float64]) -> int:
    """In a kept mode (``UserState.kept_mode``) whose dimensions are all within tolerance, the one
    the user pushes along (the largest error in tolerance units; toward the goal): its index in
    ``dims``, or -1 when a dimension is not within tolerance (it drives that one as usual)."""
    arm = [k for k, d in enumerate(dims) if d != GRIPPER_DIM]
    if not arm or any(abs(err[dims[k]]) > tol[dims[k]] for k in arm):
        return -1
    return max(arm, key=lambda k: abs(err[dims[k]]) / tol[dims[k]])


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
    release: bool = False,
) -> UserState:
    """One decision of the simulated user. Returns the new state; its ``raw`` is the output.

    Args:
        state: The state after the previous decision.
        time: Current time (s).
        mode: The interface's current mode index.
        ee_pose: End-effector pose ``[x, y, z, qw, qx, qy, qz]``.
        goal_poses: ``(n, 7)`` (or flat ``n * 7``) goal poses.
        goal_index: The user's goal.
        interface: The interface it operates (modes, raw layout, speeds).
        config: The user's behaviour.
        belief: The current belief over goals (``n``), or ``None`` if unavailable (then no
            "unhelped" requests and no requests instead of mode switches are made).
        release: The goal is reached only once the held object is let go (a stage with a
            release, :attr:`drake_disamb.config.StageSpec.release_opening`): at the goal the user
            changes to the gripper mode and opens the gripper, instead of letting go of the
            interface (rule 1).
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
    err = goal_error(ee_pose, goals[goal_index], config.use_orientation)

    reached = goal_reached(err, config)
    if reached and not release:
        return _evolve(
            state, raw=np.zeros(RAW_SIZE), unhelped_since=NOT_COUNTING, target_mode=-1, hold_until=0.0
        )
    if reached:  # at the goal, letting go of the object (rule 1 with a release): no late release
        state = _evolve(state, hold_until=0.0)

    # The "unhelped" timer runs whenever the belief is known, also while reacting.
    unhelped_since = NOT_COUNTING
    if belief is not None and config.request_when_unhelped_for is not None and not reached:
        rho1 = RHO1_TIMES_N / n if config.rho1 is None else config.rho1
        if not helped(belief, goal_index, rho1):
            unhelped_since = time if state.unhelped_since == NOT_COUNTING else state.unhelped_since
    state = _evolve(state, unhelped_since=unhelped_since)

    if not state.started:
        start_until = 0.0
        draws = state.draws
        if config.start_delay > 0:
            rng = _draw(config, draws) if config.start_delay_log_sd > 0 else None
            draws += rng is not None
            start_until = time + lognormal(config.start_delay, config.start_delay_log_sd, rng)
        state = _evolve(state, started=True, start_until=start_until, draws=draws)

    if time < state.busy_until - 1e-9:
        return _evolve(state, raw=np.zeros(RAW_SIZE))
    if time < state.hold_until - 1e-9:
        return state  # letting go late: the drive is held
    lag_done = state.hold_until > 0.0
    assisted = belief is not None and helped(
        belief, goal_index, RHO1_TIMES_N / n if config.rho1 is None else config.rho1
    )
    new = _decide(state, time, mode, err, interface, config, belief, assisted, reached)
    driving = interface.variant.is_driving
    if (
        config.release_lag > 0
        and not lag_done
        and not reached
        and driving(state.raw)
        and not driving(new.raw)
    ):
        # The lag has a stream of its own keyed by this decision's counter, and the counter is not
        # advanced: the decision made when the lag ends replays this one's draws, so the user
        # carries out late what it decided (a pause, a review's or a correction's outcome) instead
        # of drawing it anew (which made every random reason to stop driving twice as likely, or,
        # for a rate per decision, almost never carried out).
        rng = np.random.default_rng([int(config.seed), int(state.draws), 1])
        lag = float(rng.exponential(config.release_lag))
        return _evolve(state, hold_until=time + lag)
    if new.hold_until != 0.0:
        new = _evolve(new, hold_until=0.0)
    return new


def _decide(
    state: UserState,
    time: float,
    mode: int,
    err: NDArray[np.float64],
    interface: InterfaceConfig,
    config: UserConfig,
    belief: ArrayLike | None,
    assisted: bool,
    releasing: bool = False,
) -> UserState:
    """Rules 3 to 6 at a free decision (not reacting, not letting go late); ``assisted``: the
    autonomy assists the user's goal (:func:`helped`); ``releasing``: at the goal of a stage that
    ends by letting go of the held object (rule 1 with a release)."""
    modes = interface.modes
    n_modes = len(modes)
    variant = interface.variant
    selection = interface.mode_selection
    direct = selection == "direct"
    back = variant.steps_back
    zero = np.zeros(RAW_SIZE)
    period = config.period(interface)
    draws = state.draws

    def rng() -> np.random.Generator:
        nonlocal draws
        g = _draw(config, draws)
        draws += 1
        return g

    def request_chance(p: float) -> bool:
        if config.request_decay_time is not None:
            p *= math.exp(-time / config.request_decay_time)
        return p >= 1.0 or (p > 0 and rng().random() < p)

    def press(signal: list[float], **changes: object) -> UserState:
        wait = config.reaction_time
        if config.reaction_time_jitter > 0 or config.reaction_log_sd > 0:
            g = rng()
            if config.reaction_time_jitter > 0:
                wait += g.uniform(-config.reaction_time_jitter, config.reaction_time_jitter)
            wait = lognormal(wait, config.reaction_log_sd, g)
        return _evolve(
            state,
            raw=np.array(signal, dtype=float),
            busy_until=time + max(wait, 2.0 * period),
            draws=draws,
            presses=state.presses + 1,
            progress_mode=-1,  # every press restarts the stall watch (rule 5)
            **changes,
        )

    def request(**changes: object) -> UserState:
        # Every request restarts the "unhelped" timer and drops a mode-cycling target.
        return press(variant.request_raw(), target_mode=-1, request_mode=mode, request_since=time, **changes)

    def settle(**changes: object) -> UserState | None:
        if config.settle_time <= 0 or (config.settle_prob < 1.0 and rng().random() >= config.settle_prob):
            return None
        wait = lognormal(
            config.settle_time, config.settle_log_sd, rng() if config.settle_log_sd > 0 else None
        )
        return _evolve(state, raw=zero, busy_until=time + max(wait, period), draws=draws, **changes)

    # Rule 1 with a release: at the goal, change to the gripper mode (the presses, with the waits
    # after them, as any mode change), settle into it, and open the gripper until the stage ends.
    if releasing:
        grip = n_modes - 1
        state = _evolve(state, request_mode=-1, judge=False, kept_mode=-1)
        if mode != grip:
            return press(variant.change_raw(mode, grip, selection), target_mode=grip, overshot=False)
        if state.target_mode == grip:
            state = _evolve(state, target_mode=-1)
            out = settle()
            if out is not None:
                return out
        raw = np.array(variant.drive_raw([1.0]))  # the gripper mode's one dimension: opens
        return _evolve(state, raw=raw, target_mode=-1, draws=draws)

    # A request was made: wait for the mode it chooses, then settle into it and judge it.
    if state.request_mode >= 0:
        if mode == state.request_mode and time - state.request_since < config.request_wait - 1e-9:
            return _evolve(state, raw=zero)
        changed = mode != state.request_mode
        state = _evolve(state, request_mode=-1, judge=True)
        if changed:
            out = settle()
            if out is not None:
                return out

    # Rule 3: requests.
    restart = NOT_COUNTING if state.unhelped_since == NOT_COUNTING else time
    if config.request_at_start and not state.requested_at_start:
        if request_chance(config.request_prob):
            return request(requested_at_start=True, unhelped_since=restart)
        state = _evolve(state, requested_at_start=True, draws=draws)
    if (
        config.request_when_unhelped_for is not None
        and state.unhelped_since != NOT_COUNTING
        and time - state.unhelped_since >= config.request_when_unhelped_for - 1e-9
    ):
        if request_chance(config.request_prob):
            return request(unhelped_since=time)
        state = _evolve(state, unhelped_since=time, draws=draws)  # let it pass; look again later

    if time < state.start_until - 1e-9:
        return _evolve(state, raw=zero, draws=draws)

    remaining = mode_remaining(err, modes, config)
    if config.aim_error > 0 and mode < n_modes - 1:
        # Where to stop along the current mode's dimensions is judged by eye on entering it; once
        # there, if nothing else is left to do, it looks again (a correction, judged anew).
        if state.aim_mode != mode:
            state = _aim(state, mode, err, modes, config, rng())
        seen = _seen_error(state, err, modes[mode])
        seen_remaining = float(mode_remaining(seen, (modes[mode],), config)[0])
        if seen_remaining <= 1.0 < remaining[mode]:
            # The primary movement ended short: correct it now, in this mode (a corrective
            # submovement, with probability correction_prob, or when nothing else is left).
            others = np.delete(remaining[: n_modes - 1], mode)
            if (
                others.size == 0
                or float(np.max(others)) <= 1.0
                or (config.correction_prob > 0 and rng().random() < config.correction_prob)
            ):
                state = _aim(state, mode, err, modes, config, rng())
                seen = _seen_error(state, err, modes[mode])
                seen_remaining = float(mode_remaining(seen, (modes[mode],), config)[0])
        err = seen
        remaining = remaining.copy()
        remaining[mode] = seen_remaining
    arm_remaining = remaining[: n_modes - 1]
    target = state.target_mode

    # The mode a request chose: keep it, or cycle away to one of its own choice.
    if state.judge:
        state = _evolve(state, judge=False, kept_mode=mode if config.keep_assisted_mode else -1)
        if config.accept_prob < 1.0 and rng().random() >= config.accept_prob:
            g = rng() if config.mode_temperature > 0 else None
            target = choose_mode(
                arm_remaining, mode, n_modes, config, g, exclude_current=True, direct=direct, back=back
            )
            if target != mode and arm_remaining[target] > 1.0:
                return press(
                    variant.change_raw(mode, target, selection),
                    target_mode=target,
                    overshot=False,
                    kept_mode=-1,
                )
            target = -1
    # The kept mode: while the assistance helps, the arm approaches the goal in it whatever is left
    # along the mode's own dimensions, so the user keeps using it until the whole goal's remaining
    # error stops falling (rule 5 watches it) or the assistance stops helping.
    stay = config.stay_while_assisted and variant.proportional
    keep = (state.kept_mode == mode or stay) and mode < n_modes - 1 and assisted
    if state.kept_mode >= 0 and not keep:
        state = _evolve(state, kept_mode=-1)
    if keep:
        remaining = remaining.copy()
        remaining[mode] = max(float(remaining[mode]), float(np.max(arm_remaining)))
        arm_remaining = remaining[: n_modes - 1]

    if target >= 0 and target == mode:
        overshoot = config.overshoot_prob > 0 and not direct and not state.overshot
        if overshoot and rng().random() < config.overshoot_prob:
            # One too many (one step on): cycling goes round again to the target. Direct selection
            # is one deliberate press per change: nothing to overshoot.
            return press(variant.step_raw(1), overshot=True)
        state = _evolve(state, target_mode=-1, overshot=False)
        out = settle()
        if out is not None:
            return out
        target = -1
    if target >= 0 and remaining[target] <= 1.0:
        target = -1  # nothing left to do there
    use_requests = belief is not None and config.request_instead_prob > 0
    if target < 0 and remaining[mode] <= 1.0:
        if use_requests and request_chance(config.request_instead_prob):
            return request()
        g = rng() if config.mode_temperature > 0 else None
        # A Boltzmann user never "chooses" the exhausted mode it is in (the oracle cannot: it is the least).
        target = choose_mode(
            arm_remaining, mode, n_modes, config, g, exclude_current=g is not None, direct=direct, back=back
        )
        if target == mode:  # unreachable with validated tolerances: nothing left anywhere
            return _evolve(state, raw=zero, target_mode=-1, draws=draws)
        return press(variant.change_raw(mode, target, selection), target_mode=target, overshot=False)
    if target >= 0:
        return press(variant.change_raw(mode, target, selection), target_mode=target)
    state = _evolve(state, target_mode=-1)

    # Rule 5: a mode in which commanding has stopped paying off is left for another one.
    if config.stall_time is not None:
        now_remaining = float(remaining[mode])
        if state.progress_mode != mode or now_remaining <= state.progress_best - config.stall_progress:
            state = _evolve(state, progress_mode=mode, progress_since=time, progress_best=now_remaining)
        elif time - state.progress_since >= config.stall_time - 1e-9:
            others = arm_remaining.copy()
            if mode < others.size:
                others[mode] = -np.inf
            if np.max(others) > 1.0:
                if use_requests and request_chance(config.request_instead_prob):
                    return request()
                g = rng() if config.mode_temperature > 0 else None
                best = choose_mode(
                    arm_remaining, mode, n_modes, config, g, exclude_current=True, direct=direct, back=back
                )
                if others[best] > 1.0:
                    return press(variant.change_raw(mode, best, selection), target_mode=best, overshot=False)
            # Nothing else to do: the arm does not follow (the autonomy holds it at another goal,
            # or a limit): ask the system for help if it can, else keep at it and watch again.
            if use_requests:
                return request()
            state = _evolve(state, progress_since=time, progress_best=now_remaining)

    # Reviews: while the mode still helps, is another one better now? (People interleave modes.)
    # Not while a kept mode carries the user with the assistance (win-stay).
    if (
        config.mode_review_rate > 0
        and not keep
        and rng().random() < -math.expm1(-config.mode_review_rate * period)
    ):
        g = rng() if config.mode_temperature > 0 else None
        choice = choose_mode(arm_remaining, mode, n_modes, config, g, direct=direct, back=back)
        if choice != mode and arm_remaining[choice] > 1.0:
            if use_requests and request_chance(config.request_instead_prob):
                return request()  # a change is wanted: ask for it instead, as in rules 4 and 5
            return press(variant.change_raw(mode, choice, selection), target_mode=choice, overshot=False)

    # Pauses (fatigue, thinking).
    if config.pause_rate > 0 and rng().random() < -math.expm1(-config.pause_rate * period):
        g = rng() if config.pause_log_sd > 0 else None
        wait = lognormal(config.pause_duration, config.pause_log_sd, g)
        # The stall watch (rule 5) counts commanding time: it starts again after the pause.
        return _evolve(state, raw=zero, busy_until=time + max(wait, period), draws=draws, progress_mode=-1)

    # Rule 6: command.
    dims = modes[mode]
    tol = _dim_tolerances(config)
    speeds = interface.dim_speeds()
    raw = zero
    if variant.proportional:
        axes = [0.0, 0.0]
        active = []
        for k, d in enumerate(dims):
            if d == GRIPPER_DIM or (abs(err[d]) <= tol[d] and not (keep and k == _pushed(err, dims, tol))):
                continue
            axis = float(np.clip(err[d] / config.approach_time / speeds[d], -1.0, 1.0))
            if abs(axis) < config.min_axis:
                axis = math.copysign(config.min_axis, err[d])
            axes[k] = axis
            active.append(k)
        if active and (config.direction_kappa is not None or config.deflection_log_sd > 0):
            g = rng()
            stick = np.array(axes)
            size = float(np.linalg.norm(stick))
            if config.direction_kappa is not None:
                stick = sample_von_mises_fisher(stick, config.direction_kappa, g)
            stick = stick * lognormal(size, config.deflection_log_sd, g)
            axes = stick.tolist()
        for k in range(2):
            if config.axis_noise > 0 and k in active:
                axes[k] += float(rng().normal(0.0, config.axis_noise))
        raw = np.array(variant.drive_raw(axes))
    else:
        d = dims[0]
        if d != GRIPPER_DIM:
            if err[d] > tol[d] or (keep and 0.0 <= err[d]):
                raw = np.array(variant.drive_raw([1.0]))
            elif err[d] < -tol[d] or keep:
                raw = np.array(variant.drive_raw([-1.0]))
    if (
        config.wrong_press_prob > 0
        and variant.is_driving(raw)
        and not variant.is_driving(state.raw)
        and rng().random() < config.wrong_press_prob
    ):
        return press(variant.step_raw(1))  # meant to drive, hit the mode-change action
    return _evolve(state, raw=raw, draws=draws)
