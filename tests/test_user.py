"""Simulated user: core policy, the SimulatedUser system in isolation, and closed loops that reach goals."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest
from support import integrate_pose

from drake_disamb.core.geometry import quat_from_rotvec
from drake_disamb.interfaces import (
    REQUEST_BUTTON,
    InterfaceConfig,
    command_from_raw,
    initial_state,
    interface_update,
)
from drake_disamb.user import (
    NOT_COUNTING,
    UserConfig,
    UserState,
    goal_error,
    goal_reached,
    mode_remaining,
    mode_usefulness,
    presses_to,
    user_step,
)

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
JOY = InterfaceConfig(kind="joystick")
HEAD = InterfaceConfig(kind="head_array")
NO_REQUESTS = UserConfig(request_at_start=False, request_when_unhelped_for=None)

# Two goals; the user's goal 0 is 0.2 m along +x and 0.05 m along -z from the robot.
EE = np.array([0.0, -0.4, 0.3, *IDENTITY])
GOALS = np.array([[0.2, -0.4, 0.25, *IDENTITY], [-0.2, -0.5, 0.3, *IDENTITY]])


def step(state, t, mode, *, interface=JOY, config=NO_REQUESTS, ee=EE, belief=None, goal=0):
    return user_step(state, t, mode, ee, GOALS, goal, interface, config, belief)


# ---------------------------------------------------------------------------------------------
# core policy
# ---------------------------------------------------------------------------------------------


def test_config_validation() -> None:
    with pytest.raises(ValueError, match="success_position_tolerance"):
        UserConfig(position_tolerance=0.02, success_position_tolerance=0.02)
    with pytest.raises(ValueError, match="reaction_time_jitter"):
        UserConfig(reaction_time=0.3, reaction_time_jitter=0.3)
    with pytest.raises(ValueError, match="min_axis"):
        UserConfig(min_axis=0.0)
    with pytest.raises(ValueError, match="request_when_unhelped_for"):
        UserConfig(request_when_unhelped_for=-1.0)
    with pytest.raises(ValueError, match="seed"):
        UserConfig(seed=-3)
    with pytest.raises(ValueError, match="stall_time"):
        UserConfig(stall_time=0.0)
    with pytest.raises(ValueError, match="stall_progress"):
        UserConfig(stall_progress=float("nan"))
    with pytest.raises(ValueError, match=r"UserConfig\.backoff_after: expected a finite number > 0, got 0"):
        UserConfig(backoff_after=0.0)
    with pytest.raises(ValueError, match=r"UserConfig\.backoff_time: expected a finite number >= 0"):
        UserConfig(backoff_time=-1.0)
    with pytest.raises(
        ValueError, match=r"UserConfig\.correction_prob: expected a probability in \[0, 1\], got 1\.5"
    ):
        UserConfig(correction_prob=1.5)
    with pytest.raises(
        ValueError, match=r"UserConfig\.keep_assisted_mode: expected true or false, got 'yes'"
    ):
        UserConfig(keep_assisted_mode="yes")


def test_state_vector_round_trip() -> None:
    s = UserState(
        busy_until=1.25,
        requested_at_start=True,
        unhelped_since=0.5,
        draws=3,
        presses=7,
        target_mode=2,
        progress_mode=4,
        progress_since=0.75,
        progress_best=12.5,
        blocked_best=40.0,
        blocked_time=1.5,
        backoff_mode=2,
        backoff_until=3.25,
        detour_mode=1,
        detour_offset=-0.125,
        raw=np.array([0.0, 0.0, 1.0, 0.0]),
    )
    back = UserState.from_vector(s.to_vector())
    assert back == s
    np.testing.assert_array_equal(back.raw, s.raw)


def test_error_and_remaining() -> None:
    err = goal_error(EE, GOALS[0])
    np.testing.assert_allclose(err, [0.2, 0, -0.05, 0, 0, 0], atol=1e-12)
    rem = mode_remaining(err, JOY.modes, NO_REQUESTS)
    np.testing.assert_allclose(rem, [20.0, 20.0, 0.0, 0.0, 0.0])  # |0.2| / 0.01 in both x-modes
    q = quat_from_rotvec([0.0, 0.3, 0.0])
    err = goal_error(EE, [*GOALS[0, :3], *q])
    np.testing.assert_allclose(err[3:], [0.0, 0.3, 0.0], atol=1e-12)
    assert not goal_reached(err, NO_REQUESTS)
    assert goal_reached([0.01, 0.01, 0, 0.04, 0.04, 0], NO_REQUESTS)


def test_joystick_axes_point_toward_the_goal() -> None:
    s = step(UserState(), 0.0, 1)  # mode {vx, vz}: axis_x -> vx, axis_y -> vz
    ax, ay = s.raw[:2]
    assert ax == 1.0  # 0.2 m / 0.5 s = 0.4 m/s > 0.13 m/s: full deflection
    assert ay == pytest.approx(-0.05 / 0.5 / 0.13)  # proportional along -z
    assert s.raw[2] == 0 and s.raw[3] == 0
    u, _ = command_from_raw(s.raw, 1, JOY)
    assert u[0] > 0 and u[2] < 0 and u[1] == 0


def test_joystick_min_axis_and_done_dimension() -> None:
    ee = EE.copy()
    ee[:3] = GOALS[0, :3] + [-0.012, 0.05, 0.005]  # x error 1.2 cm (> tol), z 0.5 cm (done), y 5 cm
    s = step(UserState(), 0.0, 1, ee=ee)
    assert s.raw[0] == pytest.approx(0.2)  # would be 0.18, raised to min_axis
    assert s.raw[1] == 0.0


def test_head_array_left_right() -> None:
    s = step(UserState(), 0.0, 0, interface=HEAD)  # vx, error +0.2 -> left
    np.testing.assert_array_equal(s.raw, [1, 0, 0, 0])
    s = step(UserState(), 0.0, 2, interface=HEAD)  # vz, error -0.05 -> right
    np.testing.assert_array_equal(s.raw, [0, 1, 0, 0])


def test_switches_to_the_mode_with_most_left_and_waits_between_presses() -> None:
    # Head array in mode vy (nothing to do along y): target is vx (largest error), reached by
    # pressing back 6 times: vy -> vz -> wx -> wy -> wz -> gripper -> vx.
    s = UserState()
    mode = 1
    presses = []
    t = 0.0
    for k in range(400):
        t = k * 0.01
        s = step(s, t, mode, interface=HEAD)
        if s.raw[2] == 1.0:
            presses.append(round(t, 2))
            mode = (mode + 1) % 7  # what the interface does (one tick later in a diagram)
        if mode == 0 and s.raw[0] == 1.0:
            break
    assert len(presses) == 6
    assert np.all(np.diff(presses) >= 0.3 - 1e-9)  # one press per reaction time
    assert presses[0] == 0.0
    assert s.raw[0] == 1.0  # now driving +x


def _drive_head_array(config: UserConfig, ee_at, until: float, mode: int = 0) -> list[UserState]:
    """Step a head-array user in a fixed ``mode`` every 10 ms up to ``until`` (s); ``ee_at(t)``."""
    s, states = UserState(), []
    for k in range(int(round(until / 0.01)) + 1):
        t = k * 0.01
        s = step(s, t, mode, interface=HEAD, config=config, ee=ee_at(t))
        states.append(s)
    return states


def test_a_stalled_mode_is_left_for_the_other_mode_with_most_left() -> None:
    # Mode vx, 0.2 m (20 tolerances) to go, but the arm does not move (a joint limit, say): after
    # stall_time of commanding, the user targets vz (0.05 m left), the other mode with work left.
    states = _drive_head_array(NO_REQUESTS, lambda t: EE, 2.0)
    assert NO_REQUESTS.mode_choice.stall_time == 2.0
    assert all(s.raw[0] == 1.0 for s in states[:-1])  # driving +x up to 1.99 s
    assert states[-1].raw[2] == 1.0 and states[-1].target_mode == 2  # back pressed toward vz
    assert states[-1].progress_mode == -1  # the watch restarts after the press


def test_progress_keeps_the_mode_and_stall_detection_can_be_disabled() -> None:
    def moving(t: float) -> np.ndarray:  # 1.2 cm/s along +x: more than stall_progress per window
        ee = EE.copy()
        ee[0] += 0.012 * t
        return ee

    assert all(s.raw[0] == 1.0 for s in _drive_head_array(NO_REQUESTS, moving, 4.0))
    off = UserConfig(
        request_at_start=False, request_when_unhelped_for=None, stall_time=None, backoff_time=0.0
    )
    assert all(s.raw[0] == 1.0 for s in _drive_head_array(off, lambda t: EE, 6.0))


def test_a_stalled_user_with_nothing_else_to_do_keeps_trying_then_backs_off() -> None:
    ee = EE.copy()
    ee[2] = GOALS[0, 2]  # only the x error is left
    states = _drive_head_array(NO_REQUESTS, lambda t: ee, 6.5)
    drive = np.array([s.raw[0] - s.raw[1] for s in states])  # right - left
    choice = NO_REQUESTS.mode_choice
    after, back = int(round(choice.backoff_after / 0.01)), int(round(choice.backoff_time / 0.01))
    assert np.all(drive[: after - 1] == 1.0)  # keeps at it up to backoff_after of commanding
    assert np.all(drive[after : after + back - 1] == -1.0)  # backs off for backoff_time
    assert np.all(drive[after + back + 1 :] == 1.0)  # nothing else to do: tries again
    assert states[-1].presses == 0


def _head_array_loop(config: UserConfig, ee: np.ndarray, until: float, mode: int = 0):
    """A head-array user at a fixed pose whose back switch cycles the modes: (t, mode, raw) per 10 ms."""
    s, rows = UserState(), []
    for k in range(int(round(until / 0.01)) + 1):
        t = k * 0.01
        s = step(s, t, mode, interface=HEAD, config=config, ee=ee)
        rows.append((t, mode, s.raw.copy()))
        if s.raw[2] == 1.0:
            mode = (mode + 1) % 7
    return rows


def test_a_blocked_user_backs_off_in_its_mode_then_routes_around() -> None:
    # The arm moves in no mode (a joint limit): vx stalls (2 s), the user goes to vz and pushes
    # -z; after backoff_after of commanding in all without progress it drives back (+z) for
    # backoff_time, then changes to another mode (vx, the only other one with work left).
    rows = _head_array_loop(NO_REQUESTS, EE, 9.0)
    drives = [(t, m, r[0] - r[1]) for t, m, r in rows if r[0] - r[1] != 0.0]  # right - left
    reverse = [(t, m) for t, m, v in drives if (m == 0 and v < 0) or (m == 2 and v > 0)]
    assert reverse, "never backed off"
    t0, m0 = reverse[0]
    assert m0 == 2 and all(m == 2 for _, m in reverse)
    commanding = sum(1 for t, _, _ in drives if t < t0) * 0.01
    assert commanding == pytest.approx(NO_REQUESTS.mode_choice.backoff_after, abs=0.03)
    assert reverse[-1][0] - t0 == pytest.approx(NO_REQUESTS.mode_choice.backoff_time, abs=0.03)
    after = [(t, m, r) for t, m, r in rows if t > reverse[-1][0]]
    assert after[0][2][2] == 1.0  # then it presses on toward another mode ...
    assert any(m == 0 and r[0] == 1.0 for _, m, r in after)  # ... and drives +x in vx again


def test_a_blocked_user_that_can_ask_may_ask_instead_of_routing_around() -> None:
    # A back-off in vx has just ended: routing around is a change of the user's own, so with a
    # belief and request_instead_prob 1 it asks for disambiguation instead; with 0 (or no belief)
    # it changes mode as before.
    backed = UserState(requested_at_start=True, backoff_mode=0, backoff_until=1.0)
    flat = np.array([0.5, 0.5])
    ask = dataclasses.replace(NO_REQUESTS, request_instead_prob=1.0)
    s = step(backed, 1.0, 0, interface=HEAD, config=ask, belief=flat)
    assert s.raw[REQUEST_BUTTON] == 1.0 and s.raw[2] == 0.0 and s.backoff_mode == -1 and s.request_mode == 0
    for config, belief in ((NO_REQUESTS, flat), (ask, None)):
        s = step(backed, 1.0, 0, interface=HEAD, config=config, belief=belief)
        assert s.raw[2] == 1.0 and s.raw[REQUEST_BUTTON] == 0.0 and s.target_mode == 2


def test_a_blocked_user_with_a_detour_lifts_the_hand_over_the_obstacle() -> None:
    # Only the x error is left and the arm does not move (the floor holds it): after the back-off
    # in vx the user goes to vz and drives up (+z, away from its goal's height) instead of trying
    # vx again; the lift stalls too (stall_time), and it goes back to vx, the hand kept lifted.
    ee = EE.copy()
    ee[2] = GOALS[0, 2]
    lifting = dataclasses.replace(NO_REQUESTS, detour_lift=0.1)
    rows = _head_array_loop(lifting, ee, 10.0)
    drives = [(t, m, r[0] - r[1]) for t, m, r in rows if r[0] - r[1] != 0.0]  # right - left
    back_x = [t for t, m, v in drives if m == 0 and v < 0]
    assert back_x, "never backed off in vx"
    later = [(t, m, v) for t, m, v in drives if t > back_x[-1]]
    assert later[0][1] == 2 and later[0][2] > 0  # next it drives in vz, up
    up = [t for t, m, v in later if m == 2]
    assert all(v > 0 for t, m, v in later if m == 2)
    assert up[-1] - up[0] == pytest.approx(lifting.mode_choice.stall_time, abs=0.05)
    assert [m for t, m, v in later if t > up[-1]][0] == 0  # then vx again, over the obstacle
    # Without the detour (the default) it tries vx again right after the back-off.
    plain = [(t, m, r[0] - r[1]) for t, m, r in _head_array_loop(NO_REQUESTS, ee, 8.0) if r[0] != r[1]]
    t_back = max(t for t, m, v in plain if m == 0 and v < 0)
    assert all(m == 0 and v > 0 for t, m, v in plain if t > t_back)


def test_progress_restarts_the_back_off_watch() -> None:
    def moving(t: float) -> np.ndarray:  # 1.2 cm/s along +x
        ee = EE.copy()
        ee[0] += 0.012 * t
        return ee

    states = _drive_head_array(NO_REQUESTS, moving, 8.0)
    assert all(s.raw[0] == 1.0 and s.backoff_mode == -1 for s in states)
    assert max(s.blocked_time for s in states) < 1.0


def test_released_between_presses() -> None:
    s = step(UserState(), 0.0, 3)  # joystick {wy}: nothing to do -> press mode
    assert s.raw[2] == 1.0
    s = step(s, 0.01, 3)  # reacting: released
    np.testing.assert_array_equal(s.raw, np.zeros(4))
    s = step(s, 0.29, 3)
    np.testing.assert_array_equal(s.raw, np.zeros(4))
    s = step(s, 0.30, 3)  # mode still {wy} (as if the press was lost): presses again
    assert s.raw[2] == 1.0 and s.presses == 2


def test_request_at_start_then_when_unhelped() -> None:
    cfg = UserConfig(request_at_start=True, request_when_unhelped_for=1.0)
    wrong = np.array([0.2, 0.8])  # argmax is goal 1, not the user's goal 0
    s = step(UserState(), 0.0, 0, config=cfg, belief=wrong)
    np.testing.assert_array_equal(s.raw, [0, 0, 0, 1])
    assert s.requested_at_start and s.unhelped_since == 0.0
    requests = [0.0]
    for k in range(1, 350):
        t = k * 0.01
        s = step(s, t, 0, config=cfg, belief=wrong)
        if s.raw[3] == 1.0:
            requests.append(round(t, 2))
    assert requests == [0.0, 1.0, 2.0, 3.0]  # every 1 s while unhelped


def test_no_request_while_helped() -> None:
    cfg = UserConfig(request_at_start=False, request_when_unhelped_for=0.5)
    good = np.array([0.9, 0.1])  # argmax is the user's goal and p* > rho1 = 0.6
    s = UserState()
    for k in range(200):
        s = step(s, k * 0.01, 0, config=cfg, belief=good)
        assert s.raw[3] == 0.0
    assert s.unhelped_since == NOT_COUNTING
    flat = np.array([0.55, 0.45])  # right argmax but p* <= rho1: alpha = 0 -> unhelped
    presses = 0
    for k in range(200, 300):
        s = step(s, k * 0.01, 0, config=cfg, belief=flat)
        presses += int(s.raw[3] == 1.0)
    assert presses == 1  # at t = 2.5 s


def test_stops_within_tolerance() -> None:
    ee = EE.copy()
    ee[:3] = GOALS[0, :3] + [0.005, -0.005, 0.005]
    s = step(UserState(), 0.0, 0, ee=ee, config=UserConfig())  # even the start request is skipped
    np.testing.assert_array_equal(s.raw, np.zeros(4))


def test_seeded_randomness_is_reproducible() -> None:
    cfg = UserConfig(reaction_time_jitter=0.1, axis_noise=0.05, seed=7, request_at_start=False)

    def run(config: UserConfig) -> list[float]:
        s = UserState()
        out = []
        for k in range(200):
            s = step(s, k * 0.01, 2 if k < 100 else 1, config=config)  # {wx, wz} -> press, then drive
            out.extend([*s.raw, s.busy_until])
        return out

    a, b = run(cfg), run(cfg)
    assert a == b
    c = run(UserConfig(reaction_time_jitter=0.1, axis_noise=0.05, seed=8, request_at_start=False))
    assert a != c


# ---------------------------------------------------------------------------------------------
# Closed loop in numpy: user -> interface -> kinematic end effector
# ---------------------------------------------------------------------------------------------


def _numpy_loop(interface: InterfaceConfig, ee0: np.ndarray, goal: np.ndarray, t_max: float):
    cfg = UserConfig(request_at_start=False, request_when_unhelped_for=None)
    goals = goal[None, :]
    s_i = initial_state(interface)
    s_u = UserState()
    pos, quat = ee0[:3].copy(), ee0[3:].copy()
    for k in range(int(t_max / interface.control_period)):
        t = k * interface.control_period
        u_h, _ = command_from_raw(s_i.held_raw, s_i.mode, interface)  # outputs from state
        raw = s_u.raw
        s_u = user_step(s_u, t, s_i.mode, np.concatenate((pos, quat)), goals, 0, interface, cfg)
        s_i, _ = interface_update(s_i, raw, t, interface)
        pos, quat = integrate_pose(pos, quat, u_h, interface.control_period)
        if goal_reached(goal_error(np.concatenate((pos, quat)), goal), cfg):
            return t, s_i
    return None, s_i


@pytest.mark.parametrize("kind", ["joystick", "head_array"])
@pytest.mark.parametrize("initial_mode", [0, -1])
def test_user_reaches_a_6d_goal_without_assistance(kind: str, initial_mode: int) -> None:
    interface = InterfaceConfig(kind=kind, initial_mode=initial_mode % len(InterfaceConfig(kind=kind).modes))
    goal = np.array([0.15, -0.55, 0.2, *quat_from_rotvec([0.3, -0.4, 0.5])])
    t, s_i = _numpy_loop(interface, EE, goal, t_max=60.0)
    assert t is not None, f"{kind} user did not reach the goal"
    assert s_i.mode_switch_count >= 3  # it had to visit translation and rotation modes


# ---------------------------------------------------------------------------------------------
# SimulatedUser system
# ---------------------------------------------------------------------------------------------


def _user_context(system, mode, ee=EE, belief=None):
    from pydrake.systems.analysis import Simulator

    sim = Simulator(system)
    ctx = sim.get_mutable_context()
    system.GetInputPort("mode").FixValue(ctx, [float(mode)])
    system.GetInputPort("ee_pose").FixValue(ctx, np.asarray(ee, dtype=float))
    system.GetInputPort("goal_poses").FixValue(ctx, GOALS.reshape(-1))
    if belief is not None:
        system.GetInputPort("belief").FixValue(ctx, np.asarray(belief, dtype=float))
    sim.Initialize()
    return sim, ctx


def test_system_output_is_held_state() -> None:
    from drake_disamb.user.system import SimulatedUser

    user = SimulatedUser("head_array", 0, 2, NO_REQUESTS)
    sim, ctx = _user_context(user, mode=0)
    out = user.get_output_port(0)
    np.testing.assert_array_equal(out.Eval(ctx), np.zeros(4))  # nothing before the first update
    sim.AdvanceTo(0.005)
    np.testing.assert_array_equal(out.Eval(ctx), [1, 0, 0, 0])  # left: +x toward goal 0
    for i in range(user.num_input_ports()):
        assert not user.HasDirectFeedthrough(i, 0)


def test_system_presses_mode_button_once_and_requests_with_belief() -> None:
    from drake_disamb.user.system import SimulatedUser

    cfg = UserConfig(request_at_start=True, request_when_unhelped_for=1.0)
    user = SimulatedUser(InterfaceConfig(kind="joystick"), 0, 2, cfg)
    sim, ctx = _user_context(user, mode=3, belief=[0.3, 0.7])  # {wy}: nothing to do there
    raws = []
    for k in range(150):
        sim.AdvanceTo(k * 0.01 + 0.005)
        raws.append(user.get_output_port(0).Eval(ctx).copy())
    raws = np.array(raws)
    request_ticks = np.flatnonzero(raws[:, 3] == 1.0)
    mode_ticks = np.flatnonzero(raws[:, 2] == 1.0)
    # Start request, then one after 1 s of a wrong argmax -- due at tick 100 but the user is still
    # reacting to its mode press at tick 90, so it comes at 120.
    assert list(request_ticks) == [0, 120]
    assert list(mode_ticks) == [30, 60, 90]  # one press per 0.3 s reaction time (mode stays 3 here)
    assert np.all(raws[request_ticks + 1] == 0) and np.all(raws[mode_ticks + 1] == 0)  # released
    assert user.get_user_state(ctx).presses == 5


def _bad(index: int, value: float, array: np.ndarray = EE) -> np.ndarray:
    out = array.copy().ravel()
    out[index] = value
    return out


@pytest.mark.parametrize(
    "port, value",
    [
        ("ee_pose", _bad(0, np.nan)),
        ("ee_pose", _bad(3, np.inf)),
        ("ee_pose", np.array([0.0, -0.4, 0.3, 0.0, 0.0, 0.0, 0.0])),  # zero quaternion
        ("goal_poses", _bad(3, 0.0, GOALS)),  # the user's own goal has a zero quaternion
        ("goal_poses", _bad(10, 1e200, GOALS)),  # another goal's quaternion is out of range
        ("mode", np.array([np.nan])),
        ("mode", np.array([1.5])),
        ("mode", np.array([7.0])),  # the joystick has 5 modes
        ("stage", np.array([-1.0])),
    ],
)
def test_system_unusable_inputs_let_go_and_are_counted(port: str, value: np.ndarray) -> None:
    from drake_disamb.user.system import SimulatedUser

    user = SimulatedUser("joystick", 0, 2, NO_REQUESTS)
    sim, ctx = _user_context(user, mode=0)
    count = user.GetOutputPort("sanitized_input_count")
    sim.AdvanceTo(0.005)
    assert np.any(user.get_output_port(0).Eval(ctx) != 0) and count.Eval(ctx)[0] == 0
    user.GetInputPort(port).FixValue(ctx, value)
    with pytest.warns(RuntimeWarning, match="lets go") as record:
        sim.AdvanceTo(0.035)  # three ticks
    assert len(record) == 1  # at most one warning per second of simulated time
    np.testing.assert_array_equal(user.get_output_port(0).Eval(ctx), np.zeros(4))
    assert count.Eval(ctx)[0] == 3
    fresh, fresh_ctx = _user_context(user, mode=0)  # the count lives in the context
    assert count.Eval(fresh_ctx)[0] == 0


@pytest.mark.parametrize("error", [ValueError("ee_pose/goal_pose: expected 7 numbers"), RuntimeError("bug")])
def test_system_other_errors_propagate(monkeypatch: pytest.MonkeyPatch, error: Exception) -> None:
    from drake_disamb.user import system as module

    def broken(*args: object) -> None:
        raise error

    user = module.SimulatedUser("joystick", 0, 2, NO_REQUESTS)
    sim, ctx = _user_context(user, mode=0)
    monkeypatch.setattr(module, "user_step", broken)
    with pytest.raises(type(error), match=re.escape(str(error))):
        sim.AdvanceTo(0.005)
    assert user.GetOutputPort("sanitized_input_count").Eval(ctx)[0] == 0


def test_system_follows_the_stage_goal_and_lets_go_when_done() -> None:
    from drake_disamb.user.system import SimulatedUser

    user = SimulatedUser("head_array", [0, 1], 2, NO_REQUESTS)
    assert user.goal_indices == (0, 1) and user.goal_index == 0
    sim, ctx = _user_context(user, mode=0)  # mode vx; goal 0 is at +x, goal 1 at -x
    out = user.get_output_port(0)
    sim.AdvanceTo(0.005)  # stage input unconnected: stage 0
    np.testing.assert_array_equal(out.Eval(ctx), [1, 0, 0, 0])
    user.GetInputPort("stage").FixValue(ctx, [1.0])
    sim.AdvanceTo(0.015)
    np.testing.assert_array_equal(out.Eval(ctx), [0, 1, 0, 0])  # right: -x toward goal 1
    user.GetInputPort("stage").FixValue(ctx, [2.0])  # task done
    sim.AdvanceTo(0.025)
    np.testing.assert_array_equal(out.Eval(ctx), np.zeros(4))


def test_system_constructor_validation() -> None:
    from drake_disamb.user.system import SimulatedUser

    # A kind's name makes its InterfaceConfig, which checks it; the goals and the timing are the
    # resolved scenario's (scenario.user.goals, user.config.reaction_time: tests/test_bounds.py),
    # which the system asserts.
    with pytest.raises(ValueError, match="kind"):
        SimulatedUser("trackball", 0, 2)
    with pytest.raises(AssertionError):
        SimulatedUser("joystick", [0, 5], 2)
    with pytest.raises(AssertionError):
        SimulatedUser("joystick", 0, 2, UserConfig(reaction_time=0.015))


def test_diagram_loop_reaches_goal() -> None:
    """SimulatedUser -> interface -> blender (with autonomy) -> kinematic end effector -> user."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder, LeafSystem
    from pydrake.systems.primitives import ConstantVectorSource

    from drake_disamb.core.blending import BlendingConfig
    from drake_disamb.interfaces.system import make_interface
    from drake_disamb.systems.autonomy import PotentialFieldAutonomy
    from drake_disamb.systems.blending import SharedControlBlender
    from drake_disamb.systems.loop import ControlLoop
    from drake_disamb.user.system import SimulatedUser

    class KinematicEndEffector(LeafSystem):
        """Test stand-in for the station: integrates ``ee_velocity_command`` (6) into ``ee_pose`` (7)."""

        def __init__(self, pose0: np.ndarray, dt: float) -> None:
            super().__init__()
            self.DeclareVectorInputPort("ee_velocity_command", 6)
            index = self.DeclareDiscreteState(pose0)
            self.DeclareStateOutputPort("ee_pose", index)
            self.DeclarePeriodicDiscreteUpdateEvent(dt, 0.0, self._step)
            self.dt = dt

        def _step(self, context, discrete_state):
            x = context.get_discrete_state(0).get_value()
            u = self.get_input_port(0).Eval(context)
            p, q = integrate_pose(x[:3], x[3:], u, self.dt)
            discrete_state.get_mutable_vector(0).SetFromVector(np.concatenate((p, q)))

    goals = GOALS.copy()
    goals[0, 3:] = quat_from_rotvec([0.0, 0.0, 0.3])
    n = len(goals)
    b = DiagramBuilder()
    user = b.AddSystem(SimulatedUser("head_array", 0, n, NO_REQUESTS))
    iface = b.AddSystem(make_interface("head_array", initial_mode=5))
    autonomy = b.AddSystem(PotentialFieldAutonomy(ControlLoop(n)))
    blender = b.AddSystem(SharedControlBlender(ControlLoop(n), BlendingConfig()))
    ee = b.AddSystem(KinematicEndEffector(EE, 0.01))
    goal_src = b.AddSystem(ConstantVectorSource(goals.reshape(-1)))
    belief = b.AddSystem(ConstantVectorSource(np.array([0.8, 0.2])))  # confident in goal 0: alpha 0.7
    b.Connect(user.get_output_port(0), iface.GetInputPort("raw"))
    b.Connect(iface.GetOutputPort("mode"), user.GetInputPort("mode"))
    b.Connect(ee.get_output_port(0), user.GetInputPort("ee_pose"))
    b.Connect(goal_src.get_output_port(0), user.GetInputPort("goal_poses"))
    b.Connect(ee.get_output_port(0), autonomy.GetInputPort("ee_pose"))
    b.Connect(goal_src.get_output_port(0), autonomy.GetInputPort("goal_poses"))
    b.Connect(iface.GetOutputPort("u_h"), blender.GetInputPort("u_h"))
    b.Connect(belief.get_output_port(0), blender.GetInputPort("belief"))
    b.Connect(autonomy.get_output_port(0), blender.GetInputPort("u_a"))
    b.Connect(blender.GetOutputPort("u"), ee.get_input_port(0))
    diagram = b.Build()
    sim = Simulator(diagram)
    ctx = sim.get_mutable_context()
    ee_ctx = ee.GetMyContextFromRoot(ctx)
    reached = None
    for k in range(1, 41):
        sim.AdvanceTo(0.5 * k)
        pose = ee.get_output_port(0).Eval(ee_ctx)
        if goal_reached(goal_error(pose, goals[0]), NO_REQUESTS):
            reached = 0.5 * k
            break
    assert reached is not None
    iface_ctx = iface.GetMyContextFromRoot(ctx)
    assert iface.GetOutputPort("mode_switch_count").Eval(iface_ctx)[0] >= 1
    alpha = blender.GetOutputPort("alpha").Eval(blender.GetMyContextFromRoot(ctx))[0]
    assert alpha in (0.0, pytest.approx(0.7))


