"""The disambiguation system (Algorithm 1 or an alternative method, for the interface's mode switch)
and the Automatic paradigm's trigger.

All the algorithms live in the core (:mod:`drake_disamb.core.disambiguation`,
:mod:`drake_disamb.core.automatic`). A request is a value: the interface latches it at the press
(:class:`LatchedRequest`: the belief, the end-effector and goal poses, the mode) and
:class:`DisambiguationSystem` solves it once, in its own update, with its mode-selection method's
``select``, into its state (the answer the interface applies); :class:`AutomaticTrigger` holds the
trigger's state and runs :func:`~drake_disamb.core.automatic.automatic_trigger_update` every
control period.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, DiscreteValues, EventStatus, LeafSystem

from drake_disamb.core.automatic import AutomaticConfig, TriggerState, automatic_trigger_update
from drake_disamb.core.disambiguation import (
    DisambiguationConfig,
    DisambiguationRequest,
    DisambiguationResult,
    ModeSelectionMethod,
    make_request,
    mode_selection_method,
    validate_modes,
)
from drake_disamb.core.layout import POSE_SIZE
from drake_disamb.system_helpers.sanitized import SanitizedInputCounter, usable_poses
from drake_disamb.system_helpers.status import DID_NOTHING
from drake_disamb.systems.loop import ControlLoop

__all__ = ["AutomaticTrigger", "DisambiguationSystem", "LastResult", "LatchedRequest"]


@dataclass(frozen=True)
class LatchedRequest:
    """One disambiguation request as a value: what the interface latches when it starts one (its
    ``request`` output, from state) and the disambiguation system solves.

    As a vector (:meth:`to_vector`): ``[id, belief (n), ee_pose (7), goal_poses (7 n), current_mode]``.

    Attributes:
        id: The request's id: the interface's count of started disambiguations (requests and
            automatic triggers), 1 for the first; 0 before any.
        belief: The belief over the ``n`` goals at the request.
        ee_pose: The end-effector pose ``[x, y, z, qw, qx, qy, qz]`` in W (m) at the request.
        goal_poses: The ``n`` goal poses, each ``[x, y, z, qw, qx, qy, qz]``, flattened.
        current_mode: The interface's mode at the request (an index into its modes: arm modes first,
            the gripper mode last).
    """

    id: float
    belief: NDArray[np.float64]
    ee_pose: NDArray[np.float64]
    goal_poses: NDArray[np.float64]
    current_mode: float

    @staticmethod
    def size(n_goals: int) -> int:
        """Length of the vector of a request over ``n_goals`` goals."""
        return 2 + n_goals + POSE_SIZE + n_goals * POSE_SIZE

    @classmethod
    def none(cls, n_goals: int) -> LatchedRequest:
        """The value before any request: id 0, every other entry NaN."""
        return cls.from_vector(np.concatenate(([0.0], np.full(cls.size(n_goals) - 1, np.nan))), n_goals)

    def to_vector(self) -> NDArray[np.float64]:
        """``[id, belief, ee_pose, goal_poses, current_mode]``."""
        return np.concatenate(([self.id], self.belief, self.ee_pose, self.goal_poses, [self.current_mode]))

    @classmethod
    def from_vector(cls, vector: NDArray[np.float64], n_goals: int) -> LatchedRequest:
        """Inverse of :meth:`to_vector` (copies)."""
        v = np.asarray(vector, dtype=float)
        if v.shape != (cls.size(n_goals),):
            raise ValueError(f"request: expected {cls.size(n_goals)} numbers, got shape {v.shape}")
        n = n_goals
        return cls(
            id=float(v[0]),
            belief=v[1 : 1 + n].copy(),
            ee_pose=v[1 + n : 1 + n + POSE_SIZE].copy(),
            goal_poses=v[1 + n + POSE_SIZE : 1 + n + POSE_SIZE + n * POSE_SIZE].copy(),
            current_mode=float(v[-1]),
        )


@dataclass(frozen=True)
class LastResult:
    """The value of the disambiguation system's ``last_result`` port.

    A holder rather than a bare ``DisambiguationResult | None``: an abstract port needs a value
    of one type from its first allocation on, and newer Drake (1.58) cannot hold ``None`` in a
    ``Value[object]``.

    Attributes:
        result: The :class:`~drake_disamb.core.disambiguation.DisambiguationResult` of the last
            answered request, or None before any request or when that request's inputs were
            unusable (the mode was kept).
        served: True once a request has been answered (``result`` may still be None).
    """

    result: DisambiguationResult | None = None
    served: bool = False


_NO_REQUEST = LastResult()


class DisambiguationSystem(LeafSystem):
    """Chooses the disambiguating control mode ``m*`` (paper Algorithm 1, or ``method``) for each
    request, once.

    .. pydrake_system::

        name: DisambiguationSystem
        input_ports:
        - request
        output_ports:
        - answer
        - last_result
        - sanitized_input_count

    Input ports:
        request (9 + 8 n): the interface's latched request (its ``request`` output, from its
            state), a :class:`LatchedRequest` vector ``[id, belief (n), ee_pose (7), goal_poses
            (7 n), current_mode]``: the belief over the ``n`` goals (renormalised here if it
            drifted), the end-effector and goal poses ``[x, y, z, qw, qx, qy, qz]`` in W (m; unit
            quaternions) and the interface's mode at the request (arm modes first, gripper last).

    Output ports (from state):
        answer (2): ``[id, m*]``: the id of the last request answered (0 before any) and the mode
            chosen for it, an index into ``modes``, or -1 when the current mode is kept (ties, or
            unusable inputs, see below). The interface applies it at the request's due time.
        last_result (abstract): a :class:`LastResult` holding the
            :class:`~drake_disamb.core.disambiguation.DisambiguationResult` of the last answered
            request (scores per dimension and mode, features, the chosen mode), or ``None`` before
            any request (``served`` False) or if its inputs were unusable. A diagnostic, never
            read by the loop (which reads ``answer``): solved again from the stored request when
            it is evaluated, with the numbers of the update's solve, and cached until the state is
            next written (in a simulated diagram Drake marks every discrete state written at each
            tick); treat it as read-only. :meth:`get_last_result` returns the result itself.
        sanitized_input_count (1): answered requests so far whose inputs were unusable.

    **Unusable inputs.** A belief that is not a probability vector up to scale (a NaN/inf or
    negative entry, or no positive one), a non-finite ``current_mode``, or a pose that is not
    finite or has an unusable quaternion (:func:`~drake_disamb.system_helpers.sanitized.usable_poses`)
    are detected before the core is called: the answer is then -1 (the mode is kept), one is added
    to ``sanitized_input_count`` and a warning is issued (at most once per second of simulated
    time). Any other error of the core propagates out of the update (and so out of the simulation).

    State: numeric only, updated by a periodic *discrete* update every ``loop.control_period``
    seconds (first at t = 0) that writes only when the request's id differs from the one last answered:
    it then solves the request (once: one call of the method per request) and writes the answer
    ``[id, m*]`` and the request itself (the *served* group, what ``last_result`` shows). In a
    diagram the interface latches a request in its (unrestricted) update of the press's tick and
    this update answers it in the same tick (Drake runs a tick's unrestricted updates before its
    discrete ones); the answer carries the request's id, so what the interface applies never
    depends on that order, only when it can. Two more groups, ``[sanitised-input count]`` and
    ``[time of the last warning]`` (s), are written only when an unusable request was answered.

    The constructor runs one request on a small scene: it loads the core's compiled kernels (a
    fraction of a second, once per process) so that the user's first request in a simulation or a
    live session is as fast as the others, and a configuration that does not fit ``n_goals`` (a
    transition matrix of the wrong size, say) fails when the diagram is built.

    Attributes:
        n_goals: Number of goals (``loop.n_goals``).
        modes: The arm modes (dimension indices), as tuples.
        config: The :class:`~drake_disamb.core.disambiguation.DisambiguationConfig`.
        method: The mode-selection method (a
            :class:`~drake_disamb.core.disambiguation.ModeSelectionMethod`); the constructor also
            takes a name registered in
            :data:`~drake_disamb.core.disambiguation.MODE_SELECTION_METHODS`.
    """

    def __init__(
        self,
        loop: ControlLoop,
        modes: Sequence[Sequence[int]],
        config: DisambiguationConfig | None = None,
        method: str | ModeSelectionMethod = "algorithm1",
    ) -> None:
        super().__init__()
        self.config = DisambiguationConfig() if config is None else config
        assert isinstance(loop, ControlLoop) and isinstance(self.config, DisambiguationConfig), (loop, config)
        self.n_goals = loop.n_goals
        self.modes = validate_modes(modes)
        self.method = mode_selection_method(method)

        n = self.n_goals
        size = LatchedRequest.size(n)
        self._request = self.DeclareVectorInputPort("request", size)
        self._answer_index = self.DeclareDiscreteState(np.array([0.0, -1.0]))
        self._served_index = self.DeclareDiscreteState(LatchedRequest.none(n).to_vector())
        self.DeclareStateOutputPort("answer", self._answer_index)
        self.DeclareAbstractOutputPort(
            "last_result",
            lambda: AbstractValue.Make(_NO_REQUEST),
            self._calc_last_result,
            prerequisites_of_calc={self.discrete_state_ticket(self._served_index)},
        )
        self._sanitized = SanitizedInputCounter(self)
        self.DeclarePeriodicDiscreteUpdateEvent(loop.control_period, 0.0, self._update)
        # One request on a small scene now, so that the compiled kernels of the core are loaded
        # (a fraction of a second, once per process) before a simulation, not at the user's first
        # request in a live session.
        self.method.select(
            make_request(
                np.full(n, 1.0 / n),
                np.zeros(3),
                0.1 * np.arange(3.0 * n).reshape(n, 3) + 0.2,
                self.modes,
                self.config,
            )
        )

    # ------------------------------------------------------------------------------------------

    @staticmethod
    def _normalised_belief(p: NDArray[np.float64]) -> NDArray[np.float64] | None:
        """``p`` (entries >= -1e-9, any positive scale) as a probability vector, or None if unusable."""
        if not (np.isfinite(p).all() and p.min() >= -1e-9 and p.max() > 0):
            return None
        p = np.maximum(p, 0.0) / p.max()  # scaled first: the sum cannot overflow
        return p / p.sum()

    def _unusable(self, request: LatchedRequest) -> str | None:
        """Why ``request`` cannot be solved (an input out of range), or None if it can."""
        if self._normalised_belief(request.belief) is None:
            return f"belief: expected a probability vector, got {request.belief.tolist()!r}"
        if not math.isfinite(request.current_mode):
            return f"current_mode: expected a mode index, got {request.current_mode!r}"
        if not usable_poses(request.ee_pose, request.goal_poses):
            return (
                f"ee_pose/goal_poses: expected finite poses with usable quaternions, got "
                f"{request.ee_pose.tolist()!r} and {request.goal_poses.tolist()!r}"
            )
        return None

    def _solve(self, request: LatchedRequest) -> DisambiguationResult | None:
        """Run the mode-selection method on one request; an unusable one (see the class docstring)
        gives None (keep the mode). Any error of the core propagates."""
        return None if self._unusable(request) is not None else self._select(request)

    def _select(self, request: LatchedRequest) -> DisambiguationResult:
        """The method's result for a usable ``request``."""
        return self.method.select(self._core_request(request))

    def _core_request(self, request: LatchedRequest) -> DisambiguationRequest:
        """The core's request of a usable latched ``request`` (what the method is given)."""
        p = self._normalised_belief(request.belief)
        current = round(request.current_mode)
        goals = request.goal_poses.reshape(self.n_goals, POSE_SIZE)
        return make_request(
            p,
            request.ee_pose[:3],
            goals[:, :3],
            self.modes,
            self.config,
            orientation=request.ee_pose[3:],
            goal_orientations=goals[:, 3:],
            current_mode=current if current >= 0 else None,
        )

    def core_request(self, request: LatchedRequest) -> DisambiguationRequest | None:
        """The request the method solves for the latched ``request`` (None when its inputs are
        unusable and the mode is kept): what a display reads the method's choice against."""
        return None if self._unusable(request) is not None else self._core_request(request)

    def get_last_result(self, context: Context) -> DisambiguationResult | None:
        """The result of the last answered request in ``context`` (None before any, or if unusable)."""
        return self.GetOutputPort("last_result").Eval(context).result

    def get_sanitized_input_count(self, context: Context) -> int:
        """Answered requests so far in ``context`` whose inputs were unusable."""
        return self._sanitized.count(context)

    def _calc_last_result(self, context: Context, output: AbstractValue) -> None:
        stored = context.get_discrete_state(self._served_index).get_value()
        served = LatchedRequest.from_vector(stored, self.n_goals)
        if served.id == 0.0:
            output.set_value(_NO_REQUEST)
            return
        output.set_value(LastResult(self._solve(served), served=True))

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        vector = self._request.Eval(context)
        answered = context.get_discrete_state(self._answer_index).get_value()[0]
        if vector[0] == answered or not math.isfinite(vector[0]):
            return DID_NOTHING  # no new request: nothing to write
        request = LatchedRequest.from_vector(vector, self.n_goals)
        reason = self._unusable(request)
        result = None if reason is not None else self._select(request)  # the one solve of this request
        mode = -1.0 if result is None or result.mode is None else float(result.mode)
        discrete_state.get_mutable_vector(self._answer_index).SetFromVector([request.id, mode])
        discrete_state.get_mutable_vector(self._served_index).SetFromVector(vector)
        if reason is not None:
            self._sanitized.record(context, discrete_state, f"request ignored, the mode is kept: {reason}")
        return EventStatus.Succeeded()


