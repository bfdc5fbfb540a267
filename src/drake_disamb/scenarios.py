"""Typed task scenarios: dataclasses loaded from YAML with a strict loader.

A :class:`Scenario` describes one shared-control trial: the task's goals (grouped in stages for
multi-step tasks), the interface and mode-switching paradigm, the parameters of every component
(inference, disambiguation, blending, autonomy, simulated user), the control rate, the success
tolerance and the seed. Two scenarios are embedded as package data
(``drake_disamb/tasks/reaching.yaml`` and ``pouring.yaml``); :func:`load_scenario` accepts one of
those names or a path to a YAML file.

The loader is strict: an unknown key, a value of the wrong type, a NaN or infinite number, an
empty goal list, a goal outside the arm's reach or a malformed YAML file raises ``ValueError``
naming the field path and the value, e.g.
``scenario.goals[2].position: expected 3 finite numbers, got [0.1, nan, 0.2]``.

Before any of that, the YAML text itself is checked (:mod:`drake_disamb.yaml_safety`): at most
1 MiB of UTF-8 text (a binary or undecodable file is named as such), nesting at most 32 deep, no
anchors or aliases, no duplicate keys. Values in error messages are cut before they are formatted.

What :func:`validate_scenario` rejects, beyond types and ranges, so that every trial it lets
through can be run:

- a ``control_period`` or ``plant_time_step`` outside [1 ms, 100 ms]
  (:data:`~drake_disamb.core._validation.TIME_STEP_RANGE`), or a plant step above the period;
- a goal out of the arm's reach (:data:`MICO_REACH` from the shoulder);
- a goal below the table: with the end effector at the goal pose, the gripper (closed or open) and
  the carried object must stay :data:`MIN_TABLE_CLEARANCE` above the table top, and the goal's
  object must not reach below the table top;
- two goals of one stage closer than twice ``success.position_tolerance``
  (:func:`min_goal_separation`): closer, a position within the tolerance of both exists, so reaching
  one can count as reaching the other, and each goal's repeller pushes the arm off the other;
- start joint angles outside the joint limits, or that put a link, a finger or the carried object
  less than :data:`MIN_TABLE_CLEARANCE` above the table top (forward kinematics of the station's
  model, :mod:`drake_disamb.clearance`);
- more than :data:`MAX_GOALS` goals.

Units are SI; positions are in the MICO base frame W (metres), orientations are unit quaternions
``[qw, qx, qy, qz]`` of the end-effector frame in W (Drake's w-first order).
"""

from __future__ import annotations

import dataclasses
import functools
import re
import types
import typing
from collections.abc import Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any, Literal

import numpy as np
import yaml

from drake_disamb.core._validation import TIME_STEP_RANGE, bounded_repr, check_real_range, is_real
from drake_disamb.core.autonomy import PotentialFieldConfig
from drake_disamb.core.blending import BlendingConfig
from drake_disamb.core.disambiguation import MICO_DFT, PRESETS
from drake_disamb.core.inference import DFTParams
from drake_disamb.core.user import UserConfig
from drake_disamb.yaml_safety import check_yaml_text, decode_yaml_bytes, read_yaml_file, yaml_error_message

INTERFACES: tuple[str, ...] = ("joystick", "head_array")
"""Interface names accepted by :attr:`Scenario.interface`."""

PARADIGMS: tuple[str, ...] = ("manual", "disambiguation")
"""Mode-switching paradigms accepted by :attr:`Scenario.paradigm`."""

INFERENCE_METHODS: tuple[str, ...] = ("dft", "bayes", "memory")
"""Intent-inference methods accepted by :attr:`InferenceSpec.method`."""

EMBEDDED_TASKS: tuple[str, ...] = ("reaching", "pouring")
"""Names of the scenarios shipped as package data in ``drake_disamb/tasks``."""

MICO_SHOULDER_POSITION: tuple[float, float, float] = (0.0, 0.0, 0.2755)
"""Position (m, in W) of the MICO's shoulder joint: D1 above the base (FACTS section 7)."""

MICO_REACH: float = 0.7
"""Radius (m) about the shoulder beyond which a goal is rejected as out of reach (FACTS section 7)."""

MIN_START_CLEARANCE: float = 0.05
"""A goal closer than this (m) to the gripper's start position is rejected: the task would be trivial."""

MIN_TABLE_CLEARANCE: float = 0.005
"""Height (m) above the table top that the arm, the gripper and the carried object must keep at the
start posture and at every goal pose."""

