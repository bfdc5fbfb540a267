"""Potential-field autonomy system: one 6-D command per goal, from the end-effector and goal poses."""

from __future__ import annotations

import warnings

import numpy as np
from pydrake.systems.framework import BasicVector, Context, LeafSystem

from drake_disamb.core.autonomy import PotentialFieldConfig, potential_field_commands_from_poses

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

    Input ports:
        ee_pose (7): end-effector pose ``[x, y, z, qw, qx, qy, qz]`` in the world frame (m; unit
            quaternion).
        goal_poses (n * 7): the n goal poses, each ``[x, y, z, qw, qx, qy, qz]``, concatenated.

    Output ports:
        u_a (n * 6): goal i's command in entries ``6 i .. 6 i + 5``, ``[vx, vy, vz, wx, wy, wz]``
            (m/s, rad/s) in the world frame (the paper's order, not Drake's ``[w; v]``); attractor to
            goal i, repellers from the other goals, each part saturated (see ``config``).
            Direct feedthrough from both inputs (stateless).

    A non-finite or zero-norm pose at run time gives an all-zero ``u_a`` with a warning (the arm is
    then only driven by the user) instead of propagating NaN.
    """

    def __init__(self, n_goals: int, config: PotentialFieldConfig | None = None) -> None:
        super().__init__()
        if not (isinstance(n_goals, int | np.integer) and not isinstance(n_goals, bool) and n_goals >= 1):
            raise ValueError(f"n_goals: expected an integer >= 1, got {n_goals!r}")
        if config is not None and not isinstance(config, PotentialFieldConfig):
            raise ValueError(f"config: expected a PotentialFieldConfig, got {config!r}")
        self.n_goals = int(n_goals)
        self.config = PotentialFieldConfig() if config is None else config
        self._ee_port = self.DeclareVectorInputPort("ee_pose", 7)
        self._goal_port = self.DeclareVectorInputPort("goal_poses", 7 * self.n_goals)
        # Depends on the two inputs only (not on time or state): computed once per input change.
        self.DeclareVectorOutputPort(
            "u_a",
            6 * self.n_goals,
            self._calc_u_a,
            prerequisites_of_calc={self._ee_port.ticket(), self._goal_port.ticket()},
        )
        self._warned = False

    def _calc_u_a(self, context: Context, output: BasicVector) -> None:
        ee = self._ee_port.Eval(context)
        goals = self._goal_port.Eval(context).reshape(self.n_goals, 7)
        try:
            u_a = potential_field_commands_from_poses(ee, goals, self.config)
        except ValueError as exc:
            if not self._warned:
                warnings.warn(f"{self.get_name()}: {exc}; u_a set to zero", RuntimeWarning, stacklevel=2)
                self._warned = True
            u_a = np.zeros((self.n_goals, 6))
        output.SetFromVector(u_a.reshape(-1))
