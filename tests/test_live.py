"""Live browser input: the page-to-raw mapping, the Meshcat system in isolation, and a live loop."""

from __future__ import annotations

import dataclasses
import struct
from types import SimpleNamespace

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from drake_disamb.interfaces import INTERFACES, InterfaceConfig, initial_state, interface_update
from drake_disamb.interfaces.kinds.joystick import sector_stick
from drake_disamb.interfaces.live import (
    AXIS_SLIDERS,
    PAD_BUTTON_OF_KEY,
    LiveInputConfig,
    LiveState,
    MeshcatLiveInput,
    live_raw_step,
    pad_buttons,
)

HEAD = InterfaceConfig(kind="head_array")
JOY = InterfaceConfig(kind="joystick")


def run(kind: str, events: dict[float, list[int]], until: float, **kwargs) -> list[np.ndarray]:
    """Step :func:`live_raw_step` every 10 ms; ``events`` maps a time to buttons clicked then."""
    state, counts, raws = LiveState(), np.zeros(4), []
    for k in range(int(round(until / 0.01)) + 1):
        t = round(k * 0.01, 10)
        for b in events.get(t, []):
            counts[b] += 1
        state = live_raw_step(state, t, kind, counts, **kwargs)
        raws.append(state.raw.copy())
    return raws


# ---------------------------------------------------------------------------------------------
# the mapping
# ---------------------------------------------------------------------------------------------


def test_head_array_switch_stays_closed_for_the_hold_time_and_the_latest_direction_wins() -> None:
    raws = run("head_array", {0.1: [0], 0.3: [0], 1.5: [0], 1.7: [1]}, 2.5)
    left = np.array([r[0] for r in raws])
    right = np.array([r[1] for r in raws])
    t = np.arange(len(raws)) * 0.01
    # Clicks at 0.1 and 0.3 s keep it closed until 0.3 + 0.6 s.
    np.testing.assert_array_equal(left[(t >= 0.1) & (t < 0.89)], 1.0)
    assert left[(t > 0.91) & (t < 1.49)].max() == 0.0
    # A Right click opens Left at once.
    assert left[170] == 0.0 and right[170] == 1.0 and left[169] == 1.0
    assert right[int(2.31 / 0.01)] == 0.0


def test_each_button_click_is_one_press_with_a_release_between() -> None:
    raws = run("head_array", {0.05: [2, 2, 3]}, 0.2)  # two back clicks and a request in one tick
    back = [r[2] for r in raws]
    request = [r[3] for r in raws]
    assert back[5:10] == [1.0, 0.0, 1.0, 0.0, 0.0]
    assert request[5:8] == [1.0, 0.0, 0.0]
    assert sum(back) == 2 and sum(request) == 1


def test_joystick_axes_clip_and_non_finite_reads_as_zero() -> None:
    s = live_raw_step(LiveState(), 0.0, "joystick", np.zeros(4), axes=(0.5, -2.0))
    np.testing.assert_array_equal(s.raw, [0.5, -1.0, 0.0, 0.0])
    s = live_raw_step(s, 0.01, "joystick", np.zeros(4), axes=(float("nan"), float("inf")))
    np.testing.assert_array_equal(s.raw, [0.0, 0.0, 0.0, 0.0])


def test_gamepad_buttons_press_on_rising_edges_only() -> None:
    s = LiveState()
    presses = 0
    for k, level in enumerate([0, 1, 1, 1, 0, 0, 1, 0]):
        s = live_raw_step(s, k * 0.01, "joystick", np.zeros(4), pad=(0, 0, level, 0))
        presses += int(s.raw[2])
    assert presses == 2


def test_a_live_mode_click_with_the_stick_deflected_selects_directly() -> None:
    # The page sends the axes with the Mode press, so direct selection needs no control of its own.
    cfg = InterfaceConfig(kind="joystick", mode_selection="direct")
    itf = initial_state(cfg)
    s = live_raw_step(LiveState(), 0.0, "joystick", np.array([0, 0, 1, 0]), axes=sector_stick(3, 5))
    itf, events = interface_update(itf, s.raw, 0.0, cfg)
    assert itf.mode == 3 and [(e.from_mode, e.to_mode) for e in events] == [(0, 3)]


