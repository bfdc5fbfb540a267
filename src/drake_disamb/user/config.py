"""The simulated user's settings: the tolerances it aims for and one nested config per behaviour.

:class:`UserConfig` holds the tolerances, the seed and ``rho1`` and nests :class:`TimingConfig`
(reaction and timing), :class:`CommandConfig` (the command and its noise, judging where to stop),
:class:`ModeChoiceConfig` (which mode next, stalls, reviews, overshoots), :class:`RequestConfig`
(disambiguation requests) and :class:`PauseConfig`. Every behaviour is off by default (the
deterministic user of :mod:`drake_disamb.user.rules`).

Every field of every group also has one flat name, its own (the groups share none): a scenario's
``user.config``, a population's overrides and ``dataclasses.replace`` give
``UserConfig(reaction_time=0.5)`` and it goes to its group (:data:`FIELD_GROUPS`,
:meth:`UserConfig.flat`). Each group checks its own fields when it is built; the errors name a
field ``UserConfig.<name>``.
"""

from __future__ import annotations

import dataclasses
import math
import numbers
import typing
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from drake_disamb.core.validation import bounded_repr, is_real

if TYPE_CHECKING:
    from drake_disamb.interfaces import InterfaceConfig

__all__ = [
    "FIELD_GROUPS",
    "CommandConfig",
    "ModeChoiceConfig",
    "PauseConfig",
    "RequestConfig",
    "TimingConfig",
    "UserConfig",
]


def _check_real(config: object, names: tuple[str, ...], allow_zero: bool = False) -> None:
    """Raise ``ValueError`` naming ``UserConfig.field`` and the value unless each field is a finite
    real > 0 (``>= 0`` with ``allow_zero``): the groups' errors name the field as a scenario's
    ``user.config`` writes it."""
    for name in names:
        value = getattr(config, name)
        if not (is_real(value) and (value >= 0 if allow_zero else value > 0)):
            bound = ">= 0" if allow_zero else "> 0"
            got = bounded_repr(value)
            raise ValueError(f"UserConfig.{name}: expected a finite number {bound}, got {got}")


def _check_optional_positive(config: object, names: tuple[str, ...]) -> None:
    for name in names:
        value = getattr(config, name)
        if value is not None and not (is_real(value) and value > 0):
            raise ValueError(f"UserConfig.{name}: expected None or a number > 0, got {value!r}")


def _check_probabilities(config: object, names: tuple[str, ...]) -> None:
    for name in names:
        value = getattr(config, name)
        if not (is_real(value) and 0 <= value <= 1):
            raise ValueError(f"UserConfig.{name}: expected a probability in [0, 1], got {value!r}")


def _check_bools(config: object, names: tuple[str, ...]) -> None:
    for name in names:
        if not isinstance(getattr(config, name), bool):
            raise ValueError(f"UserConfig.{name}: expected true or false, got {getattr(config, name)!r}")


@dataclass(frozen=True)
class TimingConfig:
    """Reaction and timing.

    Attributes:
        reaction_time: Wait (s) after a button press before the next action, everything released.
        reaction_time_jitter: Each wait is ``reaction_time + U(-jitter, +jitter)`` (s); 0 = exact.
        reaction_log_sd: Log-sd of the lognormal wait after a press (median ``reaction_time``).
        decision_period: Seconds between the user's decisions (``None`` = every control period).
        settle_time: Median extra wait (s) after a finished mode change before commanding.
        settle_log_sd: Its log-sd.
        settle_prob: Probability that a finished mode change is followed by the settle wait (else
            the user commands right after its reaction wait).
        start_delay: Median time (s) before the first mode switch or command of the trial.
        start_delay_log_sd: Its log-sd.
        start_delay_max: The longest start delay (s): a longer draw is cut to it; ``None`` = no bound
            but the lognormal's own (2 sd).
        release_lag: Mean (s) of the exponential delay with which a drive is released.
    """

    reaction_time: float = 0.3
    reaction_time_jitter: float = 0.0
    reaction_log_sd: float = 0.0
    decision_period: float | None = None
    settle_time: float = 0.0
    settle_log_sd: float = 0.0
    settle_prob: float = 1.0
    start_delay: float = 0.0
    start_delay_log_sd: float = 0.0
    start_delay_max: float | None = None
    release_lag: float = 0.0

    def __post_init__(self) -> None:
        _check_real(self, ("reaction_time",))
        _check_real(self, ("reaction_time_jitter",), allow_zero=True)
        if self.reaction_time_jitter >= self.reaction_time:
            raise ValueError(
                f"UserConfig.reaction_time_jitter: expected less than reaction_time={self.reaction_time}, "
                f"got {self.reaction_time_jitter!r}"
            )
        _check_real(
            self,
            (
                "reaction_log_sd",
                "settle_time",
                "settle_log_sd",
                "start_delay",
                "start_delay_log_sd",
                "release_lag",
            ),
            allow_zero=True,
        )
        _check_optional_positive(self, ("decision_period", "start_delay_max"))
        _check_probabilities(self, ("settle_prob",))


