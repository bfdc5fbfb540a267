"""The one place where a scenario becomes the frozen configs that the core and the systems use.

:func:`resolve_scenario` checks the scenario (:func:`~drake_disamb.config.validation.check_scenario`)
and returns a :class:`TrialConfig`:

- the blending thresholds ``(rho1, rho2, rho3)``, resolved once for the scenario's number of goals
  (:meth:`~drake_disamb.core.blending.BlendingConfig.rhos`, the paper's ``1.2 / n`` and ``1.4 / n``
  where the scenario leaves them out, or ``1 / n`` plus ``rho1_above_uniform`` /
  ``rho2_above_uniform``): the blender gets them written out, the simulated user its
  ``rho1``, the trial result reports ``rho1``;
- the DFT parameters and the potential field, one instance each, shared by the live inference,
  the autonomy and the disambiguation's forward projection. Whatever the preset, the projection
  runs the live belief update: the preset fixes how it probes (dimensions, probe speeds, step,
  horizons, weights), and its method, DFT parameters (with ``inference.agreement``, the agreement
  term's form) and potential field are replaced by the scenario's, as is its Upsilon normalisation
  when ``disambiguation.upsilon_normalization`` is set. The live inference and the projection
  hold the very same inference method (with its parameters). A method without a forward
  projection (``memory``) is refused by the disambiguation paradigm;
- the inference method and the mode-selection method (the registered variants the scenario
  names, :data:`~drake_disamb.core.inference.INFERENCE_METHODS` and
  :data:`~drake_disamb.core.disambiguation.MODE_SELECTION_METHODS`), the request latency (the
  interface's: it delays the switch) and, in the Automatic paradigm, the trigger (its
  ``confidence_threshold`` written out as ``rho1`` when left out; without its request
  button the interface logs presses but serves none);
- the interface's mode selection (``interface_mode_selection``: the joystick's; the head array
  always cycles);
- the simulated user's config (its seed is the scenario's; in the manual and automatic paradigms
  it never asks for disambiguation), the interface's, the station's (Drake's
  ``MultibodyPlantConfig``, the start posture and the scene objects) and its backend (the
  scenario's ``station``, which builds it), and Drake's ``SimulatorConfig``;
- everything else the builder reads (:func:`drake_disamb.builder.build_shared_control_diagram`
  reads nothing but the resolved config): the control period (:attr:`TrialConfig.loop`, with the
  belief's size), the task manager's config (stage goal poses, tolerances, hold times, release
  openings, targets), the belief's goal set, the user's releases, whether the loop pauses while a
  request is computed, and the goals' names, fields, colours and legend.

:func:`check_start_clearance` is the one check that needs the built station (the gripper's start
position): the builder runs it on the resolved config.

An error from a core config's own checks is raised as a ``ValueError`` that names the scenario
field first, e.g. ``scenario.inference.dft: DFTParams.tau1 must be a finite positive number, got -1.0``.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from drake_disamb.config.checks import cut, fmt
from drake_disamb.config.schema import Scenario
from drake_disamb.config.validation import MIN_START_CLEARANCE, check_scenario
from drake_disamb.core.automatic import AutomaticConfig
from drake_disamb.core.autonomy import PotentialFieldConfig
from drake_disamb.core.blending import BlendingConfig
from drake_disamb.core.disambiguation import (
    DisambiguationConfig,
    ModeSelectionMethod,
    mode_selection_method,
    preset,
)
from drake_disamb.core.inference import INFERENCE_METHODS, DFTParams, InferenceMethod, ProjectedInference
from drake_disamb.display import LegendRow, goal_colors, legend_rows
from drake_disamb.interfaces import INTERFACES, Interface, InterfaceConfig
from drake_disamb.systems.loop import ControlLoop
from drake_disamb.systems.task import TaskConfig
from drake_disamb.user import UserConfig

T = TypeVar("T")


@dataclass(frozen=True)
class TrialConfig:
    """The frozen configs of one trial, resolved from a scenario by :func:`resolve_scenario`.

    Attributes:
        n_goals: The size of the belief (:attr:`Scenario.n_goals`: goals per stage, or every goal
            of the task with ``inference.goal_set`` ``"task"``).
        rhos: The blending thresholds ``(rho1, rho2, rho3)`` for ``n_goals``.
        blending: The blender's config, ``rho1`` and ``rho2`` written out.
        autonomy: The potential field of the autonomy, the live inference's agreement term and the
            forward projection.
        inference: The live inference's method with its parameters (for the DFT the scenario's
            ``inference.dft``, the agreement term's form from ``inference.agreement``); the forward
            projection runs this same method.
        disambiguation: The forward projection's config (``None`` in the manual paradigm): the
            preset's probing with ``inference`` and ``autonomy``.
        disambiguation_method: The mode-selection method (the variant ``disambiguation.method``
            names).
        automatic: The Automatic paradigm's trigger, ``confidence_threshold`` written out
            (``None`` in the other paradigms).
        user: The simulated user's config (seed and ``rho1`` set).
        user_goals: Per stage, the belief slot of the user's intended goal
            (:meth:`Scenario.belief_slot`).
        interface: The interface's config.
        station: The station's config (plant config, control period, start posture, scene objects).
        simulator: Drake's ``SimulatorConfig`` for ``ApplySimulatorConfig`` (a copy).
        backend: The station's backend (the scenario's ``station``, its settings checked): what
            builds the station (:func:`drake_disamb.station.backends.make_station`).
        control_period: The loop's period (s): every system of the shared-control diagram ticks
            at it (the interface's and station's configs carry it too).
        task: The task manager's config: per stage, its goal poses, hold time, release opening
            and target (the user's goal where the stage ends at its target), and the success
            tolerances.
        task_name: The scenario's ``task`` (the diagram is named after it).
        task_goal_poses: With ``inference.goal_set`` ``"task"`` in a multi-step task, the
            ``(n_goals, 7)`` poses of every goal of the task: the belief's one goal set from start
            to end; ``None``: the belief is over the current stage's goals (the task manager's).
        user_releases: Per stage, whether it ends by letting go of the held object (the
            simulated user then opens the gripper at the goal).
        hold_while_computing: Whether the loop pauses while a disambiguation is computed
            (``disambiguation.hold_while_computing``).
        goal_names: Per stage, the names of its goals (in the order of ``task.stage_goal_poses``).
        goal_fields: Per stage, the scenario field of each of its goals (``scenario.goals[i]``),
            what an error about the goal names.
        goal_colors: Per stage, the ``(r, g, b, a)`` of each belief slot (its goal's object's
            colour, :func:`drake_disamb.display.goal_colors`).
        legend: The Meshcat legend (:func:`drake_disamb.display.legend_rows`).
    """

    n_goals: int
    rhos: tuple[float, float, float]
    blending: BlendingConfig
    autonomy: PotentialFieldConfig
    inference: InferenceMethod
    disambiguation: DisambiguationConfig | None
    user: UserConfig
    user_goals: tuple[int, ...]
    interface: InterfaceConfig
    station: Any
    simulator: Any
    backend: Any
    disambiguation_method: ModeSelectionMethod
    control_period: float
    task: TaskConfig
    task_name: str
    task_goal_poses: NDArray[np.float64] | None = dataclasses.field(compare=False)
    user_releases: tuple[bool, ...]
    hold_while_computing: bool
    goal_names: tuple[tuple[str, ...], ...]
    goal_fields: tuple[tuple[str, ...], ...]
    goal_colors: tuple[tuple[tuple[float, float, float, float], ...], ...]
    legend: tuple[LegendRow, ...]
    automatic: AutomaticConfig | None = None

    @property
    def loop(self) -> ControlLoop:
        """The belief's size and the control period: what each belief-sized system takes."""
        return ControlLoop(self.n_goals, self.control_period)


