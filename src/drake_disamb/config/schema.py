"""The scenario schema: dataclasses read by Drake's YAML loader, nesting Drake's own config structs.

A :class:`Scenario` describes one shared-control trial: the task's goals (grouped in stages for
multi-step tasks), the interface and mode-switching paradigm, the settings of every component
(inference, disambiguation, blending, autonomy, simulated user), the control rate, Drake's
``SimulatorConfig`` (``simulator_config``) and ``MultibodyPlantConfig`` (``plant_config``) with
Drake's own field names, the success tolerance and the seed.

The classes are what :func:`pydrake.common.yaml.yaml_load_typed` fills in and
:func:`~pydrake.common.yaml.yaml_dump_typed` writes out, so they follow its rules: plain mutable
dataclasses whose every field has a default, with types it understands (``str``, ``int``,
``float``, ``bool``, ``list[...]``, ``X | None``, nested dataclasses and Drake's structs). This
module has no ``from __future__ import annotations``: the loader reads each field's type from
``dataclasses.fields()`` and needs real types, not strings. An optional field's default is
always ``None``: Drake's dump leaves a ``None`` out, and a key left out keeps the default.

The settings of the core algorithms are the core's own frozen configs (``DFTParams``,
``BlendingConfig``, ``PotentialFieldConfig``, ``UserConfig``). Their scenario forms
(:class:`DFTSpec`, :class:`BlendingSpec`, :class:`PotentialFieldSpec`, :class:`UserBehaviorSpec`)
are made from them field by field (:func:`_spec_class`), so a field is declared once, in the core;
the field meanings are documented there. :func:`drake_disamb.config.resolve.resolve_scenario`
turns a scenario into the frozen configs.

Metadata on a field tells :func:`drake_disamb.config.checks.check_data` more than its type:
``required`` (the key must be written), ``choices`` (accepted strings), ``size`` (accepted list
lengths) and ``max_items``.

Units are SI; positions are in the MICO base frame W (metres), orientations are unit quaternions
``[qw, qx, qy, qz]`` of the end-effector frame in W (Drake's w-first order).
"""

import copy
import dataclasses
import functools
import typing
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from pydrake.multibody.plant import MultibodyPlantConfig
from pydrake.systems.analysis import SimulatorConfig

from drake_disamb.config.checks import schema_fields, variant_tag, variant_types
from drake_disamb.core.automatic import AutomaticConfig
from drake_disamb.core.autonomy import PotentialFieldConfig
from drake_disamb.core.blending import BlendingConfig
from drake_disamb.core.disambiguation import MICO_DFT, MODE_SELECTION_METHODS, PRESETS, UPSILON_NORMALIZATIONS
from drake_disamb.core.inference import AGREEMENT_MEASURES, INFERENCE_METHODS, DFTParams
from drake_disamb.core.layout import SHAPE_SIZES
from drake_disamb.core.validation import MAX_GOALS
from drake_disamb.interfaces import INTERFACES, MODE_SELECTIONS
from drake_disamb.station import default_plant_config
from drake_disamb.station.backends import Sim, StationBackend
from drake_disamb.user import UserConfig

PARADIGMS: tuple[str, ...] = ("manual", "disambiguation", "automatic")
"""Mode-switching paradigms accepted by :attr:`Scenario.paradigm`."""

GOAL_SETS: tuple[str, ...] = ("stage", "task")
"""What the belief is over (:attr:`InferenceSpec.goal_set`)."""

SHAPES: tuple[str, ...] = tuple(SHAPE_SIZES)
"""Object shapes; their ``size`` entries are :data:`drake_disamb.core.layout.SHAPE_SIZES`."""


def _meta(**kwargs: Any) -> dict[str, Any]:
    return {"check": kwargs}


