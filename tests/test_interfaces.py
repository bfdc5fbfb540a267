"""Interfaces: core update logic and the joystick / head-array systems in isolation."""

from __future__ import annotations

import numpy as np
import pytest

from drake_disamb.core.layout import GRIPPER_DIM
from drake_disamb.interfaces import (
    Answer,
    InterfaceConfig,
    InterfaceState,
    command_from_raw,
    initial_state,
    interface_update,
    sanitize_raw,
)
from drake_disamb.interfaces.kinds.joystick import DIRECT_SELECT_DEFLECTION, sector_mode, sector_stick

DT = 0.01

# ---------------------------------------------------------------------------------------------
# core
# ---------------------------------------------------------------------------------------------


def test_mode_lists() -> None:
    joy = InterfaceConfig(kind="joystick")
    head = InterfaceConfig(kind="head_array")
    assert joy.modes == ((0, 1), (0, 2), (3, 5), (4,), (GRIPPER_DIM,))
    assert head.modes == tuple((d,) for d in range(7))
    assert joy.arm_modes == joy.modes[:-1] and head.arm_modes == head.modes[:-1]
    assert (joy.max_linear_speed, joy.max_angular_speed) == (0.13, 0.4)
    assert (head.max_linear_speed, head.max_angular_speed) == (0.1, 0.2)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"kind": "trackball"}, "kind"),
        ({"kind": "joystick", "initial_mode": 5}, "initial_mode"),
        ({"kind": "head_array", "initial_mode": -1}, "initial_mode"),
        ({"max_linear_speed": 0.0}, "max_linear_speed"),
        ({"max_angular_speed": float("inf")}, "max_angular_speed"),
        ({"control_period": -0.01}, "control_period"),
        ({"button_threshold": 0.0}, "button_threshold"),
    ],
)
def test_config_validation(kwargs: dict, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        InterfaceConfig(**kwargs)


def test_state_vector_round_trip() -> None:
    s = InterfaceState(3, 1.0, 0.0, 7, 2, 1, np.array([0.5, -1.0, 1.0, 0.0]))
    back = InterfaceState.from_vector(s.to_vector())
    assert back == s
    np.testing.assert_array_equal(back.held_raw, s.held_raw)
    with pytest.raises(ValueError, match="InterfaceState"):
        InterfaceState.from_vector(np.zeros(3))


def test_sanitize_raw() -> None:
    joy = InterfaceConfig(kind="joystick")
    clean, bad = sanitize_raw([2.0, np.nan, 0.7, np.inf], joy)
    np.testing.assert_array_equal(clean, [1.0, 0.0, 1.0, 0.0])
    assert bad
    clean, bad = sanitize_raw([-3.0, 0.25, 0.2, 1.0], joy)
    np.testing.assert_array_equal(clean, [-1.0, 0.25, 0.0, 1.0])
    assert not bad
    head = InterfaceConfig(kind="head_array")
    clean, _ = sanitize_raw([0.9, 0.1, 1, 0], head)
    np.testing.assert_array_equal(clean, [1, 0, 1, 0])
    with pytest.raises(ValueError, match="raw"):
        sanitize_raw([0, 0, 0], joy)


def test_joystick_commands_per_mode() -> None:
    joy = InterfaceConfig(kind="joystick")
    raw = np.array([0.5, -1.0, 0.0, 0.0])
    u, g = command_from_raw(raw, 0, joy)  # {vx, vy}
    np.testing.assert_allclose(u, [0.065, -0.13, 0, 0, 0, 0])
    assert g == 0.0
    u, _ = command_from_raw(raw, 1, joy)  # {vx, vz}
    np.testing.assert_allclose(u, [0.065, 0, -0.13, 0, 0, 0])
    u, _ = command_from_raw(raw, 2, joy)  # {wx, wz}
    np.testing.assert_allclose(u, [0, 0, 0, 0.2, 0, -0.4])
    u, _ = command_from_raw(raw, 3, joy)  # {wy}: axis_x only
    np.testing.assert_allclose(u, [0, 0, 0, 0, 0.2, 0])
    u, g = command_from_raw(raw, 4, joy)  # gripper
    np.testing.assert_allclose(u, 0.0)
    assert g == pytest.approx(0.5 * joy.gripper_speed)


def test_head_array_commands_per_mode() -> None:
    head = InterfaceConfig(kind="head_array")
    for mode in range(6):
        u, g = command_from_raw(np.array([1.0, 0, 0, 0]), mode, head)
        expected = np.zeros(6)
        expected[mode] = 0.1 if mode < 3 else 0.2
        np.testing.assert_allclose(u, expected)
        u, _ = command_from_raw(np.array([0, 1.0, 0, 0]), mode, head)
        np.testing.assert_allclose(u, -expected)
        assert g == 0.0
    u, _ = command_from_raw(np.array([1.0, 1.0, 0, 0]), 0, head)  # both switches cancel
    np.testing.assert_allclose(u, 0.0)
    u, g = command_from_raw(np.array([0, 1.0, 0, 0]), 6, head)  # gripper closes
    np.testing.assert_allclose(u, 0.0)
    assert g == -head.gripper_speed


def test_core_update_a_request_is_served_when_its_answer_comes() -> None:
    cfg = InterfaceConfig(kind="head_array", initial_mode=0)
    none = Answer(0.0, -1.0)  # the disambiguation system has answered nothing yet
    s = initial_state(cfg)
    s, ev = interface_update(s, [0, 0, 0, 1], 0.0, cfg, none)
    assert s.mode == 0 and s.request_count == 1 and s.started_count == 1 and s.pending_due == 0.0
    assert [e.kind for e in ev] == ["disambiguation_request"]
    s, ev = interface_update(s, [0, 0, 0, 1], DT, cfg, Answer(2.0, 3.0))  # another request's answer
    assert ev == [] and s.mode == 0 and s.pending_due == 0.0 and s.served_count == 0
    s, ev = interface_update(s, [0, 0, 0, 1], 2 * DT, cfg, Answer(1.0, 4.0))  # its own
    assert s.mode == 4 and s.served_count == 1 and s.pending_due == -1.0 and s.started_count == 1
    assert [(e.time, e.kind, e.from_mode, e.to_mode) for e in ev] == [(2 * DT, "disambiguation_switch", 0, 4)]
    for k in range(3, 6):  # held: no new request, and the answer is not applied again
        s, ev = interface_update(s, [0, 0, 0, 1], k * DT, cfg, Answer(1.0, 2.0))
        assert ev == [] and s.mode == 4
    assert s.request_count == 1


def test_core_update_invalid_choice_warns_and_keeps_mode() -> None:
    cfg = InterfaceConfig(kind="joystick", initial_mode=1)
    messages: list[str] = []
    s = initial_state(cfg)
    s, ev = interface_update(s, [0, 0, 0, 1], 0.0, cfg, Answer(1.0, 4.0), messages.append)  # 4 = gripper
    assert s.mode == 1 and s.served_count == 1 and [e.kind for e in ev] == ["disambiguation_request"]
    assert len(messages) == 1 and "disambiguation_mode" in messages[0]


# ---------------------------------------------------------------------------------------------
# Systems
# ---------------------------------------------------------------------------------------------


class _Driver:
    """Steps an interface system tick by tick with fixed input values (a Simulator underneath)."""

    def __init__(self, system, answer: tuple[float, float] | None = None) -> None:
        from pydrake.systems.analysis import Simulator

        self.system = system
        self.sim = Simulator(system)
        self.ctx = self.sim.get_mutable_context()
        self.k = 0
        if answer is not None:
            self.answer(*answer)
        system.GetInputPort("raw").FixValue(self.ctx, np.zeros(4))
        self.sim.Initialize()

    def answer(self, request: float, mode: float) -> None:
        """The disambiguation system's answer from now on: ``mode`` for request ``request``."""
        self.system.GetInputPort("answer").FixValue(self.ctx, [request, mode])

    def tick(self, raw) -> None:
        """Hold ``raw`` for one update (the update at time k * DT)."""
        self.system.GetInputPort("raw").FixValue(self.ctx, np.asarray(raw, dtype=float))
        self.sim.AdvanceTo(self.k * DT + 0.5 * DT)
        self.k += 1

    def out(self, name: str):
        return self.system.GetOutputPort(name).Eval(self.ctx)

    def scalar(self, name: str) -> float:
        return float(self.out(name)[0])


def test_joystick_mode_cycling_counts_rising_edges_only() -> None:
    from drake_disamb.interfaces.system import make_interface

    d = _Driver(make_interface("joystick"))
    seen = []
    for _ in range(5):  # press and hold for 3 ticks, release for 2: one switch per press
        for _ in range(3):
            d.tick([0, 0, 1, 0])
        d.tick([0, 0, 0, 0])
        d.tick([0, 0, 0, 0])
        seen.append(int(d.scalar("mode")))
    assert seen == [1, 2, 3, 4, 0]  # cycles through all 5 modes (gripper last) and wraps
    assert d.scalar("mode_switch_count") == 5
    assert d.scalar("request_count") == 0
    log = d.system.get_event_log(d.ctx)
    assert [(e.kind, e.from_mode, e.to_mode) for e in log] == [
        ("mode_switch", 0, 1),
        ("mode_switch", 1, 2),
        ("mode_switch", 2, 3),
        ("mode_switch", 3, 4),
        ("mode_switch", 4, 0),
    ]
    assert [e.time for e in log] == pytest.approx([0.0, 0.05, 0.10, 0.15, 0.20])
    assert d.out("event_log") == log  # the abstract output port carries the same tuple


def test_head_array_back_cycles_seven_modes() -> None:
    from drake_disamb.interfaces.system import make_interface

    d = _Driver(make_interface("head_array", initial_mode=5))
    modes = []
    for _ in range(8):
        d.tick([0, 0, 1, 0])
        d.tick([0, 0, 0, 0])
        modes.append(int(d.scalar("mode")))
    assert modes == [6, 0, 1, 2, 3, 4, 5, 6]
    assert d.scalar("mode_switch_count") == 8


def test_request_switches_mode_when_its_answer_comes() -> None:
    from drake_disamb.interfaces.system import make_interface

    d = _Driver(make_interface("head_array", initial_mode=0), answer=(0.0, -1.0))
    d.tick([1, 0, 0, 1])  # left held and request pressed in the same update
    assert d.scalar("mode") == 0 and d.scalar("paused") == 1  # waiting for the answer
    assert d.scalar("request_count") == 1 and d.scalar("mode_switch_count") == 0
    d.answer(1.0, 4.0)  # what the disambiguation system answers in the press's tick
    d.tick([1, 0, 0, 1])  # still held: no second request; the answer is applied
    assert d.scalar("mode") == 4 and d.scalar("paused") == 0 and d.scalar("served_count") == 1
    np.testing.assert_allclose(d.out("u_h"), [0, 0, 0, 0, 0.2, 0])  # held "left" now drives wy
    assert d.scalar("request_count") == 1
    log = d.system.get_event_log(d.ctx)
    assert [(e.kind, e.from_mode, e.to_mode, round(e.time, 6)) for e in log] == [
        ("disambiguation_request", 0, 0, 0.0),
        ("disambiguation_switch", 0, 4, DT),
    ]


def test_interface_latches_each_request_when_it_starts() -> None:
    """The update that starts a disambiguation latches its belief, poses and mode (after a manual
    switch in the same update) into the ``request`` state; nothing changes it until the next one."""
    from drake_disamb.interfaces.system import make_interface
    from drake_disamb.systems.disambiguation import LatchedRequest

    system = make_interface("head_array", n_goals=2, initial_mode=0, request_latency=0.05)
    d = _Driver(system, answer=(0.0, -1.0))

    def inputs(belief: list[float], x: float) -> None:
        system.GetInputPort("belief").FixValue(d.ctx, belief)
        system.GetInputPort("ee_pose").FixValue(d.ctx, [x, 0.2, 0.3, 1.0, 0.0, 0.0, 0.0])
        system.GetInputPort("goal_poses").FixValue(d.ctx, np.arange(14.0) + x)

    def latched() -> LatchedRequest:
        return LatchedRequest.from_vector(d.out("request"), 2)

    inputs([0.3, 0.7], 0.1)
    assert latched().id == 0.0 and np.isnan(latched().belief).all()  # none yet
    d.tick([0, 0, 1, 1])  # the mode button and the request together: the mode switches first
    first = latched()
    assert (first.id, first.current_mode, first.belief.tolist()) == (1.0, 1.0, [0.3, 0.7])
    np.testing.assert_array_equal(first.ee_pose, [0.1, 0.2, 0.3, 1.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(first.goal_poses, np.arange(14.0) + 0.1)
    inputs([0.9, 0.1], 0.5)  # what the request was made of changes during the wait
    d.tick([0, 0, 0, 0])
    d.tick([0, 0, 0, 1])  # a press during the wait: a request, but it starts nothing
    d.answer(1.0, 4.0)
    np.testing.assert_array_equal(latched().to_vector(), first.to_vector())
    d.tick([0, 0, 0, 0])  # 0.03
    d.tick([0, 0, 0, 0])  # 0.04
    assert d.scalar("mode") == 1 and d.scalar("paused") == 1
    d.tick([0, 0, 0, 0])  # 0.05: due, and answered
    assert d.scalar("mode") == 4 and d.scalar("paused") == 0 and d.scalar("request_count") == 2
    d.tick([0, 0, 0, 1])  # the next request: the inputs of now
    second = latched()
    assert (second.id, second.current_mode, second.belief.tolist()) == (2.0, 4.0, [0.9, 0.1])
    np.testing.assert_array_equal(second.goal_poses, np.arange(14.0) + 0.5)


def test_unconnected_request_inputs_are_latched_as_nan() -> None:
    from drake_disamb.interfaces.system import make_interface
    from drake_disamb.systems.disambiguation import LatchedRequest

    d = _Driver(make_interface("joystick", initial_mode=2), answer=(0.0, -1.0))
    d.tick([0, 0, 0, 1])
    request = LatchedRequest.from_vector(d.out("request"), 1)
    assert request.id == 1.0 and request.current_mode == 2.0
    assert np.isnan(request.to_vector()[1:-1]).all()


def test_request_minus_one_keeps_mode() -> None:
    from drake_disamb.interfaces.system import make_interface

    d = _Driver(make_interface("joystick", initial_mode=2), answer=(0.0, -1.0))
    for request in (1.0, 2.0):
        d.tick([0, 0, 0, 1])
        d.answer(request, -1.0)
        d.tick([0, 0, 0, 0])
        assert d.scalar("served_count") == request and d.scalar("paused") == 0
    assert d.scalar("mode") == 2
    assert d.scalar("request_count") == 2
    assert [e.kind for e in d.system.get_event_log(d.ctx)] == ["disambiguation_request"] * 2


def test_request_without_disambiguation_system_is_logged_only() -> None:
    from drake_disamb.interfaces.system import make_interface

    d = _Driver(make_interface("joystick", initial_mode=3))  # answer left unconnected
    d.tick([0, 0, 0, 1])
    assert d.scalar("mode") == 3 and d.scalar("request_count") == 1
    assert d.scalar("served_count") == 1 and d.scalar("paused") == 0  # no latency: served at once


def test_nonfinite_raw_gives_zero_command() -> None:
    from drake_disamb.interfaces.system import make_interface

    d = _Driver(make_interface("joystick"))
    d.tick([0.5, 0.5, 0, 0])
    np.testing.assert_allclose(d.out("u_h"), [0.065, 0.065, 0, 0, 0, 0])
    with pytest.warns(RuntimeWarning, match="non-finite"):
        d.tick([np.nan, np.inf, np.nan, -np.inf])
    np.testing.assert_array_equal(d.out("u_h"), np.zeros(6))
    assert d.scalar("nonfinite_count") == 1
    assert d.scalar("mode_switch_count") == 0 and d.scalar("request_count") == 0
    d.tick([np.nan, 0.5, 0, 0])  # only the bad axis is zeroed
    np.testing.assert_allclose(d.out("u_h"), [0, 0.065, 0, 0, 0, 0])
    assert d.scalar("nonfinite_count") == 2


def test_speed_limits_and_clipping_are_config_fields() -> None:
    from drake_disamb.interfaces.system import make_interface

    d = _Driver(make_interface("joystick", max_linear_speed=0.05, max_angular_speed=0.3, initial_mode=2))
    d.tick([5.0, -5.0, 0, 0])  # clipped to [1, -1]
    np.testing.assert_allclose(d.out("u_h"), [0, 0, 0, 0.3, 0, -0.3])
    d = _Driver(make_interface("head_array", max_linear_speed=0.07, initial_mode=2))
    d.tick([0, 1, 0, 0])
    np.testing.assert_allclose(d.out("u_h"), [0, 0, -0.07, 0, 0, 0])


def test_gripper_mode_drives_only_the_gripper() -> None:
    from drake_disamb.interfaces.system import make_interface

    d = _Driver(make_interface("joystick", initial_mode=4, gripper_speed=0.03))
    d.tick([-1.0, 1.0, 0, 0])
    np.testing.assert_array_equal(d.out("u_h"), np.zeros(6))
    assert d.scalar("gripper_command") == pytest.approx(-0.03)
    d = _Driver(make_interface("joystick", initial_mode=0))
    d.tick([-1.0, 1.0, 0, 0])
    assert d.scalar("gripper_command") == 0.0


def test_outputs_come_from_state() -> None:
    from drake_disamb.interfaces.system import make_interface

    for system in (make_interface("joystick"), make_interface("head_array", n_goals=3)):
        for j in range(system.num_input_ports()):
            for i in range(system.num_output_ports()):
                assert not system.HasDirectFeedthrough(j, i)
    # The raw signal is only seen after an update.
    system = make_interface("joystick")
    ctx = system.CreateDefaultContext()
    system.GetInputPort("raw").FixValue(ctx, [1.0, 1.0, 0.0, 0.0])
    np.testing.assert_array_equal(system.GetOutputPort("u_h").Eval(ctx), np.zeros(6))


def test_set_mode_and_attributes() -> None:
    from drake_disamb.interfaces.system import make_interface

    joy = make_interface("joystick")
    assert joy.modes == [[0, 1], [0, 2], [3, 5], [4], [6]] and joy.arm_modes == joy.modes[:-1]
    assert joy.raw_layout == ("axis_x", "axis_y", "mode_button", "disambiguation_button")
    ctx = joy.CreateDefaultContext()
    joy.set_mode(ctx, 3)
    assert joy.GetOutputPort("mode").Eval(ctx)[0] == 3
    with pytest.raises(ValueError, match="mode"):
        joy.set_mode(ctx, 5)
    head = make_interface(InterfaceConfig(kind="head_array", initial_mode=6))
    assert head.get_name() == "head_array"
    assert head.GetOutputPort("mode").Eval(head.CreateDefaultContext())[0] == 6
    assert len(head.arm_modes) == 6
    with pytest.raises(ValueError, match="kind: expected one of"):
        make_interface("trackball")
    with pytest.raises(ValueError, match="config"):
        make_interface(3)  # type: ignore[arg-type]


# ---------------------------------------------------------------------------------------------
# direct mode selection (joystick)
# ---------------------------------------------------------------------------------------------


def test_sector_layout_is_clockwise_from_up() -> None:
    # 5 joystick modes, 72 degrees each: {vx,vy} up, {vx,vz} up-right, {wx,wz} down-right,
    # {wy} down-left, gripper up-left; a stick below the deflection threshold selects nothing.
    assert sector_mode(0.0, 1.0, 5) == 0
    assert sector_mode(0.9, 0.3, 5) == 1
    assert sector_mode(0.6, -0.8, 5) == 2
    assert sector_mode(-0.6, -0.8, 5) == 3
    assert sector_mode(-0.9, 0.3, 5) == 4
    assert sector_mode(0.0, DIRECT_SELECT_DEFLECTION * 0.99, 5) is None
    for m in range(5):
        x, y = sector_stick(m, 5)
        assert np.hypot(x, y) == pytest.approx(1.0)
        assert sector_mode(x, y, 5) == m


def _press(state: InterfaceState, axes: tuple[float, float], t: float, config: InterfaceConfig):
    """Press the mode button with the stick at ``axes`` for one tick, then release everything."""
    state, events = interface_update(state, [*axes, 1.0, 0.0], t, config)
    state2, events2 = interface_update(state, [0.0, 0.0, 0.0, 0.0], t + DT, config)
    assert events2 == []
    return state, state2, events


def test_direct_selection_selects_the_sector_mode_with_one_event_per_press() -> None:
    cfg = InterfaceConfig(kind="joystick", mode_selection="direct", initial_mode=0)
    s = initial_state(cfg)
    # Deflected toward {wy} (mode 3): one press, one switch 0 -> 3.
    held, s, events = _press(s, sector_stick(3, 5), 0.0, cfg)
    assert s.mode == 3 and s.mode_switch_count == 1
    assert [(e.kind, e.from_mode, e.to_mode) for e in events] == [("mode_switch", 0, 3)]
    # The stick selected: it does not drive while the button is held.
    assert held.held_raw[:2].tolist() == [0.0, 0.0]
    assert np.all(command_from_raw(held.held_raw, held.mode, cfg)[0] == 0.0)
    # Centred: the press cycles as with "cycle" (3 -> 4).
    _, s, events = _press(s, (0.0, 0.0), 0.1, cfg)
    assert s.mode == 4 and [(e.from_mode, e.to_mode) for e in events] == [(3, 4)]
    # Selecting the current mode keeps it and is still one logged press.
    _, s, events = _press(s, sector_stick(4, 5), 0.2, cfg)
    assert s.mode == 4 and s.mode_switch_count == 3
    assert [(e.kind, e.from_mode, e.to_mode) for e in events] == [("mode_switch", 4, 4)]
    # Held button with the stick moving: still one selection.
    s, events = interface_update(s, [*sector_stick(1, 5), 1.0, 0.0], 0.3, cfg)
    s, more = interface_update(s, [*sector_stick(2, 5), 1.0, 0.0], 0.31, cfg)
    assert s.mode == 1 and len(events) == 1 and more == []


def test_cycle_selection_ignores_the_stick_and_drives_while_pressing() -> None:
    cfg = InterfaceConfig(kind="joystick", initial_mode=0)
    assert cfg.mode_selection == "cycle"
    s, events = interface_update(initial_state(cfg), [*sector_stick(3, 5), 1.0, 0.0], 0.0, cfg)
    assert s.mode == 1 and [(e.from_mode, e.to_mode) for e in events] == [(0, 1)]
    assert s.held_raw[:2].tolist() == pytest.approx(list(sector_stick(3, 5)))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"kind": "joystick", "mode_selection": "sector"}, "InterfaceConfig.mode_selection.*'sector'"),
        ({"kind": "head_array", "mode_selection": "direct"}, "InterfaceConfig.mode_selection.*'direct'"),
    ],
)
def test_mode_selection_validation(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        InterfaceConfig(**kwargs)


# ---------------------------------------------------------------------------------------------
# the registry and the variants
# ---------------------------------------------------------------------------------------------


def test_registry_lists_the_kinds_in_rank_order_and_names_them_in_errors() -> None:
    from drake_disamb.interfaces import INTERFACES, check_kind, interfaces_in

    assert list(INTERFACES)[:2] == ["joystick", "head_array"]
    assert [k.rank for k in INTERFACES.values()] == sorted(k.rank for k in INTERFACES.values())
    assert interfaces_in(["head_array", "joystick", "head_array", "other"]) == ["joystick", "head_array"]
    with pytest.raises(ValueError, match=r"interface kind: expected one of \('joystick', 'head_array'"):
        check_kind("trackball")


def test_a_variant_is_its_device_model_its_affordances_and_its_live_controls() -> None:
    """The three parts of a variant, each in its own module, none holding another's members: the
    update reads the device, the simulated user the affordances, the live page its controls."""
    from drake_disamb.interfaces import INTERFACES
    from drake_disamb.interfaces.affordances import Affordances
    from drake_disamb.interfaces.device import Device
    from drake_disamb.interfaces.live_controls import LiveControls

    parts = {
        Device: {"sanitize", "mode_event", "select", "held", "drives", "modes", "mode_steps", "mode_order"},
        Affordances: {"drive_raw", "is_driving", "step_raw", "change_raw", "request_raw"},
        LiveControls: {"live_controls", "live_axes", "live_help", "pulse_raw"},
    }
    for part, members in parts.items():
        own = set(vars(part)) | set(part.__annotations__)
        assert members <= own, (part, members - own)
        others = set().union(*(m for p, m in parts.items() if p is not part))
        assert not others & own, (part, others & own)
    assert all(isinstance(kind, part) for kind in INTERFACES.values() for part in parts)
    assert {part.__module__ for part in parts} == {
        "drake_disamb.interfaces.device",
        "drake_disamb.interfaces.affordances",
        "drake_disamb.interfaces.live_controls",
    }


@pytest.mark.parametrize("name", ["joystick", "head_array"])
def test_every_kind_drives_steps_and_requests_through_its_own_raw_signal(name: str) -> None:
    """What the simulated user and the live page rely on, read from the variant alone."""
    from drake_disamb.interfaces import INTERFACES

    kind = INTERFACES[name]
    cfg = InterfaceConfig(kind=name)
    assert cfg.variant is kind and cfg.modes == kind.modes and cfg.modes[-1] == (GRIPPER_DIM,)
    assert len(kind.raw_layout) == 4 and kind.raw_layout[-1] == "disambiguation_button"
    assert any(c.role == "request" for c in kind.live_controls) and kind.live_help
    s = initial_state(cfg)
    s, _ = interface_update(s, kind.drive_raw([1.0]), 0.0, cfg)  # drive mode 0 positive
    u, _ = command_from_raw(s.held_raw, s.mode, cfg)
    assert u[kind.modes[0][0]] == pytest.approx(kind.default_speeds[0])
    assert kind.is_driving(kind.drive_raw([-1.0]))
    s, events = interface_update(s, kind.step_raw(1), 0.01, cfg)
    s, more = interface_update(s, np.zeros(4), 0.02, cfg)
    assert s.mode == 1 and [e.kind for e in events + more] == ["mode_switch"]
    s, events = interface_update(s, kind.request_raw(), 0.03, cfg)
    assert [e.kind for e in events] == ["disambiguation_request"]


def test_the_mode_order_is_a_field_of_the_variant() -> None:
    from drake_disamb.interfaces.kinds.head_array import HeadArray

    order = ((0,), (1,), (2,), (5,), (3,), (4,))
    cfg = InterfaceConfig(kind="head_array", variant=HeadArray(mode_order=order))
    assert cfg.modes == (*order, (GRIPPER_DIM,)) and cfg.arm_modes == order
    s, _ = interface_update(initial_state(cfg), [0.0, 0.0, 1.0, 0.0], 0.0, cfg)  # next mode: wz
    s, _ = interface_update(s, [0.0, 0.0, 0.0, 0.0], 0.01, cfg)
    s, _ = interface_update(s, [0.0, 0.0, 1.0, 0.0], 0.02, cfg)
    s, _ = interface_update(s, [0.0, 0.0, 1.0, 0.0], 0.03, cfg)
    s, _ = interface_update(s, [0.0, 0.0, 1.0, 0.0], 0.04, cfg)  # held: one press
    s, _ = interface_update(s, [0.0, 0.0, 0.0, 0.0], 0.05, cfg)
    s, _ = interface_update(s, [0.0, 0.0, 1.0, 0.0], 0.06, cfg)
    s, _ = interface_update(s, [1.0, 0.0, 0.0, 0.0], 0.07, cfg)
    assert s.mode == 3
    u, _ = command_from_raw(s.held_raw, s.mode, cfg)
    assert u.tolist() == [0.0, 0.0, 0.0, 0.0, 0.0, pytest.approx(0.2)]
    assert HeadArray().mode_steps(1, 0) == 6  # forward only: round the cycle


@pytest.mark.parametrize(
    ("order", "message"),
    [
        (((0,), (1,)), "every arm dimension"),
        (((0, 1), (2,), (3,), (4,), (5,)), "1 to 1 arm dimension"),
        (((0,), (0,), (1,), (2,), (3,), (4,), (5,)), "distinct"),
        (((0,), (1,), (2,), (3,), (4,), (6,)), r"\[0, 5\]"),
    ],
)
def test_mode_order_validation(order: tuple, message: str) -> None:
    from drake_disamb.interfaces.kinds.head_array import HeadArray

    with pytest.raises(ValueError, match=rf"HeadArray\.mode_order: .*{message}"):
        HeadArray(mode_order=order)


def test_a_variant_of_another_kind_is_rejected() -> None:
    from drake_disamb.interfaces.kinds.head_array import HeadArray

    with pytest.raises(ValueError, match="InterfaceConfig.variant: expected a joystick variant"):
        InterfaceConfig(kind="joystick", variant=HeadArray())
