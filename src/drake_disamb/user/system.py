"""Simulated user system: drives an interface's ``raw`` input toward its own goal."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from pydrake.systems.framework import Context, DiscreteValues, EventStatus, LeafSystem

from drake_disamb.interfaces import RAW_SIZE, InterfaceConfig
from drake_disamb.system_helpers.sanitized import SanitizedInputCounter, usable_poses
from drake_disamb.system_helpers.status import flag_set
from drake_disamb.user import UserConfig, UserState, user_step

__all__ = ["SimulatedUser", "UserConfig"]


class SimulatedUser(LeafSystem):
    """A simulated user of any registered interface (policy in :mod:`drake_disamb.user`).

    .. pydrake_system::

        name: SimulatedUser
        input_ports:
        - mode
        - ee_pose
        - goal_poses
        - belief
        - stage
        - paused
        output_ports:
        - raw
        - sanitized_input_count

    Input ports:
        mode (1): the interface's current mode index.
        ee_pose (7): end-effector pose ``[x, y, z, qw, qx, qy, qz]`` in the world frame (m).
        goal_poses (n * 7): every goal pose, concatenated; the user's own is entry ``goal_index``.
        belief (n): the current belief; optional. Unconnected, the user never makes "unhelped"
            requests (only the start-of-trial one, if configured).
        stage (1): the task's current stage (e.g. ``TaskManager``'s ``stage``); optional,
            unconnected = stage 0. The user's goal is ``goal_index[stage]``; at or past the last
            stage (the task is done) the user lets go.
        paused (1): above 0.5 while the system computes a disambiguation with its loop paused
            (the interface's ``paused`` with ``hold_while_computing``); optional, unconnected =
            never. The user waits meanwhile (``user_step``'s ``paused``).

    Output ports:
        raw (4): the interface's raw signal, computed at the last update and held (no direct
            feedthrough), in the interface's ``raw_layout``. Presses (mode changes, requests) last
            one decision period and are followed by at least two decision periods with everything released.
        sanitized_input_count (1): updates so far whose inputs were unusable (see below).

    State: discrete :meth:`UserState.to_vector <drake_disamb.user.UserState.to_vector>` and
    ``raw`` again in a group of its own (the state output port ``raw``), updated every decision
    period (``config.timing.decision_period``, default the interface's ``control_period``; at least the
    control period, so each press is seen as exactly one rising edge) from t = 0; and
    ``[sanitised-input count]``, ``[time of the last warning]`` (s).

    **Unusable inputs.** A pose with a NaN/inf entry or an unusable quaternion
    (:func:`~drake_disamb.system_helpers.sanitized.usable_poses`), a mode that is not an integer index
    of the interface's modes, or a negative or non-finite stage (checked before the policy is
    called) make the user let go (raw zeros) for that update, add one to
    ``sanitized_input_count`` and warn (at most once per second of simulated time). Any other
    error of the policy propagates.

    Attributes:
        interface: The :class:`~drake_disamb.interfaces.InterfaceConfig` it operates.
        goal_indices: Its goal per stage (a single-stage task has one entry).
        releases: Per stage, whether the stage ends by letting go of the held object (at the goal
            the user changes to the gripper mode and opens it: ``user_step``'s ``release``).
        config: Its :class:`~drake_disamb.user.UserConfig`.
    """

    def __init__(
        self,
        interface_kind: str | InterfaceConfig,
        goal_index: int | Sequence[int],
        n_goals: int,
        config: UserConfig | None = None,
        releases: Sequence[bool] | None = None,
        **overrides: object,
    ) -> None:
        super().__init__()
        # A kind's name makes its InterfaceConfig (which checks it); the rest is a resolved
        # scenario's (its checks name the fields, scenario.user...): asserted here.
        if not isinstance(interface_kind, InterfaceConfig):
            interface_kind = InterfaceConfig(kind=interface_kind)
        self.interface = interface_kind
        cfg = UserConfig() if config is None else config
        assert isinstance(cfg, UserConfig), cfg
        self.config = replace(cfg, **overrides) if overrides else cfg
        indices = [goal_index] if isinstance(goal_index, int | np.integer) else list(goal_index)
        assert isinstance(n_goals, int | np.integer) and n_goals >= 1, n_goals
        assert indices and all(isinstance(g, int | np.integer) and 0 <= g < n_goals for g in indices), indices
        period = self.config.period(self.interface)
        # One press is one rising edge of the interface, and presses are released and the new
        # mode seen before the next decision (resolution: scenario.user.config.decision_period,
        # reaction_time).
        assert period >= self.interface.control_period - 1e-12, period
        assert self.config.min_reaction_time >= 2 * period, self.config.min_reaction_time
        self.goal_indices: tuple[int, ...] = tuple(int(g) for g in indices)
        flags = [False] * len(indices) if releases is None else list(releases)
        assert len(flags) == len(indices), (flags, indices)
        self.releases: tuple[bool, ...] = tuple(bool(f) for f in flags)
        self.n_goals = int(n_goals)
        self.raw_layout = self.interface.raw_layout

        self._state_index = self.DeclareDiscreteState(UserState().to_vector())
        # The raw signal again, in a group of its own: the output is a state output port (its
        # evaluation calls no Python).
        self._raw_index = self.DeclareDiscreteState(np.zeros(RAW_SIZE))
        self._mode_port = self.DeclareVectorInputPort("mode", 1)
        self._ee_port = self.DeclareVectorInputPort("ee_pose", 7)
        self._goal_port = self.DeclareVectorInputPort("goal_poses", 7 * self.n_goals)
        self._belief_port = self.DeclareVectorInputPort("belief", self.n_goals)
        self._stage_port = self.DeclareVectorInputPort("stage", 1)
        self._paused_port = self.DeclareVectorInputPort("paused", 1)
        self.DeclareStateOutputPort("raw", self._raw_index)
        self._sanitized = SanitizedInputCounter(self)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    @property
    def goal_index(self) -> int:
        """The goal of the first stage (the only one in a single-step task)."""
        return self.goal_indices[0]

    def get_user_state(self, context: Context) -> UserState:
        """The user's state in ``context`` as a numpy :class:`~drake_disamb.user.UserState`."""
        return UserState.from_vector(context.get_discrete_state(self._state_index).get_value())

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        state = self.get_user_state(context)
        mode_value = float(self._mode_port.Eval(context)[0])
        ee = np.asarray(self._ee_port.Eval(context), dtype=float)
        goals = np.asarray(self._goal_port.Eval(context), dtype=float)
        belief = None
        if self._belief_port.HasValue(context):
            belief = np.asarray(self._belief_port.Eval(context), dtype=float)
        stage = 0.0
        if self._stage_port.HasValue(context):
            stage = float(self._stage_port.Eval(context)[0])
        if math.isfinite(stage) and stage >= len(self.goal_indices):  # the task is done: let go
            new = replace(state, raw=np.zeros(RAW_SIZE), target_mode=-1)
            self._write(new, discrete_state, state)
            return EventStatus.Succeeded()
        n_modes = len(self.interface.modes)
        usable = (
            math.isfinite(stage)
            and stage >= 0
            and math.isfinite(mode_value)
            and mode_value == round(mode_value)
            and 0 <= mode_value < n_modes
            and usable_poses(ee, goals)
        )
        if usable:
            new = user_step(
                state,
                context.get_time(),
                int(round(mode_value)),
                ee,
                goals,
                self.goal_indices[int(stage)],
                self.interface,
                self.config,
                belief,
                self.releases[int(stage)],
                flag_set(self._paused_port, context),
            )
        else:
            message = (
                f"unusable inputs (mode={mode_value!r}, stage={stage!r}, ee_pose={ee.tolist()}, "
                f"goal_poses={goals.tolist()}); the user lets go"
            )
            self._sanitized.record(context, discrete_state, message)
            new = replace(state, raw=np.zeros(RAW_SIZE))
        self._write(new, discrete_state, state)
        return EventStatus.Succeeded()

    def _write(self, state: UserState, discrete_state: DiscreteValues, before: UserState) -> None:
        # ``discrete_state`` starts as a copy of the current state: only changes are written.
        vector = state.to_vector()
        if not np.array_equal(vector, before.to_vector()):
            discrete_state.get_mutable_vector(self._state_index).SetFromVector(vector)
            if not np.array_equal(state.raw, before.raw):
                discrete_state.get_mutable_vector(self._raw_index).SetFromVector(state.raw)
