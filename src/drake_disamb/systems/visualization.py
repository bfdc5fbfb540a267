"""Meshcat display of the shared-control state: goal probabilities, the active mode, alpha.

What is drawn (all under ``/shared_control`` in the Meshcat scene tree):

- ``goals/g<i>``: one sphere per goal at its position, in the goal's own colour (its object's, see
  :func:`drake_disamb.display.goal_colors`), sized and made opaque by its probability (radius from
  ``min_radius`` at p = 0 to ``max_radius`` at p = 1; opacity from :data:`MIN_OPACITY` to
  :data:`MAX_OPACITY` in :data:`COLOR_LEVELS` steps). Sizes are animated with the ``scale``
  property and opacities by switching the ``visible`` flag of pre-built spheres, so both show in
  the saved recording (a Meshcat animation replays transforms and properties only). A multi-step
  task gives one colour set per stage (``goals/g<i>/s/c<k>``), switched by the ``stage`` input.
- ``mode/d<k>``: the active control mode's dimensions at the gripper, in W: an arrow (thin
  cylinder with a cone-less tip sphere) along x/y/z for a translational dimension, a flat ring
  about the axis for a rotational one (red/green/blue for x/y/z), and a yellow sphere for the
  gripper mode.
- ``alpha``: a vertical bar beside the arm whose height is the autonomy's share alpha (a faint
  full-height sleeve shows alpha = 1); in a live session a read-only ``alpha`` slider too.
- a legend (optional): lines of the Meshcat control panel naming the intended goal, the goals'
  colours and what the above means (:func:`drake_disamb.display.legend_rows`). Meshcat's
  ``StaticHtml`` leaves the control panel out; :func:`drake_disamb.display.add_legend_to_html` puts
  the same legend on a saved recording.

:func:`frame_workspace` points the camera at the table, the arm and the objects and lays the floor
grid at the foot of the table.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydrake.geometry import Cylinder, Meshcat, Rgba, Sphere
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.tree import BodyIndex
from pydrake.systems.framework import Context, EventStatus, LeafSystem

from drake_disamb.core.layout import GRIPPER_DIM
from drake_disamb.display import OKABE_ITO, LegendRow

ROOT = "/shared_control"
COLOR_LEVELS = 5
"""Number of opacity steps of a goal's sphere between p = 0 and p = 1."""
MIN_OPACITY = 0.3
"""Opacity of a goal's sphere at p = 0."""
MAX_OPACITY = 0.9
"""Opacity of a goal's sphere at p = 1."""

GOAL_PALETTE: tuple[tuple[float, float, float], ...] = (
    (0.122, 0.467, 0.706),
    (1.000, 0.498, 0.055),
    (0.173, 0.627, 0.173),
    (0.839, 0.153, 0.157),
    (0.580, 0.404, 0.741),
    (0.549, 0.337, 0.294),
    (0.890, 0.467, 0.761),
    (0.498, 0.498, 0.498),
)
"""Fallback goal colours (matplotlib's tab10) when no colours are given; a scenario's
visualizer uses its objects' colours (:func:`drake_disamb.display.goal_colors`)."""

AXIS_COLORS = (OKABE_ITO["vermillion"], OKABE_ITO["bluish_green"], OKABE_ITO["blue"])
"""The x, y and z axes' colours: Okabe and Ito's colour-blind-safe vermillion, bluish green and blue
(red, green and blue as robotics draws axes, told apart by people who confuse red and green)."""


def goal_color(index: int) -> tuple[float, float, float]:
    """The display colour of goal ``index`` (cycles through :data:`GOAL_PALETTE`)."""
    return GOAL_PALETTE[index % len(GOAL_PALETTE)]


def _color_sets(goal_colors: ArrayLike | None, n_goals: int) -> list[NDArray[np.float64]]:
    """``goal_colors`` as a list of ``(n_goals, 3)`` RGB arrays, one per stage (checked)."""
    if goal_colors is None:
        return [np.array([goal_color(i) for i in range(n_goals)], dtype=float)]
    try:
        c = np.asarray(goal_colors, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"goal_colors: expected numbers, got {goal_colors!r}") from None
    if c.ndim == 2:
        c = c[None]
    if c.ndim != 3 or c.shape[0] < 1 or c.shape[1] != n_goals or c.shape[2] not in (3, 4):
        raise ValueError(
            f"goal_colors: expected {n_goals} colours (r, g, b[, a]), or one such set per stage, "
            f"got shape {c.shape}"
        )
    if not np.all((c >= 0) & (c <= 1)):
        raise ValueError("goal_colors: expected entries in [0, 1]")
    return [stage[:, :3].copy() for stage in c]