def test_validation_and_state_round_trip() -> None:
    with pytest.raises(ValueError, match="kind"):
        live_raw_step(LiveState(), 0.0, "trackball", np.zeros(4))
    with pytest.raises(ValueError, match="hold_time"):
        LiveInputConfig(hold_time=0.0)
    with pytest.raises(ValueError, match="dead_zone"):
        LiveInputConfig(dead_zone=1.0)
    s = live_raw_step(LiveState(), 0.3, "head_array", np.array([1.0, 0.0, 1.0, 0.0]))
    back = LiveState.from_vector(s.to_vector())
    np.testing.assert_array_equal(back.to_vector(), s.to_vector())
    with pytest.raises(ValueError, match="LiveState vector"):
        LiveState.from_vector(np.zeros(3))


def run_pad(kind: str, held: dict[int, tuple[float, float]], until: float) -> np.ndarray:
    """Step :func:`live_raw_step` every 10 ms with no clicks; ``held`` maps a live control's index
    to the ``[from, to)`` seconds its gamepad button is pressed. The raw signals, one row per tick."""
    state, raws = LiveState(), []
    n = len(INTERFACES[kind].live_controls)
    for k in range(int(round(until / 0.01)) + 1):
        t = round(k * 0.01, 10)
        pad = [1.0 if i in held and held[i][0] <= t < held[i][1] else 0.0 for i in range(n)]
        state = live_raw_step(state, t, kind, np.zeros(n), pad=pad)
        raws.append(state.raw.copy())
    return np.array(raws)


def test_every_kind_has_a_gamepad_button_for_each_control_it_shows() -> None:
    for kind, variant in INTERFACES.items():
        buttons = pad_buttons(kind)
        assert len(buttons) == len(variant.live_controls)
        shown = [
            b
            for b, c in zip(buttons, variant.live_controls, strict=True)
            if c.role in ("drive+", "drive-", "next", "previous", "request")
        ]
        assert all(b is not None for b in shown), (kind, buttons)
        assert len(set(shown)) == len(shown), (kind, buttons)
    assert pad_buttons("head_array") == tuple(
        PAD_BUTTON_OF_KEY[c.keycode] for c in INTERFACES["head_array"].live_controls
    )
    assert pad_buttons("joystick") == (None, None, 0, 1)


def test_a_gamepad_drives_a_switch_interface_while_pressed_and_no_longer() -> None:
    t = np.arange(int(round(1.5 / 0.01)) + 1) * 0.01
    raws = run_pad("head_array", {0: (0.1, 0.5), 1: (0.8, 0.9)}, 1.5)  # D-pad left, then right
    left, right = raws[:, 0], raws[:, 1]
    np.testing.assert_array_equal(left[(t >= 0.1) & (t < 0.495)], 1.0)
    assert left[t >= 0.505].max() == 0.0  # released: open at once, no hold time
    np.testing.assert_array_equal(right[(t >= 0.8) & (t < 0.895)], 1.0)
    assert right[t >= 0.905].max() == 0.0
    both = run_pad("head_array", {0: (0.1, 0.5), 1: (0.2, 0.5)}, 0.6)
    assert np.abs(both[25:45, :2]).max() == 0.0  # both directions pressed: neither


def test_a_held_gamepad_button_is_one_mode_event_or_request() -> None:
    raws = run_pad("head_array", {2: (0.1, 0.6), 3: (0.3, 0.4)}, 1.0)  # Back held, Request tapped
    assert raws[:, 2].sum() == 1 and raws[:, 3].sum() == 1
    raws = run_pad("sip_and_puff", {2: (0.1, 0.3), 3: (0.5, 0.7)}, 1.0)  # soft puff, then soft sip
    variant = INTERFACES["sip_and_puff"]
    for role, start in (("next", 10), ("previous", 50)):
        pulse = np.asarray(variant.pulse_raw(role), dtype=float)
        hits = [k for k, r in enumerate(raws) if np.array_equal(r, pulse)]
        assert hits == [start], (role, hits)