# ---------------------------------------------------------------------------------------------
# judging where to stop (aim_error) and a stalled user who can ask for help
# ---------------------------------------------------------------------------------------------

AIMING = UserConfig(request_at_start=False, request_when_unhelped_for=None, aim_error=0.3)


def test_aim_is_judged_on_entering_a_mode_and_stops_short() -> None:
    s = step(UserState(), 0.0, 0, interface=HEAD, config=AIMING)
    assert s.aim_mode == 0 and s.raw[0] == 1.0  # drives +x
    # Stops short: the aim is a share (in [0, 2 * aim_error]) of the 0.2 m it saw, toward the robot.
    assert 0.0 <= s.aim_0 <= 2 * 0.3 * 0.2 and s.aim_1 == 0.0
    assert UserState.from_vector(s.to_vector()) == s


def test_a_user_that_thinks_the_mode_is_done_moves_on_and_corrects_later() -> None:
    # 4 cm still to go along x, but the user judged it would stop 4 cm short: x looks done, and it
    # goes for vz (5 cm left) although x is not done (the exact user keeps driving x).
    ee = EE.copy()
    ee[0] = GOALS[0, 0] - 0.04
    judged = UserState(aim_mode=0, aim_0=0.04)
    s = step(judged, 1.0, 0, interface=HEAD, config=AIMING, ee=ee)
    assert s.raw[2] == 1.0 and s.target_mode == 2
    exact = step(UserState(aim_mode=0), 1.0, 0, interface=HEAD, config=NO_REQUESTS, ee=ee)
    assert exact.raw[0] == 1.0
    # With nothing else left it looks again (a correction) and keeps driving x.
    ee[2] = GOALS[0, 2]
    s = step(judged, 1.0, 0, interface=HEAD, config=AIMING, ee=ee)
    assert s.raw[0] == 1.0 and s.aim_mode == 0 and s.aim_0 != 0.04