def probability_level(p: float, levels: int = COLOR_LEVELS) -> int:
    """Colour step ``0 .. levels - 1`` of a probability (non-finite counts as 0)."""
    if not np.isfinite(p):
        return 0
    return int(np.clip(np.floor(p * levels), 0, levels - 1))


def _axis_rotation(axis: int) -> RotationMatrix:
    """Rotation taking z (the axis of Meshcat cylinders) onto axis 0/1/2 of W."""
    if axis == 0:
        return RotationMatrix.MakeYRotation(np.pi / 2)
    if axis == 1:
        return RotationMatrix.MakeXRotation(-np.pi / 2)
    return RotationMatrix()


class SharedControlVisualizer(LeafSystem):
    """Draws goal probabilities, the active control mode and alpha in Meshcat.

    .. pydrake_system::

        name: SharedControlVisualizer
        input_ports:
        - belief
        - goal_poses
        - ee_pose
        - mode
        - alpha
        - stage (multi-step colours only)

    Input ports:
        belief (n): goal probabilities (dimensionless, a probability vector).
        goal_poses (n * 7): goal poses ``[x, y, z, qw, qx, qy, qz]`` (m, unit quaternion) in W.
        ee_pose (7): end-effector pose in W (m, unit quaternion).
        mode (1): index of the active control mode into ``modes``.
        alpha (1): the autonomy's share of the blended command, in [0, 1].
        stage (1): index of the current stage (the task manager's ``stage``); declared only when
            ``goal_colors`` gives more than one stage. Goal ``i`` is drawn in
            ``goal_colors[stage][i]`` (a stage beyond the last keeps the last stage's colours).

    No output ports. A periodic publish event (every ``publish_period`` seconds, at
    initialization, and on ``ForcedPublish``) updates the scene; every update carries the context
    time so that a running Meshcat recording (``meshcat.StartRecording()``) captures it.
    Non-finite inputs are drawn as "no information" (smallest goal, no mode, alpha 0) instead of
    failing.

    Args:
        goal_colors: ``(n, 3 or 4)``: the colour ``(r, g, b[, a])`` of each goal (the alpha is not
            used: opacity shows the probability); or ``(n_stages, n, 3 or 4)``: one set per stage
            of a multi-step task. Default: :data:`GOAL_PALETTE`.
        legend: Lines shown in the Meshcat control panel (one read-only row each, in order), e.g.
            :func:`drake_disamb.display.legend_rows`; ``None`` shows none.
    """

    def __init__(
        self,
        meshcat: Meshcat,
        n_goals: int,
        modes: Sequence[Sequence[int]],
        goal_colors: ArrayLike | None = None,
        publish_period: float = 1.0 / 32.0,
        min_radius: float = 0.012,
        max_radius: float = 0.05,
        alpha_bar_position: ArrayLike = (0.35, 0.25, 0.0),
        alpha_bar_height: float = 0.4,
        add_slider: bool = True,
        legend: Sequence[LegendRow] | None = None,
    ) -> None:
        super().__init__()
        if meshcat is None:
            raise ValueError("meshcat: expected a Meshcat instance, got None")
        if not (isinstance(n_goals, int) and n_goals >= 1):
            raise ValueError(f"n_goals: expected an integer >= 1, got {n_goals!r}")
        if len(modes) == 0:
            raise ValueError("modes: expected at least one control mode, got []")
        for i, mode in enumerate(modes):
            if not all(0 <= int(d) <= GRIPPER_DIM for d in mode):
                raise ValueError(f"modes[{i}]: expected dimension indices in 0..6, got {list(mode)!r}")
        if not (np.isfinite(publish_period) and publish_period > 0):
            raise ValueError(f"publish_period: expected a finite number > 0, got {publish_period!r}")
        if not 0 < min_radius < max_radius:
            raise ValueError(
                f"min_radius/max_radius: expected 0 < min < max, got {min_radius!r}, {max_radius!r}"
            )
        self._meshcat = meshcat
        self._n = n_goals
        self._modes = [tuple(int(d) for d in m) for m in modes]
        self._colors = _color_sets(goal_colors, n_goals)
        self._r_min = float(min_radius)
        self._r_max = float(max_radius)
        self._bar_xyz = np.asarray(alpha_bar_position, dtype=float)
        self._bar_height = float(alpha_bar_height)
        self._slider = "alpha (autonomy share)" if add_slider else None
        self._legend = [row.html() for row in legend] if legend is not None else []
        # What was last sent, to skip redundant messages (kept per instance; reset on init).
        self._last_level: list[int | None] = [None] * n_goals
        self._last_mode: int | None = None
        self._last_stage: int | None = None

        self._belief = self.DeclareVectorInputPort("belief", n_goals)
        self._goal_poses = self.DeclareVectorInputPort("goal_poses", n_goals * 7)
        self._ee_pose = self.DeclareVectorInputPort("ee_pose", 7)
        self._mode = self.DeclareVectorInputPort("mode", 1)
        self._alpha = self.DeclareVectorInputPort("alpha", 1)
        self._stage = self.DeclareVectorInputPort("stage", 1) if len(self._colors) > 1 else None
        self.DeclarePeriodicPublishEvent(publish_period, 0.0, self._publish)
        self.DeclareForcedPublishEvent(self._publish)
        self.DeclareInitializationPublishEvent(self._initialize)
        self._create_objects()

    @property
    def goal_colors(self) -> list[list[tuple[float, float, float]]]:
        """``[stage][goal]`` the ``(r, g, b)`` the spheres are drawn in."""
        return [[tuple(float(c) for c in rgb) for rgb in stage] for stage in self._colors]  # type: ignore[misc]

    # -- scene creation -----------------------------------------------------------------------

    def _create_objects(self) -> None:
        m = self._meshcat
        m.Delete(ROOT)
        for i in range(self._n):
            for k, colors in enumerate(self._colors):
                for level in range(COLOR_LEVELS):
                    opacity = MIN_OPACITY + (MAX_OPACITY - MIN_OPACITY) * level / (COLOR_LEVELS - 1)
                    path = f"{ROOT}/goals/g{i}/s/c{k}/level{level}"
                    # Unit sphere, scaled to the probability's radius on the goal's group node.
                    m.SetObject(path, Sphere(1.0), Rgba(*colors[i], opacity))
                    m.SetProperty(path, "visible", level == 0)
                m.SetProperty(f"{ROOT}/goals/g{i}/s/c{k}", "visible", k == 0)
        # Mode display: translations as arrows, rotations as rings, gripper as a sphere.
        arrow_len, ring_r = 0.12, 0.06
        for k in range(3):
            rgb = AXIS_COLORS[k]
            path = f"{ROOT}/mode/d{k}"
            R = _axis_rotation(k)
            axis = np.eye(3)[k]
            m.SetObject(f"{path}/shaft", Cylinder(0.005, arrow_len), Rgba(*rgb, 1.0))
            m.SetTransform(f"{path}/shaft", RigidTransform(R, axis * arrow_len / 2))
            m.SetObject(f"{path}/tip", Sphere(0.012), Rgba(*rgb, 1.0))
            m.SetTransform(f"{path}/tip", RigidTransform(axis * arrow_len))
            m.SetObject(f"{path}/neg", Cylinder(0.003, arrow_len), Rgba(*rgb, 0.35))
            m.SetTransform(f"{path}/neg", RigidTransform(R, -axis * arrow_len / 2))
            rpath = f"{ROOT}/mode/d{k + 3}"
            m.SetObject(f"{rpath}/ring", Cylinder(ring_r, 0.004), Rgba(*rgb, 0.35))
            m.SetTransform(f"{rpath}/ring", RigidTransform(R, [0.0, 0.0, 0.0]))
            m.SetObject(f"{rpath}/axis", Cylinder(0.003, 2 * ring_r), Rgba(*rgb, 1.0))
            m.SetTransform(f"{rpath}/axis", RigidTransform(R, [0.0, 0.0, 0.0]))
        m.SetObject(f"{ROOT}/mode/d{GRIPPER_DIM}", Sphere(0.03), Rgba(1.0, 0.85, 0.1, 0.6))
        for d in range(GRIPPER_DIM + 1):
            m.SetProperty(f"{ROOT}/mode/d{d}", "visible", False)
        # Alpha bar: unit-height cylinder whose base sits at the bar position, scaled in z.
        m.SetObject(f"{ROOT}/alpha/bar/cyl", Cylinder(0.02, 1.0), Rgba(0.85, 0.2, 0.6, 0.9))
        m.SetTransform(f"{ROOT}/alpha/bar/cyl", RigidTransform([0.0, 0.0, 0.5]))
        m.SetObject(f"{ROOT}/alpha/sleeve", Cylinder(0.024, self._bar_height), Rgba(0.5, 0.5, 0.5, 0.15))
        m.SetTransform(f"{ROOT}/alpha/sleeve", RigidTransform([0.0, 0.0, self._bar_height / 2]))
        m.SetTransform(f"{ROOT}/alpha", RigidTransform(self._bar_xyz))
        m.SetProperty(f"{ROOT}/alpha/bar", "scale", [1.0, 1.0, 1e-3])
        if self._slider is not None and self._slider not in m.GetSliderNames():
            m.AddSlider(self._slider, 0.0, 1.0, 0.01, 0.0)
        for name in self._legend:
            m.AddButton(name)

    # -- events -------------------------------------------------------------------------------

    def _initialize(self, context: Context) -> EventStatus:
        self._last_level = [None] * self._n
        self._last_mode = None
        self._last_stage = None
        return self._publish(context)

    def _publish(self, context: Context) -> EventStatus:
        m = self._meshcat
        t = context.get_time()
        belief = np.asarray(self._belief.Eval(context), dtype=float)
        goals = np.asarray(self._goal_poses.Eval(context), dtype=float).reshape(self._n, 7)
        ee = np.asarray(self._ee_pose.Eval(context), dtype=float)
        mode_value = float(self._mode.Eval(context)[0])
        alpha = float(self._alpha.Eval(context)[0])

        if self._stage is not None:
            value = float(self._stage.Eval(context)[0])
            stage = int(np.clip(value, 0, len(self._colors) - 1)) if np.isfinite(value) else 0
            if stage != self._last_stage:
                for i in range(self._n):
                    for k in range(len(self._colors)):
                        m.SetProperty(f"{ROOT}/goals/g{i}/s/c{k}", "visible", k == stage, t)
                self._last_stage = stage

        for i in range(self._n):
            p = belief[i] if np.isfinite(belief[i]) else 0.0
            p = float(np.clip(p, 0.0, 1.0))
            radius = self._r_min + (self._r_max - self._r_min) * p
            path = f"{ROOT}/goals/g{i}"
            xyz = goals[i, :3] if np.all(np.isfinite(goals[i, :3])) else np.zeros(3)
            m.SetTransform(path, RigidTransform(xyz), t)
            m.SetProperty(f"{path}/s", "scale", [radius] * 3, t)
            level = probability_level(p)
            if level != self._last_level[i]:
                for c in range(len(self._colors)):
                    for k in range(COLOR_LEVELS):
                        m.SetProperty(f"{path}/s/c{c}/level{k}", "visible", k == level, t)
                self._last_level[i] = level

        mode = int(mode_value) if np.isfinite(mode_value) and 0 <= mode_value < len(self._modes) else -1
        if np.all(np.isfinite(ee[:3])):
            m.SetTransform(f"{ROOT}/mode", RigidTransform(ee[:3]), t)
        if mode != self._last_mode:
            active = set(self._modes[mode]) if mode >= 0 else set()
            for d in range(GRIPPER_DIM + 1):
                m.SetProperty(f"{ROOT}/mode/d{d}", "visible", d in active, t)
            self._last_mode = mode

        a = float(np.clip(alpha, 0.0, 1.0)) if np.isfinite(alpha) else 0.0
        m.SetProperty(f"{ROOT}/alpha/bar", "scale", [1.0, 1.0, max(a * self._bar_height, 1e-3)], t)
        if self._slider is not None:
            m.SetSliderValue(self._slider, a)
        return EventStatus.Succeeded()


