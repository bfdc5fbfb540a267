"""The operator panel fed from the diagram: what the robot believes and why, beside the scene.

:class:`PanelVisualizer` publishes, every ``publish_period``, one panel state (a JSON-ready dict,
:mod:`drake_disamb.operator_page.model` words it) to its sinks: the operator page's server
(:class:`~drake_disamb.operator_page.server.OperatorPage`, to the person) and a
:class:`~drake_disamb.operator_page.replay.PanelRecorder` (to the trial's saved recording). In the
scene it draws, under ``/operator``, a ring and a pin over the most likely goal (``guess``) and,
after a request or an automatic switch, the cue of the motion the new mode allows (``cue``): pale
arrows along the mode's dimension that tells the goals apart most (a ring about it for a rotation)
whose two ends are balls in the colours of the goals each direction points at; it follows the
gripper while the mode is the chosen one, for :data:`CUE_SECONDS`. Every scene update carries the
context time, so a running Meshcat recording keeps it.

Why the mode is what it is comes from the disambiguation's own result: when the interface applies
an answer (its ``served_count`` grows), the system's update reads the answered request (the
interface's latched ``request``, rebuilt as the method saw it by
:meth:`~drake_disamb.systems.disambiguation.DisambiguationSystem.core_request`) and the method's
result (``last_result``), works out which goals the mode tells apart
(:func:`~drake_disamb.core.disambiguation.told_apart.told_apart`) and keeps the line in its state
(:class:`WhyState`): computed once per answer, in the Context. The publish only reads.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import Cylinder, Rgba, Sphere
from pydrake.math import RigidTransform
from pydrake.systems.framework import Context, EventStatus, LeafSystem, State

from drake_disamb.core.disambiguation import DisambiguationRequest
from drake_disamb.core.disambiguation.told_apart import ToldApart, told_apart
from drake_disamb.core.layout import GRIPPER_DIM, POSE_SIZE
from drake_disamb.display import css_color
from drake_disamb.operator_page.model import (
    LiveControlsLike,
    goal_rows,
    key_actions,
    leading_goal,
    mode_label,
    mode_title,
    why_line,
)
from drake_disamb.operator_page.replay import PanelRecorder
from drake_disamb.system_helpers.status import DID_NOTHING
from drake_disamb.systems.disambiguation import LastResult, LatchedRequest
from drake_disamb.systems.visualization import _axis_rotation

__all__ = ["CUE_SECONDS", "PanelConfig", "PanelSink", "PanelVisualizer", "WhyState"]

ROOT = "/operator"
CUE_SECONDS = 12.0
"""How long (s) the scene's cue stays after a switch (less if the mode changes)."""

CUE_LENGTH = 0.14
"""Length (m) of each arm of the cue's arrows, and radius of its ring."""

PIN_COLOR = (0.0, 0.0, 0.0)
"""The guess's ring and pin: black (Okabe-Ito's first colour)."""


class PanelSink(Protocol):
    """Where the panel states go (the operator page, a recorder)."""

    def show(self, panel: dict[str, Any]) -> None: ...


@dataclass(frozen=True)
class PanelConfig:
    """What the panel needs to know of the trial (plain values).

    Attributes:
        title: The condition, e.g. ``reaching · Head array · disambiguation``.
        variant: The interface variant (its live controls and modes).
        modes: Every mode of the interface (gripper last); ``mode`` indexes them.
        goal_names: Per stage, the name of each belief slot.
        goal_colors: Per stage, the ``(r, g, b)`` of each belief slot (its object's colour).
        stage_names: The stages' names (one stage: its name is not shown).
        axis_keys: The axis keys of a kind with ``live_axes`` (``interfaces.live.AXIS_SLIDERS``).
        requests_served: Whether a request makes the robot choose a mode.
        mode_selection: The interface's ``mode_selection``.
    """

    title: str
    variant: LiveControlsLike
    modes: tuple[tuple[int, ...], ...]
    goal_names: tuple[tuple[str, ...], ...]
    goal_colors: tuple[tuple[tuple[float, float, float], ...], ...]
    stage_names: tuple[str, ...] = ()
    axis_keys: tuple[tuple[str, str, str], ...] = ()
    requests_served: bool = True
    mode_selection: str = "cycle"

    @property
    def n_goals(self) -> int:
        return len(self.goal_names[0])

    @property
    def arm_modes(self) -> tuple[tuple[int, ...], ...]:
        return self.modes[:-1]


