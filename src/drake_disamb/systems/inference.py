"""Drake systems for intent inference: field-theoretic (DFT), recursive Bayes and memory-based.

All three share the same ports, so they can replace each other in a diagram:

Input ports (vector-valued):

- ``u_h`` (6): human command ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s), world frame W, at the
  end-effector origin. This is the paper's order, *not* Drake's ``[w; v]`` spatial-velocity order.
  A command with a NaN or infinite entry is read as zero (counted, see ``sanitized_input_count``).
- ``ee_pose`` (7): end-effector pose ``[x, y, z, qw, qx, qy, qz]`` in W (m; unit quaternion).
  Only the position enters the inference.
- ``goal_poses`` (7 n): the n goal poses, each ``[x, y, z, qw, qx, qy, qz]``, flattened.
- ``u_a`` (6 n): per-goal autonomy commands ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s, W),
  flattened. Only evaluated by the DFT system with the agreement term on; may stay unconnected
  otherwise.
- ``paused`` (1, optional): while it is above 0.5 the belief is held where it is (the DFT's time
  derivative is zero, the discrete methods skip their step; a changed goal set still resets it):
  the study's system did not update its belief while it computed a disambiguation request (the
  interface's ``paused``). Unconnected: never paused.

Output ports (vector-valued, computed from state only: no direct feedthrough):

- ``belief`` (n): the goal probabilities, a probability vector at every instant (the stored
  belief projected onto the simplex, once per change of the state; ``g_star`` and ``p_star`` read
  this output's cached value).
- ``g_star`` (1): 0-based index of the most probable goal (first one on ties).
- ``p_star`` (1): its probability.
- ``sanitized_input_count`` (1): control ticks so far at which an input the method reads held a
  NaN/inf and was replaced (``u_h`` for the DFT and Bayes systems, the end-effector position for
  the memory-based one), each checked by the periodic update; a warning names the system, at most
  once per second of simulated time. Discrete state ``[count]`` and ``[time of the last
  warning]`` (s), written only at such ticks.

When ``goal_poses`` differs from the goal set the system last saw (by more than
``goal_change_tolerance`` in any entry), the next periodic update resets the belief to the rest
state over the new set (the multi-step task). The algorithms are the numpy core's
(:mod:`drake_disamb.core.inference`); these systems only hold state and move data.

:func:`inference_system` builds the system of a core inference method, chosen by the method's
type (a new method registers its system with ``inference_system.register``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import (
    BasicVector,
    Context,
    DiscreteValues,
    EventStatus,
    LeafSystem,
    State,
    ValueProducer,
)

from drake_disamb.core.inference import (
    BayesInference,
    DFTInference,
    DFTParams,
    DFTRow,
    InferenceMethod,
    MemoryInference,
    bayes_step,
    dft_drive,
    memory_step,
    normalize_belief,
    rest_state,
    sanitize_command,
)
from drake_disamb.core.validation import all_finite
from drake_disamb.system_helpers.sanitized import SanitizedInputCounter
from drake_disamb.system_helpers.status import DID_NOTHING, flag_set
from drake_disamb.systems.loop import ControlLoop

SIMPLEX_TOLERANCE = 1e-12
"""Largest ``|sum(p) - 1|``, and largest ``-min(p)``, the DFT system's periodic projection leaves
alone (the belief output is projected onto the simplex anyway)."""


def _assert_square(matrix: NDArray[np.float64] | None, n: int) -> None:
    """What the systems rely on of a (checked) goal-transition matrix: ``None`` or ``n x n``."""
    assert matrix is None or np.shape(matrix) == (n, n), np.shape(matrix)


def _goals_changed(new: NDArray[np.float64], old: NDArray[np.float64], tol: float) -> bool:
    """True if any entry moved by more than ``tol`` or changed between finite and NaN."""
    if new.tobytes() == old.tobytes():  # the common case, every tick (equal bits: nothing moved)
        return False
    nan_new, nan_old = np.isnan(new), np.isnan(old)
    diff = np.abs(np.where(nan_new | nan_old, 0.0, new - old))
    return bool(np.any(diff > tol) or np.any(nan_new != nan_old))


class _IntentInferenceBase(LeafSystem):
    """Ports, input reading and outputs shared by the three inference systems.

    Subclasses define ``_raw_belief(context)``: the stored belief (continuous or discrete state).
    """

    def __init__(self, loop: ControlLoop, rest: ArrayLike | None, tol: float) -> None:
        super().__init__()
        assert isinstance(loop, ControlLoop), loop
        assert math.isfinite(tol) and tol >= 0, tol
        self._n = loop.n_goals
        self._rest = rest_state(self._n, rest).astype(float)  # the core's check of a rest state
        self._period = loop.control_period
        self._tol = float(tol)
        self._u_h = self.DeclareVectorInputPort("u_h", 6)
        self._ee_pose = self.DeclareVectorInputPort("ee_pose", 7)
        self._goal_poses = self.DeclareVectorInputPort("goal_poses", 7 * self._n)
        self._u_a = self.DeclareVectorInputPort("u_a", 6 * self._n)
        self._paused = self.DeclareVectorInputPort("paused", 1)

    @property
    def n_goals(self) -> int:
        """Number of goals n."""
        return self._n

    @property
    def control_period(self) -> float:
        """Period (s) of the state update events."""
        return self._period

    def _declare_outputs(self, ticket) -> None:  # noqa: ANN001 (DependencyTicket)
        # The belief output projects the stored belief (``ticket``: the state it is stored in) once
        # per change of that state; g_star and p_star read the belief output's cached value.
        self._belief_port = self.DeclareVectorOutputPort(
            "belief", BasicVector(self._n), self._calc_belief, {ticket}
        )
        projected = {self._belief_port.cache_entry().ticket()}
        self.DeclareVectorOutputPort("g_star", BasicVector(1), self._calc_g_star, projected)
        self.DeclareVectorOutputPort("p_star", BasicVector(1), self._calc_p_star, projected)
        self._sanitized = SanitizedInputCounter(self)

    # -- inputs ---------------------------------------------------------------------------------

    def _command(self, context: Context) -> NDArray[np.float64]:
        """``u_h``, a command with a NaN/inf entry read as zero (counted by :meth:`_count_sanitized`)."""
        u = np.asarray(self._u_h.Eval(context), dtype=float)
        return u if all_finite(u) else sanitize_command(u)

    def _sanitized_input(self, context: Context) -> str | None:
        """What this tick's inputs held that the method replaces, or None (default: ``u_h``)."""
        if not self._u_h.HasValue(context):  # e.g. a system driven without a command
            return None
        u = np.asarray(self._u_h.Eval(context), dtype=float)
        return None if all_finite(u) else f"non-finite human command u_h={u.tolist()} read as zero"

    def _count_sanitized(self, context: Context, discrete_state: DiscreteValues) -> bool:
        """Count (and warn about) a sanitised input of this tick in ``discrete_state``; True if any."""
        message = self._sanitized_input(context)
        if message is None:
            return False
        self._sanitized.record(context, discrete_state, message)
        return True

    def _held(self, context: Context) -> bool:
        """The ``paused`` input is set: the belief is not updated."""
        return flag_set(self._paused, context)

    def _position(self, context: Context) -> NDArray[np.float64]:
        return np.asarray(self._ee_pose.Eval(context), dtype=float)[:3]

    def _goal_poses_now(self, context: Context) -> NDArray[np.float64]:
        return np.asarray(self._goal_poses.Eval(context), dtype=float).copy()

    def _goal_positions(self, goal_poses: NDArray[np.float64]) -> NDArray[np.float64]:
        return goal_poses.reshape(self._n, 7)[:, :3]

    # -- outputs --------------------------------------------------------------------------------

    def _calc_belief(self, context: Context, output: BasicVector) -> None:
        # A copy projected onto the simplex: the stored state may carry integrator error.
        output.SetFromVector(normalize_belief(self._raw_belief(context)))

    def _belief(self, context: Context) -> NDArray[np.float64]:
        """The belief output's (cached) value."""
        return self._belief_port.Eval(context)

    def _calc_g_star(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector([float(np.argmax(self._belief(context)))])

    def _calc_p_star(self, context: Context, output: BasicVector) -> None:
        output.SetFromVector([float(np.max(self._belief(context)))])


class FieldTheoreticIntentInference(_IntentInferenceBase):
    """Field-theoretic intent inference: the belief is continuous state following the DFT ODE.

    .. pydrake_system::

        name: FieldTheoreticIntentInference
        input_ports:
        - u_h
        - ee_pose
        - goal_poses
        - u_a
        - paused
        output_ports:
        - belief
        - g_star
        - p_star
        - sanitized_input_count

    Ports are described in the module docstring: ``u_h`` (6; m/s, rad/s; ``[v; w]`` order),
    ``ee_pose`` (7; m, ``[x, y, z, qw, qx, qy, qz]``), ``goal_poses`` (7 n), ``u_a`` (6 n; only
    evaluated with ``params.agreement``), ``paused`` (1; optional: above 0.5 the belief is held) in;
    ``belief`` (n), ``g_star`` (1, 0-based index), ``p_star`` (1), ``sanitized_input_count`` (1;
    ticks with a non-finite ``u_h``) out.

    State: continuous ``p`` (n) with time derivative
    :func:`~drake_disamb.core.inference.dft_mass_conserving_rhs` (the DFT right-hand side
    projected so that ``sum(p)`` stays 1, with a positivity guard whose ``guard_time`` is the
    control period: no entry falls faster than ``p / control_period``, so an explicit step of up to
    one control period never takes it below zero), integrated by the simulator's integrator (the
    drive, the part of the right-hand side that does not depend on ``p``, is a cache
    entry on the inputs: computed once per control tick, not at every integrator stage; it also
    holds whether ``u_h`` was finite, the verdict the periodic update counts, and the goal poses
    it was computed with, which the periodic update compares);
    discrete ``goal_poses`` (7 n), the goal set the belief refers to. Every
    ``control_period`` an unrestricted update re-projects ``p`` onto the simplex when it has left
    it (an entry below ``-SIMPLEX_TOLERANCE``, or ``|sum(p) - 1| > SIMPLEX_TOLERANCE``: a guard
    against integrator error; otherwise it writes nothing, which matters for speed: any written
    unrestricted update makes Drake rewrite every subsystem's state that has one in that tick, and
    everything computed from them is computed again) or, if ``goal_poses`` changed, resets ``p`` to
    the rest state. At initialization ``p`` is the rest state.

    Args:
        loop: The number of goals n and the control period (s) of the projection / goal-change
            check.
        params: DFT parameters (:class:`~drake_disamb.core.inference.DFTParams`); its
            ``transition`` and ``lam`` (if a matrix) are n x n.
        rest: Rest state (task prior, a probability vector of n entries); overrides
            ``params.rest``; None keeps ``params.rest`` (uniform if that is None too).
        goal_change_tolerance: Largest change (m or quaternion units) of any ``goal_poses`` entry
            still read as "the same goal set".
    """

    def __init__(
        self,
        loop: ControlLoop,
        params: DFTParams | None = None,
        rest: ArrayLike | None = None,
        goal_change_tolerance: float = 1e-9,
    ) -> None:
        params = DFTParams() if params is None else params
        assert isinstance(params, DFTParams), params
        super().__init__(loop, params.rest if rest is None else rest, goal_change_tolerance)
        # Sizes resolution checked (scenario.inference.dft.transition, .rest).
        _assert_square(params.transition, self._n)
        assert np.ndim(params.lam) == 0 or np.shape(params.lam) == (self._n, self._n), np.shape(params.lam)
        self._params = replace(params, rest=self._rest)
        # The core's drive and flow for one belief, prepared once (the same kernels and numbers as
        # dft_drive / dft_mass_conserving_rhs_from_drive, without their per-call checks and layout).
        self._dft = DFTRow(self._params, self._n, self._period)
        self.DeclareContinuousState(self._n)
        # The drive (the part of the right-hand side that does not depend on p) changes only with
        # the inputs, which are held between control ticks: a cache entry computes it once per
        # change instead of at every integrator stage.
        inputs = [self._u_h, self._ee_pose, self._goal_poses, self._paused]
        inputs += [self._u_a] if params.agreement else []
        self._drive = self.DeclareCacheEntry(
            "DFT drive rest/tau2 + lambda sigma(xi) (1/s), u_h finite, goal_poses, held",
            ValueProducer(
                allocate=lambda: AbstractValue.Make((np.zeros(self._n), True, np.zeros(7 * self._n), False)),
                calc=self._calc_drive,
            ),
            prerequisites_of_calc={port.ticket() for port in inputs},
        )
        self._goals_index = self.DeclareDiscreteState(np.full(7 * self._n, np.nan))
        self.DeclareInitializationUnrestrictedUpdateEvent(self._reset_update)
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._period, 0.0, self._periodic_update)
        self._declare_outputs(self.xc_ticket())

    @property
    def params(self) -> DFTParams:
        """The DFT parameters in use (``rest`` filled in)."""
        return self._params

    def _raw_belief(self, context: Context) -> NDArray[np.float64]:
        return context.get_continuous_state_vector().CopyToVector()

    def _calc_drive(self, context: Context, value: AbstractValue) -> None:
        # The drive and whether u_h was finite (the verdict the periodic update counts, so that
        # the command is read and checked once per tick).
        # Vector ports give float64 arrays (copies) of their declared sizes: only u_h's values are
        # checked. The goal poses are kept with the drive: the periodic update compares them.
        goal_poses = self._goal_poses.Eval(context)
        x_g = self._goal_positions(goal_poses)
        u_a = self._u_a.Eval(context) if self._params.agreement else None
        u = self._u_h.Eval(context)
        finite = all_finite(u)
        command = u if finite else sanitize_command(u)
        drive = dft_drive(command, self._ee_pose.Eval(context)[:3], x_g, self._dft, u_a)
        value.set_value((drive, finite, goal_poses, self._held(context)))

    def DoCalcTimeDerivatives(self, context: Context, derivatives) -> None:  # noqa: N802, ANN001
        drive, _, _, held = self._drive.Eval(context)
        if held:  # the belief is held (the ``paused`` input)
            derivatives.get_mutable_vector().SetFromVector(np.zeros(self._n))
            return
        p = context.get_continuous_state_vector().CopyToVector()
        derivatives.get_mutable_vector().SetFromVector(self._dft.mass_conserving_rhs(p, drive))

    def _reset_update(self, context: Context, state: State) -> None:
        state.get_mutable_continuous_state().get_mutable_vector().SetFromVector(self._rest)
        state.get_mutable_discrete_state(self._goals_index).SetFromVector(self._goal_poses_now(context))

    def _periodic_update(self, context: Context, state: State) -> EventStatus:
        counted = False
        if self._u_h.HasValue(context):
            # The drive of this tick's inputs (already computed by the integrator) holds the
            # verdict on u_h and the goal poses: the inputs are read and checked once per tick.
            _, finite, goals, _ = self._drive.Eval(context)
            if not finite:
                counted = self._count_sanitized(context, state.get_mutable_discrete_state())
        else:  # e.g. a system driven without a command
            goals = self._goal_poses.Eval(context)
        old = context.get_discrete_state(self._goals_index).get_value()
        if _goals_changed(goals, old, self._tol):
            self._reset_update(context, state)
            return EventStatus.Succeeded()
        p = context.get_continuous_state_vector().CopyToVector()
        # The usual case: the flow conserves sum(p) up to rounding and keeps p >= 0. Nothing
        # is written then, so the belief and what depends on it are not recomputed after the tick.
        # (On a list of floats: a NaN entry fails the first test, as it fails np.min(p) >= ...)
        entries = p.tolist()
        if (
            all(x >= -SIMPLEX_TOLERANCE for x in entries)
            and abs(math.fsum(entries) - 1.0) <= SIMPLEX_TOLERANCE
        ):
            return EventStatus.Succeeded() if counted else DID_NOTHING
        state.get_mutable_continuous_state().get_mutable_vector().SetFromVector(normalize_belief(p))
        return EventStatus.Succeeded()