# ----------------------------------------------------------------------------------------------
# Framing the view
# ----------------------------------------------------------------------------------------------


def illustration_bounds(plant: Any, scene_graph: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Axis-aligned box ``(lower, upper)`` (m, in W) around the plant's illustration geometry.

    Boxes, cylinders and spheres count with their full extent; a mesh counts with its frame's origin
    (enough to frame a scene). Poses are those of the plant's default context (the start posture).

    Raises:
        ValueError: the plant has no illustration geometry.
    """
    from pydrake.geometry import Role

    inspector = scene_graph.model_inspector()
    context = plant.CreateDefaultContext()
    points = []
    for index in range(plant.num_bodies()):
        body = plant.get_body(BodyIndex(index))
        frame_id = plant.GetBodyFrameIdIfExists(body.index())
        if frame_id is None:
            continue
        X_WB = plant.EvalBodyPoseInWorld(context, body)
        for g in inspector.GetGeometries(frame_id, Role.kIllustration):
            X_WG = X_WB @ inspector.GetPoseInFrame(g)
            shape = inspector.GetShape(g)
            kind = type(shape).__name__
            if kind == "Box":
                half = np.array([shape.width(), shape.depth(), shape.height()]) / 2
            elif kind == "Cylinder":
                half = np.array([shape.radius(), shape.radius(), shape.length() / 2])
            elif kind == "Sphere":
                half = np.full(3, shape.radius())
            else:
                half = np.zeros(3)
            corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
            points.append((X_WG.rotation().matrix() @ corners.T).T + X_WG.translation())
    if not points:
        raise ValueError("plant: expected illustration geometry to frame, found none")
    every = np.concatenate(points)
    return every.min(axis=0), every.max(axis=0)


CAMERA_FOV = 75.0
"""Vertical field of view (degrees) of Meshcat's default perspective camera."""


def frame_workspace(
    meshcat: Meshcat,
    lower: ArrayLike,
    upper: ArrayLike,
    work_height: float = 0.0,
    view_direction: ArrayLike = (0.1, -1.0, 1.0),
    fill: float = 1.5,
    zoom: float = 1.8,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Point Meshcat's camera at the workspace and lay the floor grid at the scene's foot.

    The camera looks at the centre of the box's top part (from ``work_height``, e.g. the table top,
    to the box's top), from ``view_direction`` (a direction from the target toward the camera, in
    W). It zooms in by ``zoom`` (a narrower view from farther away: less wide-angle distortion)
    and stands where the diameter of that part's bounding sphere spans ``fill`` times the view's
    height. The floor grid moves from z = 0 (where it would cut a table top at z = 0) down to the
    box's bottom (the foot of the table's legs).

    Args:
        lower, upper: The scene's box (m, in W), e.g. :func:`illustration_bounds`.
        work_height: Height (m) of the working surface.

    Returns:
        The camera position and target (m, in W).
    """
    lo = np.asarray(lower, dtype=float)
    hi = np.asarray(upper, dtype=float)
    if lo.shape != (3,) or hi.shape != (3,) or not np.all(np.isfinite(lo) & np.isfinite(hi) & (lo <= hi)):
        raise ValueError(f"lower/upper: expected two finite 3-vectors with lower <= upper, got {lo}, {hi}")
    d = np.asarray(view_direction, dtype=float)
    if d.shape != (3,) or not np.isfinite(d).all() or np.linalg.norm(d) == 0:
        raise ValueError(f"view_direction: expected a non-zero 3-vector, got {view_direction!r}")
    if not (np.isfinite(fill) and fill > 0 and np.isfinite(zoom) and zoom > 0):
        raise ValueError(f"fill/zoom: expected numbers > 0, got {fill!r}, {zoom!r}")
    d = d / np.linalg.norm(d)
    z0 = float(np.clip(work_height, lo[2], hi[2]))
    target = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, z0 + 0.25 * (hi[2] - z0)])
    radius = 0.5 * float(np.linalg.norm([hi[0] - lo[0], hi[1] - lo[1], hi[2] - z0]))
    distance = radius * zoom / (fill * np.tan(np.radians(CAMERA_FOV) / 2))
    camera = target + distance * d
    meshcat.SetCameraPose(camera, target)
    meshcat.SetProperty("/Cameras/default/rotated/<object>", "zoom", float(zoom))
    # Meshcat's grid lies in its node's x-z plane, turned into W's x-y plane by a quarter turn
    # about x: keep the turn, lower the node.
    meshcat.SetTransform(
        "/Grid", RigidTransform(RotationMatrix.MakeXRotation(np.pi / 2), [0.0, 0.0, float(lo[2])])
    )
    return camera, target


def visualizer_for_trial(
    meshcat: Meshcat, config: Any, modes: Sequence[Sequence[int]], **kwargs: Any
) -> SharedControlVisualizer:
    """The :class:`SharedControlVisualizer` of a trial: its goals in their objects' colours (one set
    per stage) and its legend, as a resolved scenario gives them (``config``, a
    :class:`~drake_disamb.config.TrialConfig`: ``n_goals``, ``goal_colors``, ``legend``);
    ``kwargs`` go to the constructor. A multi-step trial's visualizer has the ``stage`` input port."""
    return SharedControlVisualizer(
        meshcat, config.n_goals, modes, goal_colors=config.goal_colors, legend=config.legend, **kwargs
    )