def _spec_class(
    config_type: type,
    name: str,
    defaults: Any,
    *,
    types: dict[str, Any] | None = None,
    exclude: tuple[str, ...] = (),
    doc: str,
) -> type:
    """A mutable dataclass with the fields of the frozen core config ``config_type`` (flat: a
    config of nested groups with ``flat_types`` / ``flat`` gives every group's fields by name).

    Defaults are those of the instance ``defaults``; ``types`` replaces a field's type by one Drake's
    loader reads (a numpy matrix as ``list[list[float]]``); ``exclude`` leaves fields out (the
    resolver sets them). ``spec.to_config(**extra)`` builds the frozen config (lists become arrays).
    """
    if hasattr(config_type, "flat_types"):  # a config of nested groups, written flat
        hints, values = config_type.flat_types(), defaults.flat()
    else:
        hints = typing.get_type_hints(config_type)
        values = {f.name: getattr(defaults, f.name) for f in dataclasses.fields(config_type)}
    types = types or {}
    fields = []
    for key in values:
        if key in exclude:
            continue
        tp = types.get(key, hints[key])
        value = values[key]
        if value is not None and type(None) in typing.get_args(tp):  # programming error, at import
            raise TypeError(f"{name}.{key}: an optional field needs the default None, got {value!r}")
        fields.append((key, tp, field(default_factory=functools.partial(copy.deepcopy, value))))

    def to_config(self: Any, **extra: Any) -> Any:
        values = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        values = {k: np.asarray(v, dtype=float) if isinstance(v, list) else v for k, v in values.items()}
        return config_type(**values, **extra)

    cls = dataclasses.make_dataclass(name, fields, namespace={"to_config": to_config, "__doc__": doc})
    cls.__module__ = __name__
    return cls


DFTSpec = _spec_class(
    DFTParams,
    "DFTSpec",
    MICO_DFT,
    types={"lam": float, "transition": list[list[float]] | None, "rest": list[float] | None},
    exclude=("agreement_measure",),
    doc="""The field-theoretic update's parameters: the fields of
    :class:`drake_disamb.core.inference.DFTParams`, defaults those of the ``mico`` preset
    (:data:`~drake_disamb.core.disambiguation.MICO_DFT`). ``lam`` is a scalar gain here. The
    agreement term's form is :attr:`InferenceSpec.agreement`.""",
)
BlendingSpec = _spec_class(
    BlendingConfig,
    "BlendingSpec",
    BlendingConfig(),
    doc="""The blender's settings: the fields of :class:`drake_disamb.core.blending.BlendingConfig`
    (``rho1`` and ``rho2`` left out are the paper's ``1.2 / n`` and ``1.4 / n`` for ``n`` goals).""",
)
PotentialFieldSpec = _spec_class(
    PotentialFieldConfig,
    "PotentialFieldSpec",
    PotentialFieldConfig(),
    doc="""The autonomy's gains and limits: the fields of
    :class:`drake_disamb.core.autonomy.PotentialFieldConfig`.""",
)
UserBehaviorSpec = _spec_class(
    UserConfig,
    "UserBehaviorSpec",
    UserConfig(stall_time=None, request_when_unhelped_for=None),
    exclude=("rho1", "seed"),
    doc="""The simulated user's behaviour: the fields of :class:`drake_disamb.user.UserConfig`
    but ``seed`` and ``rho1``, which the resolver sets from :attr:`Scenario.seed` and the blending
    thresholds. ``stall_time`` and ``request_when_unhelped_for`` are off when left out (the
    embedded tasks set 2 s and 3 s).""",
)

AutomaticSpec = _spec_class(
    AutomaticConfig,
    "AutomaticSpec",
    AutomaticConfig(),
    doc="""The Automatic paradigm's trigger: the fields of
    :class:`drake_disamb.core.automatic.AutomaticConfig` (its module docstring says why each).
    ``confidence_threshold`` left out is the blending's ``rho1``.""",
)


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

    shape: str = field(default="box", metadata=_meta(choices=SHAPES))
    size: list[float] = field(default_factory=lambda: [0.05, 0.05, 0.05], metadata=_meta(size=(1, 2, 3)))
    color: list[float] = field(default_factory=lambda: [0.6, 0.6, 0.6, 1.0], metadata=_meta(size=(4,)))
    offset: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0], metadata=_meta(size=(3,)))


@dataclass
class GoalSpec:
    """One goal pose of the end effector, and the object that marks it.

    Attributes:
        name: Unique name (used in plots and logs); required.
        position: ``[x, y, z]`` (m, in W); required.
        orientation: ``[qw, qx, qy, qz]`` of the end-effector frame in W (normalised where used).
        stage: Index into :attr:`Scenario.stages` of the stage whose goal set holds this goal.
        object: What to draw at the goal.
    """

    name: str = field(default="", metadata=_meta(required=True))
    position: list[float] = field(default_factory=list, metadata=_meta(required=True, size=(3,)))
    orientation: list[float] = field(default_factory=lambda: [1.0, 0.0, 0.0, 0.0], metadata=_meta(size=(4,)))
    stage: int = 0
    object: ObjectSpec = field(default_factory=ObjectSpec)