MAX_GOALS: int = 100
"""Most goals a scenario may have (all stages together); the study's tasks have 4 and 5."""


def min_goal_separation(success: SuccessSpec) -> float:
    """Smallest distance (m) allowed between two goal positions of one stage.

    Twice ``success.position_tolerance``: a goal counts as reached within that distance of it, so
    closer goals share positions that count as reaching both (the belief cannot tell them apart, and
    each goal's repeller pushes the arm off the other). Orientations do not relax this: the
    autonomy's repellers act on positions only. For the embedded tasks (tolerance 0.02 m) it is
    0.04 m; their goals are 0.24 m or more apart.
    """
    return 2.0 * success.position_tolerance


# ----------------------------------------------------------------------------------------------
# Dataclasses
# ----------------------------------------------------------------------------------------------


@dataclass
class ObjectSpec:
    """The object drawn (and placed in the scene) at a goal.

    Attributes:
        shape: ``"box"``, ``"cylinder"`` or ``"sphere"``.
        size: Box: ``[lx, ly, lz]``; cylinder: ``[radius, length]`` (axis along z of W);
            sphere: ``[radius]`` (m).
        color: ``[r, g, b, a]`` in ``[0, 1]``.
        offset: Object centre minus goal position (m, in W). A reaching goal sits at the object
            (offset 0); a pour pose sits above its container (negative z offset).
    """

    shape: Literal["box", "cylinder", "sphere"] = "box"
    size: list[float] = field(default_factory=lambda: [0.05, 0.05, 0.05])
    color: list[float] = field(default_factory=lambda: [0.6, 0.6, 0.6, 1.0])
    offset: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])


@dataclass
class GoalSpec:
    """One goal pose of the end effector, and the object that marks it.

    Attributes:
        name: Unique name (used in plots and logs).
        position: ``[x, y, z]`` (m, in W).
        orientation: ``[qw, qx, qy, qz]`` of the end-effector frame in W (normalised on load).
        stage: Index into :attr:`Scenario.stages` of the stage whose goal set holds this goal.
        object: What to draw at the goal.
    """

    name: str
    position: list[float]
    orientation: list[float] = field(default_factory=lambda: [1.0, 0.0, 0.0, 0.0])
    stage: int = 0
    object: ObjectSpec = field(default_factory=ObjectSpec)


@dataclass
class StageSpec:
    """One step of a multi-step task.

    Attributes:
        name: Stage name (e.g. ``"pour"``, ``"place"``).
        hold_time: How long (s) the end effector must stay at a goal to complete the stage;
            ``None`` uses :attr:`SuccessSpec.hold_time`.
    """

    name: str = "reach"
    hold_time: float | None = None


@dataclass
class SuccessSpec:
    """When a goal counts as reached: within both tolerances, continuously for ``hold_time``.

    Attributes:
        position_tolerance: Distance (m) between the end-effector origin and the goal position.
        orientation_tolerance: Angle (rad) of the rotation between the end-effector and goal
            orientations.
        hold_time: Time (s) the end effector must stay within both tolerances.
    """

    position_tolerance: float = 0.02
    orientation_tolerance: float = 0.15
    hold_time: float = 0.3


@dataclass
class InferenceSpec:
    """Intent inference.

    Attributes:
        method: ``"dft"`` (field-theoretic, continuous state), ``"bayes"`` or ``"memory"``.
        dft: Parameters of the field-theoretic update; default the ``mico`` disambiguation preset's
            (:data:`drake_disamb.core.disambiguation.MICO_DFT`), so that the live belief and the
            disambiguation's forward projection run the same update.
    """

    method: Literal["dft", "bayes", "memory"] = "dft"
    dft: DFTParams = MICO_DFT


@dataclass
class DisambiguationSpec:
    """Disambiguation (Algorithm 1).

    Attributes:
        preset: Name of a preset in :mod:`drake_disamb.core.disambiguation` (``"mico"`` or
            ``"authors-r3"``).
    """

    preset: str = "mico"


@dataclass
class UserSpec:
    """The simulated user.

    Attributes:
        goals: Intended goal per stage: an index into that stage's goal list (the goals of the
            stage in the order they appear in :attr:`Scenario.goals`).
        config: The user's behaviour (:class:`drake_disamb.core.user.UserConfig`). The builder
            sets its ``seed`` from :attr:`Scenario.seed` and its ``rho1`` from the blending
            thresholds, and turns its disambiguation requests off in the manual paradigm. Its
            success tolerances must not exceed the task's (:class:`SuccessSpec`): the user stops
            commanding once it believes it has arrived.
    """

    goals: list[int] = field(default_factory=lambda: [0])
    config: UserConfig = field(default_factory=UserConfig)


