"""Every check of a scenario beyond its types: what :func:`check_scenario` rejects, so that every
trial it lets through can be run.

First the types, on the scenario's plain data (:func:`~drake_disamb.config.checks.check_data`:
an unknown key, a wrong type, a NaN or infinite number, a vector of the wrong length, a string
that is not one of its field's choices). Then:

- a ``control_period`` or ``plant_config.time_step`` outside [1 ms, 100 ms]
  (:data:`~drake_disamb.core.validation.TIME_STEP_RANGE`), a plant step above the period, a
  ``plant_config`` the station cannot use (:func:`drake_disamb.station.check_plant_config`), or a
  ``station`` backend's setting it cannot use (:func:`check_station`);
- a ``simulator_config`` Drake would refuse, or that does not start at t = 0;
- no goal, more than :data:`~drake_disamb.core.validation.MAX_GOALS` goals, more stages than goals,
  stages with different numbers of goals;
- a goal out of the arm's reach (:data:`MICO_REACH` from the shoulder), or in or over its base
  (closer than :data:`MIN_BASE_DISTANCE` to the base's axis);
- a ``duration`` outside (0, :data:`~drake_disamb.config.checks.MAX_DURATION`] (so no trial runs
  practically forever), a hold time (``success.hold_time``, ``stages[i].hold_time``) that is
  negative, or (:func:`check_hold_times`, for a scenario as specified) not shorter than the
  duration, a ``disambiguation.request_latency`` outside
  [0, :data:`~drake_disamb.config.checks.MAX_REQUEST_LATENCY`] (the bounds the protocol and the
  commands' options share);
- a DFT time constant (``inference.dft.tau1``, ``tau2``) not above 0, a negative ``lam``;
- a goal below the table: with the end effector at the goal pose, the gripper (closed or open) and
  the carried object must stay :data:`MIN_TABLE_CLEARANCE` above the table top, and the goal's
  object must not reach below the table top;
- two goals of one stage closer than twice ``success.position_tolerance``
  (:func:`min_goal_separation`): closer, a position within the tolerance of both exists, so reaching
  one can count as reaching the other, and each goal's repeller pushes the arm off the other;
- start joint angles outside the joint limits, or that put a link, a finger or the carried object
  less than :data:`MIN_TABLE_CLEARANCE` above the table top (forward kinematics of the station's
  model, :mod:`drake_disamb.station.geometry`);
- a simulated user whose intended goals or success tolerances do not fit the task, who decides
  more often than the control period, or who waits less than two decisions after a press.

Every error is a ``ValueError`` naming the field path and the value, e.g.
``scenario.goals[3].position: goal 'yellow_bottle' is out of the arm's reach: ...``. The checks of
the core's own configs (``DFTParams``, ``BlendingConfig``...) run when the resolver builds them
(:func:`drake_disamb.config.resolve.resolve_scenario`), which calls :func:`check_scenario` first.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from drake_disamb.config.checks import (
    check_data,
    check_duration,
    check_request_latency,
    fmt,
)
from drake_disamb.config.schema import Scenario, SuccessSpec, to_plain
from drake_disamb.core.inference import INFERENCE_METHODS, DFTInference
from drake_disamb.core.layout import SHAPE_SIZES
from drake_disamb.core.validation import MAX_GOALS, TIME_STEP_RANGE, check_real_range

MICO_SHOULDER_POSITION: tuple[float, float, float] = (0.0, 0.0, 0.2755)
"""Position (m, in W) of the MICO's shoulder joint: D1 above the base (docs/facts.md section 8)."""

MICO_REACH: float = 0.7
"""Radius (m) about the shoulder beyond which a goal is rejected as out of reach (docs/facts.md section 8)."""

MIN_BASE_DISTANCE: float = 0.15
"""A goal closer than this (m) to the base's axis (the z axis of W) is refused: it lies in or over
the arm's base and shoulder, where the gripper cannot be placed."""

MIN_START_CLEARANCE: float = 0.05
"""A goal closer than this (m) to the gripper's start position is rejected: the task would be trivial."""

