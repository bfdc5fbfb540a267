"""The study's population of simulated users: each subject's behaviour drawn from documented distributions.

A :class:`Subject` is a name (``"S01"``, ...) and ``user``: overrides of ``Scenario.user.config``
(the fields of :class:`drake_disamb.user.UserConfig`, plain JSON values) that the study runner
applies to each of the subject's trials. :func:`draw_subjects` draws them from a
:class:`PopulationConfig`: per parameter, a distribution *across subjects* (a subject keeps its
values for all its trials; the within-trial randomness -- each reaction time, pause, stick
direction, mode choice -- is drawn by the user model from the trial's seed).

The default distributions come from the behaviour measured in the authors' logs of 4 of the
paper's subjects (``drake-disamb study calibrate DATA_DIR``, :mod:`drake_disamb.study.measures.calibration`)
where the logs show it, and from the literature where they cannot; ``docs/population.md`` gives
the table, the estimate behind every entry and the reasoning. None is fitted to the
Manual-versus-Disambiguation comparison.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drake_disamb.core.validation import is_real
from drake_disamb.user import UserConfig

__all__ = ["LogNormal", "PopulationConfig", "Subject", "Uniform", "draw_subjects"]


@dataclass(frozen=True)
class LogNormal:
    """Across subjects: ``median * exp(log_sd * z)``, clipped to ``[low, high]``."""

    median: float
    log_sd: float = 0.0
    low: float = 0.0
    high: float = math.inf

    def __post_init__(self) -> None:
        if not (is_real(self.median) and self.median > 0 and is_real(self.log_sd) and self.log_sd >= 0):
            raise ValueError(f"LogNormal: expected median > 0 and log_sd >= 0, got {self!r}")
        if not self.low <= self.high:
            raise ValueError(f"LogNormal: expected low <= high, got {self!r}")

    def draw(self, rng: np.random.Generator) -> float:
        value = self.median * math.exp(self.log_sd * rng.standard_normal())
        return float(min(max(value, self.low), self.high))


@dataclass(frozen=True)
class Uniform:
    """Across subjects: uniform in ``[low, high]``."""

    low: float
    high: float

    def __post_init__(self) -> None:
        if not (is_real(self.low) and is_real(self.high) and self.low <= self.high):
            raise ValueError(f"Uniform: expected finite low <= high, got {self!r}")

    def draw(self, rng: np.random.Generator) -> float:
        return float(rng.uniform(self.low, self.high))


Distribution = LogNormal | Uniform


def _default_distributions() -> dict[str, Distribution]:
    # Every entry: docs/population.md (estimates printed by `drake-disamb study calibrate`).
    return {
        # Press interval within a mode change: median 0.47 s, between-subject log-sd 0.14.
        "reaction_time": LogNormal(0.47, 0.14, low=0.25),
        # Within-subject log-sd of the press interval (0.76 pooled; the per-subject spread is small).
        "reaction_log_sd": Uniform(0.6, 0.8),
        # Switch -> next command (>= 0.1 s) median 2.54 s, less the press wait (0.47): 2.07 s;
        # between 0.20, within 0.93; 35 % of switches have the command held through them.
        "settle_time": LogNormal(2.07, 0.20),
        "settle_prob": Uniform(0.55, 0.75),
        # Trial start -> first switch or command: median 5.62 s, between 0.42, within 0.84.
        "start_delay": LogNormal(5.6, 0.42, high=20.0),
        "start_delay_log_sd": Uniform(0.7, 0.9),
        # Pauses (zero command >= 0.5 s, no event inside): 0.19..0.33 per s of commanding.
        "pause_rate": LogNormal(0.26, 0.22),
        # Pause duration: median 1.72 s, between 0.31, within 0.72.
        "pause_duration": LogNormal(1.7, 0.31),
        "pause_log_sd": Uniform(0.6, 0.8),
        # Joystick direction spread within command runs: von Mises kappa 9.8 (per subject 7.5..13).
        "direction_kappa": LogNormal(9.8, 0.23),
        # Joystick deflection: per-subject medians 0.35..1 of full (between log-sd 0.52): the gain.
        "approach_time": LogNormal(0.8, 0.52, low=0.3, high=3.0),
        "deflection_log_sd": Uniform(0.2, 0.5),
        # Literature (not in the logs): release lags of a simple reaction, wrong presses, mode choice.
        "release_lag": LogNormal(0.06, 0.3),
        "wrong_press_prob": Uniform(0.0, 0.05),
        "mode_temperature": LogNormal(0.15, 0.5),
        # Head-array presses per mode change 2.06 (the simulated users, on the study's system:
        # 3.45 with U(0, 0.1), 2.45 with this).
        "press_cost": Uniform(0.1, 0.3),
        # Commanding s per mode change 1.83 (head array), 3.76 (joystick); on the study's system
        # the simulated users gave 1.94 and 3.24 with this.
        "mode_review_rate": LogNormal(0.2, 0.3),
        # Head-array changes of >= 7 presses (a full round, one per overshoot): 0.02 of changes.
        "overshoot_prob": Uniform(0.0, 0.04),
        # Requests: a mode change is a request with probability p0 * exp(-t / tau), fitted to the
        # Disambiguation trials' changes: p0 0.45..0.63 per subject, tau 131 s (one for all: a
        # zero log-sd, kept among the draws so that the later draws stay as they were); first
        # request in the first 3 s in 0.42 of Disambiguation trials; the chosen mode kept 0.77
        # (the next action a command; a kept mode already done counts as left, so accept_prob is
        # above it: 0.85-1.0 measured 0.68 on the simulated users). A request is made at the
        # start or instead of a change of the user's own (no timer: request_when_unhelped_for is
        # fixed off), so p0 is people's own.
        "request_instead_prob": Uniform(0.45, 0.64),
        "request_prob": Uniform(0.3, 0.55),
        "request_decay_time": LogNormal(131.0, 0.0),
        "accept_prob": Uniform(0.85, 1.0),
        # Literature (no pose in the logs): judging by eye where to stop, relative error 10-30 %.
        "aim_error": LogNormal(0.2, 0.3, high=0.4),
        # A movement that ended short is corrected at once in the same mode: short stops (0.1 to
        # 0.5 s) between commands per dwell c -> c / (1 + c) per subject, head array 0.05..0.23
        # (the joystick's own below; pooled over both interfaces it was 0.12..0.39).
        "correction_prob": Uniform(0.05, 0.23),
        # Letting the autonomy carry the arm (drawn last, so that the draws above stay as they
        # were): in reaching, people forgo 0.81 (joystick) and 0.69 (head array) of their mode
        # changes per minute while the belief's argmax is their goal, against while it is unsure;
        # pauses begun while the assistance moves the arm last a median 1.60 s (between 0.30), as
        # long as the others (1.79 s): the carry's watch.
        "carry_prob": Uniform(0.65, 0.85),
        "carry_duration": LogNormal(1.6, 0.30),
        # Counter-steering (drawn after the carry): in reaching people forgo 0.76 (joystick) and
        # 0.30 (head array) of their changes per minute while the argmax is another goal, against
        # while it is unsure: their range, one value per subject for both interfaces.
        "counter_prob": Uniform(0.3, 0.75),
        # The joystick's corrections (drawn last): its short stops per dwell per subject give
        # c / (1 + c) 0.23..0.55 (a stick is nudged in place far more than a switch is re-pressed).
        "stick_correction_prob": Uniform(0.23, 0.55),
    }


def _default_fixed() -> dict[str, Any]:
    return {
        "decision_period": 0.1,  # decisions at 10 Hz (intermittent human control, ~100-200 ms)
        "settle_log_sd": 0.93,  # within: pooled log-sd of the settles
        "request_wait": 3.0,  # the system's 2-2.5 s latency; request -> switch 2.5-3.2 s in the logs
        "request_at_start": True,
        # The longest start in the logs: 20.0 s (119 trials). Their starts' upper tail is lighter
        # than a lognormal's (log residuals: 95th percentile 1.10, the lognormal's 1.4); a slow
        # subject's draws reached a minute, which the experimenter's rule ended as given up.
        "start_delay_max": 20.0,
        # A request is one way to change mode: people's share of changes made by requests is one
        # rate over the trial (p0 exp(-t / tau), fitted over every change, the start's included),
        # and the model makes it so. A timer's request ("when unhelped for" a while) came on top
        # of the changes, with the changes out of the chosen mode after it (docs/population.md).
        "request_when_unhelped_for": None,
        "keep_assisted_mode": True,  # a kept request mode is used while the assistance helps
        # With the joystick, any mode is used so while assisted: people's changes per minute while
        # the belief is confident 2.4, while not 7.9 (head array 5.9 and 11.0, Manual 7.1 and 8.9).
        "stay_while_assisted": True,
        # Backing off when blocked (a joint limit, the floor): the logs have no pose to show it.
        "backoff_after": 4.0,  # two stall windows of commanding without the goal's error falling
        "backoff_time": 1.0,
        # Routing over the obstacle after a back-off: a hand's width up (our choice, no pose logged).
        "detour_lift": 0.1,
    }


@dataclass(frozen=True)
class PopulationConfig:
    """The population's distributions.

    Attributes:
        distributions: ``UserConfig`` field -> its distribution across subjects
            (:class:`LogNormal` or :class:`Uniform`); drawn in this order.
        fixed: ``UserConfig`` field -> one value for every subject.
    """

    distributions: dict[str, Distribution] = field(default_factory=_default_distributions)
    fixed: dict[str, Any] = field(default_factory=_default_fixed)

    def __post_init__(self) -> None:
        names = set(UserConfig.flat_types()) - {"seed", "rho1"}
        for where, mapping in (("distributions", self.distributions), ("fixed", self.fixed)):
            for key in mapping:
                if key not in names:
                    raise ValueError(
                        f"PopulationConfig.{where}: {key!r} is not a UserConfig field "
                        f"(one of {sorted(names)})"
                    )
        for key, dist in self.distributions.items():
            if not isinstance(dist, LogNormal | Uniform):
                raise ValueError(
                    f"PopulationConfig.distributions[{key!r}]: expected LogNormal or Uniform, got {dist!r}"
                )
        overlap = set(self.distributions) & set(self.fixed)
        if overlap:
            raise ValueError(f"PopulationConfig: fields both drawn and fixed: {sorted(overlap)}")


@dataclass(frozen=True)
class Subject:
    """One simulated subject: ``name`` (``"S01"``, ...) and ``user``, overrides of
    ``Scenario.user.config`` (plain JSON values)."""

    name: str
    user: dict[str, Any]

    def config(self, base: UserConfig | None = None) -> UserConfig:
        """The subject's :class:`UserConfig` (``base`` with the overrides; validates them)."""
        return dataclasses.replace(base or UserConfig(), **self.user)


def draw_subjects(n: int, seed: int, config: PopulationConfig | None = None) -> list[Subject]:
    """``n`` subjects drawn from ``config`` (default: :class:`PopulationConfig`).

    Subject ``i`` uses ``default_rng([seed, i])``: the same seed gives the same subjects, and a
    subject does not depend on ``n``. Every subject's overrides make a valid ``UserConfig``.
    """
    if isinstance(n, bool) or not isinstance(n, int) or n < 0:
        raise ValueError(f"n: expected an integer >= 0, got {n!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"seed: expected an integer >= 0, got {seed!r}")
    cfg = PopulationConfig() if config is None else config
    subjects = []
    for i in range(n):
        rng = np.random.default_rng([seed, i])
        user: dict[str, Any] = {k: v for k, v in cfg.fixed.items()}
        for key, dist in cfg.distributions.items():
            user[key] = round(dist.draw(rng), 6)
        subject = Subject(name=f"S{i + 1:02d}", user=user)
        subject.config()  # the overrides make a valid UserConfig
        subjects.append(subject)
    return subjects