def test_a_user_that_sees_the_shortfall_corrects_it_in_the_same_mode() -> None:
    # As above (x looks done 4 cm short, vz has 5 cm left), but the user corrects at once with
    # correction_prob: always at 1 (aiming anew, still short), never at 0, and with 0.5 some of
    # the seeded users do and some move on.
    ee = EE.copy()
    ee[0] = GOALS[0, 0] - 0.04
    judged = UserState(aim_mode=0, aim_0=0.04)
    s = step(judged, 1.0, 0, interface=HEAD, config=dataclasses.replace(AIMING, correction_prob=1.0), ee=ee)
    assert s.raw[0] == 1.0 and s.target_mode == -1 and s.aim_mode == 0 and 0.0 <= s.aim_0 < 0.04
    s = step(judged, 1.0, 0, interface=HEAD, config=dataclasses.replace(AIMING, correction_prob=0.0), ee=ee)
    assert s.raw[2] == 1.0 and s.target_mode == 2
    corrected = [
        step(
            judged,
            1.0,
            0,
            interface=HEAD,
            config=dataclasses.replace(AIMING, correction_prob=0.5, seed=k),
            ee=ee,
        ).raw[0]
        == 1.0
        for k in range(40)
    ]
    assert 5 < sum(corrected) < 35