class _DiscreteInference(_IntentInferenceBase):
    """Discrete-state belief updated every ``control_period``; layout ``[belief (n), extra, goals]``.

    Subclasses define ``_step(context, belief, extra, x_g) -> (belief, extra)``: one update of the
    belief (and of the method's extra state) with the goal positions ``x_g`` (n, 3).
    """

    def __init__(self, loop: ControlLoop, rest, tol: float, n_extra: int) -> None:  # noqa: ANN001
        super().__init__(loop, rest, tol)
        self._n_extra = n_extra
        self._state_index = self.DeclareDiscreteState(np.full(self._n + n_extra + 7 * self._n, np.nan))
        self.DeclareInitializationDiscreteUpdateEvent(self._reset_update)
        self.DeclarePeriodicDiscreteUpdateEvent(self._period, 0.0, self._periodic_update)
        self._declare_outputs(self.xd_ticket())

    def _raw_belief(self, context: Context) -> NDArray[np.float64]:
        return context.get_discrete_state(self._state_index).CopyToVector()[: self._n]

    def _reset_extra(self, context: Context) -> NDArray[np.float64]:
        return np.zeros(self._n_extra)

    def _reset_update(self, context: Context, discrete_state: DiscreteValues) -> None:
        value = np.concatenate([self._rest, self._reset_extra(context), self._goal_poses_now(context)])
        discrete_state.get_mutable_vector(self._state_index).SetFromVector(value)

    def _periodic_update(self, context: Context, discrete_state: DiscreteValues) -> None:
        self._count_sanitized(context, discrete_state)
        goals = self._goal_poses_now(context)
        x = context.get_discrete_state(self._state_index).CopyToVector()
        n, k = self._n, self._n_extra
        if _goals_changed(goals, x[n + k :], self._tol):
            self._reset_update(context, discrete_state)
            return
        if self._held(context):
            return  # the belief (and the method's extra state) held where it is
        belief, extra = self._step(context, x[:n], x[n : n + k], self._goal_positions(goals))
        discrete_state.get_mutable_vector(self._state_index).SetFromVector(
            np.concatenate([normalize_belief(belief), extra, goals])
        )