def ordered_variant(kind: str, order: object, path: str = "interface_mode_order") -> Interface:
    """The registered interface ``kind`` with its arm modes in ``order`` (lists of dimension
    indices, as in ``Scenario.interface_mode_order``).

    Raises:
        ValueError: an unknown kind, or an order that is not a valid mode order of the kind,
            prefixed by ``path``.
    """
    if kind not in INTERFACES:
        raise ValueError(f"{path}: unknown interface (registered: {', '.join(INTERFACES)})")
    if not isinstance(order, list | tuple):
        raise ValueError(f"{path}: expected a list of modes, got {fmt(order)}")
    modes = tuple(tuple(m) if isinstance(m, list | tuple) else m for m in order)
    return _named(path, lambda: dataclasses.replace(INTERFACES[kind], mode_order=modes))


def interface_variant(s: Scenario, name: str = "scenario") -> Interface:
    """The interface variant of a scenario's trials: the registered kind with the scenario's
    ``interface_mode_order`` for it (its registered order where the scenario gives none). Every
    entry is checked, not only the trial's kind's.

    Raises:
        ValueError: an entry that is not a valid mode order of its kind, naming it.
    """
    variants = {
        kind: ordered_variant(kind, order, f"{name}.interface_mode_order.{kind}")
        for kind, order in s.interface_mode_order.items()
    }
    return variants.get(s.interface, INTERFACES[s.interface])