def test_a_stick_user_corrects_with_its_own_probability() -> None:
    # As above with the joystick (mode 0 = {vx, vy}, x looks done 4 cm short, vz left): with
    # stick_correction_prob set, the joystick user corrects with it, whatever correction_prob
    # (the head array's) is; unset, correction_prob serves both.
    ee = EE.copy()
    ee[0] = GOALS[0, 0] - 0.04
    judged = UserState(aim_mode=0, aim_0=0.04)
    stick = dataclasses.replace(AIMING, correction_prob=0.0, stick_correction_prob=1.0)
    s = step(judged, 1.0, 0, interface=JOY, config=stick, ee=ee)
    assert s.raw[0] > 0.0 and s.raw[2] == 0.0 and s.aim_mode == 0  # corrects in place
    s = step(judged, 1.0, 0, interface=HEAD, config=stick, ee=ee)
    assert s.raw[2] == 1.0  # the head array's probability is 0: it moves on
    moves_on = dataclasses.replace(AIMING, correction_prob=1.0, stick_correction_prob=0.0)
    assert step(judged, 1.0, 0, interface=JOY, config=moves_on, ee=ee).raw[2] == 1.0
    both = dataclasses.replace(AIMING, correction_prob=1.0)
    assert step(judged, 1.0, 0, interface=JOY, config=both, ee=ee).raw[0] > 0.0
    with pytest.raises(ValueError, match=r"UserConfig\.stick_correction_prob: expected a probability"):
        UserConfig(stick_correction_prob=-0.1)