@dataclass(frozen=True)
class WhyState:
    """The panel's state: the last disambiguation applied and why its mode is what it is.

    Attributes:
        served: The interface's ``served_count`` when it was applied (0: none yet).
        requests: The interface's ``request_count`` then (a later press is a new request).
        automatic: The robot started it (no request press since the previous one).
        mode: The interface's mode after it.
        time: When it was applied (s).
        line: One line: why this mode.
        detail: The method's own first line of explanation (its scores), or ``""``.
        told: Which goals the mode tells apart (the scene's cue), or ``None``.
    """

    served: int = 0
    requests: int = 0
    automatic: bool = False
    mode: int = -1
    time: float = -math.inf
    line: str = ""
    detail: str = ""
    told: ToldApart | None = field(default=None)


class PanelVisualizer(LeafSystem):
    """Publishes the operator panel and draws its cues in the scene (module docstring).

    .. pydrake_system::

        name: PanelVisualizer
        input_ports:
        - belief
        - goal_poses
        - ee_pose
        - mode
        - alpha
        - paused
        - served_count
        - request_count
        - stage (multi-step tasks)
        - request (with a disambiguation system)
        - last_result (with a disambiguation system)

    Input ports: the inference's ``belief`` (n), the goal poses (7 n) and the end-effector pose (7)
    in W (m, unit quaternions), the interface's ``mode``, ``paused``, ``served_count``,
    ``request_count`` (1 each) and latched ``request``, the blender's ``alpha`` (1), the task's
    ``stage`` (1), the disambiguation system's ``last_result`` (abstract).

    State: one abstract :class:`WhyState`, written by a periodic unrestricted update (every
    ``update_period``, from 0) only when the interface has applied a new answer.

    Publishes every ``publish_period`` s (at initialization too) to every sink in ``sinks``.

    Args:
        config: The trial's :class:`PanelConfig`.
        sinks: Where the panel states go.
        meshcat: The scene to draw the guess and the cue in (``None``: none).
        core_request: The disambiguation system's
            :meth:`~drake_disamb.systems.disambiguation.DisambiguationSystem.core_request`
            (``None``: no disambiguation in this trial; the ``request`` and ``last_result`` inputs
            are not declared).
        publish_period: Seconds between two panel states.
        clock: The wall clock stamped on every state (``wall``, s since the epoch).
        record: Keep the states for the trial's recording in :attr:`recorder` (a
            :class:`~drake_disamb.operator_page.replay.PanelRecorder`; else ``None``).
        update_period: Seconds between two looks for a new answer (the control period: the why
            is ready by the publish after the switch).
    """

    def __init__(
        self,
        config: PanelConfig,
        sinks: Sequence[PanelSink],
        meshcat: Any = None,
        core_request: Callable[[LatchedRequest], DisambiguationRequest | None] | None = None,
        publish_period: float = 0.02,
        clock: Callable[[], float] = time.time,
        record: bool = False,
        update_period: float = 0.01,
    ) -> None:
        super().__init__()
        assert isinstance(config, PanelConfig), config
        self.config = config
        self.recorder = PanelRecorder() if record else None
        self._sinks = [*sinks, *([self.recorder] if self.recorder is not None else [])]
        self._meshcat = meshcat
        self._core_request = core_request
        self._clock = clock
        n = config.n_goals
        self._belief = self.DeclareVectorInputPort("belief", n)
        self._goal_poses = self.DeclareVectorInputPort("goal_poses", n * POSE_SIZE)
        self._ee_pose = self.DeclareVectorInputPort("ee_pose", POSE_SIZE)
        self._inputs = {
            name: self.DeclareVectorInputPort(name, 1)
            for name in ("mode", "alpha", "paused", "served_count", "request_count")
        }
        self._stage = self.DeclareVectorInputPort("stage", 1) if len(config.goal_names) > 1 else None
        self._request = self._last_result = None
        if core_request is not None:
            self._request = self.DeclareVectorInputPort("request", LatchedRequest.size(n))
            self._last_result = self.DeclareAbstractInputPort("last_result", AbstractValue.Make(LastResult()))
        self._why = self.DeclareAbstractState(AbstractValue.Make(WhyState()))
        self.DeclarePeriodicUnrestrictedUpdateEvent(update_period, 0.0, self._update)
        self.DeclarePeriodicPublishEvent(publish_period, 0.0, self._publish)
        self.DeclareForcedPublishEvent(self._publish)
        self.DeclareInitializationPublishEvent(self._initialize)
        # Publish-side bookkeeping, as Drake's MeshcatVisualizer keeps: what the scene was last sent.
        self._sent: dict[str, Any] = {}
        if meshcat is not None:
            self._create_scene()

    # -- reading the inputs ---------------------------------------------------------------------------

    def _value(self, context: Context, name: str) -> float:
        return float(self._inputs[name].Eval(context)[0])

    def _stage_index(self, context: Context) -> int:
        if self._stage is None:
            return 0
        value = float(self._stage.Eval(context)[0])
        return int(np.clip(value, 0, len(self.config.goal_names) - 1)) if math.isfinite(value) else 0

    def _mode_index(self, context: Context) -> int:
        value = self._value(context, "mode")
        n = len(self.config.modes)
        return int(value) if math.isfinite(value) and 0 <= value < n else 0

    def why(self, context: Context) -> WhyState:
        """The panel's :class:`WhyState` in ``context``."""
        return context.get_abstract_state(self._why).get_value()

    # -- the update: why, once per answer -----------------------------------------------------------

    def _update(self, context: Context, state: State) -> EventStatus:
        served = int(round(self._value(context, "served_count")))
        before = self.why(context)
        if served == before.served:
            return DID_NOTHING
        requests = int(round(self._value(context, "request_count")))
        mode = self._mode_index(context)
        names = self.config.goal_names[self._stage_index(context)]
        automatic = requests == before.requests
        line, detail, told = self._explain(context, served, names, automatic)
        after = WhyState(served, requests, automatic, mode, context.get_time(), line, detail, told)
        state.get_mutable_abstract_state(self._why).set_value(after)
        return EventStatus.Succeeded()

    def _explain(
        self, context: Context, served: int, names: Sequence[str], automatic: bool
    ) -> tuple[str, str, ToldApart | None]:
        """``(line, detail, told)`` of the answer to request ``served``."""
        if self._core_request is None:
            return "No mode choice in this condition: your mode is kept.", "", None
        latched = LatchedRequest.from_vector(self._request.Eval(context), self.config.n_goals)
        result = self._last_result.Eval(context).result if latched.id == served else None
        request = self._core_request(latched) if result is not None else None
        if result is None or request is None:
            return (
                "The robot could not choose a mode (its inputs were unusable): your mode is kept.",
                "",
                None,
            )
        told = told_apart(request, result)
        line = why_line(told, self.config.arm_modes, result.mode, names, automatic)
        return line, result.explain().splitlines()[0], told

    # -- the publish --------------------------------------------------------------------------------

    def panel_state(self, context: Context) -> dict[str, Any]:
        """The panel state of ``context`` (what :meth:`_publish` sends; JSON-ready)."""
        cfg = self.config
        stage = self._stage_index(context)
        belief = np.asarray(self._belief.Eval(context), dtype=float)
        colors = [css_color(c) for c in cfg.goal_colors[stage]]
        goals = goal_rows(belief, cfg.goal_names[stage], colors)
        lead = leading_goal(np.nan_to_num(belief))
        mode = self._mode_index(context)
        alpha = self._value(context, "alpha")
        share = int(round(100 * float(np.clip(alpha, 0.0, 1.0)))) if math.isfinite(alpha) else 0
        dims = cfg.modes[mode]
        keys = key_actions(
            cfg.variant, cfg.modes, mode, cfg.axis_keys, cfg.requests_served, cfg.mode_selection
        )
        return {
            "t": float(context.get_time()),
            "wall": float(self._clock()),
            "title": cfg.title,
            "stage": f"stage {stage + 1} of {len(cfg.stage_names)}: {cfg.stage_names[stage]}"
            if len(cfg.stage_names) > 1
            else "",
            "guess": None if lead is None else {k: goals[lead][k] for k in ("name", "percent", "color")},
            "goals": goals,
            "mode": {
                "title": mode_title(dims),
                "detail": f"{mode_label(dims)}, one of the {len(cfg.modes)} modes",
            },
            "keys": [k.to_dict() for k in keys],
            "share": share,
            "status": self._status(context, mode),
        }

    def _status(self, context: Context, mode: int) -> dict[str, str]:
        why = self.why(context)
        if self._value(context, "paused") >= 0.5:
            asked = self._value(context, "request_count") > why.requests
            who = "you asked" if asked else "by itself: it is unsure of your goal"
            return {"kind": "choosing", "text": f"The robot is choosing a mode\u2026 ({who})", "detail": ""}
        if why.line and mode == why.mode:
            return {"kind": "why", "text": why.line, "detail": why.detail}
        return {"kind": "", "text": "", "detail": ""}

    def _initialize(self, context: Context) -> EventStatus:
        self._sent = {}
        return self._publish(context)

    def _publish(self, context: Context) -> EventStatus:
        panel = self.panel_state(context)
        for sink in self._sinks:
            sink.show(panel)
        if self._meshcat is not None:
            self._draw(context)
        return EventStatus.Succeeded()

    # -- the scene ------------------------------------------------------------------------------------

    def _colors(self) -> list[tuple[float, float, float]]:
        """Every goal colour of every stage, once each, then grey (no goal)."""
        seen: dict[tuple[float, float, float], None] = {}
        for stage in self.config.goal_colors:
            for rgb in stage:
                seen.setdefault(tuple(float(c) for c in rgb[:3]), None)  # type: ignore[arg-type]
        return [*seen, (0.6, 0.6, 0.6)]

    def _create_scene(self) -> None:
        m = self._meshcat
        m.Delete(ROOT)
        black = Rgba(*PIN_COLOR, 0.9)
        m.SetObject(f"{ROOT}/guess/ring", Cylinder(0.068, 0.004), Rgba(*PIN_COLOR, 0.3))
        m.SetObject(f"{ROOT}/guess/pin", Cylinder(0.003, 0.05), black)
        m.SetTransform(f"{ROOT}/guess/pin", RigidTransform([0.0, 0.0, 0.085]))
        m.SetObject(f"{ROOT}/guess/head", Sphere(0.012), black)
        m.SetTransform(f"{ROOT}/guess/head", RigidTransform([0.0, 0.0, 0.115]))
        m.SetProperty(f"{ROOT}/guess", "visible", False)
        ghost = Rgba(1.0, 1.0, 1.0, 0.55)
        m.SetObject(f"{ROOT}/cue/axis/move", Cylinder(0.009, 2 * CUE_LENGTH), ghost)
        m.SetObject(f"{ROOT}/cue/axis/turn", Cylinder(CUE_LENGTH, 0.004), Rgba(1.0, 1.0, 1.0, 0.45))
        for end in ("plus", "minus"):
            for j, rgb in enumerate(self._colors()):
                path = f"{ROOT}/cue/axis/{end}/c{j}"
                m.SetObject(path, Sphere(0.03), Rgba(*rgb, 1.0))
                m.SetProperty(path, "visible", False)
        m.SetProperty(f"{ROOT}/cue", "visible", False)

    def _set(self, path: str, prop: str, value: Any, t: float) -> None:
        """Send a property only when it changed (publish-side bookkeeping)."""
        key = f"{path}:{prop}"
        if self._sent.get(key) != value:
            self._meshcat.SetProperty(path, prop, value, t)
            self._sent[key] = value

    def _draw(self, context: Context) -> None:
        m, t = self._meshcat, context.get_time()
        belief = np.nan_to_num(np.asarray(self._belief.Eval(context), dtype=float))
        goals = np.asarray(self._goal_poses.Eval(context), dtype=float).reshape(-1, POSE_SIZE)
        lead = leading_goal(belief)
        if lead is not None and np.all(np.isfinite(goals[lead, :3])):
            m.SetTransform(f"{ROOT}/guess", RigidTransform(goals[lead, :3]), t)
        self._set(f"{ROOT}/guess", "visible", lead is not None, t)
        why = self.why(context)
        told = why.told
        ee = np.asarray(self._ee_pose.Eval(context), dtype=float)
        shown = (
            told is not None
            and self._mode_index(context) == why.mode
            and t - why.time < CUE_SECONDS
            and bool(np.all(np.isfinite(ee[:3])))
        )
        self._set(f"{ROOT}/cue", "visible", shown, t)
        if not shown:
            return
        d = told.dimension
        turn = 3 <= d < GRIPPER_DIM
        m.SetTransform(f"{ROOT}/cue", RigidTransform(ee[:3]), t)
        self._draw_cue(d - 3 if turn else d, turn, told, self._stage_index(context), t)

    def _draw_cue(self, axis: int, turn: bool, told: ToldApart, stage: int, t: float) -> None:
        """The cue's axis (an arrow both ways, or a ring about it) and its two ends' balls."""
        self._meshcat.SetTransform(f"{ROOT}/cue/axis", RigidTransform(_axis_rotation(axis), np.zeros(3)), t)
        self._set(f"{ROOT}/cue/axis/move", "visible", not turn, t)
        self._set(f"{ROOT}/cue/axis/turn", "visible", turn, t)
        palette = self._colors()
        stage_colors = [tuple(float(c) for c in rgb[:3]) for rgb in self.config.goal_colors[stage]]
        for end, goal, sign in (("plus", told.plus_goal, 1.0), ("minus", told.minus_goal, -1.0)):
            # Along the arrow (z of the axis frame) for a translation; on the ring for a rotation,
            # a quarter turn either way from its +x point.
            where = [0.0, sign * CUE_LENGTH, 0.0] if turn else [0.0, 0.0, sign * CUE_LENGTH]
            self._meshcat.SetTransform(f"{ROOT}/cue/axis/{end}", RigidTransform(where), t)
            pick = len(palette) - 1 if goal is None else palette.index(stage_colors[goal])
            for j in range(len(palette)):
                self._set(f"{ROOT}/cue/axis/{end}/c{j}", "visible", j == pick, t)