MIN_TABLE_CLEARANCE: float = 0.005
"""Height (m) above the table top that the arm, the gripper and the carried object must keep at the
start posture and at every goal pose."""


def min_goal_separation(success: SuccessSpec) -> float:
    """Smallest distance (m) allowed between two goal positions of one stage.

    Twice ``success.position_tolerance``: a goal counts as reached within that distance of it, so
    closer goals share positions that count as reaching both (the belief cannot tell them apart, and
    each goal's repeller pushes the arm off the other). Orientations do not relax this: the
    autonomy's repellers act on positions only. For the embedded tasks (tolerance 0.02 m) it is
    0.04 m; their goals are 0.24 m or more apart.
    """
    return 2.0 * success.position_tolerance


def check_counts(n_goals: int | None, n_stages: int | None, name: str = "scenario") -> None:
    """Reject no goal, no stage, more than :data:`MAX_GOALS` goals or more stages than goals (a
    count ``None``: not known, as in a layer that does not write the list).

    Cheap, so the loader runs it on each layer's parsed data before Drake's (slower) loader reads it.
    """
    if n_stages == 0:
        raise ValueError(f"{name}.stages: expected at least one stage, got []")
    if n_goals == 0:
        raise ValueError(f"{name}.goals: expected at least one goal, got []")
    if n_goals is not None and n_goals <= MAX_GOALS and n_stages is not None and n_stages > n_goals:
        raise ValueError(
            f"{name}.stages: every stage needs a goal, got {n_stages} stages for {n_goals} goals"
        )
    for what, n in (("goals", n_goals), ("stages", n_stages)):
        if n is not None and n > MAX_GOALS:
            raise ValueError(f"{name}.{what}: expected at most {MAX_GOALS} {what}, got {n}")


def _check_positive(value: float, path: str, allow_zero: bool = False) -> None:
    if not (value >= 0 if allow_zero else value > 0):
        raise ValueError(
            f"{path}: expected a finite number {'>= 0' if allow_zero else '> 0'}, got {fmt(value)}"
        )


def _check_dft(s: Scenario, name: str) -> None:
    """The DFT's time constants are positive and its excitation ``lam`` is not negative (checked
    here, before anything divides by them)."""
    d, path = s.inference.dft, f"{name}.inference.dft"
    _check_positive(d.tau1, f"{path}.tau1")
    _check_positive(d.tau2, f"{path}.tau2")
    lam = np.asarray(d.lam, dtype=float)
    if np.any(lam < 0):
        raise ValueError(f"{path}.lam: expected numbers >= 0, got {fmt(d.lam)}")


def _check_simulator_config(s: Scenario, name: str) -> None:
    from pydrake.systems.analysis import GetIntegrationSchemes

    c, path = s.simulator_config, f"{name}.simulator_config"
    schemes = GetIntegrationSchemes()
    if c.integration_scheme not in schemes:
        got = fmt(c.integration_scheme)
        raise ValueError(f"{path}.integration_scheme: expected one of {', '.join(schemes)}, got {got}")
    _check_positive(c.max_step_size, f"{path}.max_step_size")
    _check_positive(c.accuracy, f"{path}.accuracy")
    _check_positive(c.target_realtime_rate, f"{path}.target_realtime_rate", allow_zero=True)
    if c.start_time != 0.0:
        raise ValueError(f"{path}.start_time: expected 0 (a trial starts at t = 0), got {fmt(c.start_time)}")


FIXED_STEP_STABILITY: dict[str, float] = {
    "explicit_euler": 2.0,
    "runge_kutta2": 2.0,
    "runge_kutta3": 2.51,
}
"""Stability limit of ``h * D`` for the fixed-step explicit schemes, where ``D`` is the decay rate of
the DFT belief's linearised flow (the interval of absolute stability on the negative real axis)."""