@pytest.mark.parametrize("interface", [HEAD, JOY])
def test_a_kept_request_mode_is_used_while_the_assistance_helps(interface: InterfaceConfig) -> None:
    # The request chose mode 0 (x first) and the user kept it, but x is done (z is left): while the
    # autonomy assists its goal it keeps pushing toward the goal in the mode (the arm approaches
    # the goal through the assistance); once the autonomy pulls toward the other goal or gives no
    # assistance, or the mode is not the kept one, x is done as before and it goes for z.
    ee = EE.copy()
    ee[0] = GOALS[0, 0] - 0.005
    kept = UserState(kept_mode=0, requested_at_start=True)
    cfg = dataclasses.replace(NO_REQUESTS, keep_assisted_mode=True)
    s = step(kept, 1.0, 0, interface=interface, config=cfg, ee=ee, belief=np.array([0.9, 0.1]))
    assert s.raw[0] > 0.0 and s.raw[2] == 0.0 and s.kept_mode == 0  # toward +x, no press
    assert UserState.from_vector(s.to_vector()) == s
    for belief in ([0.1, 0.9], [0.5, 0.5]):  # pulled toward the other goal; no assistance
        away = step(kept, 1.0, 0, interface=interface, config=cfg, ee=ee, belief=np.array(belief))
        assert away.raw[2] == 1.0 and away.kept_mode == -1
    plain = step(  # not the kept mode
        UserState(requested_at_start=True), 1.0, 0, interface=interface, ee=ee, belief=np.array([0.9, 0.1])
    )
    assert plain.raw[2] == 1.0