@dataclass
class StageSpec:
    """One step of a multi-step task.

    Attributes:
        name: Stage name (e.g. ``"pour"``, ``"place"``).
        hold_time: How long (s) the end effector must stay at a goal to complete the stage;
            ``None`` uses :attr:`SuccessSpec.hold_time`.
        release_opening: The stage ends by letting go of the held object: it completes only once
            the end effector has been at a goal for ``hold_time`` *and* the gripper is open at
            least this wide (m, the distance between the fingertip pads; more than the opening at
            the start, at most the gripper's 0.12 m). The simulated user, at the goal, changes to
            the gripper mode and opens it. ``None``: no release (the pose alone completes it).
            The object stays with the gripper in the simulation: what is checked is the opening
            at the goal, not where the object falls.
        ends_at_target: The stage completes only at the user's intended goal
            (``user.goals[stage]``), as when an experimenter named the target and ends the trial
            there: an arm that passes or rests at another goal does not end it (a reach, where
            nothing is done that cannot be undone). False (default): at any goal (a pour or a
            release: what is done there is done, and a wrong goal is a failure).
    """

    name: str = "reach"
    hold_time: float | None = None
    release_opening: float | None = None
    ends_at_target: bool = False


@dataclass
class SuccessSpec:
    """When a goal counts as reached: within both tolerances, continuously for ``hold_time``.

    Attributes:
        position_tolerance: Distance (m) between the end-effector origin and the goal position.
        orientation_tolerance: Angle (rad) of the rotation between the end-effector and goal
            orientations.
        hold_time: Time (s) the end effector must stay within both tolerances.
        give_up_after: The experimenter's rule for a hopeless trial: it ends, as a failure, when
            the end effector has come no closer to the intended goal of its stage, by one
            ``position_tolerance`` or ``orientation_tolerance`` (their sum in tolerance units),
            for this long (s); ``None`` (default): only the time limit ends it.
    """

    position_tolerance: float = 0.02
    orientation_tolerance: float = 0.15
    hold_time: float = 0.3
    give_up_after: float | None = None


@dataclass
class InferenceSpec:
    """Intent inference.

    Attributes:
        method: A name registered in :data:`drake_disamb.core.inference.INFERENCE_METHODS`:
            ``"dft"`` (field-theoretic, continuous state), ``"bayes"`` or ``"memory"``.
        dft: Parameters of the field-theoretic update (default the ``mico`` preset's). The
            disambiguation's forward projection runs the same update with the same parameters.
        agreement: Form of the DFT's agreement term (when ``dft.agreement`` is on), live and in
            the forward projection: ``"dot"`` the paper's ``u_h^rot . u_a^rot`` (rad^2/s^2, at
            most about 0.08 with the head array) or ``"cosine"`` the cosine of their angle (in
            ``[-1, 1]``; the default, the ``mico`` preset's: with the dot product a joystick
            reaching trial stalls, docs/choices.md, "Where we differ from the paper"). See
            :attr:`drake_disamb.core.inference.DFTParams.agreement_measure`.
        goal_set: What the belief is over in a multi-step task: ``"stage"`` (the default) the
            current stage's goals, reset to the rest state when a stage completes, or ``"task"``
            every goal of the task from start to end (the paper's study: one belief over the
            pouring task's 4 goals, uniform at the start only). Either way a stage completes only
            at one of its own goals; the same for a single-stage task. Measured with the simulated
            user, ``"task"`` keeps the belief (and the assistance) on the goal just completed, where
            the gripper still is (proximity term): it pulls the cup back toward the container and
            2 of the 4 joystick pouring trials fail (docs/choices.md, "Where we differ from the paper").
    """

    method: str = field(default="dft", metadata=_meta(choices=INFERENCE_METHODS))
    dft: DFTSpec = field(default_factory=DFTSpec)
    agreement: str = field(default=MICO_DFT.agreement_measure, metadata=_meta(choices=AGREEMENT_MEASURES))
    goal_set: str = field(default="stage", metadata=_meta(choices=GOAL_SETS))


