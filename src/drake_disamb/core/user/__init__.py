"""The simulated user of a control interface (pure numpy), in parts: its settings
(:mod:`~drake_disamb.core.user.config`), its memory (:mod:`~drake_disamb.core.user.state`), how
it sees the task (:mod:`~drake_disamb.core.user.judgement`), its rules, one function each
(:mod:`~drake_disamb.core.user.rules`), and one decision (:mod:`~drake_disamb.core.user.policy`,
whose docstring describes the policy)."""

from drake_disamb.core.user.config import (
    FIELD_GROUPS,
    CommandConfig,
    ModeChoiceConfig,
    PauseConfig,
    RequestConfig,
    TimingConfig,
    UserConfig,
)
from drake_disamb.core.user.judgement import (
    choose_mode,
    goal_error,
    goal_reached,
    helped,
    mode_remaining,
    mode_usefulness,
    presses_to,
)
from drake_disamb.core.user.policy import user_step
from drake_disamb.core.user.state import NOT_COUNTING, UserState

__all__ = [
    "FIELD_GROUPS",
    "NOT_COUNTING",
    "CommandConfig",
    "ModeChoiceConfig",
    "PauseConfig",
    "RequestConfig",
    "TimingConfig",
    "UserConfig",
    "UserState",
    "choose_mode",
    "goal_error",
    "goal_reached",
    "helped",
    "mode_remaining",
    "mode_usefulness",
    "presses_to",
    "user_step",
]