@pytest.mark.parametrize("interface", [HEAD, JOY])
def test_a_push_in_a_kept_mode_holds_its_direction_while_the_arm_crosses_the_goal(
    interface: InterfaceConfig,
) -> None:
    # x is done 5 mm short (z is left) in the kept mode 0 while assisted: the push goes toward +x.
    # The assistance then carries the arm 5 mm past the goal along x, still within tolerance: the
    # push keeps its direction (it does not turn back at every crossing). Once x is out of
    # tolerance the user drives back as usual and the push is over; the next one aims anew.
    cfg = dataclasses.replace(NO_REQUESTS, keep_assisted_mode=True)
    helping = np.array([0.9, 0.1])
    ee = EE.copy()
    ee[0] = GOALS[0, 0] - 0.005
    s = step(
        UserState(kept_mode=0, requested_at_start=True),
        1.0,
        0,
        interface=interface,
        config=cfg,
        ee=ee,
        belief=helping,
    )
    assert s.raw[0] > 0.0 and (s.push_mode, s.push_axis, s.push_sign) == (0, 0, 1.0)
    assert UserState.from_vector(s.to_vector()) == s
    ee[0] = GOALS[0, 0] + 0.005  # past the goal, within tolerance
    s = step(s, 1.1, 0, interface=interface, config=cfg, ee=ee, belief=helping)
    assert s.raw[0] > 0.0 and s.push_sign == 1.0  # still toward +x
    ee[0] = GOALS[0, 0] + 0.05  # out of tolerance: back toward the goal, the push over
    s = step(s, 1.2, 0, interface=interface, config=cfg, ee=ee, belief=helping)
    back = s.raw[0] < 0.0 if interface is JOY else s.raw[1] == 1.0
    assert back and s.push_mode == -1
    ee[0] = GOALS[0, 0] + 0.005  # done again: a new push, toward the goal now (-x)
    s = step(s, 1.3, 0, interface=interface, config=cfg, ee=ee, belief=helping)
    assert s.push_sign == -1.0 and (s.raw[0] < 0.0 if interface is JOY else s.raw[1] == 1.0)


def test_with_stay_while_assisted_a_joystick_user_keeps_any_mode_while_the_assistance_helps() -> None:
    # As above, but mode 0 was the user's own choice (no request): with stay_while_assisted the
    # joystick user keeps it while the autonomy assists the goal (win-stay: a small push blended
    # with the autonomy's command), and does not review it; otherwise it leaves it. The head
    # array's full-speed switches would drive the arm away along the done dimension: it leaves.
    ee = EE.copy()
    ee[0] = GOALS[0, 0] - 0.005
    own = UserState(requested_at_start=True)
    helping = np.array([0.9, 0.1])
    stay = dataclasses.replace(NO_REQUESTS, stay_while_assisted=True, mode_review_rate=1000.0)
    s = step(own, 1.0, 0, interface=JOY, config=stay, ee=ee, belief=helping)
    assert 0.0 < s.raw[0] <= stay.command.min_axis + 1e-12 and s.raw[2] == 0.0  # a small push toward +x
    away = step(own, 1.0, 0, interface=JOY, config=stay, ee=ee, belief=np.array([0.5, 0.5]))
    assert away.raw[2] == 1.0  # no assistance: x is done, it goes for z
    plain = dataclasses.replace(stay, stay_while_assisted=False)
    assert step(own, 1.0, 0, interface=JOY, config=plain, ee=ee, belief=helping).raw[2] == 1.0
    assert step(own, 1.0, 0, interface=HEAD, config=stay, ee=ee, belief=helping).raw[2] == 1.0