def belief_rate_bound(s: Scenario) -> float:
    """An upper bound (1/s) on how fast the DFT belief's flow relaxes: ``1/tau1 + 1/tau2 +
    n |lambda| / 2`` (``sum(drive) = 1/tau2 + sum(lambda sigma(xi))`` with ``|sigma| <= 1/2``), for the
    belief's ``n`` goals (the largest stage's, or every goal with ``inference.goal_set`` ``"task"``)."""
    d = s.inference.dft
    n = max(len(s.belief_goals(k)) for k in range(len(s.stages)))
    lam = np.abs(np.asarray(d.lam, dtype=float))
    excitation = n * float(lam) / 2 if lam.ndim == 0 else float(np.max(lam.sum(axis=1))) * n / 2
    return 1.0 / d.tau1 + 1.0 / d.tau2 + excitation


def _check_belief_integrator(s: Scenario, name: str) -> None:
    """A fixed-step explicit scheme must be stable on the DFT belief
    (``benchmarks/bench_belief_integrator.py`` shows the authors' lambda = 200 at 10 ms taking explicit
    Euler to a negative belief and costing it 2 points of accuracy)."""
    c = s.simulator_config
    limit = FIXED_STEP_STABILITY.get(c.integration_scheme)
    if (
        not issubclass(INFERENCE_METHODS.get(s.inference.method), DFTInference)
        or c.use_error_control
        or limit is None
    ):
        return
    rate = belief_rate_bound(s)
    if c.max_step_size * rate > limit:
        raise ValueError(
            f"{name}.simulator_config.max_step_size: {c.max_step_size!r} s is too long for "
            f"{c.integration_scheme} on this DFT belief (it relaxes at up to {rate:.3g} /s; the "
            f"scheme is stable up to {limit / rate:.3g} s): take a shorter step, runge_kutta3, or "
            "use_error_control: true"
        )


def check_station(s: Scenario, name: str = "scenario") -> None:
    """The station's part of a scenario (all that ``station-demo`` uses): the control period, the
    plant config (:func:`drake_disamb.station.check_plant_config`, a plant step at most the period)
    and the backend's settings (``station``: an ``!Lcm`` station's bus, channels and timeouts).

    Raises:
        ValueError: naming the field path and the value.
    """
    from drake_disamb.station import check_plant_config

    check_real_range(s.control_period, f"{name}.control_period", *TIME_STEP_RANGE, unit="s")
    check_plant_config(s.plant_config, f"{name}.plant_config")
    if s.plant_config.time_step > s.control_period * (1 + 1e-9):
        raise ValueError(
            f"{name}.plant_config.time_step: expected at most the control period ({s.control_period!r} s), "
            f"got {s.plant_config.time_step!r}"
        )
    check = getattr(s.station, "check", None)  # a backend with settings checks them
    if check is not None:
        try:
            check()
        except ValueError as exc:  # its message names station.<field>
            raise ValueError(f"{name}.{exc}") from None


def _check_timing(s: Scenario, name: str) -> None:
    check_station(s, name)
    _check_simulator_config(s, name)
    check_duration(s.duration, f"{name}.duration")
    check_request_latency(s.disambiguation.request_latency, f"{name}.disambiguation.request_latency")


def _check_object(obj: Any, path: str) -> None:
    n = SHAPE_SIZES[obj.shape]
    if len(obj.size) != n:
        raise ValueError(f"{path}.size: expected {n} finite numbers for a {obj.shape}, got {fmt(obj.size)}")
    if any(v <= 0 for v in obj.size):
        raise ValueError(f"{path}.size: expected positive dimensions, got {fmt(obj.size)}")
    if any(not 0 <= v <= 1 for v in obj.color):
        raise ValueError(f"{path}.color: expected [r, g, b, a] in [0, 1], got {fmt(obj.color)}")


def _check_quaternion(q: Sequence[float], path: str) -> None:
    if np.linalg.norm(q) < 1e-6:
        raise ValueError(f"{path}: expected a non-zero quaternion, got {fmt(q)}")