@dataclass(frozen=True)
class CommandConfig:
    """The command along the mode's dimensions, its noise, and judging where to stop.

    Attributes:
        approach_time: Proportional gain: the user asks for ``error / approach_time`` (m/s or
            rad/s) of a proportional interface (the joystick).
        min_axis: Smallest deflection used while a dimension is not done, in (0, 1].
        axis_noise: Standard deviation of Gaussian noise added to each deflected axis (0 = none).
        direction_kappa: Von Mises-Fisher concentration of the stick direction about the intended
            one (``None`` = exact).
        deflection_log_sd: Log-sd of the lognormal factor on the stick's deflection (0 = exact).
        aim_error: Relative error of the user's judgement of where to stop (0 = exact): on entering
            a mode it aims each of the mode's dimensions at ``goal - eps * error`` with ``eps``
            half-normal of scale this (truncated at 2), i.e. the primary movement stops short by a
            share of the distance it sees, and the user corrects later.
        correction_prob: With ``aim_error``: probability that, when a movement in a mode ends
            short of the goal (the aim reached, the mode not done), the user corrects it at once
            in the same mode (a corrective submovement, aimed anew) rather than moving on to
            another mode and coming back later (0 = it always moves on while others are left).
        stick_correction_prob: The same with a proportional interface (the joystick), or
            ``None`` for ``correction_prob`` with every interface. People nudge a stick in place
            far more often than they re-press a switch (``study calibrate``, corrections per
            dwell: joystick 0.95, head array 0.15).
    """

    approach_time: float = 0.5
    min_axis: float = 0.2
    axis_noise: float = 0.0
    direction_kappa: float | None = None
    deflection_log_sd: float = 0.0
    aim_error: float = 0.0
    correction_prob: float = 0.0
    stick_correction_prob: float | None = None

    def __post_init__(self) -> None:
        _check_real(self, ("approach_time",))
        _check_real(self, ("axis_noise", "deflection_log_sd", "aim_error"), allow_zero=True)
        if not (is_real(self.min_axis) and 0 < self.min_axis <= 1):
            raise ValueError(f"UserConfig.min_axis: expected a number in (0, 1], got {self.min_axis!r}")
        _check_optional_positive(self, ("direction_kappa",))
        _check_probabilities(self, ("correction_prob",))
        if self.stick_correction_prob is not None:
            _check_probabilities(self, ("stick_correction_prob",))