@dataclass
class CarriedObjectSpec:
    """An object held in the gripper from the start of the trial (e.g. the cup when pouring).

    Attributes:
        shape, size, color: As in :class:`ObjectSpec`.
        offset: Object centre in the end-effector frame (m).
        orientation: ``[qw, qx, qy, qz]`` of the object in the end-effector frame. The default
            turns a cylinder's axis (its z) onto the end-effector x axis: with the gripper's
            approach axis horizontal and its fingers closing horizontally, the cup stands upright.
    """

    shape: Literal["box", "cylinder", "sphere"] = "cylinder"
    size: list[float] = field(default_factory=lambda: [0.035, 0.09])
    color: list[float] = field(default_factory=lambda: [0.9, 0.9, 0.95, 1.0])
    offset: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    orientation: list[float] = field(
        default_factory=lambda: [0.7071067811865476, 0.0, 0.7071067811865476, 0.0]
    )


@dataclass
class Scenario:
    """One shared-control trial, in the style of Drake's typed scenario structs.

    Attributes:
        task: Task name (``"reaching"``, ``"pouring"``, or a user-chosen name).
        description: Free text.
        interface: ``"joystick"`` or ``"head_array"``.
        paradigm: ``"manual"`` or ``"disambiguation"``.
        inference, disambiguation, blending, autonomy, user: Component settings.
        control_period: Period (s) of the control loop (interface, autonomy, blending,
            differential IK); 0.01 s = 100 Hz, the MICO's Cartesian velocity interface.
        plant_time_step: Discrete step (s) of the arm's MultibodyPlant (SAP, joint PD). The default
            equals the control period: the arm only receives new set points every control tick,
            the PD is integrated implicitly, and the loop runs about 8 times faster than with a
            1 ms plant (``benchmarks/bench_loop.py`` prints both); 0.001 resolves contact finer.
        duration: Simulated-time limit (s) of a trial.
        success: Success tolerance.
        seed: Seed of every random draw in the trial.
        initial_mode: Index into the interface's mode list of the mode at the start.
        start_joint_positions: The arm's 6 joint angles (rad) at the start; ``None`` means the
            station's home configuration.
        goals: Every goal of every stage.
        stages: The task's stages, in order (one for single-step tasks). Every stage has the
            same number of goals: the goal set switches when a stage completes.
        carried_object: An object held in the gripper from the start, or ``None``.
    """

    task: str = "reaching"
    description: str = ""
    interface: Literal["joystick", "head_array"] = "head_array"
    paradigm: Literal["manual", "disambiguation"] = "disambiguation"
    inference: InferenceSpec = field(default_factory=InferenceSpec)
    disambiguation: DisambiguationSpec = field(default_factory=DisambiguationSpec)
    blending: BlendingConfig = field(default_factory=BlendingConfig)
    autonomy: PotentialFieldConfig = field(default_factory=PotentialFieldConfig)
    user: UserSpec = field(default_factory=UserSpec)
    control_period: float = 0.01
    plant_time_step: float = 0.01
    duration: float = 60.0
    success: SuccessSpec = field(default_factory=SuccessSpec)
    seed: int = 0
    initial_mode: int = 0
    start_joint_positions: list[float] | None = None
    goals: list[GoalSpec] = field(default_factory=list)
    stages: list[StageSpec] = field(default_factory=lambda: [StageSpec()])
    carried_object: CarriedObjectSpec | None = None

    # -- derived views -------------------------------------------------------------------------

    @property
    def n_stages(self) -> int:
        """Number of stages."""
        return len(self.stages)

    def stage_goals(self, stage: int) -> list[GoalSpec]:
        """The goals of ``stage``, in the order they appear in :attr:`goals`."""
        return [g for g in self.goals if g.stage == stage]

    @property
    def n_goals(self) -> int:
        """Number of goals per stage (the size of the belief)."""
        return len(self.stage_goals(0))

    def stage_goal_poses(self, stage: int) -> np.ndarray:
        """``(n_goals, 7)`` array of ``[x, y, z, qw, qx, qy, qz]`` for ``stage``."""
        return np.array([[*g.position, *_unit(g.orientation)] for g in self.stage_goals(stage)], dtype=float)

    def hold_time(self, stage: int) -> float:
        """Hold time (s) of ``stage``."""
        h = self.stages[stage].hold_time
        return self.success.hold_time if h is None else h