def _solid(label: str, obj: Any, pose: Sequence[float]) -> Any:
    """``obj`` as a :class:`drake_disamb.clearance.Solid` at ``pose`` ``[x, y, z, qw, qx, qy, qz]``."""
    from drake_disamb.clearance import Solid, pose_matrix

    return Solid(label, obj.shape, tuple(obj.size), pose_matrix(pose))


def check_scenario(scenario: Scenario, name: str = "scenario") -> None:
    """Check every field and cross-field constraint of ``scenario`` (see the module docstring).

    The table and start-posture checks use the station's model
    (:func:`drake_disamb.station.geometry.model_geometry`, which imports pydrake).

    Raises:
        ValueError: naming the field path (``scenario.goals[2].position`` ...) and the value.
    """
    s = scenario
    check_data(Scenario, to_plain(s), name)
    _check_timing(s, name)
    for path, value in (
        ("success.position_tolerance", s.success.position_tolerance),
        ("success.orientation_tolerance", s.success.orientation_tolerance),
    ):
        _check_positive(value, f"{name}.{path}")
    _check_positive(s.success.hold_time, f"{name}.success.hold_time", allow_zero=True)
    if s.success.give_up_after is not None:
        check_duration(s.success.give_up_after, f"{name}.success.give_up_after")
    if s.seed < 0:
        raise ValueError(f"{name}.seed: expected a non-negative integer, got {fmt(s.seed)}")
    if s.initial_mode < 0:
        raise ValueError(
            f"{name}.initial_mode: expected a non-negative mode index, got {fmt(s.initial_mode)}"
        )
    check_counts(len(s.goals), len(s.stages), name)
    _check_dft(s, name)
    _check_belief_integrator(s, name)
    for i, stage in enumerate(s.stages):
        if stage.hold_time is not None:
            _check_positive(stage.hold_time, f"{name}.stages[{i}].hold_time", allow_zero=True)
        if stage.release_opening is not None:
            _check_release(stage.release_opening, f"{name}.stages[{i}].release_opening")
    held: list[Any] = []  # the carried object as a clearance.Solid in the end-effector frame
    if s.carried_object is not None:
        c = s.carried_object
        _check_object(c, f"{name}.carried_object")
        _check_quaternion(c.orientation, f"{name}.carried_object.orientation")
        held.append(_solid("carried_object", c, [*c.offset, *c.orientation]))
    _check_goals(s, held, name)
    _check_user(s, name)
    if s.start_joint_positions is not None:
        _check_start_posture(s.start_joint_positions, held, f"{name}.start_joint_positions")
    if s.joint_velocity_limits is not None:
        _check_speed_limits(s.joint_velocity_limits, f"{name}.joint_velocity_limits")


def check_hold_times(scenario: Scenario, name: str = "scenario") -> None:
    """Every hold time (``success.hold_time``, ``stages[i].hold_time``) is shorter than the duration,
    so that a stage can be completed. Applied where a scenario is specified (loaded from a file or
    plain data: the protocol's trials, ``--switch``), not to a scenario cut short on purpose (a
    warm-up run of a fraction of a second)."""
    s = scenario
    holds = [("success.hold_time", s.success.hold_time)]
    holds += [
        (f"stages[{i}].hold_time", st.hold_time) for i, st in enumerate(s.stages) if st.hold_time is not None
    ]
    for path, hold in holds:
        if not hold < s.duration:
            raise ValueError(
                f"{name}.{path}: expected a number of seconds shorter than the duration ({s.duration:g} s), "
                f"got {fmt(hold)}: the stage could never be completed"
            )


def _check_release(opening: float, path: str) -> None:
    """A release opening is wider than the gripper at the start and within its travel (m)."""
    from drake_disamb.station.config import FINGER_MAX_OPENING, MICO_HOME_GRIPPER_OPENING

    if not (MICO_HOME_GRIPPER_OPENING < opening <= FINGER_MAX_OPENING):
        raise ValueError(
            f"{path}: expected an opening (m) above the gripper's at the start "
            f"({MICO_HOME_GRIPPER_OPENING}) and at most {FINGER_MAX_OPENING}, got {fmt(opening)}"
        )