def test_a_review_that_wants_another_mode_may_ask_for_it_instead() -> None:
    # In vz with vx far from done, a review leaves vz: by cycling, or (request_instead_prob 1, a
    # belief) by a request.
    review = dataclasses.replace(NO_REQUESTS, mode_review_rate=1000.0)
    flat = np.array([0.5, 0.5])
    s = step(UserState(requested_at_start=True), 0.0, 2, config=review, interface=HEAD, belief=flat)
    assert s.raw[2] == 1.0 and s.target_mode == 0
    ask = dataclasses.replace(review, request_instead_prob=1.0)
    s = step(UserState(requested_at_start=True), 0.0, 2, config=ask, interface=HEAD, belief=flat)
    assert s.raw[3] == 1.0 and s.request_mode == 2


def test_a_stalled_user_with_nothing_else_to_do_asks_for_help_when_it_can() -> None:
    # Only the x error is left and the arm does not follow (the autonomy holding it at another
    # goal): with requests available the user asks for disambiguation after stall_time.
    ee = EE.copy()
    ee[2] = GOALS[0, 2]
    cfg = UserConfig(request_at_start=False, request_when_unhelped_for=None, request_instead_prob=0.4)
    s, presses = UserState(), []
    for k in range(301):
        s = step(s, k * 0.01, 0, interface=HEAD, config=cfg, ee=ee, belief=np.array([0.1, 0.9]))
        presses.append(s.raw[3])
    assert max(presses) == 1.0 and s.presses >= 1


# ---------------------------------------------------------------------------------------------
# direct mode selection (joystick)
# ---------------------------------------------------------------------------------------------

JOY_DIRECT = InterfaceConfig(kind="joystick", mode_selection="direct")


def _presses_to_target(interface: InterfaceConfig, config: UserConfig, mode: int, ee: np.ndarray):
    """Run the user against the core interface (every 10 ms) until it commands the arm; return the
    presses it made, the mode it ends in and the interface's logged switches."""
    s, itf = UserState(), initial_state(dataclasses.replace(interface, initial_mode=mode))
    events = []
    for k in range(1000):
        t = k * 0.01
        s = step(s, t, itf.mode, interface=interface, config=config, ee=ee)
        itf, ev = interface_update(itf, s.raw, t, interface)
        events += ev
        if command_from_raw(itf.held_raw, itf.mode, interface)[0].any():
            break
    return s.presses, itf.mode, events


def test_user_reaches_a_target_mode_in_one_direct_press() -> None:
    # Only wy is left to do (a rotation about y): the target is mode 3 ({wy}). From {vx, vy} the
    # cycling joystick takes 3 presses (0 -> 1 -> 2 -> 3), direct selection one.
    ee = np.array([0.2, -0.4, 0.25, *quat_from_rotvec(np.array([0.0, 0.3, 0.0]))])
    presses, mode, events = _presses_to_target(JOY, NO_REQUESTS, 0, ee)
    assert (presses, mode, len(events)) == (3, 3, 3)
    presses, mode, events = _presses_to_target(JOY_DIRECT, NO_REQUESTS, 0, ee)
    assert (presses, mode) == (1, 3)
    assert [(e.kind, e.from_mode, e.to_mode) for e in events] == [("mode_switch", 0, 3)]


def test_overshoot_is_a_cycling_error_not_a_direct_selection_one() -> None:
    # Only wy is left to do: the target is mode 3 ({wy}). A user who always presses once too many
    # on reaching its target does so while cycling (one step past wy, then round again); with
    # direct selection a change is one deliberate press and there is nothing to overshoot.
    ee = np.array([0.2, -0.4, 0.25, *quat_from_rotvec(np.array([0.0, 0.3, 0.0]))])
    config = dataclasses.replace(NO_REQUESTS, overshoot_prob=1.0)
    presses, mode, events = _presses_to_target(JOY, config, 0, ee)
    assert [(e.from_mode, e.to_mode) for e in events][:4] == [(0, 1), (1, 2), (2, 3), (3, 4)]
    assert mode == 3 and presses > 3
    presses, mode, events = _presses_to_target(JOY_DIRECT, config, 0, ee)
    assert [(e.from_mode, e.to_mode) for e in events] == [(0, 3)]
    assert (presses, mode) == (1, 3)


def test_press_cost_counts_one_press_per_direct_selection() -> None:
    assert presses_to(0, np.arange(4), 5).tolist() == [0, 1, 2, 3]
    assert presses_to(0, np.arange(4), 5, direct=True).tolist() == [0, 1, 1, 1]
    assert presses_to(3, 1, 5) == 3 and presses_to(3, 1, 5, direct=True) == 1
    u = mode_usefulness([1.0, 1.0, 1.0, 1.0], 0, 5, 0.1, direct=True)
    assert u.tolist() == pytest.approx([1.0, 0.9, 0.9, 0.9])


@pytest.mark.parametrize(
    ("interface", "presses"), [(JOY, 4), (JOY_DIRECT, 1), (HEAD, 6)], ids=["cycle", "direct", "head_array"]
)
def test_at_the_goal_of_a_release_stage_the_user_changes_to_the_gripper_mode_and_opens_it(
    interface: InterfaceConfig, presses: int
) -> None:
    # At the goal (rule 1) with a release: from the first mode to the gripper mode (the last), by
    # cycling (4 presses on the joystick, 6 on the head array) or one direct selection; then it
    # opens the gripper (the gripper mode's one dimension, joystick axis_x / head-array left) and
    # keeps it open, while the arm gets no command.
    ee = EE.copy()
    ee[:3] = GOALS[0, :3]
    grip = len(interface.modes) - 1
    s, itf = UserState(), initial_state(interface)
    events, gripper = [], []
    for k in range(600):
        t = k * 0.01
        s = user_step(s, t, itf.mode, ee, GOALS, 0, interface, NO_REQUESTS, None, release=True)
        itf, ev = interface_update(itf, s.raw, t, interface)
        events += ev
        u_h, g = command_from_raw(itf.held_raw, itf.mode, interface)
        assert not u_h.any()  # the arm is not driven
        gripper.append(g)
    assert itf.mode == grip and s.presses == presses
    assert [e.to_mode for e in events][-1] == grip and all(e.kind == "mode_switch" for e in events)
    assert gripper[-1] == pytest.approx(interface.gripper_speed) and min(gripper) == 0.0  # opens
    # without a release the user lets go at the goal (rule 1)
    s = user_step(UserState(), 0.0, 0, ee, GOALS, 0, interface, NO_REQUESTS, None)
    np.testing.assert_array_equal(s.raw, np.zeros(4))