def _unit(q: Sequence[float]) -> list[float]:
    a = np.asarray(q, dtype=float)
    return (a / np.linalg.norm(a)).tolist()


# ----------------------------------------------------------------------------------------------
# Strict loader
# ----------------------------------------------------------------------------------------------


def _fmt(value: Any) -> str:
    """``repr(value)`` cut to 200 characters, never formatting more (see :func:`bounded_repr`)."""
    return bounded_repr(value, 200)


def _cut(text: str, limit: int = 400) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _convert(tp: Any, value: Any, path: str) -> Any:
    """Convert plain YAML data ``value`` to type ``tp``; raise ``ValueError`` naming ``path``."""
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if tp is Any:
        return value
    if origin in (typing.Union, types.UnionType):
        if value is None:
            if type(None) in args:
                return None
            raise ValueError(f"{path}: expected a value, got None")
        errors = []
        for arg in args:
            if arg is type(None):
                continue
            try:
                return _convert(arg, value, path)
            except ValueError as exc:
                errors.append(str(exc))
        raise ValueError(errors[0] if len(errors) == 1 else f"{path}: no accepted type matches {_fmt(value)}")
    if origin is Literal:
        if value not in args:
            choices = ", ".join(repr(a) for a in args)
            raise ValueError(f"{path}: expected one of {choices}, got {_fmt(value)}")
        return value
    if dataclasses.is_dataclass(tp):
        return _load_dataclass(tp, value, path)
    if tp is bool:
        if not isinstance(value, bool):
            raise ValueError(f"{path}: expected true or false, got {_fmt(value)}")
        return value
    if tp is int:
        if not isinstance(value, int) or isinstance(value, bool):
            raise ValueError(f"{path}: expected an integer, got {_fmt(value)}")
        return value
    if tp is float:
        if not is_real(value):
            raise ValueError(f"{path}: expected a finite number, got {_fmt(value)}")
        return float(value)
    if tp is str:
        if not isinstance(value, str):
            raise ValueError(f"{path}: expected a string, got {_fmt(value)}")
        return value
    if origin is list:
        if not isinstance(value, list):
            raise ValueError(f"{path}: expected a list, got {_fmt(value)}")
        (item,) = args
        return [_convert(item, v, f"{path}[{i}]") for i, v in enumerate(value)]
    if origin is np.ndarray or tp is np.ndarray:
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError, OverflowError) as exc:
            raise ValueError(f"{path}: expected numbers, got {_fmt(value)}") from exc
        if any(isinstance(v, bool) for v in np.asarray(value, dtype=object).ravel()):
            raise ValueError(f"{path}: expected numbers, got {_fmt(value)}")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{path}: expected finite numbers, got {_fmt(value)}")
        return arr
    raise TypeError(f"{path}: unsupported field type {tp!r}")  # pragma: no cover (programming error)


@functools.cache
def _init_fields(cls: Any) -> tuple[dict[str, Any], dict[str, dataclasses.Field]]:
    """``cls``'s resolved field types and its ``__init__`` fields, worked out once per class.

    ``typing.get_type_hints`` evaluates every string annotation on each call (and is twice as slow on
    Python 3.12 as on 3.11), so a list of thousands of stages must not call it once per item.
    """
    return typing.get_type_hints(cls), {f.name: f for f in dataclasses.fields(cls) if f.init}


def _load_dataclass(cls: Any, data: Any, path: str) -> Any:
    if isinstance(data, cls):
        return data
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a mapping of {cls.__name__} fields, got {_fmt(data)}")
    hints, fields = _init_fields(cls)
    for key in data:
        if key not in fields:
            known = ", ".join(sorted(fields))
            shown = key if isinstance(key, str) and key.isidentifier() and len(key) <= 60 else _fmt(key)
            raise ValueError(f"{path}.{_cut(shown, 60)}: unknown key (known keys of {cls.__name__}: {known})")
    kwargs = {}
    for name in fields:
        if name in data:
            kwargs[name] = _convert(hints[name], data[name], f"{path}.{name}")
    missing = [
        name
        for name, f in fields.items()
        if name not in kwargs
        and f.default is dataclasses.MISSING
        and f.default_factory is dataclasses.MISSING
    ]
    if missing:
        raise ValueError(f"{path}.{missing[0]}: required field missing")
    try:
        return cls(**kwargs)
    except ValueError as exc:  # e.g. DFTParams / PotentialFieldConfig self-validation
        raise ValueError(f"{path}: {_cut(str(exc))}") from exc