def _check_goals(s: Scenario, held: Sequence[Any], name: str) -> None:
    from drake_disamb import clearance
    from drake_disamb.station.geometry import model_geometry  # pydrake: imported when goals are checked

    geometry = model_geometry()
    table = geometry.table_top
    names: set[str] = set()
    shoulder = np.asarray(MICO_SHOULDER_POSITION)
    for i, g in enumerate(s.goals):
        path = f"{name}.goals[{i}]"
        if g.name in names:
            raise ValueError(f"{path}.name: duplicate goal name {fmt(g.name)}")
        names.add(g.name)
        pos = np.asarray(g.position, dtype=float)
        _check_quaternion(g.orientation, f"{path}.orientation")
        if not 0 <= g.stage < len(s.stages):
            raise ValueError(
                f"{path}.stage: expected a stage index in [0, {len(s.stages) - 1}], got {fmt(g.stage)}"
            )
        _check_object(g.object, f"{path}.object")
        low, part = geometry.gripper_lowest_point([*pos, *g.orientation], held)
        if low < table + MIN_TABLE_CLEARANCE:
            raise ValueError(
                f"{path}.position: goal {fmt(g.name)} is too low: with the end effector there, "
                f"{part} would reach z = {low:.4f} m, less than {MIN_TABLE_CLEARANCE} m above the table "
                f"top (z = {table:g} m), got {fmt(g.position)}"
            )
        bottom = clearance.lowest_z(_solid(g.name, g.object, [*(pos + g.object.offset), 1.0, 0.0, 0.0, 0.0]))
        if bottom < table - 1e-3:
            raise ValueError(
                f"{path}.position: goal {fmt(g.name)} is too low for its object: the {g.object.shape}'s "
                f"bottom (goal + object.offset {fmt(g.object.offset)}) would be at z = {bottom:.3f} m, "
                f"below the table top (z = {table:g} m), got {fmt(g.position)}"
            )
        axis = float(np.hypot(pos[0], pos[1]))
        if axis < MIN_BASE_DISTANCE:
            raise ValueError(
                f"{path}.position: goal {fmt(g.name)} is in or over the arm's base: {axis:.3f} m from the "
                f"base's axis (at least {MIN_BASE_DISTANCE} m), got {fmt(g.position)}"
            )
        dist = float(np.linalg.norm(pos - shoulder))
        if dist > MICO_REACH:
            raise ValueError(
                f"{path}.position: goal {fmt(g.name)} is out of the arm's reach: {dist:.3f} m from the "
                f"shoulder at {list(MICO_SHOULDER_POSITION)} (reach {MICO_REACH} m), got {fmt(g.position)}"
            )
    counts = [len(s.stage_goals(k)) for k in range(len(s.stages))]
    for k, count in enumerate(counts):
        if count == 0:
            raise ValueError(f"{name}.stages[{k}]: stage {fmt(s.stages[k].name)} has no goals")
        if count != counts[0]:
            raise ValueError(
                f"{name}.stages[{k}]: every stage needs the same number of goals ({counts[0]} in stage 0), "
                f"got {count}"
            )
    _check_separation(s, name)


def _check_user(s: Scenario, name: str) -> None:
    if len(s.user.goals) != len(s.stages):
        raise ValueError(
            f"{name}.user.goals: expected one intended goal index per stage ({len(s.stages)}), "
            f"got {fmt(s.user.goals)}"
        )
    for k, idx in enumerate(s.user.goals):
        n = len(s.stage_goals(k))
        if not 0 <= idx < n:
            raise ValueError(f"{name}.user.goals[{k}]: expected a goal index in [0, {n - 1}], got {fmt(idx)}")
    u = s.user.config
    for user_field, task_field in (
        ("success_position_tolerance", "position_tolerance"),
        ("success_orientation_tolerance", "orientation_tolerance"),
    ):
        if getattr(u, user_field) > getattr(s.success, task_field):
            raise ValueError(
                f"{name}.user.config.{user_field}: expected at most {name}.success.{task_field} "
                f"({getattr(s.success, task_field)!r}), got {fmt(getattr(u, user_field))}"
            )
    _check_user_timing(s, name)