class RecursiveBayesIntentInference(_DiscreteInference):
    """Recursive Bayesian intent inference (the paper's baseline), discrete state.

    .. pydrake_system::

        name: RecursiveBayesIntentInference
        input_ports:
        - u_h
        - ee_pose
        - goal_poses
        - u_a
        - paused
        output_ports:
        - belief
        - g_star
        - p_star
        - sanitized_input_count

    Ports as in the module docstring (``u_a`` is declared for interchangeability and never read).
    Every ``control_period``: ``p <- normalize(likelihood(u_h | g) * P^T p)``
    (:func:`~drake_disamb.core.inference.bayes_step`), or a reset to the rest state when
    ``goal_poses`` changed. Discrete state ``[belief (n), goal_poses (7 n)]`` (and the
    sanitised-input count: ticks with a non-finite ``u_h``).

    Args:
        loop: The number of goals n and the update period (s).
        method: The method's settings (:class:`~drake_disamb.core.inference.BayesInference`: the
            likelihood's ``sigma``, the goal-transition matrix P, n x n, or None for I).
        rest: Initial / reset belief (probability vector); None means uniform.
        goal_change_tolerance: As for :class:`FieldTheoreticIntentInference`.
    """

    def __init__(
        self,
        loop: ControlLoop,
        method: BayesInference | None = None,
        rest: ArrayLike | None = None,
        goal_change_tolerance: float = 1e-9,
    ) -> None:
        method = BayesInference() if method is None else method
        assert isinstance(method, BayesInference), method
        _assert_square(method.transition, loop.n_goals)
        self._P = method.transition
        self._sigma = float(method.sigma)
        super().__init__(loop, rest, goal_change_tolerance, n_extra=0)

    def _step(self, context, belief, extra, x_g):  # noqa: ANN001, ANN202
        p = bayes_step(belief, self._command(context), self._position(context), x_g, self._P, self._sigma)
        return p, extra