# ----------------------------------------------------------------------------------------------
# Validation
# ----------------------------------------------------------------------------------------------


def _check_vec(value: Sequence[float], n: int | tuple[int, ...], path: str) -> np.ndarray:
    sizes = (n,) if isinstance(n, int) else n
    a = np.asarray(value, dtype=float)
    if a.ndim != 1 or a.size not in sizes or not np.all(np.isfinite(a)):
        what = " or ".join(str(s) for s in sizes)
        raise ValueError(f"{path}: expected {what} finite numbers, got {_fmt(list(value))}")
    return a


def _check_positive(value: float, path: str, allow_zero: bool = False) -> None:
    ok = is_real(value) and (value >= 0 if allow_zero else value > 0)
    if not ok:
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{path}: expected a finite number {bound}, got {_fmt(value)}")


def _check_object(obj: ObjectSpec | CarriedObjectSpec, path: str) -> None:
    sizes = {"box": 3, "cylinder": 2, "sphere": 1}
    size = _check_vec(obj.size, sizes[obj.shape], f"{path}.size")
    if np.any(size <= 0):
        raise ValueError(f"{path}.size: expected positive dimensions, got {_fmt(obj.size)}")
    color = _check_vec(obj.color, 4, f"{path}.color")
    if np.any((color < 0) | (color > 1)):
        raise ValueError(f"{path}.color: expected [r, g, b, a] in [0, 1], got {_fmt(obj.color)}")
    _check_vec(obj.offset, 3, f"{path}.offset")


