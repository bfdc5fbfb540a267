"""Potential-field autonomy system: one 6-D command per goal, from the end-effector and goal poses."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiscreteValues,
    EventStatus,
    LeafSystem,
)

from drake_disamb.core.autonomy import PotentialFieldConfig, potential_field_commands_from_poses
from drake_disamb.system_helpers.sanitized import SanitizedInputCounter, usable_poses
from drake_disamb.system_helpers.status import DID_NOTHING
from drake_disamb.systems.loop import ControlLoop

__all__ = ["PotentialFieldAutonomy"]


class PotentialFieldAutonomy(LeafSystem):
    """Per-goal potential-field autonomy commands (a thin wrapper of
    :func:`drake_disamb.core.autonomy.potential_field_commands`).

    .. pydrake_system::

        name: PotentialFieldAutonomy
        input_ports:
        - ee_pose
        - goal_poses
        output_ports:
        - u_a
        - sanitized_input_count

    Input ports:
        ee_pose (7): end-effector pose ``[x, y, z, qw, qx, qy, qz]`` in the world frame (m; unit
            quaternion).
        goal_poses (n * 7): the n goal poses, each ``[x, y, z, qw, qx, qy, qz]``, concatenated.

    Output ports:
        u_a (n * 6): goal i's command in entries ``6 i .. 6 i + 5``, ``[vx, vy, vz, wx, wy, wz]``
            (m/s, rad/s) in the world frame (the paper's order, not Drake's ``[w; v]``); attractor to
            goal i, repellers from the other goals, each part saturated (see ``config``).
            Direct feedthrough from both inputs only (no state, no time).
        sanitized_input_count (1): control ticks so far at which a pose was unusable (see below);
            from state.

    **Unusable poses.** A pose with a NaN or infinite entry, an entry beyond ``1e150``, or a
    quaternion of (near) zero norm (:func:`~drake_disamb.system_helpers.sanitized.usable_poses`,
    checked before the core is called), gives an all-zero ``u_a`` (the arm is then only driven by
    the user) instead of propagating NaN. Every ``loop.control_period`` (first at t = 0) a discrete
    update checks the inputs again and, if they are unusable, adds one to
    ``sanitized_input_count`` and warns (at most once per second of simulated time). Any other
    error of the core propagates.

    State: discrete ``[sanitised-input count]`` and ``[time of the last warning]`` (s), only
    written at ticks with unusable poses.

    Args:
        loop: The number of goals and the control period.
        config: The potential field (default :class:`PotentialFieldConfig`'s defaults).
    """

    def __init__(self, loop: ControlLoop, config: PotentialFieldConfig | None = None) -> None:
        super().__init__()
        config = PotentialFieldConfig() if config is None else config
        assert isinstance(loop, ControlLoop) and isinstance(config, PotentialFieldConfig), (loop, config)
        self.n_goals = loop.n_goals
        self.config = config
        self._ee_port = self.DeclareVectorInputPort("ee_pose", 7)
        self._goal_port = self.DeclareVectorInputPort("goal_poses", 7 * self.n_goals)
        # Depends on the two inputs only (not on time or state): computed once per input change.
        inputs = {self._ee_port.ticket(), self._goal_port.ticket()}
        self.DeclareVectorOutputPort("u_a", 6 * self.n_goals, self._calc_u_a, prerequisites_of_calc=inputs)
        self._sanitized = SanitizedInputCounter(self)
        self.DeclarePeriodicDiscreteUpdateEvent(loop.control_period, 0.0, self._check_inputs)

    def _inputs(self, context: Context) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return self._ee_port.Eval(context), self._goal_port.Eval(context)

    def _calc_u_a(self, context: Context, output: BasicVector) -> None:
        ee, goals = self._inputs(context)
        if not usable_poses(ee, goals):  # counted and warned by _check_inputs
            output.SetFromVector(np.zeros(6 * self.n_goals))
            return
        # Checked once, just above: the core's own checks are skipped (checked=False).
        u_a = potential_field_commands_from_poses(ee, goals.reshape(self.n_goals, 7), self.config, False)
        output.SetFromVector(u_a.reshape(-1))

    def _check_inputs(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        # Its own check of the inputs (a compiled pass over 7 (n + 1) numbers), not the output's:
        # the count does not need the core, and the output is not computed just for the check.
        ee, goals = self._inputs(context)
        if usable_poses(ee, goals):
            return DID_NOTHING
        message = f"unusable pose (ee_pose={ee.tolist()}, goal_poses={goals.tolist()}); u_a set to zero"
        self._sanitized.record(context, discrete_state, message)
        return EventStatus.Succeeded()