class MemoryBasedIntentInference(_DiscreteInference):
    """Memory-based intent prediction (Dragan & Srinivasa, the paper's baseline), discrete state.

    .. pydrake_system::

        name: MemoryBasedIntentInference
        input_ports:
        - u_h
        - ee_pose
        - goal_poses
        - u_a
        - paused
        output_ports:
        - belief
        - g_star
        - p_star
        - sanitized_input_count

    Ports as in the module docstring (``u_h`` and ``u_a`` are declared for interchangeability and
    never read: the method only looks at the end-effector path). Every ``control_period`` the
    move from the previous to the current end-effector position updates the running path cost and
    the belief (:func:`~drake_disamb.core.inference.memory_step`), or the state resets when
    ``goal_poses`` changed (the trial start becomes the current position).
    Discrete state ``[belief (n), cost (1), x_start (3), x_prev (3), goal_poses (7 n)]`` (m^2, m),
    and the sanitised-input count: ticks with a non-finite end-effector position (read as no move).

    Args:
        loop: The number of goals n and the update period (s).
        method: The method's settings (:class:`~drake_disamb.core.inference.MemoryInference`: the
            goal-transition matrix P, n x n, or None for I).
        rest: Initial / reset belief (probability vector); None means uniform.
        goal_change_tolerance: As for :class:`FieldTheoreticIntentInference`.
    """

    def __init__(
        self,
        loop: ControlLoop,
        method: MemoryInference | None = None,
        rest: ArrayLike | None = None,
        goal_change_tolerance: float = 1e-9,
    ) -> None:
        method = MemoryInference() if method is None else method
        assert isinstance(method, MemoryInference), method
        _assert_square(method.transition, loop.n_goals)
        self._P = method.transition
        super().__init__(loop, rest, goal_change_tolerance, n_extra=7)

    def _reset_extra(self, context: Context) -> NDArray[np.float64]:
        x = self._position(context)
        return np.concatenate([[0.0], x, x])

    def _sanitized_input(self, context: Context) -> str | None:
        x = self._position(context)
        return None if all_finite(x) else f"non-finite end-effector position {x.tolist()}: no move"

    def _step(self, context, belief, extra, x_g):  # noqa: ANN001, ANN202
        cost, x_start, x_prev = extra[0], extra[1:4], extra[4:7]
        x_now = self._position(context)
        if not np.all(np.isfinite(x_now)):
            x_now = x_prev  # no usable position: no move, no evidence
        if not np.all(np.isfinite(x_start)):
            x_start = x_now
        if not np.all(np.isfinite(x_prev)):
            x_prev = x_now
        p, cost = memory_step(belief, cost, x_prev, x_now, x_start, x_g, self._P)
        return p, np.concatenate([[float(cost)], x_start, x_now])


@functools.singledispatch
def inference_system(method: InferenceMethod, loop: ControlLoop) -> LeafSystem:
    """The Drake system running ``method`` (with its configuration) over ``loop.n_goals`` goals,
    updated every ``loop.control_period`` seconds; chosen by the method's type."""
    raise ValueError(
        f"inference method {method.name!r}: no Drake system is registered for {type(method).__name__}"
    )


@inference_system.register
def _(method: DFTInference, loop: ControlLoop) -> LeafSystem:
    return FieldTheoreticIntentInference(loop, method.params)


@inference_system.register
def _(method: BayesInference, loop: ControlLoop) -> LeafSystem:
    return RecursiveBayesIntentInference(loop, method)


@inference_system.register
def _(method: MemoryInference, loop: ControlLoop) -> LeafSystem:
    return MemoryBasedIntentInference(loop, method)