class AutomaticTrigger(LeafSystem):
    """The Automatic paradigm's trigger: counts the moments the system should disambiguate by itself.

    .. pydrake_system::

        name: AutomaticTrigger
        input_ports:
        - belief
        - u_h
        - mode
        output_ports:
        - automatic_request_count

    The rule and why are in :mod:`drake_disamb.core.automatic` (low confidence while the user
    commands, for ``dwell_time`` since the last mode change, ``min_interval`` after the last automatic
    switch at the earliest: the last trigger plus ``request_latency``).

    Input ports:
        belief (n): the current belief over the ``n`` goals.
        u_h (6): the user's command ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s; the paper's order, not
            Drake's ``[w; v]``), from the interface's state.
        mode (1): the interface's current mode index (from its state).

    Output ports:
        automatic_request_count (1): triggers so far (from state). The interface starts a
            disambiguation when it grows (its ``automatic_request_count`` input) and logs the mode
            change it causes as ``"automatic_switch"``.

    State: two discrete groups, ``[dwell (s), mode seen, time of the last trigger (s; -1e9 before the
    first)]`` and ``[trigger count]``, updated by a periodic discrete update every
    ``loop.control_period`` seconds (first at t = 0).

    Attributes:
        n_goals: Number of goals (``loop.n_goals``).
        config: The :class:`~drake_disamb.core.automatic.AutomaticConfig` (threshold written out).
        control_period: Period (s) of the update (``loop.control_period``: the dwell grows by it
            per commanding tick).
        request_latency: Seconds (>= 0) from a trigger to its switch (the interface's).
    """

    _NEVER = -1e9
    """The state's "no trigger yet" time: finite, so that an unchanged state compares equal."""

    def __init__(self, loop: ControlLoop, config: AutomaticConfig, request_latency: float = 0.0) -> None:
        super().__init__()
        # The resolved trigger: its threshold written out (scenario.disambiguation.automatic), the
        # interface's request latency (scenario.disambiguation.request_latency).
        assert isinstance(loop, ControlLoop) and isinstance(config, AutomaticConfig), (loop, config)
        assert config.confidence_threshold is not None, config
        assert math.isfinite(request_latency) and request_latency >= 0, request_latency
        self.n_goals = loop.n_goals
        self.config = config
        self.control_period = loop.control_period
        self.request_latency = float(request_latency)
        self._belief = self.DeclareVectorInputPort("belief", self.n_goals)
        self._u_h = self.DeclareVectorInputPort("u_h", 6)
        self._mode = self.DeclareVectorInputPort("mode", 1)
        self._main = self.DeclareDiscreteState(np.array([0.0, -1.0, self._NEVER]))
        self._count = self.DeclareDiscreteState(np.zeros(1))
        self.DeclareStateOutputPort("automatic_request_count", self._count)
        self.DeclarePeriodicDiscreteUpdateEvent(self.control_period, 0.0, self._update)

    def get_trigger_count(self, context: Context) -> int:
        """Triggers so far in ``context``."""
        return int(round(context.get_discrete_state(self._count).get_value()[0]))

    def _update(self, context: Context, discrete_state) -> EventStatus:  # noqa: ANN001
        dwell, mode, last = context.get_discrete_state(self._main).get_value().tolist()
        count = context.get_discrete_state(self._count).get_value()[0]
        before = TriggerState(
            count=int(round(count)),
            dwell=dwell,
            mode=int(round(mode)),
            last_trigger=-np.inf if last <= self._NEVER else last,
        )
        after, fired = automatic_trigger_update(
            before,
            self._belief.Eval(context),
            self._u_h.Eval(context),
            float(self._mode.Eval(context)[0]),
            context.get_time(),
            self.control_period,
            self.config,
            self.request_latency,
        )
        last_out = self._NEVER if not np.isfinite(after.last_trigger) else after.last_trigger
        discrete_state.get_mutable_vector(self._main).SetFromVector([after.dwell, after.mode, last_out])
        if fired:
            discrete_state.get_mutable_vector(self._count).SetFromVector([after.count])
        return EventStatus.Succeeded()
