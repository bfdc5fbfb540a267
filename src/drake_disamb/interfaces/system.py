"""The interface system: any registered kind of control interface as a Drake LeafSystem.

The logic (raw layout, modes, speeds, edge detection, request handling) is numpy, in
:mod:`~drake_disamb.interfaces.update` and the kinds' modules (:mod:`drake_disamb.interfaces.kinds`);
:class:`InterfaceSystem` holds its state, latches the disambiguation requests it starts and runs
its update every control period, whatever the kind (:func:`make_interface`).
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import Context, DiscreteValues, EventStatus, LeafSystem, State

from drake_disamb.core.layout import POSE_SIZE
from drake_disamb.interfaces import (
    RAW_SIZE,
    Answer,
    InterfaceConfig,
    InterfaceEvent,
    InterfaceState,
    command_from_raw,
    disambiguation_due,
    initial_state,
    interface_update,
)
from drake_disamb.system_helpers.status import DID_NOTHING
from drake_disamb.systems.disambiguation import LatchedRequest

__all__ = ["EventLog", "InterfaceEvent", "InterfaceSystem", "make_interface"]


class EventLog(tuple):
    """The interface's event log: an immutable tuple of frozen :class:`InterfaceEvent`.

    Drake copies every abstract state value whenever an unrestricted update runs anywhere in the
    diagram (every control tick), and a Python value is copied with ``copy.deepcopy``. The log is
    truly immutable (a tuple of frozen dataclasses of floats, ints and strings), so a copy may
    share it: ``deepcopy`` and ``copy`` return the log itself, whatever its length.
    """

    __slots__ = ()

    def __copy__(self) -> EventLog:
        return self

    def __deepcopy__(self, memo: dict) -> EventLog:
        return self


class InterfaceSystem(LeafSystem):
    """A control interface: raw device signals in, the human command, mode bookkeeping and
    disambiguation requests out.

    .. pydrake_system::

        name: InterfaceSystem
        input_ports:
        - raw
        - belief
        - ee_pose
        - goal_poses
        - answer
        - automatic_request_count
        output_ports:
        - u_h
        - gripper_command
        - mode
        - request_count
        - mode_switch_count
        - nonfinite_count
        - served_count
        - paused
        - request
        - event_log

    Input ports:
        raw (4): the device signals in the kind's layout (``raw_layout``; e.g. joystick
            ``[axis_x, axis_y, mode_button, disambiguation_button]``, axes in [-1, 1], clipped,
            buttons 0/1; head array ``[left, right, back, disambiguation_button]``, switches 0/1).
            Levels ``>= button_threshold`` (0.5) count as pressed; NaN/inf entries are read as 0
            (counted in ``nonfinite_count``, warned once).
        belief (n), ee_pose (7), goal_poses (7 n): what a disambiguation request is made of: the
            belief over the ``n_goals`` goals, the end-effector pose ``[x, y, z, qw, qx, qy, qz]``
            in W (m) and the goal poses, flattened. Evaluated only in an update that starts a
            disambiguation (a request press or an automatic trigger), which latches them into the
            ``request`` state. May be left unconnected with no disambiguation system (latched as
            NaN).
        answer (2): the disambiguation system's ``answer`` ``[request id, m*]``: the id of the last
            request it answered and the mode chosen for it (an index into ``arm_modes``, or -1 =
            keep the current mode). Read by the updates from a started disambiguation's due time
            (``config.request_latency`` after it) on, until the answer carries its id; that update
            applies it. May be left unconnected (manual paradigm): requests are then logged,
            counted and waited for, and the mode is kept.
        automatic_request_count (1): the Automatic paradigm's trigger count
            (:class:`~drake_disamb.systems.disambiguation.AutomaticTrigger`); when it grows, a
            disambiguation starts as on a request press, but with no press, and the mode change it
            causes is logged as ``"automatic_switch"``. Unconnected in the other paradigms.

    Output ports (all state output ports, so none depends directly on an input):
        u_h (6): human command ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s) in the world frame, from
            the raw signal held at the last update and the current mode; zero in the gripper mode.
            (The paper's order, not Drake's ``[w; v]``.)
        gripper_command (1): finger opening speed (m/s, positive opens); nonzero only in the
            gripper mode.
        mode (1): current mode index into ``modes``.
        request_count (1): disambiguation requests so far.
        mode_switch_count (1): manual mode switches so far (disambiguation switches not counted).
        nonfinite_count (1): updates whose raw signal held NaN/inf.
        served_count (1): disambiguations served so far (requests and automatic triggers whose
            answer was applied).
        paused (1): 1 from the update that starts a disambiguation (a request press or an
            automatic trigger) until the update that applies its answer, while the system
            computes it, else 0. With ``disambiguation.hold_while_computing`` it pauses the loop
            (the inference's, the blender's and the simulated user's ``paused`` inputs).
        request (9 + 8 n): the latest disambiguation request, latched by the update that started
            it: a :class:`~drake_disamb.systems.disambiguation.LatchedRequest` vector ``[id, belief,
            ee_pose, goal_poses, mode]`` (the inputs of that update and the mode after its manual
            switch, if any; id 0 before any). The disambiguation system's ``request`` input.
        event_log (abstract): :class:`EventLog` (a ``tuple[InterfaceEvent, ...]``), every mode
            switch, request and disambiguation or automatic switch with its time, in order.

    **A request's timing.** The update of the press's tick latches the request; in a diagram the
    disambiguation system answers it in its discrete update of that same tick, and the interface
    applies the answer in the first update at least ``config.request_latency`` after the press
    that has it: ``request_latency`` after the press (the next tick when the latency is 0).

    State: discrete ``[mode, previous mode-button level, previous request-button level, mode-switch
    count, request count, non-finite count, held raw (4), pending switch time (s, -1 if none), pending
    is automatic, served count, automatic count seen]``
    (:class:`~drake_disamb.interfaces.InterfaceState`); one more discrete group per vector
    output holding its value (so the outputs are state output ports, evaluated without calling
    Python); the latched ``request``; ``[stable (0/1), raw (4), automatic count, pending switch
    time]``, whether the update of that raw signal and trigger count leaves the state as it is
    (see below); and the
    abstract event log. All are updated together by a periodic unrestricted update every
    ``config.control_period`` seconds (first at t = 0), so that the rest of the loop sees this
    tick's command in this tick. The update is a pure function of the state and its inputs (time
    only stamps events and brings a pending disambiguation due): an update that changes the state
    also checks whether the same raw signal and trigger count would change it again, and records
    the answer; the following updates with those inputs (and no disambiguation due) end at once,
    writing nothing, so that Drake rewrites no state at such a tick.

    Attributes:
        config: The :class:`~drake_disamb.interfaces.InterfaceConfig`.
        n_goals: The number of goals a request's belief and goal poses cover.
        modes: All control modes as lists of dimension indices (0..5 = vx..wz, 6 = gripper);
            the gripper mode is the last entry.
        arm_modes: ``modes`` without the gripper mode (what the disambiguation system indexes).
        raw_layout: The names of the raw entries.
    """

    _NO_TRIGGER = -1.0
    """The stable record's trigger count when ``automatic_request_count`` is unconnected (a count is
    never negative, and a negative one starts nothing, as no trigger does)."""

    _NOT_STABLE = np.array([0.0, *[np.nan] * RAW_SIZE, np.nan, -1.0])
    """The stable record of a state whose next update has not been checked."""

    def __init__(self, config: InterfaceConfig, n_goals: int = 1) -> None:
        super().__init__()
        assert isinstance(config, InterfaceConfig), config  # a config checks itself when made
        assert isinstance(n_goals, int | np.integer) and n_goals >= 1, n_goals
        self.config = config
        self.n_goals = int(n_goals)
        self.modes: list[list[int]] = [list(m) for m in config.modes]
        self.arm_modes: list[list[int]] = [list(m) for m in config.arm_modes]
        self.raw_layout: tuple[str, ...] = config.raw_layout
        self.set_name(config.kind)

        initial = initial_state(config)
        n = self.n_goals
        self._state_index = self.DeclareDiscreteState(initial.to_vector())
        self._log_index = self.DeclareAbstractState(AbstractValue.Make(EventLog()))
        # Every vector output is a copy of state, so each gets its own discrete group, written by
        # the same update as the main group, and a state output port (no Python on evaluation).
        self._output_groups = {
            name: self.DeclareDiscreteState(value) for name, value in self._output_values(initial).items()
        }
        self._request_index = self.DeclareDiscreteState(LatchedRequest.none(n).to_vector())
        self._stable_index = self.DeclareDiscreteState(self._NOT_STABLE)

        self._raw_port = self.DeclareVectorInputPort("raw", RAW_SIZE)
        self._request_inputs = (
            self.DeclareVectorInputPort("belief", n),
            self.DeclareVectorInputPort("ee_pose", POSE_SIZE),
            self.DeclareVectorInputPort("goal_poses", n * POSE_SIZE),
        )
        self._answer_port = self.DeclareVectorInputPort("answer", 2)
        self._automatic_port = self.DeclareVectorInputPort("automatic_request_count", 1)

        for name, group in self._output_groups.items():
            self.DeclareStateOutputPort(name, group)
        self.DeclareStateOutputPort("request", self._request_index)
        self.DeclareStateOutputPort("event_log", self._log_index)
        self.DeclarePeriodicUnrestrictedUpdateEvent(config.control_period, 0.0, self._update)

    # -- helpers ---------------------------------------------------------------------------------

    def _read_state(self, context: Context) -> InterfaceState:
        return InterfaceState.from_vector(context.get_discrete_state(self._state_index).get_value())

    def set_mode(self, context: Context, mode: int) -> None:
        """Set the current mode in ``context`` (e.g. a randomised initial mode)."""
        if not (isinstance(mode, int | np.integer) and 0 <= mode < len(self.modes)):
            raise ValueError(f"mode: expected an integer in [0, {len(self.modes) - 1}], got {mode!r}")
        state = replace(self._read_state(context), mode=int(mode))
        discrete = context.get_mutable_discrete_state()
        self._write(state, discrete)
        discrete.get_mutable_vector(self._stable_index).SetFromVector(self._NOT_STABLE)

    def get_event_log(self, context: Context) -> EventLog:
        """The events logged so far in ``context`` (an immutable tuple)."""
        return context.get_abstract_state(self._log_index).get_value()

    # -- update and outputs ------------------------------------------------------------------------

    def _update(self, context: Context, state: State) -> EventStatus:
        raw = self._raw_port.Eval(context)
        automatic = (
            float(self._automatic_port.Eval(context)[0]) if self._automatic_port.HasValue(context) else None
        )
        trigger = self._NO_TRIGGER if automatic is None else automatic
        # The common period: the same raw signal and trigger count as an update that was found to
        # leave the state as it is, and no disambiguation due. It ends here (before the state is
        # even read).
        stable = context.get_discrete_state(self._stable_index).get_value()
        known, *known_raw, known_trigger, due = stable.tolist()
        if (
            known
            and known_trigger == trigger
            and known_raw == raw.tolist()
            and not disambiguation_due(due, context.get_time())
        ):
            return DID_NOTHING
        time = context.get_time()
        vector = context.get_discrete_state(self._state_index).get_value()
        before = InterfaceState.from_vector(vector)
        answer = None
        if self._answer_port.HasValue(context):
            request_id, choice = self._answer_port.Eval(context)
            answer = Answer(float(request_id), float(choice))

        def warn(message: str) -> None:
            warnings.warn(f"{self.get_name()}: {message}", RuntimeWarning, stacklevel=2)

        after, events = interface_update(before, raw, time, self.config, answer, warn, automatic)
        # ``state`` starts as a copy of the current state: only what changed is written.
        discrete = state.get_mutable_discrete_state()
        after_vector = after.to_vector()
        changed = not np.array_equal(after_vector, vector)
        if changed:
            self._write(after, discrete, after_vector)
        if after.started_count > before.started_count:
            self._latch(context, after, events, discrete)
        if events:
            log = context.get_abstract_state(self._log_index).get_value()
            state.get_mutable_abstract_state(self._log_index).set_value(EventLog((*log, *events)))
        if changed or events:  # would the same inputs change the new state again?
            again, more = interface_update(after, raw, time, self.config, answer, None, automatic)
            settled = not more and np.array_equal(again.to_vector(), after_vector)
        else:
            settled = True
        record = np.array([1.0 if settled else 0.0, *raw, trigger, after.pending_due])
        if not (changed or events) and record.tobytes() == stable.tobytes():
            # Nothing written: the simulator then leaves the context (and every cached value) alone.
            return DID_NOTHING
        discrete.get_mutable_vector(self._stable_index).SetFromVector(record)
        return EventStatus.Succeeded()

    def _latch(
        self, context: Context, after: InterfaceState, events: list[InterfaceEvent], discrete: DiscreteValues
    ) -> None:
        """Write the request that this update started into the ``request`` group: its id, the
        request inputs now (NaN where unconnected) and the mode it was made in."""
        values = [
            port.Eval(context) if port.HasValue(context) else np.full(port.size(), np.nan)
            for port in self._request_inputs
        ]
        # The mode after this update's manual switch: before the answer, if one was applied at once.
        applied = [e for e in events if e.kind in ("disambiguation_switch", "automatic_switch")]
        mode = applied[0].from_mode if applied else after.mode
        request = LatchedRequest(float(after.started_count), *values, float(mode))
        discrete.get_mutable_vector(self._request_index).SetFromVector(request.to_vector())

    def _output_values(self, state: InterfaceState) -> dict[str, list[float]]:
        """The value of every vector output port for ``state`` (port name -> vector)."""
        u_h, gripper = command_from_raw(state.held_raw, state.mode, self.config)
        return {
            "u_h": u_h.tolist(),
            "gripper_command": [gripper],
            "mode": [float(state.mode)],
            "mode_switch_count": [float(state.mode_switch_count)],
            "request_count": [float(state.request_count)],
            "nonfinite_count": [float(state.nonfinite_count)],
            "served_count": [float(state.served_count)],
            "paused": [1.0 if state.pending_due >= 0.0 else 0.0],
        }

    def _write(self, state: InterfaceState, discrete_state: DiscreteValues, vector=None) -> None:  # noqa: ANN001
        """Write ``state`` (and its ``vector``, if already computed) and every output group."""
        vector = state.to_vector() if vector is None else vector
        discrete_state.get_mutable_vector(self._state_index).SetFromVector(vector)
        for name, value in self._output_values(state).items():
            discrete_state.get_mutable_vector(self._output_groups[name]).SetFromVector(value)


def make_interface(config: InterfaceConfig | str, n_goals: int = 1, **overrides: object) -> InterfaceSystem:
    """The interface system of ``config`` (or of the registered kind named ``config``, with its
    defaults) latching requests over ``n_goals`` goals, with ``overrides`` of
    :class:`~drake_disamb.interfaces.InterfaceConfig` fields; named after its kind."""
    cfg = InterfaceConfig(kind=config) if isinstance(config, str) else config
    if not isinstance(cfg, InterfaceConfig):
        raise ValueError(f"config: expected an InterfaceConfig or an interface name, got {config!r}")
    return InterfaceSystem(replace(cfg, **overrides) if overrides else cfg, n_goals)
