"""State lives in the Context: one diagram serves any number of Contexts and Simulators at once.

No System object keeps a value computed from a Context (the systems' memos of their last inputs
were such values, shared by every Context); the tests step one diagram in two Contexts, with two
Simulators, interleaved, and compare with the two run one after the other; and a trial solves each
disambiguation request once.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator
from pydrake.systems.framework import Diagram

from drake_disamb.builder import SharedControlDiagram, build_shared_control_diagram
from drake_disamb.config import load_scenario


def _scenario(duration: float = 3.0, request_instead_prob: float = 0.5):  # type: ignore[no-untyped-def]
    """Reaching goal 1, with requests that take 0.3 s and pause the loop, and a user whose waits
    and whose requests instead of mode switches are drawn (seeded: the draws counter is state)."""
    s = load_scenario("reaching")
    s.user.goals = [1]
    s.user.config.reaction_time_jitter = 0.05
    s.user.config.request_instead_prob = request_instead_prob
    return dataclasses.replace(
        s,
        duration=duration,
        disambiguation=dataclasses.replace(s.disambiguation, request_latency=0.3, hold_while_computing=True),
    )


def _leaf_systems(diagram: Diagram) -> list:  # type: ignore[type-arg]
    out = []
    for system in diagram.GetSystems():
        out += _leaf_systems(system) if isinstance(system, Diagram) else [system]
    return out


def _attributes(system: object) -> dict[str, object]:
    """What a system object holds: each attribute's identity, and an array's bytes too."""
    return {
        name: (id(value), value.tobytes() if isinstance(value, np.ndarray) else None)
        for name, value in vars(system).items()
    }


def _context(handles: SharedControlDiagram, variant: int):  # type: ignore[no-untyped-def]
    """A root context; ``variant`` 1 starts in another mode with other draws of the user."""
    context = handles.diagram.CreateDefaultContext()
    handles.initialize(context)
    if variant:
        interface = handles.systems["interface"]
        interface.set_mode(interface.GetMyMutableContextFromRoot(context), 3)
        user = handles.systems["user"]
        sub = user.GetMyMutableContextFromRoot(context)
        state = dataclasses.replace(user.get_user_state(sub), draws=1000)
        sub.SetDiscreteState(0, state.to_vector())  # the user's first group: its UserState
    return context


def _simulator(handles: SharedControlDiagram, context) -> Simulator:  # type: ignore[no-untyped-def]
    simulator = Simulator(handles.diagram, context)
    ApplySimulatorConfig(handles.config.simulator, simulator)
    simulator.Initialize()
    return simulator


def _trajectory(handles: SharedControlDiagram, context) -> dict[str, object]:  # type: ignore[no-untyped-def]
    """Everything a run leaves in its context: the logs, the event log and the final state."""
    interface = handles.systems["interface"]
    out: dict[str, object] = {
        "events": interface.get_event_log(interface.GetMyContextFromRoot(context)),
        "x": context.get_continuous_state_vector().CopyToVector(),
    }
    for i in range(context.num_discrete_state_groups()):
        out[f"xd{i}"] = context.get_discrete_state(i).CopyToVector()
    for name, logger in handles.loggers.items():
        log = logger.FindLog(context)
        out[f"{name} times"], out[name] = log.sample_times().copy(), log.data().copy()
    return out


def test_two_contexts_interleaved_give_the_runs_of_each_alone() -> None:
    handles = build_shared_control_diagram(_scenario())
    end = handles.scenario.duration
    stops = np.round(np.arange(0.07, end + 0.07, 0.07).clip(max=end), 10)  # the same steps for all
    alone = []
    for variant in (0, 1):
        context = _context(handles, variant)
        simulator = _simulator(handles, context)
        for t in stops:
            simulator.AdvanceTo(t)
        alone.append(_trajectory(handles, context))
    assert alone[0]["events"] != alone[1]["events"]  # two different runs
    contexts = [_context(handles, 0), _context(handles, 1)]
    simulators = [_simulator(handles, c) for c in contexts]
    for t in stops:  # a bit of A, the same of B, ...
        for simulator in simulators:
            simulator.AdvanceTo(t)
    for context, expected in zip(contexts, alone, strict=True):
        got = _trajectory(handles, context)
        assert got.keys() == expected.keys()
        assert got.pop("events") == expected["events"]
        for key, value in got.items():
            np.testing.assert_array_equal(value, expected[key], err_msg=key)  # NaN equals NaN
    requests = [sum(e.kind == "disambiguation_request" for e in run["events"]) for run in alone]  # type: ignore[attr-defined]
    assert requests[0] >= 1 and requests[1] >= 2  # the request path ran in both


def test_simulating_changes_no_system_object() -> None:
    """Two simulations of one diagram leave every system object as it was: values computed from a
    Context live in that Context (state, cache entries), never on the system."""
    handles = build_shared_control_diagram(_scenario(duration=2.0))
    leaves = _leaf_systems(handles.diagram)
    before = [_attributes(system) for system in leaves]
    for variant in (0, 1):
        _simulator(handles, _context(handles, variant)).AdvanceTo(handles.scenario.duration)
    changed = [
        f"{system.get_name()}.{name}"
        for system, was in zip(leaves, before, strict=True)
        for name, value in _attributes(system).items()
        if was.get(name) != value
    ]
    assert changed == []


def test_a_trial_solves_each_request_once(monkeypatch: pytest.MonkeyPatch) -> None:
    from drake_disamb.trial import run_trial

    handles = build_shared_control_diagram(_scenario(duration=2.0, request_instead_prob=1.0))
    disambiguation = handles.systems["disambiguation"]
    calls = []
    select = disambiguation.method.select

    def counted(request):  # type: ignore[no-untyped-def]
        calls.append(request)
        return select(request)

    monkeypatch.setattr(disambiguation.method, "select", counted)
    result = run_trial(handles, progress=False, stop_at_success=False)
    assert result.requests >= 2
    assert len(calls) == result.requests  # every press started one: the user waits while paused
    switches = [e for e in result.events if e.kind == "disambiguation_switch"]
    presses = [e.time for e in result.events if e.kind == "disambiguation_request"]
    for switch in switches:  # each switch comes the latency after its press
        assert min(abs(switch.time - 0.3 - t) for t in presses) < 1e-6
