"""The disambiguation system (Algorithm 1 or an alternative method, for the interface's mode switch)
and the Automatic paradigm's trigger.

All the algorithms live in the core (:mod:`drake_disamb.core.disambiguation`,
:mod:`drake_disamb.core.automatic`); :class:`DisambiguationSystem` only reads its inputs, makes a
:class:`~drake_disamb.core.disambiguation.DisambiguationRequest`, runs its mode-selection method's
``select`` on it and keeps the last result;
:class:`AutomaticTrigger` holds the trigger's state and runs
:func:`~drake_disamb.core.automatic.automatic_trigger_update` every control period.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import BasicVector, Context, DiscreteValues, EventStatus, LeafSystem

from drake_disamb.core.automatic import AutomaticConfig, TriggerState, automatic_trigger_update
from drake_disamb.core.disambiguation import (
    DisambiguationConfig,
    DisambiguationResult,
    ModeSelectionMethod,
    make_request,
    mode_selection_method,
    validate_modes,
)
from drake_disamb.core.layout import POSE_SIZE
from drake_disamb.core.validation import is_real
from drake_disamb.system_helpers.sanitized import SanitizedInputCounter, usable_poses
from drake_disamb.system_helpers.status import DID_NOTHING

__all__ = ["AutomaticTrigger", "DisambiguationSystem", "LastResult"]


@dataclass(frozen=True)
class _Inputs:
    """The inputs of one disambiguation request (a snapshot of the input ports)."""

    belief: NDArray[np.float64]
    ee_pose: NDArray[np.float64]
    goal_poses: NDArray[np.float64]
    current_mode: float


@dataclass(frozen=True)
class LastResult:
    """The value of the disambiguation system's ``last_result`` port.

    A holder rather than a bare ``DisambiguationResult | None``: an abstract port needs a value
    of one type from its first allocation on, and newer Drake (1.58) cannot hold ``None`` in a
    ``Value[object]``.

    Attributes:
        result: The :class:`~drake_disamb.core.disambiguation.DisambiguationResult` of the last
            served request, or None before any request or when that request's inputs were
            unusable (the mode was kept).
        served: True once a request has been served (``result`` may still be None).
    """

    result: DisambiguationResult | None = None
    served: bool = False


_NO_REQUEST = LastResult()


class DisambiguationSystem(LeafSystem):
    """Chooses the disambiguating control mode ``m*`` (paper Algorithm 1, or ``method``) on request.

    .. pydrake_system::

        name: DisambiguationSystem
        input_ports:
        - belief
        - ee_pose
        - goal_poses
        - current_mode
        - request_count
        output_ports:
        - disambiguation_mode
        - last_result
        - sanitized_input_count

    Input ports:
        belief (n): the current belief over the ``n`` goals (probability vector; renormalised
            here if it drifted).
        ee_pose (7): end-effector pose ``[x, y, z, qw, qx, qy, qz]`` in W (m; unit quaternion).
        goal_poses (n * 7): the goal poses, each ``[x, y, z, qw, qx, qy, qz]`` in W.
        current_mode (1): the interface's current mode, an index into its mode list (arm modes
            first, gripper mode last); must come from interface *state*.
        request_count (1): the interface's running count of *served* disambiguations (its
            ``served_count`` output, from its state): requests and automatic triggers, counted when
            the interface reads ``disambiguation_mode``, i.e. at the switch time, ``request_latency``
            after a press.

    Output ports:
        disambiguation_mode (1): ``m*`` as an index into ``modes``, or -1 when the current mode is
            kept (ties, or unusable inputs, see below). Computed on demand from
            ``belief``, ``ee_pose``, ``goal_poses`` and ``current_mode`` (direct feedthrough from
            those four, not from ``request_count``): the interface evaluates it only in the update
            in which it serves a disambiguation (a press, or ``request_latency`` after it), and
            switches mode in that same control period.
        last_result (abstract): a :class:`LastResult` holding the
            :class:`~drake_disamb.core.disambiguation.DisambiguationResult` of the last request
            (scores per dimension and mode, features, the chosen mode), or ``None`` before any
            request (``served`` False) or if its inputs were unusable. Computed from state (the
            inputs of the served request), on demand; treat it as read-only.
            :meth:`get_last_result` returns the result itself.
        sanitized_input_count (1): served requests so far whose inputs were unusable (from state).

    **Unusable inputs.** A belief that is not a probability vector up to scale (a NaN/inf or
    negative entry, or no positive one), a non-finite ``current_mode``, or a pose that is not
    finite or has an unusable quaternion (:func:`~drake_disamb.system_helpers.sanitized.usable_poses`)
    are detected before the core is called: ``disambiguation_mode`` is then -1 (the mode is kept)
    and, when the interface served such a request, the next update adds one to
    ``sanitized_input_count`` and warns (at most once per second of simulated time). Any other
    error of the core propagates out of the port evaluation (and so out of the simulation).

    State: numeric only. Two discrete groups updated by a periodic *discrete* update every
    ``control_period`` seconds (first at t = 0; initialised from the inputs): the *tick* group
    ``[request_count seen, current_mode seen]`` and the *served* group ``[has request, request]``,
    where a request is ``[belief (n), ee_pose (7), goal_poses (7 n), current_mode (1)]``. Drake
    runs a tick's discrete updates after its unrestricted ones, so when ``request_count`` has grown
    since the previous tick, the interface served the request in this very tick, from inputs that
    the discrete phase still sees unchanged (the belief, the sampled pose and the goals change
    at discrete updates or by integration, later), except the mode, which the interface has just
    switched: the request takes the mode seen at the previous tick, the one the interface had. So
    the served request is exactly what the interface used (unless the belief was reset or
    re-projected in that same tick), and ``last_result`` shows it from that tick on. The update
    writes only when the count or the mode changed (at other ticks it does nothing, so nothing
    computed from this system is recomputed). Two more groups, ``[sanitised-input count]`` and
    ``[time of the last warning]`` (s), are written only when an unusable request was served.

    The constructor runs one request on a small scene: it loads the core's compiled kernels (a
    fraction of a second, once per process) so that the user's first request in a simulation or a
    live session is as fast as the others, and a configuration that does not fit ``n_goals`` (a
    transition matrix of the wrong size, say) fails when the diagram is built.

    Attributes:
        n_goals: Number of goals.
        modes: The arm modes (dimension indices), as tuples.
        config: The :class:`~drake_disamb.core.disambiguation.DisambiguationConfig`.
        method: The mode-selection method (a
            :class:`~drake_disamb.core.disambiguation.ModeSelectionMethod`); the constructor also
            takes a name registered in
            :data:`~drake_disamb.core.disambiguation.MODE_SELECTION_METHODS`.
    """

    def __init__(
        self,
        n_goals: int,
        modes: Sequence[Sequence[int]],
        config: DisambiguationConfig | None = None,
        control_period: float = 0.01,
        method: str | ModeSelectionMethod = "algorithm1",
    ) -> None:
        super().__init__()
        if isinstance(n_goals, bool) or not isinstance(n_goals, int | np.integer) or n_goals < 1:
            raise ValueError(f"n_goals: expected a positive integer, got {n_goals!r}")
        if not (np.isfinite(control_period) and control_period > 0):
            raise ValueError(f"control_period: expected a finite number > 0, got {control_period!r}")
        self.n_goals = int(n_goals)
        self.modes = validate_modes(modes)
        self.config = DisambiguationConfig() if config is None else config
        if not isinstance(self.config, DisambiguationConfig):
            raise ValueError(f"config: expected a DisambiguationConfig, got {config!r}")
        self.method = mode_selection_method(method)

        n = self.n_goals
        self._belief = self.DeclareVectorInputPort("belief", n)
        self._ee_pose = self.DeclareVectorInputPort("ee_pose", POSE_SIZE)
        self._goal_poses = self.DeclareVectorInputPort("goal_poses", n * POSE_SIZE)
        self._current_mode = self.DeclareVectorInputPort("current_mode", 1)
        self._request_count = self.DeclareVectorInputPort("request_count", 1)

        # Tick group: [request_count seen, current_mode seen]; served group: [has request (0/1),
        # request] (the request's layout is that of _pack).
        self._tick_index = self.DeclareDiscreteState(np.zeros(2))
        self._served_index = self.DeclareDiscreteState(np.zeros(1 + n + POSE_SIZE + n * POSE_SIZE + 1))
        self._memo: tuple[bytes, LastResult] | None = None
        feedthrough = {
            port.ticket() for port in (self._belief, self._ee_pose, self._goal_poses, self._current_mode)
        }
        self.DeclareVectorOutputPort(
            "disambiguation_mode", 1, self._calc_mode, prerequisites_of_calc=feedthrough
        )
        self.DeclareAbstractOutputPort(
            "last_result",
            lambda: AbstractValue.Make(_NO_REQUEST),
            self._calc_last_result,
            prerequisites_of_calc={self.discrete_state_ticket(self._served_index)},
        )
        self._sanitized = SanitizedInputCounter(self)
        self.DeclareInitializationDiscreteUpdateEvent(self._initialize)
        self.DeclarePeriodicDiscreteUpdateEvent(control_period, 0.0, self._update)
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

    def _read(self, context: Context) -> _Inputs:
        return _Inputs(
            belief=np.array(self._belief.Eval(context), dtype=float),
            ee_pose=np.array(self._ee_pose.Eval(context), dtype=float),
            goal_poses=np.array(self._goal_poses.Eval(context), dtype=float),
            current_mode=float(self._current_mode.Eval(context)[0]),
        )

    def _pack(self, context: Context) -> NDArray[np.float64]:
        """The inputs now as one snapshot vector ``[belief, ee_pose, goal_poses, current_mode]``."""
        return np.concatenate(
            (
                self._belief.Eval(context),
                self._ee_pose.Eval(context),
                self._goal_poses.Eval(context),
                self._current_mode.Eval(context),
            )
        )

    def _unpack(self, snapshot: NDArray[np.float64]) -> _Inputs:
        n = self.n_goals
        return _Inputs(
            belief=snapshot[:n].copy(),
            ee_pose=snapshot[n : n + POSE_SIZE].copy(),
            goal_poses=snapshot[n + POSE_SIZE : n + POSE_SIZE + n * POSE_SIZE].copy(),
            current_mode=float(snapshot[-1]),
        )

    @staticmethod
    def _normalised_belief(p: NDArray[np.float64]) -> NDArray[np.float64] | None:
        """``p`` (entries >= -1e-9, any positive scale) as a probability vector, or None if unusable."""
        if not (np.isfinite(p).all() and p.min() >= -1e-9 and p.max() > 0):
            return None
        p = np.maximum(p, 0.0) / p.max()  # scaled first: the sum cannot overflow
        return p / p.sum()

    def _unusable(self, request: _Inputs) -> str | None:
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

    def _solve(self, request: _Inputs) -> DisambiguationResult | None:
        """Run the core on one request; an unusable one (see :meth:`_unusable`) gives None (keep the
        mode). Any error of the core propagates."""
        if self._unusable(request) is not None:
            return None
        p = self._normalised_belief(request.belief)
        current = round(request.current_mode)
        goals = request.goal_poses.reshape(self.n_goals, POSE_SIZE)
        return self.method.select(
            make_request(
                p,
                request.ee_pose[:3],
                goals[:, :3],
                self.modes,
                self.config,
                orientation=request.ee_pose[3:],
                goal_orientations=goals[:, 3:],
                current_mode=current if current >= 0 else None,
            )
        )

    def get_last_result(self, context: Context) -> DisambiguationResult | None:
        """The result of the last served request in ``context`` (None before any, or if unusable)."""
        return self.GetOutputPort("last_result").Eval(context).result

    def get_sanitized_input_count(self, context: Context) -> int:
        """Served requests so far in ``context`` whose inputs were unusable."""
        return self._sanitized.count(context)

    def _calc_mode(self, context: Context, output: BasicVector) -> None:
        result = self._solve(self._read(context))
        output.SetAtIndex(0, -1.0 if result is None or result.mode is None else float(result.mode))

    def _calc_last_result(self, context: Context, output: AbstractValue) -> None:
        served = context.get_discrete_state(self._served_index).get_value()
        if served[0] < 0.5:
            output.set_value(_NO_REQUEST)
            return
        # The method is a pure function of the served request: a one-entry memo keeps a result
        # from being recomputed when the state is rewritten with the same request every tick.
        key = served.tobytes()
        if self._memo is None or self._memo[0] != key:
            self._memo = (key, LastResult(self._solve(self._unpack(served[1:])), served=True))
        output.set_value(self._memo[1])

    def _seen(self, context: Context, previous_count: float) -> tuple[float, float]:
        """``(request_count, current_mode)`` now; a non-finite count keeps ``previous_count`` (a
        non-finite mode is kept as it is: a request served with it is unusable, and counted)."""
        count = float(self._request_count.Eval(context)[0])
        mode = float(self._current_mode.Eval(context)[0])
        return (count if math.isfinite(count) else previous_count), mode

    def _initialize(self, context: Context, discrete_state: DiscreteValues) -> None:
        discrete_state.get_mutable_vector(self._tick_index).SetFromVector(self._seen(context, 0.0))

    def _update(self, context: Context, discrete_state: DiscreteValues) -> EventStatus:
        seen_count, seen_mode = context.get_discrete_state(self._tick_index).get_value()
        count, mode = self._seen(context, float(seen_count))
        same_mode = mode == seen_mode or (math.isnan(mode) and math.isnan(seen_mode))
        if count == seen_count and same_mode:
            return DID_NOTHING  # no request served, the same mode: nothing to write
        if count > seen_count:  # served in this tick, with the mode the interface had before it
            request = self._pack(context)
            request[-1] = seen_mode
            discrete_state.get_mutable_vector(self._served_index).SetFromVector(
                np.concatenate(([1.0], request))
            )
            reason = self._unusable(self._unpack(request))
            if reason is not None:
                message = f"request ignored, the mode is kept: {reason}"
                self._sanitized.record(context, discrete_state, message)
        discrete_state.get_mutable_vector(self._tick_index).SetFromVector([count, mode])
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
    ``control_period`` seconds (first at t = 0).

    Attributes:
        n_goals: Number of goals.
        config: The :class:`~drake_disamb.core.automatic.AutomaticConfig` (threshold written out).
        control_period: Period (s) of the update (the dwell grows by it per commanding tick).
        request_latency: Seconds (>= 0) from a trigger to its switch (the interface's).
    """

    _NEVER = -1e9
    """The state's "no trigger yet" time: finite, so that an unchanged state compares equal."""

    def __init__(
        self,
        n_goals: int,
        config: AutomaticConfig,
        control_period: float = 0.01,
        request_latency: float = 0.0,
    ) -> None:
        super().__init__()
        if isinstance(n_goals, bool) or not isinstance(n_goals, int | np.integer) or n_goals < 1:
            raise ValueError(f"n_goals: expected a positive integer, got {n_goals!r}")
        if not isinstance(config, AutomaticConfig) or config.confidence_threshold is None:
            raise ValueError(
                "config: expected an AutomaticConfig with its confidence_threshold written out, "
                f"got {config!r}"
            )
        if not (is_real(control_period) and control_period > 0):
            raise ValueError(f"control_period: expected a finite number > 0, got {control_period!r}")
        if not (is_real(request_latency) and request_latency >= 0):
            raise ValueError(f"request_latency: expected a finite number >= 0, got {request_latency!r}")
        self.n_goals = int(n_goals)
        self.config = config
        self.control_period = float(control_period)
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