@dataclass(frozen=True)
class ModeChoiceConfig:
    """Which mode next, and when to leave one.

    Attributes:
        stall_time: Seconds of commanding in one mode without progress after which the user
            switches to another mode (the stall rule); ``None`` disables.
        stall_progress: The progress that counts, as a fall of the mode's remaining error in
            tolerance units (1 = one ``position_tolerance`` or ``orientation_tolerance``).
        backoff_after: Backing off: after this long commanding (s, in any modes, across presses
            and requests) without the goal's remaining error (summed over the arm modes) falling
            by ``stall_progress``, the arm is blocked (a joint limit, the floor, the IK stopping)...
        backoff_time: ... and the user drives back the way it came in its mode for this long
            (s), then changes to another mode: it routes around. 0: it never backs off.
        detour_lift: Routing around over the obstacle (the floor, an object): after a back-off in
            a mode that does not move the hand vertically, the user first lifts the end effector
            by this much (m, world +z) and keeps it there until the blocked mode's dimensions are
            done (then it comes down as any error); blocked again meanwhile, it drops the detour.
            0: no detour.
        mode_temperature: Softmax temperature of the mode choice, in usefulness units (0 = the best).
        press_cost: Usefulness a mode loses per press needed to reach it.
        overshoot_prob: Probability of one press too many on reaching the target mode by cycling
            (not with direct selection: one deliberate press per change).
        mode_review_rate: Reviews per second of commanding time of whether another mode would be
            better (a Boltzmann choice with the current mode in it, at no press cost); 0 = only
            when the mode is done or stalled.
        wrong_press_prob: Probability that starting to drive makes a mode change instead.
        stay_while_assisted: With a proportional interface (the joystick), keep using *any* arm
            mode the user is in, not only a kept request mode, while the autonomy assists its goal
            (win-stay): a small push in the mode (``min_axis``) is blended with the autonomy's
            command, which carries the arm home. Not with a switched interface (the head array),
            whose full-speed switches along a done dimension drive the arm away from the goal
            (there only a kept request mode is used so, with ``keep_assisted_mode``).
        unsure_rotation_weight: While the autonomy does not assist the user's goal (the belief
            unsure, or on another goal), the weight of a rotation mode's remaining error in the
            mode choice while a translation mode still has work left, in [0, 1]: people translate
            first and leave the rotation for later (``study calibrate``, commanding by belief:
            while unsure, head array 0.15 of the time translating and 0.008 rotating, joystick
            0.15 and 0.027), when the assistance, once it helps, rotates the gripper for them.
            1: no difference (rotation modes weigh as their error), the default and the study
            population's (0 was tried and not kept: docs/population.md).
    """

    stall_time: float | None = 2.0
    stall_progress: float = 1.0
    backoff_after: float = 4.0
    backoff_time: float = 1.0
    detour_lift: float = 0.0
    mode_temperature: float = 0.0
    press_cost: float = 0.0
    overshoot_prob: float = 0.0
    mode_review_rate: float = 0.0
    wrong_press_prob: float = 0.0
    stay_while_assisted: bool = False
    unsure_rotation_weight: float = 1.0

    def __post_init__(self) -> None:
        if self.stall_time is not None and not (is_real(self.stall_time) and self.stall_time > 0):
            raise ValueError(f"UserConfig.stall_time: expected None or a number > 0, got {self.stall_time!r}")
        if not (is_real(self.stall_progress) and self.stall_progress > 0):
            raise ValueError(
                f"UserConfig.stall_progress: expected a finite number > 0, got {self.stall_progress!r}"
            )
        _check_real(self, ("backoff_after",))
        _check_real(
            self,
            ("backoff_time", "detour_lift", "mode_temperature", "press_cost", "mode_review_rate"),
            allow_zero=True,
        )
        _check_probabilities(self, ("overshoot_prob", "wrong_press_prob"))
        w = self.unsure_rotation_weight
        if not (is_real(w) and 0 <= w <= 1):
            raise ValueError(f"UserConfig.unsure_rotation_weight: expected a number in [0, 1], got {w!r}")
        _check_bools(self, ("stay_while_assisted",))


