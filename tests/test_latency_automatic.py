"""Request latency, the Automatic paradigm's trigger and the mode-selection method option: the core
functions, the LeafSystems driven in isolation with fixed inputs, the scenario checks and closed-loop
trials."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from drake_disamb.config import load_scenario, resolve_scenario
from drake_disamb.core.automatic import AutomaticConfig, TriggerState, automatic_trigger_update
from drake_disamb.core.disambiguation import select_disambiguating_mode
from drake_disamb.interfaces import (
    Answer,
    InterfaceConfig,
    InterfaceState,
    initial_state,
    interface_update,
)
from drake_disamb.interfaces.system import make_interface
from drake_disamb.systems.disambiguation import AutomaticTrigger, DisambiguationSystem, LatchedRequest
from drake_disamb.systems.loop import ControlLoop

DT = 0.01
PRESS = [0.0, 0.0, 0.0, 1.0]
IDLE = [0.0, 0.0, 0.0, 0.0]
TRIGGER = AutomaticConfig(confidence_threshold=0.5, dwell_time=0.05, min_interval=0.2)


# ------------------------------------------------------------------------------------------------
# Core: the interface update with a latency
# ------------------------------------------------------------------------------------------------


def _run(config: InterfaceConfig, raws, choice: float = 4.0, automatic=None):  # type: ignore[no-untyped-def]
    """Run the core update over ``raws`` (one per tick), the disambiguation system answering every
    request ``choice`` in the tick it starts (as in a diagram: the next update has the answer);
    returns the states, the events and the times at which a disambiguation was served."""
    state, events, served = initial_state(config), [], []
    states = []
    for k, raw in enumerate(raws):
        t = round(k * DT, 10)
        answer = Answer(float(state.started_count), choice)
        auto = None if automatic is None else automatic[k]
        new_state, new = interface_update(state, raw, t, config, answer, None, auto)
        if new_state.served_count > state.served_count:
            served.append(t)
        state = new_state
        events += new
        states.append(state)
    return states, events, served


def test_latency_zero_switches_in_the_update_after_the_press() -> None:
    states, events, served = _run(InterfaceConfig(kind="head_array"), [PRESS, IDLE, IDLE])
    assert served == [0.01] and [s.mode for s in states] == [0, 4, 4] and states[1].served_count == 1
    assert [s.pending_due for s in states] == [0.0, -1.0, -1.0]
    assert [(e.time, e.kind) for e in events] == [
        (0.0, "disambiguation_request"),
        (0.01, "disambiguation_switch"),
    ]


def test_the_switch_comes_latency_after_the_press_with_the_answer_to_it() -> None:
    cfg = InterfaceConfig(kind="head_array", request_latency=0.05)
    raws = [IDLE, PRESS, IDLE, PRESS, IDLE, IDLE, IDLE, IDLE, IDLE]
    states, events, served = _run(cfg, raws)
    # Pressed at 0.01: switched at 0.06 (the first update >= 0.01 + 0.05), not before.
    assert served == [0.06]
    assert [s.mode for s in states] == [0, 0, 0, 0, 0, 0, 4, 4, 4]
    assert states[1].pending_due == pytest.approx(0.06) and states[6].pending_due == -1.0
    # The second press (0.03, during the wait) is a request, but starts nothing.
    assert [(e.time, e.kind) for e in events] == [
        (0.01, "disambiguation_request"),
        (0.03, "disambiguation_request"),
        (0.06, "disambiguation_switch"),
    ]
    assert states[-1].request_count == 2 and states[-1].served_count == 1


def test_a_due_request_waits_for_its_answer() -> None:
    cfg = InterfaceConfig(kind="head_array", request_latency=0.02)
    state, _ = interface_update(initial_state(cfg), PRESS, 0.0, cfg, Answer(0.0, -1.0))
    for t in (0.02, 0.03):  # due, but the answer is to an earlier request: still pending
        state, events = interface_update(state, IDLE, t, cfg, Answer(0.0, 3.0))
        assert events == [] and state.pending_due == pytest.approx(0.02) and state.mode == 0
    state, events = interface_update(state, IDLE, 0.04, cfg, Answer(1.0, 3.0))
    assert state.mode == 3 and state.pending_due == -1.0
    assert [(e.time, e.kind) for e in events] == [(0.04, "disambiguation_switch")]


def test_a_manual_switch_during_the_wait_is_applied_and_the_choice_can_keep_it() -> None:
    cfg = InterfaceConfig(kind="head_array", request_latency=0.03)
    back = [0.0, 0.0, 1.0, 0.0]
    # Press at 0, mode button at 0.01 (0 -> 1); the answer served at 0.03 is mode 1: nothing to switch.
    states, events, served = _run(cfg, [PRESS, back, IDLE, IDLE, IDLE], choice=1.0)
    assert served == [0.03] and states[-1].mode == 1 and states[-1].mode_switch_count == 1
    assert [e.kind for e in events] == ["disambiguation_request", "mode_switch"]


def test_requests_not_served_without_serve_requests() -> None:
    cfg = InterfaceConfig(kind="head_array", serve_requests=False)
    states, events, served = _run(cfg, [PRESS, IDLE])
    assert served == [] and states[-1].mode == 0 and states[-1].request_count == 1
    assert [e.kind for e in events] == ["disambiguation_request"]


def test_an_automatic_trigger_switches_without_a_press_after_the_latency() -> None:
    cfg = InterfaceConfig(kind="head_array", request_latency=0.02)
    counts = [0, 1, 1, 2, 2, 2, 2]  # the second trigger (0.03) comes during the wait: dropped
    states, events, served = _run(cfg, [IDLE] * 7, automatic=counts)
    assert served == [0.03]
    assert [(e.time, e.kind, e.from_mode, e.to_mode) for e in events] == [(0.03, "automatic_switch", 0, 4)]
    s = states[-1]
    assert s.request_count == 0 and s.mode_switch_count == 0 and s.served_count == 1 and s.automatic_seen == 2


def test_state_vector_round_trip_with_a_pending_switch() -> None:
    s = InterfaceState(
        mode=2, request_count=1, pending_due=3.25, pending_automatic=1, served_count=4, automatic_seen=2
    )
    back = InterfaceState.from_vector(s.to_vector())
    assert (back.pending_due, back.pending_automatic, back.served_count, back.automatic_seen) == (
        3.25,
        1,
        4,
        2,
    )


@pytest.mark.parametrize("value", [-0.1, math.nan, math.inf, "2"])
def test_interface_config_rejects_a_bad_latency(value: object) -> None:
    with pytest.raises(ValueError, match=r"InterfaceConfig\.request_latency: expected a finite number >= 0"):
        InterfaceConfig(request_latency=value)  # type: ignore[arg-type]


# ------------------------------------------------------------------------------------------------
# Core: the trigger
# ------------------------------------------------------------------------------------------------

LOW = [0.4, 0.3, 0.3]  # max 0.4 < 0.5
HIGH = [0.6, 0.2, 0.2]
MOVE = [0.1, 0, 0, 0, 0, 0]
STILL = [0.0] * 6


def _trigger(sequence, config: AutomaticConfig = TRIGGER, latency: float = 0.0) -> list[float]:  # type: ignore[no-untyped-def]
    """Fire times of the trigger over ``sequence`` = [(belief, u_h, mode), ...], one per tick."""
    state, fired = TriggerState(), []
    for k, (belief, u_h, mode) in enumerate(sequence):
        t = round(k * DT, 10)
        state, f = automatic_trigger_update(state, belief, u_h, mode, t, DT, config, latency)
        if f:
            fired.append(t)
    return fired


def test_trigger_fires_after_the_dwell_then_at_most_once_per_interval() -> None:
    # Low confidence while commanding: dwell 0.05 s = 5 ticks (t = 0 .. 0.04), fires at 0.04; then
    # again 0.2 s later at the earliest.
    assert _trigger([(LOW, MOVE, 0)] * 50) == [0.04, 0.24, 0.44]


def test_the_interval_counts_from_the_switch_when_the_system_takes_time() -> None:
    # With a latency of 0.1 s the switch comes 0.1 s after the trigger; the next trigger
    # min_interval (0.2 s) after the switch at the earliest.
    assert _trigger([(LOW, MOVE, 0)] * 80, latency=0.1) == [0.04, 0.34, 0.64]


def test_trigger_waits_while_confident_or_still_and_restarts_at_a_mode_change() -> None:
    assert _trigger([(HIGH, MOVE, 0)] * 30) == []  # assisted: nothing to do
    assert _trigger([(LOW, STILL, 0)] * 30) == []  # the user is not commanding
    # Pauses neither count nor reset: 3 ticks moving, 10 still, 2 moving -> fires at the 5th moving tick.
    seq = [(LOW, MOVE, 0)] * 3 + [(LOW, STILL, 0)] * 10 + [(LOW, MOVE, 0)] * 2
    assert _trigger(seq) == [0.14]
    # A mode change (the user's own switch) restarts the clock: 4 ticks, switch, 5 more.
    seq = [(LOW, MOVE, 0)] * 4 + [(LOW, MOVE, 1)] * 5
    assert _trigger(seq) == [0.08]
    # Confidence reaching the threshold restarts it too.
    seq = [(LOW, MOVE, 0)] * 4 + [(HIGH, MOVE, 0)] + [(LOW, MOVE, 0)] * 5
    assert _trigger(seq) == [0.09]
    # A non-finite belief is never a reason to switch.
    assert _trigger([([math.nan, 0.5, 0.5], MOVE, 0)] * 30) == []


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (
            {"confidence_threshold": 1.5},
            r"AutomaticConfig\.confidence_threshold: expected a probability in \(0, 1\], got 1\.5",
        ),
        ({"confidence_threshold": 0.0}, r"AutomaticConfig\.confidence_threshold: .* got 0\.0"),
        ({"dwell_time": 0.0}, r"AutomaticConfig\.dwell_time: expected a finite number > 0, got 0\.0"),
        ({"min_interval": -1.0}, r"AutomaticConfig\.min_interval: expected a finite number >= 0, got -1\.0"),
        ({"request_button": 1}, r"AutomaticConfig\.request_button: expected true or false, got 1"),
    ],
)
def test_trigger_config_validation(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        AutomaticConfig(**kwargs)


def test_the_trigger_needs_its_threshold_written_out() -> None:
    with pytest.raises(ValueError, match="confidence_threshold"):
        automatic_trigger_update(TriggerState(), LOW, MOVE, 0, 0.0, DT, AutomaticConfig())


# ------------------------------------------------------------------------------------------------
# Systems in isolation
# ------------------------------------------------------------------------------------------------


def test_automatic_trigger_system_with_fixed_inputs() -> None:
    system = AutomaticTrigger(ControlLoop(3, control_period=DT), TRIGGER)
    names = [system.get_input_port(i).get_name() for i in range(system.num_input_ports())]
    assert names == ["belief", "u_h", "mode"]
    context = system.CreateDefaultContext()
    system.GetInputPort("belief").FixValue(context, LOW)
    system.GetInputPort("u_h").FixValue(context, MOVE)
    system.GetInputPort("mode").FixValue(context, [0.0])
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.035)  # updates at 0 .. 0.03: 4 ticks of dwell
    assert system.GetOutputPort("automatic_request_count").Eval(context)[0] == 0
    simulator.AdvanceTo(0.045)  # the 5th tick (0.04) fires
    assert system.GetOutputPort("automatic_request_count").Eval(context)[0] == 1
    simulator.AdvanceTo(0.235)
    assert system.get_trigger_count(context) == 1  # not again before 0.24
    simulator.AdvanceTo(0.245)
    assert system.get_trigger_count(context) == 2
    system.GetInputPort("belief").FixValue(context, HIGH)
    simulator.AdvanceTo(1.0)
    assert system.get_trigger_count(context) == 2


def test_automatic_trigger_system_asserts_its_resolved_config() -> None:
    # Resolution writes the threshold out and checks the latency (scenario.disambiguation.
    # request_latency: tests/test_bounds.py); the system asserts both.
    with pytest.raises(AssertionError):
        AutomaticTrigger(ControlLoop(3), AutomaticConfig())
    with pytest.raises(AssertionError):
        AutomaticTrigger(ControlLoop(3), TRIGGER, request_latency=-1.0)
    config = resolve_scenario(load_scenario("reaching", "paradigm: automatic")).automatic
    assert config is not None and config.confidence_threshold is not None
    assert AutomaticTrigger(ControlLoop(3), config).config is config


def test_automatic_trigger_system_counts_the_interval_from_the_switch() -> None:
    system = AutomaticTrigger(ControlLoop(3, control_period=DT), TRIGGER, request_latency=0.1)
    context = system.CreateDefaultContext()
    system.GetInputPort("belief").FixValue(context, LOW)
    system.GetInputPort("u_h").FixValue(context, MOVE)
    system.GetInputPort("mode").FixValue(context, [0.0])
    simulator = Simulator(system, context)
    simulator.AdvanceTo(0.045)
    assert system.get_trigger_count(context) == 1  # at 0.04; its switch at 0.14
    simulator.AdvanceTo(0.335)
    assert system.get_trigger_count(context) == 1  # not before 0.34 = 0.14 + min_interval
    simulator.AdvanceTo(0.345)
    assert system.get_trigger_count(context) == 2


class _Interface:
    """A head array stepped tick by tick with fixed inputs; the disambiguation system's answer is
    ``choice`` for every request, given in the tick the request starts (as in a diagram)."""

    def __init__(self, config: InterfaceConfig, choice: float) -> None:
        self.system = make_interface(config)
        self.sim = Simulator(self.system)
        self.ctx = self.sim.get_mutable_context()
        self.choice = choice
        self.system.GetInputPort("answer").FixValue(self.ctx, [0.0, -1.0])
        self.system.GetInputPort("raw").FixValue(self.ctx, IDLE)
        self.system.GetInputPort("automatic_request_count").FixValue(self.ctx, [0.0])
        self.sim.Initialize()
        self.k = 0

    def tick(self, raw, automatic: float = 0.0) -> None:  # type: ignore[no-untyped-def]
        self.system.GetInputPort("raw").FixValue(self.ctx, np.asarray(raw, dtype=float))
        self.system.GetInputPort("automatic_request_count").FixValue(self.ctx, [automatic])
        self.sim.AdvanceTo(self.k * DT + 0.5 * DT)
        self.k += 1
        request = self.system.GetOutputPort("request").Eval(self.ctx)[0]
        self.system.GetInputPort("answer").FixValue(self.ctx, [request, self.choice])

    def out(self, name: str) -> float:
        return float(self.system.GetOutputPort(name).Eval(self.ctx)[0])

    def log(self) -> list[tuple[float, str]]:
        return [(round(e.time, 6), e.kind) for e in self.system.get_event_log(self.ctx)]


def test_interface_system_switches_latency_after_the_press() -> None:
    d = _Interface(InterfaceConfig(kind="head_array", request_latency=0.04), choice=3.0)
    assert d.out("paused") == 0
    d.tick(PRESS)  # t = 0
    for _ in range(3):
        d.tick(IDLE)  # 0.01 .. 0.03
        assert d.out("mode") == 0 and d.out("served_count") == 0 and d.out("request_count") == 1
        assert d.out("paused") == 1  # being computed
    d.tick(IDLE)  # 0.04
    assert d.out("mode") == 3 and d.out("served_count") == 1
    assert d.out("paused") == 0
    assert d.log() == [(0.0, "disambiguation_request"), (0.04, "disambiguation_switch")]


def test_interface_system_logs_an_automatic_switch() -> None:
    d = _Interface(InterfaceConfig(kind="head_array"), choice=2.0)
    d.tick(IDLE)
    d.tick(IDLE, automatic=1.0)  # the trigger's count grew: a disambiguation starts (latency 0)
    assert d.out("paused") == 1 and d.out("mode") == 0
    d.tick(IDLE, automatic=1.0)  # no new trigger; the answer is applied
    assert d.out("mode") == 2 and d.out("request_count") == 0 and d.out("mode_switch_count") == 0
    assert d.out("served_count") == 1
    assert d.log() == [(0.02, "automatic_switch")]


IDENTITY = [1.0, 0.0, 0.0, 0.0]
GOAL_POSES = np.array([[0.2, -0.25, 0.1, *IDENTITY], [0.25, 0.2, 0.15, *IDENTITY]])
EE_POSE = np.array([0.0, 0.0, 0.1, *IDENTITY])


@pytest.mark.parametrize("method", ["entropy", "kl"])
def test_disambiguation_system_runs_the_chosen_method(method: str) -> None:
    modes = [[0], [1], [2], [3], [4], [5]]
    system = DisambiguationSystem(ControlLoop(2), modes, method=method)
    assert system.method.name == method
    context = system.CreateDefaultContext()
    belief = np.array([0.55, 0.45])
    request = LatchedRequest(1.0, belief, EE_POSE, GOAL_POSES.ravel(), 5.0)
    system.GetInputPort("request").FixValue(context, request.to_vector())
    Simulator(system, context).AdvanceTo(0.005)  # the update at t = 0 answers it
    result = system.get_last_result(context)
    assert result is not None and result.method == method
    expected = select_disambiguating_mode(
        method, belief, EE_POSE[:3], GOAL_POSES[:, :3], modes, current_mode=5
    )
    np.testing.assert_allclose(result.mode_scores, expected.mode_scores, rtol=1e-12)
    answer = system.GetOutputPort("answer").Eval(context)
    assert answer.tolist() == [1.0, -1.0 if result.mode is None else result.mode]


def test_disambiguation_system_rejects_an_unknown_method() -> None:
    with pytest.raises(
        ValueError, match=r"mode-selection method: expected one of algorithm1, entropy, kl, got 'fisher'"
    ):
        DisambiguationSystem(ControlLoop(2), [[0], [1]], method="fisher")


# ------------------------------------------------------------------------------------------------
# Scenario fields
# ------------------------------------------------------------------------------------------------


def test_scenario_fields_resolve() -> None:
    s = load_scenario("reaching")
    c = resolve_scenario(s)
    assert c.disambiguation_method.name == "algorithm1" and c.automatic is None
    assert c.interface.request_latency == 0.0 and c.interface.serve_requests
    s.paradigm = "automatic"
    s.disambiguation.method = "kl"
    s.disambiguation.request_latency = 2.25
    s.disambiguation.automatic.request_button = False
    c = resolve_scenario(s)
    assert c.disambiguation_method.name == "kl" and c.interface.request_latency == 2.25
    assert c.automatic is not None and c.automatic.confidence_threshold == c.rhos[0]  # rho1 by default
    assert not c.interface.serve_requests and c.disambiguation is not None
    s.disambiguation.automatic.confidence_threshold = 0.5
    assert resolve_scenario(s).automatic.confidence_threshold == 0.5


def test_the_simulated_user_asks_only_in_the_disambiguation_paradigm() -> None:
    s = load_scenario("reaching")
    asks = resolve_scenario(s).user.requests
    assert asks.request_at_start and asks.request_when_unhelped_for is not None
    for paradigm in ("manual", "automatic"):  # no button / the system switches by itself
        s.paradigm = paradigm
        user = resolve_scenario(s).user.requests
        assert not user.request_at_start and user.request_when_unhelped_for is None
        assert user.request_instead_prob == 0.0


@pytest.mark.parametrize(
    ("path", "value", "message"),
    [
        (
            "disambiguation.request_latency",
            -1.0,
            r"scenario\.disambiguation\.request_latency: expected a number of seconds in \[0, 60\], got -1\.0",  # noqa: E501
        ),
        (
            "disambiguation.request_latency",
            math.nan,
            r"scenario\.disambiguation\.request_latency: expected a finite number, got nan",
        ),
        ("disambiguation.method", "fisher", r"scenario\.disambiguation\.method: expected one of .*'fisher'"),
        ("paradigm", "auto", r"scenario\.paradigm: expected one of .*'auto'"),
        (
            "disambiguation.automatic.dwell_time",
            0.0,
            r"scenario\.disambiguation\.automatic: AutomaticConfig\.dwell_time: .* got 0\.0",
        ),
        (
            "disambiguation.automatic.confidence_threshold",
            1.5,
            r"scenario\.disambiguation\.automatic: .*confidence_threshold.* got 1\.5",
        ),
    ],
)
def test_scenario_errors_name_field_and_value(path: str, value: object, message: str) -> None:
    s = load_scenario("reaching")
    s.paradigm = "automatic"
    *parents, leaf = path.split(".")
    target = s
    for name in parents:
        target = getattr(target, name)
    setattr(target, leaf, value)
    with pytest.raises(ValueError, match=message):
        resolve_scenario(s)


# ------------------------------------------------------------------------------------------------
# Closed loop
# ------------------------------------------------------------------------------------------------


def _silent_user(task: str = "reaching"):  # type: ignore[no-untyped-def]
    s = load_scenario(task)
    s.user.config.request_at_start = False
    s.user.config.request_when_unhelped_for = None
    return s


def test_automatic_paradigm_trial_succeeds_with_automatic_switches() -> None:
    from drake_disamb.trial import run_trial

    s = _silent_user()
    s.paradigm = "automatic"
    s.user.goals = [3]
    s.initial_mode = 1
    s.disambiguation.automatic.confidence_threshold = 0.5
    r = run_trial(s, progress=False)
    assert r.success
    assert r.automatic_switches >= 1 and r.requests == 0
    auto = [e for e in r.events if e.kind == "automatic_switch"]
    assert [e.time for e in auto] == r.automatic_switch_times
    assert all(e.from_mode != e.to_mode for e in auto)
    # The user's own presses only: the automatic switches are not among them.
    assert r.mode_switches == sum(e.kind == "mode_switch" for e in r.events)
    assert r.button_presses == r.mode_switches
    assert np.all(np.diff(r.automatic_switch_times) >= 4.0 - 1e-9)  # min_interval (no latency here)


def test_request_latency_in_a_trial() -> None:
    from drake_disamb.trial import run_trial

    s = load_scenario("reaching")  # the embedded user asks at the start
    s.disambiguation.request_latency = 2.0
    r = run_trial(s, progress=False)
    assert r.request_times[0] == pytest.approx(0.01)
    assert r.disambiguation_switch_times[0] == pytest.approx(2.01)
    assert r.automatic_switches == 0 and r.automatic_switch_times == []


@pytest.mark.parametrize("hold", [True, False])
def test_hold_while_computing_pauses_the_loop_in_a_diagram(hold: bool) -> None:
    """With ``disambiguation.hold_while_computing`` the belief is held and the arm is sent nothing
    from the request press to its switch (the study's system); without it both go on."""
    import dataclasses

    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.trial import run_trial

    s = load_scenario("reaching")
    s = dataclasses.replace(
        s,
        paradigm="disambiguation",
        duration=2.5,
        disambiguation=dataclasses.replace(s.disambiguation, request_latency=1.0, hold_while_computing=hold),
        blending=dataclasses.replace(s.blending, assist_without_input=True),
    )
    handles = build_shared_control_diagram(s)
    result = run_trial(handles, progress=False, stop_at_success=False)
    presses = [e.time for e in result.events if e.kind == "disambiguation_request"]
    assert presses, "the simulated user asks at the start"
    t, belief = result.logs["belief"]
    _, u = result.logs["u"]
    window = (t > presses[0] + 0.05) & (t < presses[0] + 0.95)
    assert window.sum() > 50
    still = np.ptp(belief[window], axis=0).max()
    if hold:
        assert still == 0.0
        assert not np.any(u[window])
    else:
        assert still > 1e-6  # the belief relaxes (or follows the command) meanwhile