@dataclass
class DisambiguationSpec:
    """Disambiguation (Algorithm 1 or an alternative mode selection), in the Disambiguation and
    Automatic paradigms.

    Attributes:
        preset: Name of a preset in :mod:`drake_disamb.core.disambiguation` (``"mico"`` or
            ``"authors-r3"``). The preset says how the projection probes (dimensions, probe
            speeds, step and horizons, weights). The belief update it projects with is always the
            live one: the method and DFT parameters of :attr:`Scenario.inference` and the
            potential field of :attr:`Scenario.autonomy` replace the preset's own.
        method: How the mode is chosen from the forward projection, a name registered in
            :data:`drake_disamb.core.disambiguation.MODE_SELECTION_METHODS`: ``"algorithm1"`` (the
            paper), ``"entropy"`` (minimum expected entropy of the projected belief) or ``"kl"``
            (maximum expected KL divergence from the current belief).
        request_latency: Seconds (finite, >= 0) from a request press (or an automatic trigger) to
            the mode switch; the mode is the one chosen at the switch time. The paper's system took
            2 to 2.5 s; 0 (default) switches in the press's control tick.
        hold_while_computing: While a disambiguation is being computed (the ``request_latency``
            from the press to the switch) the system's loop is paused: the belief is held and the
            arm is sent nothing (alpha 0). The study's system did so (its logs: the belief
            unchanged, alpha and the blended command 0 while a request was computed). False
            (default): the belief and the blending go on meanwhile.
        automatic: The Automatic paradigm's trigger (used only with ``paradigm: automatic``).
        upsilon_normalization: What ``p(t_c) - p(t_b)`` is divided by in the feature
            ``Upsilon``: ``"unit_probe"`` (the paper: the displacement of its unit-speed probe,
            ``t_c - t_b`` for every dimension), ``"displacement"`` (our probe's displacement, m or
            rad, which weighs dimensions by their units) or ``"none"`` (the authors' code);
            ``None`` keeps the preset's (``mico``: ``"unit_probe"``, ``authors-r3``: ``"none"``).
            See :attr:`drake_disamb.core.disambiguation.DisambiguationConfig.upsilon_normalization`.
    """

    preset: str = field(default="mico", metadata=_meta(choices=PRESETS))
    method: str = field(default="algorithm1", metadata=_meta(choices=MODE_SELECTION_METHODS))
    request_latency: float = 0.0
    hold_while_computing: bool = False
    automatic: AutomaticSpec = field(default_factory=AutomaticSpec)
    upsilon_normalization: str | None = field(default=None, metadata=_meta(choices=UPSILON_NORMALIZATIONS))


@dataclass
class UserSpec:
    """The simulated user.

    Attributes:
        goals: Intended goal per stage: an index into that stage's goal list (the goals of the
            stage in the order they appear in :attr:`Scenario.goals`).
        config: The user's behaviour. Its success tolerances must not exceed the task's
            (:class:`SuccessSpec`): the user stops commanding once it believes it has arrived.
    """

    goals: list[int] = field(default_factory=lambda: [0], metadata=_meta(max_items=MAX_GOALS))
    config: UserBehaviorSpec = field(default_factory=UserBehaviorSpec)


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

    shape: str = field(default="cylinder", metadata=_meta(choices=SHAPES))
    size: list[float] = field(default_factory=lambda: [0.035, 0.09], metadata=_meta(size=(1, 2, 3)))
    color: list[float] = field(default_factory=lambda: [0.9, 0.9, 0.95, 1.0], metadata=_meta(size=(4,)))
    offset: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0], metadata=_meta(size=(3,)))
    orientation: list[float] = field(
        default_factory=lambda: [0.7071067811865476, 0.0, 0.7071067811865476, 0.0], metadata=_meta(size=(4,))
    )


def default_simulator_config() -> SimulatorConfig:
    """The trials' simulator: fixed-step RK2 with 10 ms steps.

    The belief's inputs are held between control ticks (the end-effector pose is sampled, ``u_h``
    comes from the interface's state), so its ODE is smooth between ticks: a fixed step at the
    control period is accurate (the inference re-projects the belief onto the simplex every tick).
    """
    return SimulatorConfig(integration_scheme="runge_kutta2", max_step_size=0.01, use_error_control=False)