# ---------------------------------------------------------------------------------------------
# the system, with a stand-in for the Meshcat page
# ---------------------------------------------------------------------------------------------


class FakePage:
    """The part of pydrake's Meshcat that MeshcatLiveInput uses, with a scriptable person."""

    def __init__(self) -> None:
        self.buttons: dict[str, int] = {}
        self.keycodes: dict[str, str] = {}
        self.sliders: dict[str, float] = {}
        self.gamepad = SimpleNamespace(index=None, axes=[], button_values=[])

    def AddButton(self, name: str, keycode: str = "") -> None:  # noqa: N802 (Meshcat's API)
        self.buttons[name] = 0
        self.keycodes[name] = keycode

    def GetButtonClicks(self, name: str) -> int:  # noqa: N802
        return self.buttons[name]

    def DeleteButton(self, name: str, strict: bool = True) -> bool:  # noqa: N802
        return self.buttons.pop(name, None) is not None

    def AddSlider(self, name, min, max, step, value, decrement_keycode="", increment_keycode=""):  # noqa: A002, ANN001, ANN201, N802
        self.sliders[name] = value
        return value

    def GetSliderValue(self, name: str) -> float:  # noqa: N802
        return self.sliders[name]

    def SetSliderValue(self, name: str, value: float) -> None:  # noqa: N802
        self.sliders[name] = value

    def DeleteSlider(self, name: str, strict: bool = True) -> bool:  # noqa: N802
        return self.sliders.pop(name, None) is not None

    def GetGamepad(self):  # noqa: ANN201, N802
        return self.gamepad

    def click(self, index: int, kind: str = "head_array") -> None:
        self.buttons[INTERFACES[kind].live_controls[index].label] += 1


def test_system_adds_its_controls_and_removes_them() -> None:
    page = FakePage()
    system = MeshcatLiveInput(page, HEAD)
    assert sorted(page.keycodes.values()) == sorted(c.keycode for c in INTERFACES["head_array"].live_controls)
    system.remove_controls()
    assert page.buttons == {}
    page = FakePage()
    system = MeshcatLiveInput(page, JOY)
    assert sorted(page.sliders) == sorted(name for name, _, _ in AXIS_SLIDERS)
    assert len(page.buttons) == 3  # centre, mode, request
    system.remove_controls()
    assert page.buttons == {} and page.sliders == {}


def test_system_outputs_the_page_as_raw_signals() -> None:
    page = FakePage()
    system = MeshcatLiveInput(page, HEAD)
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    simulator.AdvanceTo(0.05)
    np.testing.assert_array_equal(system.get_output_port().Eval(context), np.zeros(4))
    page.click(0)  # Left
    page.click(3)  # Request
    simulator.AdvanceTo(0.055)  # the update at 0.05 (run on leaving 0.05) reads the page
    np.testing.assert_array_equal(system.get_output_port().Eval(context), [1.0, 0.0, 0.0, 1.0])
    simulator.AdvanceTo(0.065)  # the request lasted one period; Left stays closed
    np.testing.assert_array_equal(system.get_output_port().Eval(context), [1.0, 0.0, 0.0, 0.0])
    simulator.AdvanceTo(0.7)
    np.testing.assert_array_equal(system.get_output_port().Eval(context), np.zeros(4))


def test_joystick_system_reads_sliders_or_a_gamepad_and_recentres() -> None:
    page = FakePage()
    system = MeshcatLiveInput(page, JOY)
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    x_name, y_name = (name for name, _, _ in AXIS_SLIDERS)
    page.sliders[x_name] = 0.5
    page.sliders[y_name] = -0.25
    simulator.AdvanceTo(0.015)
    np.testing.assert_array_equal(system.get_output_port().Eval(context), [0.5, -0.25, 0.0, 0.0])
    page.click(0, "joystick")  # centre the axes
    simulator.AdvanceTo(0.025)
    assert page.sliders[x_name] == 0.0 and page.sliders[y_name] == 0.0
    page.gamepad = SimpleNamespace(index=0, axes=[0.05, -0.8], button_values=[1.0, 0.0])
    simulator.AdvanceTo(0.035)  # a gamepad takes over: dead zone on x, stick up is +y, mode pressed
    np.testing.assert_allclose(system.get_output_port().Eval(context), [0.0, 0.8, 1.0, 0.0])
    simulator.AdvanceTo(0.055)  # still held: one press only
    np.testing.assert_allclose(system.get_output_port().Eval(context), [0.0, 0.8, 0.0, 0.0])