def _named(path: str, make: Callable[[], T]) -> T:
    """``make()``, with a ``ValueError`` from a core config's checks prefixed by the scenario field."""
    try:
        return make()
    except ValueError as exc:
        raise ValueError(f"{path}: {cut(str(exc))}") from exc


def _check_dft_sizes(dft: DFTParams, n: int, path: str) -> None:
    if dft.transition is not None and np.shape(dft.transition) != (n, n):
        raise ValueError(
            f"{path}.transition: expected a {n} x {n} matrix (one row per goal), got {fmt(dft.transition)}"
        )
    if dft.rest is not None and np.shape(dft.rest) != (n,):
        raise ValueError(f"{path}.rest: expected {n} probabilities (one per goal), got {fmt(dft.rest)}")


def projection_config(
    preset_name: str,
    method: InferenceMethod,
    autonomy: PotentialFieldConfig,
    path: str = "scenario",
    upsilon_normalization: str | None = None,
) -> DisambiguationConfig:
    """The forward projection's config: preset ``preset_name``'s probing, the live belief update
    ``method`` (the same instance the live inference runs).

    ``upsilon_normalization`` replaces the preset's unless ``None``.

    Raises:
        ValueError: for a method without a forward projection (``memory``).
    """
    if not isinstance(method, ProjectedInference):
        projected = [repr(m.name) for m in INFERENCE_METHODS.variants() if issubclass(m, ProjectedInference)]
        names = " and ".join(filter(None, (", ".join(projected[:-1]), projected[-1])))
        raise ValueError(
            f"{path}.inference.method: the disambiguation paradigm projects the belief forward with the "
            f"live inference's update, which exists for {names} (use the manual paradigm), "
            f"got {method.name!r}"
        )
    base = preset(preset_name)
    ups = base.upsilon_normalization if upsilon_normalization is None else upsilon_normalization
    return _named(
        f"{path}.disambiguation",
        lambda: dataclasses.replace(
            base, inference=method, potential_field=autonomy, upsilon_normalization=ups
        ),
    )


def resolve_scenario(scenario: Scenario, name: str = "scenario") -> TrialConfig:
    """Check ``scenario`` and build its frozen configs (see the module docstring).

    Raises:
        ValueError: naming the field path (``scenario.blending``, ``scenario.goals[2].position``...)
            and the value.
    """
    from drake_disamb.station import StationConfig

    s = scenario
    check_scenario(s, name)
    n = s.n_goals
    blending = _named(f"{name}.blending", s.blending.to_config)
    rhos = _named(f"{name}.blending", lambda: blending.rhos(n))
    blending = dataclasses.replace(
        blending, rho1=rhos[0], rho2=rhos[1], rho1_above_uniform=None, rho2_above_uniform=None
    )
    autonomy = _named(f"{name}.autonomy", s.autonomy.to_config)
    dft = _named(
        f"{name}.inference.dft", lambda: s.inference.dft.to_config(agreement_measure=s.inference.agreement)
    )
    _check_dft_sizes(dft, n, f"{name}.inference.dft")
    inference = _named(
        f"{name}.inference.method", lambda: INFERENCE_METHODS.get(s.inference.method).from_settings(dft)
    )
    user = _named(f"{name}.user.config", lambda: s.user.config.to_config(seed=s.seed, rho1=rhos[0]))
    disambiguation = None
    if s.paradigm != "disambiguation":
        # Manual: there is no request button. Automatic: the system switches by itself, so the
        # simulated user does not ask (a person may still press, if the trigger's request_button
        # allows it).
        user = user.without_requests()
    if s.paradigm != "manual":
        disambiguation = projection_config(
            s.disambiguation.preset,
            inference,
            autonomy,
            name,
            s.disambiguation.upsilon_normalization,
        )
    automatic = None
    if s.paradigm == "automatic":
        automatic = _named(f"{name}.disambiguation.automatic", s.disambiguation.automatic.to_config)
        if automatic.confidence_threshold is None:
            automatic = dataclasses.replace(automatic, confidence_threshold=rhos[0])
    selection = s.interface_mode_selection
    variant = interface_variant(s, name)
    interface = _named(
        f"{name}.initial_mode",
        lambda: InterfaceConfig(
            variant=variant,
            kind=s.interface,
            control_period=s.control_period,
            initial_mode=s.initial_mode,
            request_latency=float(s.disambiguation.request_latency),
            serve_requests=automatic is None or automatic.request_button,
            # A kind that does not offer the selection (the head array: no stick) cycles.
            mode_selection=selection if selection in INTERFACES[s.interface].mode_selections else "cycle",
        ),
    )
    index = {id(g): i for i, g in enumerate(s.goals)}  # a goal's place in scenario.goals
    arm = {} if s.start_joint_positions is None else {"home_q": tuple(s.start_joint_positions)}
    if s.joint_velocity_limits is not None:
        arm["joint_velocity_limits"] = tuple(float(v) for v in s.joint_velocity_limits)
    station = _named(
        name,
        lambda: StationConfig(
            plant_config=s.plant_config,
            control_period=s.control_period,
            scene_objects=tuple(scene_objects(s)),
            **arm,
        ),
    )
    return TrialConfig(
        n_goals=n,
        rhos=rhos,
        blending=blending,
        autonomy=autonomy,
        inference=inference,
        disambiguation=disambiguation,
        user=user,
        user_goals=tuple(s.belief_slot(k, int(g)) for k, g in enumerate(s.user.goals)),
        interface=interface,
        station=station,
        simulator=copy.copy(s.simulator_config),
        backend=s.station,
        disambiguation_method=_named(
            f"{name}.disambiguation.method", lambda: mode_selection_method(s.disambiguation.method)
        ),
        control_period=s.control_period,
        task=TaskConfig(
            stage_goal_poses=tuple(s.stage_goal_poses(k) for k in range(s.n_stages)),
            position_tolerance=s.success.position_tolerance,
            orientation_tolerance=s.success.orientation_tolerance,
            hold_times=tuple(s.hold_time(k) for k in range(s.n_stages)),
            control_period=s.control_period,
            release_openings=tuple(stage.release_opening for stage in s.stages),
            targets=tuple(
                goal if stage.ends_at_target else None
                for goal, stage in zip(s.user.goals, s.stages, strict=True)
            ),
        ),
        task_name=s.task,
        task_goal_poses=s.belief_goal_poses(0) if s.inference.goal_set == "task" and s.n_stages > 1 else None,
        user_releases=tuple(s.releases()),
        hold_while_computing=bool(s.disambiguation.hold_while_computing),
        goal_names=tuple(tuple(g.name for g in s.stage_goals(k)) for k in range(s.n_stages)),
        goal_fields=tuple(
            tuple(f"{name}.goals[{index[id(g)]}]" for g in s.stage_goals(k)) for k in range(s.n_stages)
        ),
        goal_colors=tuple(tuple(colors) for colors in goal_colors(s)),
        legend=tuple(legend_rows(s)),
        automatic=automatic,
    )


