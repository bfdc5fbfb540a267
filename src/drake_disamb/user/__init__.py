"""The simulated user of a control interface, in parts: its settings, its memory, how it sees the
task, its rules (one function each) and one decision (:func:`user_step`, whose module's docstring
describes the policy), all numpy; its Drake system (:mod:`~drake_disamb.user.system`) and the
study's population of simulated subjects (:mod:`~drake_disamb.user.population`) are imported from
their modules.

Its modules, and where this package sits among the others: docs/architecture.md (Layout).
"""

from drake_disamb.user.config import (
    FIELD_GROUPS,
    CommandConfig,
    ModeChoiceConfig,
    PauseConfig,
    RequestConfig,
    TimingConfig,
    UserConfig,
)
from drake_disamb.user.judgement import (
    choose_mode,
    goal_error,
    goal_reached,
    helped,
    mode_remaining,
    mode_usefulness,
    presses_to,
)
from drake_disamb.user.policy import user_step
from drake_disamb.user.state import NOT_COUNTING, UserState

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