def test_a_release_stage_does_not_stop_the_user_short_of_the_goal() -> None:
    # Away from the goal a release changes nothing: the user drives toward it as before.
    a = step(UserState(), 0.0, 0)
    b = user_step(UserState(), 0.0, 0, EE, GOALS, 0, JOY, NO_REQUESTS, None, release=True)
    assert a == b


def test_system_releases_per_stage() -> None:
    from drake_disamb.user.system import SimulatedUser

    user = SimulatedUser("head_array", [0, 1], 2, NO_REQUESTS, releases=[False, True])
    assert user.releases == (False, True)
    ee = EE.copy()
    ee[:3] = GOALS[1, :3]  # at goal 1: stage 1's goal, which ends with a release
    sim, ctx = _user_context(user, mode=6, ee=ee)  # already in the gripper mode
    out = user.get_output_port(0)
    user.GetInputPort("stage").FixValue(ctx, [1.0])
    sim.AdvanceTo(0.005)
    np.testing.assert_array_equal(out.Eval(ctx), [1, 0, 0, 0])  # left: opens the gripper
    with pytest.raises(AssertionError):  # one per stage: the resolved scenario's
        SimulatedUser("head_array", [0, 1], 2, releases=[True])


def test_user_config_groups_take_flat_fields_and_replace() -> None:
    from drake_disamb.user import FIELD_GROUPS, RequestConfig, TimingConfig

    cfg = UserConfig(reaction_time=0.5, request_prob=0.4, seed=3)
    assert cfg.timing == TimingConfig(reaction_time=0.5) and cfg.requests == RequestConfig(request_prob=0.4)
    assert cfg.seed == 3 and cfg.flat()["reaction_time"] == 0.5
    again = dataclasses.replace(cfg, settle_time=0.2, pause_rate=0.1)
    assert (
        again.timing.reaction_time == 0.5
        and again.timing.settle_time == 0.2
        and again.pauses.pause_rate == 0.1
    )
    assert UserConfig(timing=TimingConfig(reaction_time=0.5), request_prob=0.4, seed=3) == cfg
    assert set(FIELD_GROUPS) | {"seed", "rho1"} <= set(UserConfig.flat_types())
    assert list(UserConfig.flat_types()) == list(UserConfig().flat())
    assert UserConfig(**UserConfig(aim_error=0.2).flat()) == UserConfig(aim_error=0.2)
    with pytest.raises(ValueError, match=r"UserConfig: unknown fields \['reaction'\]"):
        UserConfig(reaction=0.5)
    with pytest.raises(ValueError, match=r"UserConfig\.timing: expected a TimingConfig"):
        UserConfig(timing=RequestConfig())
    with pytest.raises(ValueError, match=r"UserConfig\.pause_duration: expected a finite number > 0"):
        UserConfig(pause_duration=0.0)


def test_the_rules_are_one_function_each_in_order() -> None:
    from drake_disamb.user import rules

    names = [rule.__name__ for rule in rules.RULES]
    assert names[0] == "release_rule" and names[-1] == "pause_rule" and len(set(names)) == len(names)
    assert names.index("request_rule") < names.index("target_rule") < names.index("stall_rule")


def test_a_user_waits_while_the_system_is_busy_and_its_watches_start_again() -> None:
    """While the system computes a disambiguation with its loop paused (``paused``) the
    user lets go, whatever it was doing, and its stall and blocked watches start again after."""
    state = UserState()
    for k in range(30):  # driving +x in vx, watches running
        state = step(state, k * 0.01, 0, interface=HEAD)
    driving = HEAD.variant.is_driving
    assert driving(state.raw) and state.progress_mode == 0 and state.blocked_time > 0
    busy = user_step(state, 0.3, 0, EE, GOALS, 0, HEAD, NO_REQUESTS, None, False, True)
    assert not busy.raw.any()
    assert busy.progress_mode == -1 and busy.blocked_time == 0.0
    again = step(busy, 0.31, 0, interface=HEAD)  # not busy: it drives again
    assert driving(again.raw)


def test_waiting_for_the_system_is_not_being_unhelped() -> None:
    """A user that asks when unhelped for 3 s, and a system that takes longer than that to answer:
    after the answer the user drives (the timer starts again), it does not ask again at once."""
    config = UserConfig()  # requests at the start and when unhelped for 3 s
    uniform = np.full(2, 0.5)
    state = user_step(UserState(), 0.0, 0, EE, GOALS, 0, HEAD, config, uniform)
    assert state.raw[3] == 1.0  # the request at the start
    t = 0.01
    while t < 3.5:  # the system computes for 3.5 s
        state = user_step(state, t, 0, EE, GOALS, 0, HEAD, config, uniform, False, True)
        assert not state.raw.any()
        t += 0.01
    raws = []
    for k in range(200):  # 2 s after the answer
        state = user_step(state, 3.5 + 0.01 * k, 0, EE, GOALS, 0, HEAD, config, uniform)
        raws.append(state.raw.copy())
    assert not any(r[3] for r in raws)
    assert any(HEAD.variant.is_driving(r) for r in raws)


def test_while_unsure_a_user_translates_first_with_unsure_rotation_weight() -> None:
    # The head array in vx, done; z 0.05 m off (6 tolerances) and the gripper turned 0.5 rad about
    # z (10 tolerances): the oracle's next mode is wz. With unsure_rotation_weight 0 and the belief
    # unsure (or on the other goal) it is vz; with the assistance helping, wz again (it rotates
    # then); with nothing left to translate, wz whatever the belief.
    ee = np.array([*GOALS[0, :2], GOALS[0, 2] + 0.05, *quat_from_rotvec(np.array([0.0, 0.0, 0.5]))])
    flat, elsewhere, helping = np.array([0.5, 0.5]), np.array([0.1, 0.9]), np.array([0.9, 0.1])
    first = dataclasses.replace(NO_REQUESTS, unsure_rotation_weight=0.0)
    wz, vz = 5, 2

    def target(config: UserConfig, belief: np.ndarray | None, at: np.ndarray = ee) -> int:
        s = step(
            UserState(requested_at_start=True), 0.0, 0, interface=HEAD, config=config, ee=at, belief=belief
        )
        return s.target_mode

    assert target(NO_REQUESTS, flat) == wz and target(NO_REQUESTS, None) == wz
    assert target(first, flat) == vz and target(first, elsewhere) == vz and target(first, None) == vz
    assert target(first, helping) == wz
    level = ee.copy()
    level[2] = GOALS[0, 2]
    assert target(first, flat, level) == wz
    with pytest.raises(
        ValueError, match=r"UserConfig.unsure_rotation_weight: expected a number in \[0, 1\], got 1.5"
    ):
        UserConfig(unsure_rotation_weight=1.5)