def validate_scenario(scenario: Scenario, name: str = "scenario") -> Scenario:
    """Check ``scenario`` as :func:`resolve_scenario` does; return it unchanged.

    Raises:
        ValueError: naming the field path and the value.
    """
    resolve_scenario(scenario, name)
    return scenario


def check_start_clearance(config: TrialConfig, start_position: Sequence[float]) -> None:
    """Reject a goal of the first stage within
    :data:`~drake_disamb.config.validation.MIN_START_CLEARANCE` of the gripper's start position.

    The start position depends on the arm's kinematics (on a wire, on the measured arm), so the
    builder calls this with the resolved ``config`` once the station exists.

    Raises:
        ValueError: naming the goal's field (``scenario.goals[i].position``) and the value.
    """
    start = np.asarray(start_position, dtype=float)
    positions = np.asarray(config.task.stage_goal_poses[0])[:, :3]
    for position, goal, path in zip(positions, config.goal_names[0], config.goal_fields[0], strict=True):
        dist = float(np.linalg.norm(position - start))
        if dist < MIN_START_CLEARANCE:
            raise ValueError(
                f"{path}.position: goal {goal!r} is on top of the gripper's start position "
                f"{np.round(start, 4).tolist()} ({dist:.3f} m < {MIN_START_CLEARANCE} m), "
                f"got {fmt(position.tolist())}"
            )


def scene_objects(scenario: Scenario) -> list[Any]:
    """The station's scene objects: one per goal (at the goal plus its offset) and the carried one."""
    from drake_disamb.station import SceneObject

    objects = []
    for g in scenario.goals:
        o = g.object
        centre = np.asarray(g.position) + np.asarray(o.offset)
        objects.append(
            SceneObject(
                name=g.name,
                shape=o.shape,
                size=tuple(o.size),
                pose=(*centre.tolist(), 1.0, 0.0, 0.0, 0.0),
                rgba=tuple(o.color),
            )
        )
    if scenario.carried_object is not None:
        c = scenario.carried_object
        objects.append(
            SceneObject(
                name="carried_object",
                shape=c.shape,
                size=tuple(c.size),
                pose=(*c.offset, *c.orientation),
                rgba=tuple(c.color),
                attached_to_gripper=True,
            )
        )
    return objects