@dataclass(frozen=True)
class RequestConfig:
    """Disambiguation requests.

    Attributes:
        request_at_start: Press the disambiguation button once at the start of the trial.
        request_when_unhelped_for: Press it when the autonomy has not been helping for this long
            (s); the timer restarts after every request. ``None`` disables (manual paradigm: set
            this to ``None`` and ``request_at_start`` to False).
        request_prob: Probability of making a request the policy calls for (start, unhelped).
        request_instead_prob: Probability of asking for disambiguation instead of cycling when a
            new mode is needed (needs the belief, i.e. the disambiguation paradigm).
        request_decay_time: Request probabilities are scaled by ``exp(-t / this)`` (``None`` = 1).
        request_wait: After a request, wait up to this (s) for the mode to change.
        accept_prob: Probability of keeping the mode a request chose (else cycle away from it).
        keep_assisted_mode: Keep using the mode a request chose and the user kept (``accept_prob``)
            while the autonomy assists its goal, also when the mode's own dimensions are done: it
            pushes toward the goal in it (the blended command moves the arm toward the goal) until
            the whole goal's remaining error stops falling (the stall rule) or the assistance
            stops. False: a kept mode whose dimensions are done is left at once.
    """

    request_at_start: bool = True
    request_when_unhelped_for: float | None = 3.0
    request_prob: float = 1.0
    request_instead_prob: float = 0.0
    request_decay_time: float | None = None
    request_wait: float = 0.0
    accept_prob: float = 1.0
    keep_assisted_mode: bool = False

    def __post_init__(self) -> None:
        t = self.request_when_unhelped_for
        if t is not None and not (is_real(t) and t > 0):
            raise ValueError(
                f"UserConfig.request_when_unhelped_for: expected None or a number > 0, got {t!r}"
            )
        _check_optional_positive(self, ("request_decay_time",))
        _check_real(self, ("request_wait",), allow_zero=True)
        _check_probabilities(self, ("request_prob", "request_instead_prob", "accept_prob"))
        _check_bools(self, ("keep_assisted_mode",))


@dataclass(frozen=True)
class PauseConfig:
    """Pauses (fatigue, thinking), and letting the autonomy carry the arm.

    Attributes:
        pause_rate: Pauses per second of the time it would command (0 = none).
        pause_duration: Median pause (s).
        pause_log_sd: Its log-sd (also that of a carry).
        carry_prob: When the current mode has nothing left to do while the autonomy assists the
            user's goal, the probability that the user lets go and lets the autonomy carry the arm
            (the blending assists without input) instead of changing mode.
        carry_duration: Median carry (s): the user watches that long, then decides again (a carry
            ends at once when the assistance stops helping).
        counter_prob: When the user wants another mode while the autonomy assists *another* goal
            (the arm heads for another object), the probability that it counter-steers instead:
            it keeps pushing toward its goal in its mode for a lognormal ``carry_duration`` (the
            push of a kept mode), then decides again.
    """

    pause_rate: float = 0.0
    pause_duration: float = 1.0
    pause_log_sd: float = 0.0
    carry_prob: float = 0.0
    carry_duration: float = 1.6
    counter_prob: float = 0.0

    def __post_init__(self) -> None:
        _check_real(self, ("pause_duration", "carry_duration"))
        _check_real(self, ("pause_rate", "pause_log_sd"), allow_zero=True)
        _check_probabilities(self, ("carry_prob", "counter_prob"))


_GROUPS: dict[str, type] = {
    "timing": TimingConfig,
    "command": CommandConfig,
    "mode_choice": ModeChoiceConfig,
    "requests": RequestConfig,
    "pauses": PauseConfig,
}

FIELD_GROUPS: dict[str, str] = {
    f.name: group for group, cls in _GROUPS.items() for f in dataclasses.fields(cls)
}
"""Flat field name -> the :class:`UserConfig` group that holds it."""