def _check_user_timing(s: Scenario, name: str) -> None:
    """The simulated user decides at most once per control period (each press is one rising edge
    of the interface), and waits at least two decisions after a press (it is released and the new
    mode seen before the next one)."""
    u, path = s.user.config, f"{name}.user.config"
    period = s.control_period if u.decision_period is None else u.decision_period
    if period < s.control_period - 1e-12:
        raise ValueError(
            f"{path}.decision_period: expected at least the control period ({s.control_period!r} s), "
            f"got {fmt(u.decision_period)}"
        )
    if u.reaction_time - u.reaction_time_jitter < 2 * period:
        raise ValueError(
            f"{path}.reaction_time: expected reaction_time - reaction_time_jitter to be at least two "
            f"decision periods ({2 * period!r} s), got {fmt(u.reaction_time)} - "
            f"{fmt(u.reaction_time_jitter)}"
        )


def _check_separation(s: Scenario, name: str) -> None:
    """Reject two goals of one stage closer than :func:`min_goal_separation`."""
    min_sep = min_goal_separation(s.success)
    index = {id(g): i for i, g in enumerate(s.goals)}
    for k in range(len(s.stages)):
        goals = s.stage_goals(k)
        pos = np.array([g.position for g in goals], dtype=float)
        d = np.linalg.norm(pos[:, None, :] - pos[None, :, :], axis=-1)
        d[np.tril_indices(len(goals))] = np.inf
        a, b = np.unravel_index(int(np.argmin(d)), d.shape)
        if d[a, b] < min_sep:
            ga, gb = goals[a], goals[b]
            raise ValueError(
                f"{name}.goals[{index[id(gb)]}].position: goal {fmt(gb.name)} is {d[a, b]:.3f} m from goal "
                f"{fmt(ga.name)} ({name}.goals[{index[id(ga)]}]) of the same stage; goals must be at least "
                f"{min_sep:g} m apart (twice {name}.success.position_tolerance: closer goals share positions "
                f"that count as reaching both), got {fmt(gb.position)}"
            )


def _check_speed_limits(limits: Sequence[float], path: str) -> None:
    """Reject joint speed limits that are not in (0, the model's] (a limit above the model's would
    let the IK command what the arm's own limits refuse)."""
    from drake_disamb.station.geometry import model_geometry

    for k, (v, most) in enumerate(zip(limits, model_geometry().velocity_limits(), strict=True)):
        if not 0.0 < v <= most:
            raise ValueError(
                f"{path}[{k}]: expected a speed in (0, {most:.4f}] rad/s (joint {k + 1}'s in the model), "
                f"got {fmt(v)}"
            )


def _check_start_posture(q: Sequence[float], held: Sequence[Any], path: str) -> None:
    """Reject start joint angles outside the joint limits or that put the arm into the table."""
    from drake_disamb.station.geometry import model_geometry

    geometry = model_geometry()
    table = geometry.table_top
    lower, upper = geometry.joint_limits()
    for k, (v, lo, hi) in enumerate(zip(q, lower, upper, strict=True)):
        if not lo <= v <= hi:
            raise ValueError(
                f"{path}[{k}]: expected an angle within joint {k + 1}'s limits [{lo:.4f}, {hi:.4f}] rad, "
                f"got {fmt(v)}"
            )
    low, part = geometry.arm_lowest_point(q, held)
    if low < table + MIN_TABLE_CLEARANCE:
        raise ValueError(
            f"{path}: the start posture puts {part} at z = {low:.4f} m, less than {MIN_TABLE_CLEARANCE} m "
            f"above the table top (z = {table:g} m), got {fmt(list(q))}"
        )


__all__ = [
    "MICO_REACH",
    "MICO_SHOULDER_POSITION",
    "MIN_START_CLEARANCE",
    "MIN_TABLE_CLEARANCE",
    "check_counts",
    "check_scenario",
    "check_station",
    "min_goal_separation",
]
