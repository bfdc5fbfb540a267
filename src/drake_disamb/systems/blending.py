"""Shared-control blender: the paper's blending law as a Drake system."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiscreteValues,
    EventStatus,
    LeafSystem,
    ValueProducer,
)

from drake_disamb.core.blending import BlendingConfig, shared_control
from drake_disamb.core.validation import all_finite
from drake_disamb.system_helpers.sanitized import SanitizedInputCounter
from drake_disamb.system_helpers.status import DID_NOTHING, flag_set
from drake_disamb.systems.loop import ControlLoop

__all__ = ["BlendingConfig", "SharedControlBlender"]

_NO_STEP = (np.zeros(6), np.zeros(1), np.zeros(1), True)
"""Placeholder value of the blending-step cache entry before its first computation."""


class SharedControlBlender(LeafSystem):
    """Blend the human command with the autonomy's command for the most likely goal.

    ``u = alpha * u_a(g*) + (1 - alpha) * u_h`` with ``g* = argmax belief`` (ties to the lowest
    index) and the paper's piecewise-linear ``alpha(p(g*))`` (:mod:`drake_disamb.core.blending`),
    then the translational and rotational parts are each limited to ``config.max_linear_speed``
    (0.26 m/s) and ``config.max_angular_speed`` (0.67 rad/s).

    .. pydrake_system::

        name: SharedControlBlender
        input_ports:
        - u_h
        - belief
        - u_a
        - paused
        output_ports:
        - u
        - alpha
        - g_star
        - sanitized_input_count

    Input ports:
        u_h (6): human command ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s), world frame.
        belief (n): probability of each goal.
        u_a (n * 6): per-goal autonomy commands, goal i in entries ``6 i .. 6 i + 5``, same order
            and frame as ``u_h``.
        paused (1, optional): while above 0.5 the loop is paused: ``u`` is zero and ``alpha`` 0 (the
            study's system sent the arm nothing while it computed a disambiguation request: the
            interface's ``paused``). Unconnected: never paused.

    Output ports (``u``, ``alpha``, ``g_star``: direct feedthrough from the inputs only, no state):
        u (6): blended, speed-limited command ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s), world
            frame (the paper's order, not Drake's ``[w; v]``).
        alpha (1): the autonomy's share actually applied, in ``[0, rho3]``.
        g_star (1): index of the most likely goal.
        sanitized_input_count (1): control ticks so far at which an input held a NaN/inf (see
            below); from state.

    The three outputs share one blending step, a cache entry that depends on the four inputs only
    (computed once per change of the inputs, not per output or per integrator stage); it also holds
    whether the inputs were finite, the verdict the periodic check reuses when the step is already
    up to date (in a loop it is: the station's update reads ``u`` in the same context).

    **No user input.** The paper blends "always", so with ``assist_without_input=True`` a user who
    lets go is still driven toward ``g*`` at up to ``rho3 |u_a|`` (0.14 m/s with the default
    autonomy) until the belief relaxes below ``rho1`` -- a few seconds with the DFT's time
    constants, i.e. tens of centimetres. The default here is ``False``: the autonomy only assists
    while the user commands the arm (``u_h != 0``); with no input ``alpha`` is 0 and ``u`` is zero.
    Reasons: (1) letting go of the interface must stop an assistive arm, the user's basic safety
    expectation; (2) users give no arm input exactly while they switch modes, request
    disambiguation or drive the gripper (zero ``u_h`` in the gripper mode), and a head-array user
    spends much of a trial cycling modes -- moving the arm then, possibly toward the wrong goal,
    happens while their attention is on the mode display; (3) the disambiguation algorithm plans
    from the pose at the request and the arm should not drift while it computes (2-2.5 s in the
    paper). Set ``assist_without_input=True`` to reproduce the paper's law literally.

    Non-finite inputs never reach the arm: a NaN/inf entry of ``u_h`` or ``u_a`` is read as 0, a
    non-finite belief as 0 (if nothing finite is left, ``g*`` = 0 with ``alpha`` = 0). Every
    ``loop.control_period`` (first at t = 0) a discrete update checks the inputs and, if one holds
    a NaN/inf, adds one to ``sanitized_input_count`` and warns (at most once per second of
    simulated time). State: discrete ``[sanitised-input count]`` and ``[time of the last warning]``
    (s), written only at such ticks.

    Args:
        loop: The number of goals and the control period.
        config: The blending law's settings (default :class:`BlendingConfig`'s defaults; its
            ``rho1`` and ``rho2`` resolved for ``loop.n_goals`` by the config itself).
        overrides: :class:`BlendingConfig` fields replacing those of ``config``.
    """

    def __init__(self, loop: ControlLoop, config: BlendingConfig | None = None, **overrides: object) -> None:
        super().__init__()
        cfg = BlendingConfig() if config is None else config
        assert isinstance(loop, ControlLoop) and isinstance(cfg, BlendingConfig), (loop, cfg)
        self.config = replace(cfg, **overrides) if overrides else cfg
        self.n_goals = loop.n_goals
        self.rhos = self.config.rhos(self.n_goals)  # the config's own check: rho1 < rho2 in [0, 1]
        self._u_h_port = self.DeclareVectorInputPort("u_h", 6)
        self._belief_port = self.DeclareVectorInputPort("belief", self.n_goals)
        self._u_a_port = self.DeclareVectorInputPort("u_a", 6 * self.n_goals)
        self._paused_port = self.DeclareVectorInputPort("paused", 1)
        # One blending step per change of the inputs, shared by the three outputs (a cache entry
        # that depends on the inputs alone, not on time or on any state).
        ports = (self._u_h_port, self._belief_port, self._u_a_port, self._paused_port)
        inputs = {port.ticket() for port in ports}
        self._step = self.DeclareCacheEntry(
            "shared_control step (u, alpha, g_star)",
            ValueProducer(allocate=lambda: AbstractValue.Make(_NO_STEP), calc=self._calc_step),
            prerequisites_of_calc=inputs,
        )
        step = {self._step.ticket()}
        self.DeclareVectorOutputPort("u", 6, self._calc_u, prerequisites_of_calc=step)
        self.DeclareVectorOutputPort("alpha", 1, self._calc_alpha, prerequisites_of_calc=step)
        self.DeclareVectorOutputPort("g_star", 1, self._calc_g_star, prerequisites_of_calc=step)
        self._sanitized = SanitizedInputCounter(self)
        self.DeclarePeriodicDiscreteUpdateEvent(loop.control_period, 0.0, self._check_inputs)

    def _inputs(
        self, context: Context
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        # Vector ports give float64 arrays (copies) of their declared sizes.
        u_h = self._u_h_port.Eval(context)
        p = self._belief_port.Eval(context)
        u_a = self._u_a_port.Eval(context).reshape(self.n_goals, 6)
        return u_h, p, u_a

    def _check_inputs(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        # The step's verdict when the step is already computed for these inputs (in a loop it is:
        # the station's update reads u in this context); otherwise the inputs are checked here, so
        # that the count never needs the core.
        step = self._step
        if not (step.is_out_of_date(context) or step.is_cache_entry_disabled(context)):
            if step.Eval(context)[3]:
                return DID_NOTHING
        u_h, p, u_a = self._inputs(context)
        if all_finite(u_h, p, u_a):
            return DID_NOTHING
        message = (
            f"non-finite input (u_h={u_h.tolist()}, belief={p.tolist()}, u_a has NaN/inf: "
            f"{not np.isfinite(u_a).all()}); non-finite entries read as 0"
        )
        self._sanitized.record(context, discrete_state, message)
        return EventStatus.Succeeded()

    def _compute(
        self, u_h: NDArray[np.float64], p: NDArray[np.float64], u_a: NDArray[np.float64]
    ) -> tuple[np.ndarray, float, int, bool]:
        """``(u, alpha, g_star, whether every input was finite)``."""
        finite = all_finite(u_h, p, u_a)
        if not finite:  # counted and warned by _check_inputs
            u_h = np.where(np.isfinite(u_h), u_h, 0.0)
            u_a = np.where(np.isfinite(u_a), u_a, 0.0)
            p = np.where(np.isfinite(p), p, 0.0)
        u, alpha, g_star = shared_control(u_h, p, u_a, self.config)
        return u, float(alpha), int(g_star), finite

    def _calc_step(self, context: Context, value: AbstractValue) -> None:
        u, alpha, g_star, finite = self._compute(*self._inputs(context))
        if flag_set(self._paused_port, context):
            # Paused (the ``paused`` input): nothing reaches the arm; g_star stays the belief's argmax.
            u, alpha = np.zeros(6), 0.0
        value.set_value((u, np.array([alpha]), np.array([float(g_star)]), finite))

    def _calc_u(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._step.Eval(context)[0])

    def _calc_alpha(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._step.Eval(context)[1])

    def _calc_g_star(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector(self._step.Eval(context)[2])