def test_the_head_array_system_reads_a_gamepad() -> None:
    page = FakePage()
    system = MeshcatLiveInput(page, HEAD)
    simulator = Simulator(system)
    context = simulator.get_mutable_context()
    values = [0.0] * 17
    values[PAD_BUTTON_OF_KEY["ArrowLeft"]] = 1.0
    values[PAD_BUTTON_OF_KEY["Space"]] = 1.0
    page.gamepad = SimpleNamespace(index=0, axes=[0.0, 0.0], button_values=values)
    simulator.AdvanceTo(0.005)  # D-pad left drives +, A is the request
    np.testing.assert_array_equal(system.get_output_port().Eval(context), [1.0, 0.0, 0.0, 1.0])
    simulator.AdvanceTo(0.035)  # still held: the request once, the switch closed
    np.testing.assert_array_equal(system.get_output_port().Eval(context), [1.0, 0.0, 0.0, 0.0])
    page.gamepad = SimpleNamespace(index=0, axes=[0.0, 0.0], button_values=[0.0] * 17)
    simulator.AdvanceTo(0.045)  # released: open at once
    np.testing.assert_array_equal(system.get_output_port().Eval(context), np.zeros(4))
    page.gamepad = SimpleNamespace(index=0, axes=[], button_values=[1.0])  # a pad of one button: A
    simulator.AdvanceTo(0.055)
    np.testing.assert_array_equal(system.get_output_port().Eval(context), [0.0, 0.0, 0.0, 1.0])


def test_a_live_person_drives_the_arm() -> None:
    """The full reaching diagram driven from the page: holding Left moves the arm along +x."""
    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario
    from drake_disamb.trial import run_trial

    scenario = dataclasses.replace(load_scenario("reaching"), duration=1.5)
    page = FakePage()
    interface = InterfaceConfig(kind="head_array", control_period=scenario.control_period)
    source = MeshcatLiveInput(page, interface, LiveInputConfig(hold_time=1.0))
    handles = build_shared_control_diagram(scenario, input_source=source)
    page.click(0)  # Left, held for 1 s (the head array starts in mode vx)
    result = run_trial(handles, progress=False, stop_at_success=False)
    times, ee = result.logs["ee_pose"]
    assert result.requests == 0 and result.mode_switches == 0
    assert ee[np.searchsorted(times, 0.55), 0] > ee[0, 0] + 0.01  # moved along +x while held
    assert np.all(np.isfinite(ee))


# ---------------------------------------------------------------------------------------------
# a real Meshcat server (localhost), as if a browser had clicked
# ---------------------------------------------------------------------------------------------


def _msgpack_str_map(entries: dict[str, str]) -> bytes:
    """MessagePack of a small map of short ASCII strings (what the Meshcat page sends)."""

    def pack(s: str) -> bytes:
        b = s.encode()
        return (bytes([0xA0 | len(b)]) if len(b) < 32 else struct.pack(">BB", 0xD9, len(b))) + b

    return bytes([0x80 | len(entries)]) + b"".join(pack(k) + pack(v) for k, v in entries.items())


def test_real_meshcat_button_click_reaches_the_raw_signal() -> None:
    from pydrake.geometry import Meshcat, MeshcatParams

    meshcat = Meshcat(MeshcatParams(host="localhost"))
    system = MeshcatLiveInput(meshcat, HEAD)
    name = INTERFACES["head_array"].live_controls[2].label  # Back
    meshcat._InjectWebsocketMessage(message=_msgpack_str_map({"type": "button", "name": name}))
    assert meshcat.GetButtonClicks(name) == 1
    simulator = Simulator(system)
    simulator.AdvanceTo(0.005)
    np.testing.assert_array_equal(system.get_output_port().Eval(simulator.get_context()), [0, 0, 1, 0])
    system.remove_controls()
    assert meshcat.GetButtonNames() == []