def validate_scenario(scenario: Scenario, name: str = "scenario") -> Scenario:
    """Check every cross-field constraint of ``scenario``; return it unchanged.

    See the module docstring for what is rejected. The table and start-posture checks use the
    station's model (:mod:`drake_disamb.clearance`, which imports pydrake).

    Raises:
        ValueError: naming the field path (``scenario.goals[2].position`` ...) and the value.
    """
    s = scenario
    if s.interface not in INTERFACES:
        raise ValueError(
            f"{name}.interface: expected one of {', '.join(INTERFACES)}, got {_fmt(s.interface)}"
        )
    if s.paradigm not in PARADIGMS:
        raise ValueError(f"{name}.paradigm: expected one of {', '.join(PARADIGMS)}, got {_fmt(s.paradigm)}")
    if s.inference.method not in INFERENCE_METHODS:
        raise ValueError(
            f"{name}.inference.method: expected one of {', '.join(INFERENCE_METHODS)}, "
            f"got {_fmt(s.inference.method)}"
        )
    if s.disambiguation.preset not in PRESETS:
        raise ValueError(
            f"{name}.disambiguation.preset: expected one of {', '.join(PRESETS)}, "
            f"got {_fmt(s.disambiguation.preset)}"
        )
    check_real_range(s.control_period, f"{name}.control_period", *TIME_STEP_RANGE, unit="s")
    check_real_range(s.plant_time_step, f"{name}.plant_time_step", *TIME_STEP_RANGE, unit="s")
    _check_positive(s.duration, f"{name}.duration")
    if s.plant_time_step > s.control_period * (1 + 1e-9):
        raise ValueError(
            f"{name}.plant_time_step: expected at most the control period ({s.control_period!r} s), "
            f"got {s.plant_time_step!r}"
        )
    _check_positive(s.success.position_tolerance, f"{name}.success.position_tolerance")
    _check_positive(s.success.orientation_tolerance, f"{name}.success.orientation_tolerance")
    _check_positive(s.success.hold_time, f"{name}.success.hold_time", allow_zero=True)
    if s.seed < 0:
        raise ValueError(f"{name}.seed: expected a non-negative integer, got {_fmt(s.seed)}")
    if s.initial_mode < 0:
        raise ValueError(
            f"{name}.initial_mode: expected a non-negative mode index, got {_fmt(s.initial_mode)}"
        )
    if s.start_joint_positions is not None:
        _check_vec(s.start_joint_positions, 6, f"{name}.start_joint_positions")

    if not s.stages:
        raise ValueError(f"{name}.stages: expected at least one stage, got []")
    if not s.goals:
        raise ValueError(f"{name}.goals: expected at least one goal, got []")
    if len(s.goals) > MAX_GOALS:
        raise ValueError(f"{name}.goals: expected at most {MAX_GOALS} goals, got {len(s.goals)}")
    if len(s.stages) > len(s.goals):
        raise ValueError(
            f"{name}.stages: every stage needs a goal, got {len(s.stages)} stages for {len(s.goals)} goals"
        )
    for i, stage in enumerate(s.stages):
        if stage.hold_time is not None:
            _check_positive(stage.hold_time, f"{name}.stages[{i}].hold_time", allow_zero=True)
    held: list[Any] = []  # the carried object as a clearance.Solid in the end-effector frame
    if s.carried_object is not None:
        _check_object(s.carried_object, f"{name}.carried_object")
        q = _check_vec(s.carried_object.orientation, 4, f"{name}.carried_object.orientation")
        if np.linalg.norm(q) < 1e-6:
            raise ValueError(
                f"{name}.carried_object.orientation: expected a non-zero quaternion, "
                f"got {_fmt(s.carried_object.orientation)}"
            )
        held.append(_solid("carried_object", s.carried_object, [*s.carried_object.offset, *q]))

    from drake_disamb import clearance  # pydrake: imported when a scenario with goals is checked

    table = clearance.table_top_z()
    names: set[str] = set()
    shoulder = np.asarray(MICO_SHOULDER_POSITION)
    for i, g in enumerate(s.goals):
        path = f"{name}.goals[{i}]"
        if g.name in names:
            raise ValueError(f"{path}.name: duplicate goal name {_fmt(g.name)}")
        names.add(g.name)
        pos = _check_vec(g.position, 3, f"{path}.position")
        q = _check_vec(g.orientation, 4, f"{path}.orientation")
        if np.linalg.norm(q) < 1e-6:
            raise ValueError(f"{path}.orientation: expected a non-zero quaternion, got {_fmt(g.orientation)}")
        if not 0 <= g.stage < len(s.stages):
            raise ValueError(
                f"{path}.stage: expected a stage index in [0, {len(s.stages) - 1}], got {_fmt(g.stage)}"
            )
        _check_object(g.object, f"{path}.object")
        low, part = clearance.gripper_lowest_point([*pos, *q], held)
        if low < table + MIN_TABLE_CLEARANCE:
            raise ValueError(
                f"{path}.position: goal {_fmt(g.name)} is too low: with the end effector there, "
                f"{part} would reach z = {low:.4f} m, less than {MIN_TABLE_CLEARANCE} m above the table "
                f"top (z = {table:g} m), got {_fmt(g.position)}"
            )
        bottom = clearance.lowest_z(_solid(g.name, g.object, [*(pos + g.object.offset), 1.0, 0.0, 0.0, 0.0]))
        if bottom < table - 1e-3:
            raise ValueError(
                f"{path}.position: goal {_fmt(g.name)} is too low for its object: the {g.object.shape}'s "
                f"bottom (goal + object.offset {_fmt(g.object.offset)}) would be at z = {bottom:.3f} m, "
                f"below the table top (z = {table:g} m), got {_fmt(g.position)}"
            )
        dist = float(np.linalg.norm(pos - shoulder))
        if dist > MICO_REACH:
            raise ValueError(
                f"{path}.position: goal {_fmt(g.name)} is out of the arm's reach: {dist:.3f} m from the "
                f"shoulder at {list(MICO_SHOULDER_POSITION)} (reach {MICO_REACH} m), got {_fmt(g.position)}"
            )
    counts = [len(s.stage_goals(k)) for k in range(len(s.stages))]
    for k, count in enumerate(counts):
        if count == 0:
            raise ValueError(f"{name}.stages[{k}]: stage {_fmt(s.stages[k].name)} has no goals")
        if count != counts[0]:
            raise ValueError(
                f"{name}.stages[{k}]: every stage needs the same number of goals ({counts[0]} in stage 0), "
                f"got {count}"
            )
    _check_separation(s, name)
    try:
        s.blending.rhos(counts[0])
    except ValueError as exc:
        raise ValueError(f"{name}.blending: {_cut(str(exc))}") from exc
    if len(s.user.goals) != len(s.stages):
        raise ValueError(
            f"{name}.user.goals: expected one intended goal index per stage ({len(s.stages)}), "
            f"got {_fmt(s.user.goals)}"
        )
    for k, idx in enumerate(s.user.goals):
        if not 0 <= idx < counts[k]:
            raise ValueError(
                f"{name}.user.goals[{k}]: expected a goal index in [0, {counts[k] - 1}], got {_fmt(idx)}"
            )
    u = s.user.config
    for user_field, task_field in (
        ("success_position_tolerance", "position_tolerance"),
        ("success_orientation_tolerance", "orientation_tolerance"),
    ):
        if getattr(u, user_field) > getattr(s.success, task_field):
            raise ValueError(
                f"{name}.user.config.{user_field}: expected at most {name}.success.{task_field} "
                f"({getattr(s.success, task_field)!r}), got {_fmt(getattr(u, user_field))}"
            )
    if s.start_joint_positions is not None:
        _check_start_posture(s.start_joint_positions, held, table, f"{name}.start_joint_positions")
    return s