@dataclass(eq=False)
class Scenario:
    """One shared-control trial, in the style of Drake's typed scenario structs.

    Attributes:
        task: Task name (``"reaching"``, ``"pouring"``, or a user-chosen name).
        description: Free text.
        interface: A registered interface name (:data:`drake_disamb.interfaces.INTERFACES`:
            ``"joystick"``, ``"head_array"``, ...).
        interface_mode_selection: How a mode change selects a mode: ``"cycle"`` (default: the
            next mode) or ``"direct"`` (the joystick: a press with the stick deflected selects the
            mode of the stick's sector, one press per change; centred, it cycles: see
            :mod:`drake_disamb.interfaces.kinds.joystick`). The simulated user selects the way the
            interface offers. A kind that does not offer it (the head array, with no stick)
            cycles: the setting applies to the trials of the kinds that offer it only, so one
            setting serves a protocol with several interfaces.
        interface_mode_order: Per interface kind, its arm modes (each a list of dimension indices,
            0-2 translation, 3-5 rotation) in the order a mode change steps through them; the
            gripper mode follows. A kind left out keeps its registered order
            (:attr:`~drake_disamb.interfaces.Interface.mode_order`), so one setting serves the
            trials of every interface (the ``tnsre2020_study`` preset sets the head array's).
        paradigm: ``"manual"`` (mode button only), ``"disambiguation"`` (plus the request
            button) or ``"automatic"`` (plus the system's own switches, :class:`AutomaticSpec`).
        inference, disambiguation, blending, autonomy, user: Component settings.
        control_period: Period (s) of the control loop (interface, autonomy, blending,
            differential IK); 0.01 s = 100 Hz, the MICO's Cartesian velocity interface.
        simulator_config: Drake's ``SimulatorConfig`` (``ApplySimulatorConfig``): the integrator
            of the continuous belief (default :func:`default_simulator_config`, RK2 at 10 ms).
        plant_config: Drake's ``MultibodyPlantConfig`` of the arm (SAP, joint PD). Its
            ``time_step`` (s, in [1 ms, 100 ms] and at most the control period) defaults to the
            control period: the arm only receives new set points every control tick, the PD is
            integrated implicitly, and the loop runs several times faster than with a 1 ms plant
            (``benchmarks/bench_loop.py --time-step 0.001`` prints it); 0.001 resolves contact finer.
        station: The station's backend, a variant chosen by its YAML tag
            (:mod:`drake_disamb.station.backends`): ``!Sim {}`` (the default: the arm simulated in
            the trial's diagram) or ``!Lcm {lcm_url: ..., ...}`` (an arm behind an LCM driver).
        duration: Simulated-time limit (s) of a trial.
        success: Success tolerance.
        seed: Seed of every random draw in the trial.
        initial_mode: Index into the interface's mode list of the mode at the start.
        start_joint_positions: The arm's 6 joint angles (rad) at the start; ``None`` means the
            station's home configuration.
        joint_velocity_limits: The arm's 6 joint speed limits (rad/s, base to wrist) for the
            differential IK and the commands sent to an arm on the wire, each in (0, the model's]
            (0.628 rad/s for joints 1-3, 0.838 for joints 4-6); ``None`` means the model's. A first
            run on a real arm takes a fraction of them.
        goals: Every goal of every stage.
        stages: The task's stages, in order (one for single-step tasks). Every stage has the
            same number of goals: the goal set switches when a stage completes.
        carried_object: An object held in the gripper from the start, or ``None``.

    Two scenarios are equal when their plain data (:func:`to_plain`) is: Drake's structs have no
    ``==`` of their own.
    """

    task: str = "reaching"
    description: str = ""
    interface: str = field(default="head_array", metadata=_meta(choices=INTERFACES))
    interface_mode_selection: str = field(default="cycle", metadata=_meta(choices=MODE_SELECTIONS))
    interface_mode_order: dict[str, list[list[int]]] = field(
        default_factory=dict, metadata=_meta(choices=INTERFACES)
    )
    paradigm: str = field(default="disambiguation", metadata=_meta(choices=PARADIGMS))
    inference: InferenceSpec = field(default_factory=InferenceSpec)
    disambiguation: DisambiguationSpec = field(default_factory=DisambiguationSpec)
    blending: BlendingSpec = field(default_factory=BlendingSpec)
    autonomy: PotentialFieldSpec = field(default_factory=PotentialFieldSpec)
    user: UserSpec = field(default_factory=UserSpec)
    control_period: float = 0.01
    simulator_config: SimulatorConfig = field(default_factory=default_simulator_config)
    plant_config: MultibodyPlantConfig = field(default_factory=default_plant_config)
    station: StationBackend = field(default_factory=Sim)  # type: ignore[valid-type]
    duration: float = 60.0
    success: SuccessSpec = field(default_factory=SuccessSpec)
    seed: int = 0
    initial_mode: int = 0
    start_joint_positions: list[float] | None = field(default=None, metadata=_meta(size=(6,)))
    joint_velocity_limits: list[float] | None = field(default=None, metadata=_meta(size=(6,)))
    goals: list[GoalSpec] = field(default_factory=list)
    stages: list[StageSpec] = field(default_factory=lambda: [StageSpec()])
    carried_object: CarriedObjectSpec | None = None

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Scenario):
            return NotImplemented
        return to_plain(self) == to_plain(other)

    # -- derived views -------------------------------------------------------------------------

    @property
    def n_stages(self) -> int:
        """Number of stages."""
        return len(self.stages)

    def stage_goals(self, stage: int) -> list[GoalSpec]:
        """The goals of ``stage``, in the order they appear in :attr:`goals`."""
        return [g for g in self.goals if g.stage == stage]

    def belief_goals(self, stage: int) -> list[GoalSpec]:
        """The goals of the belief's slots while ``stage`` runs: the stage's goals, or every goal of
        the task (in :attr:`goals` order) with :attr:`InferenceSpec.goal_set` ``"task"``."""
        return list(self.goals) if self.inference.goal_set == "task" else self.stage_goals(stage)

    def belief_slot(self, stage: int, index: int) -> int:
        """The belief slot of goal ``index`` of ``stage`` (an index into :meth:`belief_goals`)."""
        goal = self.stage_goals(stage)[index]
        return next(i for i, g in enumerate(self.belief_goals(stage)) if g is goal)

    @property
    def n_goals(self) -> int:
        """The size of the belief: goals per stage, or all goals with ``inference.goal_set`` ``"task"``."""
        return len(self.belief_goals(0))

    def belief_goal_poses(self, stage: int) -> np.ndarray:
        """``(n_goals, 7)`` poses of :meth:`belief_goals` (unit quaternions)."""
        return self._poses(self.belief_goals(stage))

    def stage_goal_poses(self, stage: int) -> np.ndarray:
        """``(m, 7)`` array of ``[x, y, z, qw, qx, qy, qz]`` of the goals of ``stage`` (unit quaternions)."""
        return self._poses(self.stage_goals(stage))

    @staticmethod
    def _poses(goals: list[GoalSpec]) -> np.ndarray:
        rows = [
            [*g.position, *(np.asarray(g.orientation, dtype=float) / np.linalg.norm(g.orientation))]
            for g in goals
        ]
        return np.array(rows, dtype=float).reshape(-1, 7)

    def releases(self) -> list[bool]:
        """Per stage, whether it ends by letting go of the held object (``release_opening``)."""
        return [stage.release_opening is not None for stage in self.stages]

    def hold_time(self, stage: int) -> float:
        """Hold time (s) of ``stage``."""
        h = self.stages[stage].hold_time
        return self.success.hold_time if h is None else h


def to_plain(value: Any, schema: Any = None) -> Any:
    """Plain data (dicts, lists, numbers, strings) of a scenario or any part of it (of type
    ``schema``, by default its own).

    The same tree :func:`pydrake.common.yaml.yaml_dump_typed` writes, with ``None`` kept: a
    variant's value has the fields of the alternative it is an instance of, and its tag as
    ``_tag`` unless it is the first (an :class:`~drake_disamb.station.backends.InProcessLcm`
    station is an ``!Lcm`` one).
    """
    options = variant_types(schema)
    if options is not None and value is not None:
        k = next(i for i, cls in enumerate(options) if isinstance(value, cls))
        plain = to_plain(value, options[k])
        return plain if k == 0 else {"_tag": variant_tag(options[k]), **plain}
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, list | tuple):
        return [to_plain(v) for v in value]
    if isinstance(value, type):
        return value
    fields = schema_fields(schema if isinstance(schema, type) and schema_fields(schema) else type(value))
    if fields is None:
        return value
    return {name: to_plain(getattr(value, name), tp) for name, tp, _ in fields}