@dataclass(frozen=True, init=False)
class UserConfig:
    """Behaviour of the simulated user.

    ``UserConfig(**fields)`` takes the groups (``timing=TimingConfig(...)``) and any group field
    by its flat name (``reaction_time=0.5``, applied over its group).

    Attributes:
        position_tolerance: Per-dimension position tolerance (m): a translational dimension is done
            when its error is at most this.
        orientation_tolerance: Per-dimension orientation tolerance (rad).
        success_position_tolerance: Goal reached when the position error norm is at most this (m);
            at least ``sqrt(3) * position_tolerance``.
        success_orientation_tolerance: ... and the orientation error angle at most this (rad); at
            least ``sqrt(3) * orientation_tolerance``.
        use_orientation: If False the user ignores orientation (reaching by position only).
        rho1: Belief threshold below which the autonomy gives no assistance (as in the blender);
            ``None`` = the paper's ``1.2 / n_goals``.
        seed: Seed of the optional randomness.
        timing: :class:`TimingConfig`.
        command: :class:`CommandConfig`.
        mode_choice: :class:`ModeChoiceConfig`.
        requests: :class:`RequestConfig`.
        pauses: :class:`PauseConfig`.
    """

    position_tolerance: float
    orientation_tolerance: float
    success_position_tolerance: float
    success_orientation_tolerance: float
    use_orientation: bool
    rho1: float | None
    seed: int
    timing: TimingConfig
    command: CommandConfig
    mode_choice: ModeChoiceConfig
    requests: RequestConfig
    pauses: PauseConfig

    _TOP: typing.ClassVar[dict[str, Any]] = {
        "position_tolerance": 0.01,
        "orientation_tolerance": 0.05,
        "success_position_tolerance": 0.02,
        "success_orientation_tolerance": 0.1,
        "use_orientation": True,
        "rho1": None,
        "seed": 0,
    }

    def __init__(self, **fields: Any) -> None:
        groups = {name: fields.pop(name, None) or cls() for name, cls in _GROUPS.items()}
        for name, cls in _GROUPS.items():
            if not isinstance(groups[name], cls):
                raise ValueError(f"UserConfig.{name}: expected a {cls.__name__}, got {groups[name]!r}")
        flat: dict[str, dict[str, Any]] = {}
        for key in [k for k in fields if k in FIELD_GROUPS]:
            flat.setdefault(FIELD_GROUPS[key], {})[key] = fields.pop(key)
        unknown = sorted(set(fields) - set(self._TOP))
        if unknown:
            known = ", ".join([*self._TOP, *_GROUPS, *FIELD_GROUPS])
            raise ValueError(f"UserConfig: unknown fields {unknown}; expected some of {known}")
        for name, value in {**self._TOP, **fields}.items():
            object.__setattr__(self, name, value)
        for name, group in groups.items():
            object.__setattr__(self, name, replace(group, **flat[name]) if name in flat else group)
        self._check()

    def _check(self) -> None:
        _check_real(
            self,
            (
                "position_tolerance",
                "orientation_tolerance",
                "success_position_tolerance",
                "success_orientation_tolerance",
            ),
        )
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
        if self.rho1 is not None and not (is_real(self.rho1) and 0 <= self.rho1 <= 1):
            raise ValueError(f"UserConfig.rho1: expected None or a number in [0, 1], got {self.rho1!r}")
        if not (isinstance(self.seed, numbers.Integral) and self.seed >= 0):
            raise ValueError(f"UserConfig.seed: expected an integer >= 0, got {self.seed!r}")

    @classmethod
    def flat_types(cls) -> dict[str, Any]:
        """Every field by its flat name (the top-level ones, then each group's) -> its type: the
        scenario form of the config (``user.config`` in a scenario's YAML)."""
        hints = {name: typing.get_type_hints(cls)[name] for name in cls._TOP}
        for group in _GROUPS.values():
            hints.update(typing.get_type_hints(group))
        return hints

    def flat(self) -> dict[str, Any]:
        """Every field by its flat name -> its value (:meth:`flat_types`' order)."""
        values = {name: getattr(self, name) for name in self._TOP}
        for group in _GROUPS:
            values.update(dataclasses.asdict(getattr(self, group)))
        return values

    def without_requests(self) -> UserConfig:
        """This user with every disambiguation request off (the manual paradigm)."""
        return replace(self, request_at_start=False, request_when_unhelped_for=None, request_instead_prob=0.0)

    def period(self, interface: InterfaceConfig) -> float:
        """Seconds between decisions with ``interface``: ``decision_period`` or its control period."""
        period = self.timing.decision_period
        return interface.control_period if period is None else period

    @property
    def min_reaction_time(self) -> float:
        """The shortest possible wait after a press (s)."""
        return self.timing.reaction_time - self.timing.reaction_time_jitter

    def dim_tolerances(self) -> NDArray[np.float64]:
        """Tolerance of each dimension 0..5 (3 positions in m, 3 orientations in rad)."""
        return np.array([self.position_tolerance] * 3 + [self.orientation_tolerance] * 3)
