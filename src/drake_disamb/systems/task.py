"""The task's goal-set / stage manager and success monitor.

A multi-step task is a sequence of stages, each with its own set of ``n`` goal poses (every stage
has the same ``n``, so the belief keeps its size). The manager publishes the current stage's goal
poses; every control period it checks whether the end effector is within the success tolerance
of one of them and, once it has stayed there for the stage's hold time (and, in a stage that
ends by letting go of the held object, the gripper is open at least the stage's release opening),
records which goal was reached and when, and switches to the next stage's goal set. After the
last stage the task is done (``done`` = 1) and the goal set stays that of the last stage.

The manager does not know the user's intent: it reports which goal was reached in each stage;
whether that was the intended one is the trial's business (:func:`drake_disamb.trial.run_trial`).
A stage may instead be given its target (``targets``, a scenario's ``StageSpec.ends_at_target``:
the experimenter named it): then only that goal completes it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from pydrake.systems.framework import Context, DiscreteValues, EventStatus, LeafSystem

from drake_disamb.core.geometry import pose_errors
from drake_disamb.core.layout import POSE_SIZE
from drake_disamb.system_helpers.status import DID_NOTHING

# Discrete state layout: [stage, candidate goal, hold start time, reached[S], stage end times[S]].
_STAGE, _CANDIDATE, _HOLD_START, _HEADER = 0, 1, 2, 3


@dataclass(frozen=True, eq=False)
class TaskConfig:
    """The task as the :class:`TaskManager` runs it: a scenario's stages, resolved by
    :func:`~drake_disamb.config.resolve_scenario` (:attr:`~drake_disamb.config.TrialConfig.task`),
    which checks every bound and names the scenario's field; the manager only asserts the shapes.

    Attributes:
        stage_goal_poses: Per stage, its goal poses: an ``(n, 7)`` array of ``[x, y, z, qw, qx,
            qy, qz]`` (m; non-zero quaternions, normalised by the manager), the same ``n >= 1`` in
            every stage.
        position_tolerance: Distance (m, > 0) within which a goal position counts as reached.
        orientation_tolerance: Angle (rad, > 0) within which a goal orientation counts as reached.
        hold_times: Time (s, >= 0) the end effector must stay at a goal: one for every stage, or
            one per stage.
        control_period: Period (s, > 0) of the manager's check.
        release_openings: Per stage, ``None`` or the opening (m) the gripper must reach at the goal
            (a stage that ends by letting go of the held object); ``None``: no stage does.
        targets: Per stage, ``None`` (any of its goals completes it) or the index of the one goal
            that does; ``None``: any goal in every stage.
    """

    stage_goal_poses: Sequence[ArrayLike]
    position_tolerance: float = 0.02
    orientation_tolerance: float = 0.15
    hold_times: float | Sequence[float] = 0.3
    control_period: float = 0.01
    release_openings: Sequence[float | None] | None = None
    targets: Sequence[int | None] | None = None


class TaskManager(LeafSystem):
    """Publishes the current stage's goal set; detects a goal reached and held; switches stages.

    .. pydrake_system::

        name: TaskManager
        input_ports:
        - ee_pose
        - gripper_opening
        output_ports:
        - goal_poses
        - stage
        - done
        - reached_goals
        - stage_end_times

    Input ports:
        ee_pose (7): end-effector pose ``[x, y, z, qw, qx, qy, qz]`` in W (m, unit quaternion).
        gripper_opening (1): distance between the fingertip pads (m; the station's
            ``gripper_opening``). Read only in a stage with a release opening; unconnected
            otherwise is fine.

    Output ports:
        goal_poses (n * 7): the current stage's goal poses, each ``[x, y, z, qw, qx, qy, qz]``
            (m, unit quaternion), goal after goal.
        stage (1): index of the current stage; equals the number of stages once done.
        done (1): 1.0 once every stage is complete, else 0.0.
        reached_goals (S): per stage, the index of the goal reached (-1 while pending).
        stage_end_times (S): per stage, the time (s) it completed (NaN while pending).

    A goal counts as reached when the end effector stays within ``config.position_tolerance`` (m)
    and ``config.orientation_tolerance`` (rad) of it for the stage's hold time (and, if the stage
    has a release opening, the gripper is then open at least that wide, m: the held object let go
    at the goal; the hold goes on while it opens), checked every ``config.control_period`` seconds
    (a periodic discrete update; all outputs are state output ports, each a discrete group of its
    own written when the stage changes, so the manager has no direct feedthrough). A NaN pose
    never counts as reached, nor does a NaN opening release. With a target for the stage, only
    that goal counts in it (:class:`TaskConfig`).
    """

    def __init__(self, config: TaskConfig) -> None:
        super().__init__()
        # Resolution checked every bound (scenario.goals, success, stages, user.goals): only the
        # shapes this system relies on are asserted.
        assert isinstance(config, TaskConfig), config
        goal_sets = [np.array(poses, dtype=float) for poses in config.stage_goal_poses]
        n_stages = len(goal_sets)
        assert n_stages >= 1 and goal_sets[0].ndim == 2 and goal_sets[0].shape[0] >= 1, goal_sets
        for a in goal_sets:
            assert a.shape == goal_sets[0].shape and a.shape[1] == POSE_SIZE, a.shape
            norms = np.linalg.norm(a[:, 3:], axis=1)
            assert np.all(norms > 0), a
            a[:, 3:] /= norms[:, None]  # unit quaternions, whatever rounding they come with
        holds = config.hold_times
        holds = [float(holds)] * n_stages if np.isscalar(holds) else [float(h) for h in holds]
        releases = [None] * n_stages if config.release_openings is None else list(config.release_openings)
        targets = [None] * n_stages if config.targets is None else list(config.targets)
        assert len(holds) == len(releases) == len(targets) == n_stages, (holds, releases, targets)
        self._goal_sets = goal_sets
        self._n_goals = goal_sets[0].shape[0]
        self._n_stages = n_stages
        self._pos_tol = float(config.position_tolerance)
        self._ori_tol = float(config.orientation_tolerance)
        self._targets: list[int | None] = [None if g is None else int(g) for g in targets]
        self._holds = holds
        self._releases: list[float | None] = [None if r is None else float(r) for r in releases]
        self._period = float(config.control_period)

        self._ee_pose = self.DeclareVectorInputPort("ee_pose", POSE_SIZE)
        self._gripper_opening = self.DeclareVectorInputPort("gripper_opening", 1)
        initial = np.concatenate(([0.0, -1.0, np.nan], np.full(n_stages, -1.0), np.full(n_stages, np.nan)))
        self._state = self.DeclareDiscreteState(initial)
        # Every output is a copy of state, so each has a discrete group of its own holding its value
        # (written by the update when it changes) and is a state output port: reading it calls no
        # Python.
        self._outputs = {
            name: self.DeclareDiscreteState(value) for name, value in self._output_values(initial).items()
        }
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._update)
        for name, group in self._outputs.items():
            self.DeclareStateOutputPort(name, group)

    # -- properties ---------------------------------------------------------------------------

    @property
    def n_goals(self) -> int:
        """Goals per stage."""
        return self._n_goals

    @property
    def n_stages(self) -> int:
        """Number of stages."""
        return self._n_stages

    # -- state access -------------------------------------------------------------------------

    def _stage_index(self, context: Context) -> int:
        return int(context.get_discrete_state(self._state).get_value()[_STAGE])

    def stage(self, context: Context) -> int:
        """The current stage index (``n_stages`` once done)."""
        return self._stage_index(context)

    def is_done(self, context: Context) -> bool:
        """True once every stage is complete."""
        return self._stage_index(context) >= self._n_stages

    def reached_goals(self, context: Context) -> list[int]:
        """Per stage, the index of the goal reached (-1 while pending)."""
        x = context.get_discrete_state(self._state).get_value()
        return [int(v) for v in x[_HEADER : _HEADER + self._n_stages]]

    def stage_end_times(self, context: Context) -> list[float]:
        """Per stage, the completion time (s), NaN while pending."""
        x = context.get_discrete_state(self._state).get_value()
        return [float(v) for v in x[_HEADER + self._n_stages :]]

    def goal_error(self, context: Context, goal: int) -> float:
        """How far the end effector is from goal ``goal`` of the current stage, in tolerance
        units (distance / position tolerance + angle / orientation tolerance); 0 once done."""
        stage = self._stage_index(context)
        if stage >= self._n_stages:
            return 0.0
        dist, angle = pose_errors(self._ee_pose.Eval(context), self._goal_sets[stage][goal : goal + 1])
        return float(dist[0] / self._pos_tol + angle[0] / self._ori_tol)

    # -- update -------------------------------------------------------------------------------

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        x = context.get_discrete_state(self._state).get_value()
        stage = int(x[_STAGE])
        if stage >= self._n_stages:
            return DID_NOTHING
        dist, angle = pose_errors(self._ee_pose.Eval(context), self._goal_sets[stage])
        # Lists of floats: a few comparisons cost less than numpy's per-call overhead (a NaN error
        # is inside no tolerance either way).
        dist, angle = dist.tolist(), angle.tolist()
        pos_tol, ori_tol = self._pos_tol, self._ori_tol
        inside = [
            i for i, (d, a) in enumerate(zip(dist, angle, strict=True)) if d <= pos_tol and a <= ori_tol
        ]
        target = self._targets[stage]
        if target is not None:
            inside = [i for i in inside if i == target]  # a named target: no other goal ends the stage
        if not inside:
            if x[_CANDIDATE] == -1.0:  # far from every goal, as before: nothing to write
                return DID_NOTHING
            x = x.copy()
            x[_CANDIDATE], x[_HOLD_START] = -1.0, np.nan
            discrete_state.get_mutable_vector(self._state).SetFromVector(x)
            return EventStatus.Succeeded()
        x, t = x.copy(), context.get_time()
        goal = min(inside, key=dist.__getitem__)  # the nearest; ties to the lowest index (np.argmin's)
        if int(x[_CANDIDATE]) != goal or not np.isfinite(x[_HOLD_START]):
            x[_CANDIDATE], x[_HOLD_START] = float(goal), t
        # A tiny slack absorbs the rounding of accumulated periodic event times.
        release = self._releases[stage]
        if t - x[_HOLD_START] >= self._holds[stage] - 1e-9 and (
            release is None or float(self._gripper_opening.Eval(context)[0]) >= release
        ):
            x[_HEADER + stage] = float(goal)
            x[_HEADER + self._n_stages + stage] = t
            x[_STAGE] = float(stage + 1)
            x[_CANDIDATE], x[_HOLD_START] = -1.0, np.nan
            for name, value in self._output_values(x).items():
                discrete_state.get_mutable_vector(self._outputs[name]).SetFromVector(value)
        discrete_state.get_mutable_vector(self._state).SetFromVector(x)
        return EventStatus.Succeeded()

    # -- outputs ------------------------------------------------------------------------------

    def _output_values(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """The value of every output port for the state vector ``x`` (port name -> vector)."""
        stage = int(x[_STAGE])
        S = self._n_stages
        return {
            "goal_poses": self._goal_sets[min(stage, S - 1)].ravel(),
            "stage": np.array([float(stage)]),
            "done": np.array([1.0 if stage >= S else 0.0]),
            "reached_goals": np.array(x[_HEADER : _HEADER + S]),
            "stage_end_times": np.array(x[_HEADER + S :]),
        }


class FixedGoalSet(LeafSystem):
    """Publishes one goal set that never changes: the whole task's goals, for a belief over every
    goal of a multi-step task (a scenario's ``inference.goal_set: task``).

    .. pydrake_system::

        name: FixedGoalSet
        output_ports:
        - goal_poses

    Output ports:
        goal_poses (n * 7): the goal poses, each ``[x, y, z, qw, qx, qy, qz]`` (m, unit
            quaternion), goal after goal.

    The output depends on nothing (``nothing_ticket``). Drake's ``ConstantVectorSource`` would do
    the same job, but its output depends on every source of its context, time included, so what
    is computed from it (the belief's drive, the autonomy's commands) was computed again whenever
    the time moved: twice per control tick.
    """

    def __init__(self, goal_poses: ArrayLike) -> None:
        super().__init__()
        poses = np.array(goal_poses, dtype=float)
        if poses.ndim != 2 or poses.shape[1] != POSE_SIZE or poses.shape[0] < 1:
            raise ValueError(f"goal_poses: expected shape (n >= 1, 7), got {poses.shape}")
        if not np.all(np.isfinite(poses)):
            raise ValueError(f"goal_poses: expected finite numbers, got {poses.tolist()!r}")
        flat = poses.ravel()
        flat.setflags(write=False)
        self._value = flat
        self.DeclareVectorOutputPort(
            "goal_poses", flat.size, self._calc, prerequisites_of_calc={self.nothing_ticket()}
        )

    def _calc(self, context: Context, output) -> None:  # noqa: ANN001
        output.SetFromVector(self._value)