def _solid(label: str, obj: ObjectSpec | CarriedObjectSpec, pose: Sequence[float]) -> Any:
    """``obj`` as a :class:`drake_disamb.clearance.Solid` at ``pose`` ``[x, y, z, qw, qx, qy, qz]``."""
    from drake_disamb.clearance import Solid, pose_matrix

    return Solid(label, obj.shape, tuple(obj.size), pose_matrix(pose))


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
                f"{name}.goals[{index[id(gb)]}].position: goal {_fmt(gb.name)} is {d[a, b]:.3f} m from goal "
                f"{_fmt(ga.name)} ({name}.goals[{index[id(ga)]}]) of the same stage; goals must be at least "
                f"{min_sep:g} m apart (twice {name}.success.position_tolerance: closer goals share positions "
                f"that count as reaching both), got {_fmt(gb.position)}"
            )


def _check_start_posture(q: Sequence[float], held: Sequence[Any], table: float, path: str) -> None:
    """Reject start joint angles outside the joint limits or that put the arm into the table."""
    from drake_disamb import clearance

    lower, upper = clearance.arm_joint_limits()
    for k, (v, lo, hi) in enumerate(zip(q, lower, upper, strict=True)):
        if not lo <= v <= hi:
            raise ValueError(
                f"{path}[{k}]: expected an angle within joint {k + 1}'s limits [{lo:.4f}, {hi:.4f}] rad, "
                f"got {_fmt(v)}"
            )
    low, part = clearance.arm_lowest_point(q, held)
    if low < table + MIN_TABLE_CLEARANCE:
        raise ValueError(
            f"{path}: the start posture puts {part} at z = {low:.4f} m, less than {MIN_TABLE_CLEARANCE} m "
            f"above the table top (z = {table:g} m), got {_fmt(list(q))}"
        )


def check_start_clearance(scenario: Scenario, start_position: Sequence[float]) -> None:
    """Reject a goal within :data:`MIN_START_CLEARANCE` of the gripper's start position.

    The start position depends on the arm's kinematics, so the builder calls this once the
    station exists.

    Raises:
        ValueError: naming ``scenario.goals[i].position`` and the value.
    """
    start = np.asarray(start_position, dtype=float)
    for i, g in enumerate(scenario.goals):
        if g.stage != 0:
            continue
        dist = float(np.linalg.norm(np.asarray(g.position) - start))
        if dist < MIN_START_CLEARANCE:
            raise ValueError(
                f"scenario.goals[{i}].position: goal {g.name!r} is on top of the gripper's start position "
                f"{np.round(start, 4).tolist()} ({dist:.3f} m < {MIN_START_CLEARANCE} m), "
                f"got {_fmt(g.position)}"
            )


# ----------------------------------------------------------------------------------------------
# Public loading API
# ----------------------------------------------------------------------------------------------


def scenario_from_dict(data: Any, name: str = "scenario") -> Scenario:
    """Build and validate a :class:`Scenario` from plain data (as parsed from YAML)."""
    return validate_scenario(_load_dataclass(Scenario, data, name), name)


class _YamlLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """PyYAML's safe loader (libyaml's parser when there is one) with two changes.

    A number written with an exponent but no dot (``1e-6``) is a float, as in YAML 1.2 and in
    Drake's YAML reader (YAML 1.1 reads it as a string). A scalar the constructor cannot convert
    (a date such as ``2020-13-45``) is reported with its line instead of a bare ``ValueError``.
    """

    def construct_object(self, node: yaml.Node, deep: bool = False) -> Any:
        try:
            return super().construct_object(node, deep)
        except (ValueError, TypeError, OverflowError) as exc:
            raise yaml.constructor.ConstructorError(
                None, None, _cut(str(exc), 200), node.start_mark
            ) from None


_YamlLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$"),
    list("-+0123456789."),
)


