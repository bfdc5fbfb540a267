"""The simulated user of a control interface (pure numpy): deterministic by default, human-like
(reaction times, noise, Boltzmann mode choice, pauses, requests) with the fields listed under
"Human behaviour" below.

The user knows its goal pose. Every control tick it looks at the interface's current mode, the
end-effector pose, the goal poses and (optionally) the belief, and produces the interface's raw
signal, through the interface's own actions (``Interface.drive_raw``, ``change_raw``, ``request_raw``:
a mode change is the joystick's mode button, the head array's back switch, or what the kind uses):

1. **Done**: within the success tolerance of its goal (position *and* orientation) it lets go
   (raw all zeros). At the goal of a stage that ends by letting go of the held object
   (``release``: the pouring task's cup, set down at its place) it instead changes to the gripper
   mode (pressing as in rule 4, then its settle) and opens the gripper until the stage ends.
2. **Reacting**: after any button press it waits a reaction time with everything released (so
   presses are single rising edges and it sees the new mode before acting again).
   While the system computes a disambiguation with its loop paused (``paused``: the arm does
   not respond) it waits too, everything released, and its stall and blocked watches (rule 5) and
   its "unhelped" timer (rule 3) start again after.
3. **Request**: it presses the disambiguation button at the start of the trial
   (``request_at_start``) and whenever the autonomy has not been helping for
   ``request_when_unhelped_for`` seconds: "not helping" means the belief's argmax is not its goal,
   or the belief is too flat for any assistance (``p(g*) <= rho1``, i.e. alpha = 0). Needs the belief.
4. **Mode switch**: the *remaining error* of a dimension is its absolute error divided by its
   tolerance (``position_tolerance`` for vx..vz, ``orientation_tolerance`` for wx..wz), that of a
   mode the largest over its dimensions (0 for the gripper). When the current mode's remaining error
   is at most 1 (nothing left to do in it) the user picks the arm mode with the largest remaining
   error as its *target* and makes a mode change (the joystick's ``mode_button``, the head
   array's ``back``: ``Interface.change_raw``) once per reaction time until the target is active,
   also through modes on the way that would help a little (the shorter way round on an interface
   that also steps back). With a joystick that selects modes directly
   (``InterfaceConfig.mode_selection == "direct"``) it instead deflects the stick into the
   target's sector and presses once (:func:`~drake_disamb.interfaces.kinds.joystick.sector_stick`): one
   press per change. The target is dropped when it is reached, when it has nothing left to do
   (the autonomy finished it), or after a disambiguation request (the user then re-evaluates the
   mode the disambiguation system chose).
5. **Stall**: when it has been commanding in the current mode for ``stall_time`` seconds and the
   mode's remaining error has not fallen by ``stall_progress`` (tolerance units) -- the arm is held
   up by a joint limit, a singularity or the autonomy pulling elsewhere -- the mode no longer helps:
   the user targets the *other* arm mode with the largest remaining error (if any is above 1) and
   cycles to it as in 4. Any press restarts the count. With no other mode left, a user who can ask
   for disambiguation (a belief and ``request_instead_prob > 0``) does so: the autonomy is holding
   the arm at another goal, or a limit holds it; otherwise it keeps trying.
   **Backing off**: after ``backoff_after`` seconds of commanding (in any modes, across presses
   and requests) without the goal's remaining error, summed over the arm modes, falling by
   ``stall_progress``, the arm is blocked: the user drives back the way it came in its mode for
   ``backoff_time`` seconds, then routes around: over the obstacle first (``detour_lift``: in a
   mode that does not move the hand vertically, it lifts the end effector that much and keeps it
   up until the blocked mode's dimensions are done), else by changing to the best other mode
   with work left, or it tries again in this one when there is none. A user who can ask for
   disambiguation may ask instead of routing around (``request_instead_prob``, as for any change
   of its own).
6. **Command**: otherwise it drives toward its goal along the current mode's dimensions.
   A proportional interface (the joystick): axis k for the mode's k-th dimension, proportional to
   the error (``error / approach_time`` as a share of the interface's full-deflection speed), at
   least ``min_axis`` while the error exceeds the tolerance and 0 once within it. A switched one
   (the head array's ``left`` / ``right``): full drive positive when the error along the dimension
   is above its tolerance, negative when below minus it (``Interface.drive_raw``).

Errors are in the world frame: position ``x_goal - x_ee`` (m) and the world-frame rotation vector
``orientation_error(q_ee, q_goal)`` (rad), whose components a world-frame angular velocity along
``wx``, ``wy``, ``wz`` reduces. The success tolerances must be at least ``sqrt(3)`` times the
per-dimension tolerances, so "every dimension within tolerance" implies success and the user never
runs out of useful modes before it is done.

The rules are one function each (:mod:`drake_disamb.user.rules`), the settings one nested
config per behaviour (:mod:`drake_disamb.user.config`). Randomness is optional and seeded:
``reaction_time_jitter`` (uniform, +/- s) and ``axis_noise``
(Gaussian std added to joystick axes). Each draw uses ``default_rng([seed, counter])`` with a
counter kept in the state, so a run is a pure function of the seed.

**Human behaviour** (every field off by default, which is the deterministic user above; the
population of :mod:`drake_disamb.user.population` turns them on, docs/population.md gives the
values and where they come from):

- *Decision rate*: ``decision_period`` (s) is how often the user decides (the
  :class:`~drake_disamb.user.system.SimulatedUser` ticks at it; the raw signal is held between
  decisions). Every wait is at least two decision periods, so a press is one rising edge.
- *Reaction times*: the wait after a press is lognormal with median ``reaction_time`` and log-sd
  ``reaction_log_sd``; after a mode change is finished (the target reached, or the mode a request
  chose) the user waits a further lognormal ``settle_time`` (with probability ``settle_prob``)
  before commanding; at the start of the
  trial it does nothing but an optional request for a lognormal ``start_delay``, at most
  ``start_delay_max``.
- *Command noise*: the joystick's stick vector (``[axis_x, axis_y]``, the intended deflection of
  rule 6) gets a direction drawn from a von Mises-Fisher distribution of concentration
  ``direction_kappa`` about the intended one and a magnitude scaled by a lognormal factor of
  log-sd ``deflection_log_sd``, once per decision. *Switch timing*: when the user stops driving
  (either interface), it lets go late by an exponential ``release_lag`` (mean, s). *Wrong
  presses*: when it starts to drive it hits the mode button instead with probability
  ``wrong_press_prob``.
- *Mode choice*: a new mode is drawn by softmax over the modes' usefulness
  (:func:`mode_usefulness`: remaining error as a share of the largest, less ``press_cost`` per
  press it takes to get there) with temperature ``mode_temperature`` (0 = the best mode, rule 4);
  the presses are made one by one, and on reaching its target the user presses once more with
  probability ``overshoot_prob`` (and must go round again). With direct selection every other mode
  is one press away (``press_cost`` once) and there is nothing to overshoot: a change is one
  deliberate press with the stick in the target's sector (the joystick logs' consecutive button
  events less than 1 s apart are 3-4 % of them; an overshoot, a centred press and a second
  selection, made 11-17 % with ``overshoot_prob`` from the head array, 4-5 % without); a wrong
  press, made with the stick centred, cycles on either interface. With ``mode_review_rate`` it also
  reviews its mode while it still helps (the same choice, the current mode in it at no press cost)
  and leaves it for a clearly better one, as people interleave modes (not while a kept mode, below,
  carries it). With ``unsure_rotation_weight`` below 1, while the autonomy does not
  assist its goal and a translation is left, a rotation mode's remaining error counts that much
  in the choice (translating first).
- *Judging where to stop*: on entering an arm mode the user judges by eye where to stop along
  its dimensions and stops short by a half-normal share (scale ``aim_error``) of the distance it
  sees; the mode then looks done. With probability ``correction_prob`` (``stick_correction_prob``
  with a proportional interface, when set; or when nothing else is
  left) it sees the shortfall and corrects it at once in the same mode, aiming anew (a corrective
  submovement, Meyer et al. 1988); else it moves on and comes back later.
- *Pauses*: at a decision where it would command, it starts a pause with rate ``pause_rate``
  (per second), of lognormal duration (median ``pause_duration``, log-sd ``pause_log_sd``).
- *Letting the autonomy carry the arm*: when it wants another mode (its mode has nothing left to
  do, has stalled, or a review prefers another) while the autonomy assists its goal (the blending
  assists without input), it lets go with probability ``carry_prob`` instead of changing mode,
  and watches for a lognormal time (median ``carry_duration``, log-sd ``pause_log_sd``); then it
  decides again (another carry only if the last one brought the goal's remaining error down by
  ``stall_progress`` or by a quarter). A carry ends at once when the assistance stops helping
  (the belief turns to another goal, or falls flat).
- *Counter-steering*: when it wants another mode while the autonomy assists *another* goal (the
  arm heads for another object), it keeps pushing toward its goal in its mode instead, with
  probability ``counter_prob``, for a lognormal time (median ``carry_duration``), then decides
  again; the push ends at once when the assistance no longer pulls elsewhere.
- *Requests*: a request the policy calls for (at the start, when unhelped) is made with
  probability ``request_prob``; when a new mode is needed (its mode done, a stall, a review that
  wants another, or routing around after a back-off) the user asks for disambiguation instead
  of cycling with probability ``request_instead_prob``; both scaled by
  ``exp(-t / request_decay_time)`` (requests concentrate early). After a request it waits up to
  ``request_wait`` seconds for the mode to change, then keeps the mode the system chose with
  probability ``accept_prob`` or cycles away from it to a mode of its own choice. With
  ``keep_assisted_mode`` it keeps using a kept mode while the autonomy assists its goal, also once
  the mode's own dimensions are done (pushing toward the goal in it, along the dimension and in
  the direction the push began with, for as long as the push lasts), until the whole goal's
  remaining error stops falling (rule 5) or the assistance stops. With ``stay_while_assisted`` a
  joystick user uses any arm mode so (win-stay while assisted).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from drake_disamb.core.blending import RHO1_TIMES_N
from drake_disamb.core.sampling import lognormal
from drake_disamb.interfaces import RAW_SIZE, InterfaceConfig
from drake_disamb.user.config import UserConfig
from drake_disamb.user.judgement import draw, goal_error, goal_reached, helped, misled
from drake_disamb.user.rules import decide
from drake_disamb.user.state import NOT_COUNTING, UserState, evolve

__all__ = ["user_step"]


def user_step(
    state: UserState,
    time: float,
    mode: int,
    ee_pose: ArrayLike,
    goal_poses: ArrayLike,
    goal_index: int,
    interface: InterfaceConfig,
    config: UserConfig,
    belief: ArrayLike | None = None,
    release: bool = False,
    paused: bool = False,
) -> UserState:
    """One decision of the simulated user. Returns the new state; its ``raw`` is the output.

    Args:
        state: The state after the previous decision.
        time: Current time (s).
        mode: The interface's current mode index.
        ee_pose: End-effector pose ``[x, y, z, qw, qx, qy, qz]``.
        goal_poses: ``(n, 7)`` (or flat ``n * 7``) goal poses.
        goal_index: The user's goal.
        interface: The interface it operates (modes, raw layout, speeds).
        config: The user's behaviour.
        belief: The current belief over goals (``n``), or ``None`` if unavailable (then no
            "unhelped" requests and no requests instead of mode switches are made).
        release: The goal is reached only once the held object is let go (a stage with a
            release, :attr:`drake_disamb.config.StageSpec.release_opening`): at the goal the user
            changes to the gripper mode and opens the gripper, instead of letting go of the
            interface (rule 1).
        paused: The system is computing a disambiguation and its loop is paused (the arm
            does not respond: :attr:`drake_disamb.config.DisambiguationSpec.hold_while_computing`,
            also after an automatic trigger the user did not ask for). The user sees the arm stop
            and waits, everything released; its stall and blocked watches start again after.
    """
    goals = np.asarray(goal_poses, dtype=float).reshape(-1, 7)
    n = goals.shape[0]
    if not (0 <= goal_index < n):
        raise ValueError(f"goal_index: expected an integer in [0, {n - 1}], got {goal_index!r}")
    modes = interface.modes
    if not (0 <= mode < len(modes)):
        raise ValueError(
            f"mode: expected an integer in [0, {len(modes) - 1}] for {interface.kind}, got {mode!r}"
        )
    err = goal_error(ee_pose, goals[goal_index], config.use_orientation)

    reached = goal_reached(err, config)
    if reached and not release:
        return evolve(
            state, raw=np.zeros(RAW_SIZE), unhelped_since=NOT_COUNTING, target_mode=-1, hold_until=0.0
        )
    if reached:  # at the goal, letting go of the object (rule 1 with a release): no late release
        state = evolve(state, hold_until=0.0)
    if paused:
        # Waiting for the system's answer is not being unhelped: that timer starts again after too
        # (else a user that asks when unhelped for less than the answer takes asks again at once).
        return evolve(
            state,
            raw=np.zeros(RAW_SIZE),
            hold_until=0.0,
            progress_mode=-1,
            blocked_time=0.0,
            unhelped_since=NOT_COUNTING,
        )

    # The "unhelped" timer runs whenever the belief is known, also while reacting.
    unhelped_since = NOT_COUNTING
    if belief is not None and config.requests.request_when_unhelped_for is not None and not reached:
        rho1 = RHO1_TIMES_N / n if config.rho1 is None else config.rho1
        if not helped(belief, goal_index, rho1):
            unhelped_since = time if state.unhelped_since == NOT_COUNTING else state.unhelped_since
    state = evolve(state, unhelped_since=unhelped_since)

    if not state.started:
        start_until = 0.0
        draws = state.draws
        if config.timing.start_delay > 0:
            rng = draw(config, draws) if config.timing.start_delay_log_sd > 0 else None
            draws += rng is not None
            delay = lognormal(config.timing.start_delay, config.timing.start_delay_log_sd, rng)
            if config.timing.start_delay_max is not None:
                delay = min(delay, config.timing.start_delay_max)
            start_until = time + delay
        state = evolve(state, started=True, start_until=start_until, draws=draws)

    rho1 = RHO1_TIMES_N / n if config.rho1 is None else config.rho1
    assisted = belief is not None and helped(belief, goal_index, rho1)
    elsewhere = belief is not None and not assisted and misled(belief, goal_index, rho1)
    if state.carrying and time < state.busy_until - 1e-9 and not assisted:
        state = evolve(state, busy_until=0.0)  # the assistance stopped helping: the carry ends
    if time < state.busy_until - 1e-9:
        return evolve(state, raw=np.zeros(RAW_SIZE))
    if time < state.hold_until - 1e-9:
        return state  # letting go late: the drive is held
    lag_done = state.hold_until > 0.0
    new = decide(state, time, mode, err, interface, config, belief, assisted, reached, elsewhere)
    driving = interface.variant.is_driving
    if (
        config.timing.release_lag > 0
        and not lag_done
        and not reached
        and driving(state.raw)
        and not driving(new.raw)
    ):
        # The lag has a stream of its own keyed by this decision's counter, and the counter is not
        # advanced: the decision made when the lag ends replays this one's draws, so the user
        # carries out late what it decided (a pause, a review's or a correction's outcome) instead
        # of drawing it anew (which made every random reason to stop driving twice as likely, or,
        # for a rate per decision, almost never carried out).
        rng = np.random.default_rng([int(config.seed), int(state.draws), 1])
        lag = float(rng.exponential(config.timing.release_lag))
        return evolve(state, hold_until=time + lag)
    if new.hold_until != 0.0:
        new = evolve(new, hold_until=0.0)
    return new