def scenario_from_yaml(text: str | bytes, source: str = "<string>") -> Scenario:
    """Parse YAML ``text`` (or UTF-8 bytes) into a validated :class:`Scenario`.

    The text is first checked by :func:`drake_disamb.yaml_safety.check_yaml_text` (size, nesting,
    anchors and aliases, duplicate keys), then loaded with PyYAML's safe loader.

    Raises:
        ValueError: on malformed or unsafe YAML (naming ``source`` and the line) or any invalid field.
    """
    if isinstance(text, bytes | bytearray):
        text = decode_yaml_bytes(bytes(text), source)
    check_yaml_text(text, source, root="scenario")
    try:
        data = yaml.load(text, Loader=_YamlLoader)  # noqa: S506 (a safe loader)
    except yaml.YAMLError as exc:
        raise ValueError(yaml_error_message(exc, source)) from None
    if data is None:
        raise ValueError(f"{source}: empty YAML document, expected a scenario mapping")
    return scenario_from_dict(data, "scenario")


def embedded_scenario_text(name: str) -> str:
    """The YAML text of an embedded scenario (``"reaching"`` or ``"pouring"``)."""
    if name not in EMBEDDED_TASKS:
        raise ValueError(f"task: expected one of {', '.join(EMBEDDED_TASKS)} or a YAML path, got {name!r}")
    return resources.files("drake_disamb.tasks").joinpath(f"{name}.yaml").read_text(encoding="utf-8")


def load_scenario(path_or_name: str | Path) -> Scenario:
    """Load an embedded scenario by name (``"reaching"``, ``"pouring"``) or a YAML file by path.

    Raises:
        ValueError: an unknown name, a missing file, malformed YAML or an invalid field.
    """
    text_name = str(path_or_name)
    if isinstance(path_or_name, str) and text_name in EMBEDDED_TASKS:
        return scenario_from_yaml(embedded_scenario_text(text_name), f"<embedded {text_name}.yaml>")
    path = Path(path_or_name)
    if path.suffix.lower() not in (".yaml", ".yml") and not path.exists():
        raise ValueError(
            f"task: expected one of {', '.join(EMBEDDED_TASKS)} or a YAML path, got {text_name!r}"
        )
    if not path.is_file():
        raise ValueError(f"task: no such scenario file: {_fmt(text_name)}")
    return scenario_from_yaml(read_yaml_file(path), str(path))


def with_overrides(
    scenario: Scenario,
    *,
    interface: str | None = None,
    paradigm: str | None = None,
    goal: int | Sequence[int] | None = None,
    seed: int | None = None,
) -> Scenario:
    """A copy of ``scenario`` with command-line overrides applied, validated.

    ``goal`` is one index (used for every stage) or one index per stage.
    """
    changes: dict[str, Any] = {}
    if interface is not None:
        if interface not in INTERFACES:
            raise ValueError(f"interface: expected one of {', '.join(INTERFACES)}, got {interface!r}")
        changes["interface"] = interface
    if paradigm is not None:
        if paradigm not in PARADIGMS:
            raise ValueError(f"paradigm: expected one of {', '.join(PARADIGMS)}, got {paradigm!r}")
        changes["paradigm"] = paradigm
    if seed is not None:
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            raise ValueError(f"seed: expected a non-negative integer, got {seed!r}")
        changes["seed"] = seed
    if goal is not None:
        goals = [goal] * scenario.n_stages if isinstance(goal, int) else list(goal)
        for i, g in enumerate(goals):
            if isinstance(g, bool) or not isinstance(g, int):
                raise ValueError(f"goal[{i}]: expected an integer goal index, got {g!r}")
        if len(goals) != scenario.n_stages:
            raise ValueError(
                f"goal: expected one index or {scenario.n_stages} (one per stage), got {goals!r}"
            )
        for k, g in enumerate(goals):
            n = len(scenario.stage_goals(k))
            if not 0 <= g < n:
                raise ValueError(f"goal: expected an index in [0, {n - 1}] for stage {k}, got {g!r}")
        changes["user"] = dataclasses.replace(scenario.user, goals=goals)
    return validate_scenario(dataclasses.replace(scenario, **changes))


def scenario_to_dict(scenario: Scenario) -> dict[str, Any]:
    """Plain-data form of ``scenario`` (round-trips through :func:`scenario_from_dict`)."""

    def plain(value: Any) -> Any:
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value) if f.init}
        if isinstance(value, np.ndarray):
            return value.tolist()
        if isinstance(value, list | tuple):
            return [plain(v) for v in value]
        return value

    return plain(scenario)
