"""Meshcat display of the shared-control state: goal probabilities, the active mode, alpha.

What is drawn (all under ``/shared_control`` in the Meshcat scene tree):

- ``goals/g<i>``: one sphere per goal at its position, sized and coloured by its probability
  (radius from ``min_radius`` at p = 0 to ``max_radius`` at p = 1; colour from grey to the goal's
  colour in :data:`COLOR_LEVELS` steps). Sizes are animated with the ``scale`` property and
  colours by switching the ``visible`` flag of pre-built spheres, so both show in the saved
  recording (a Meshcat animation replays transforms and properties only).
- ``mode/d<k>``: the active control mode's dimensions at the gripper, in W: an arrow (thin
  cylinder with a cone-less tip sphere) along x/y/z for a translational dimension, a flat ring
  about the axis for a rotational one (red/green/blue for x/y/z), and a yellow sphere for the
  gripper mode.
- ``alpha``: a vertical bar beside the arm whose height is the autonomy's share alpha (a faint
  full-height sleeve shows alpha = 1); in a live session a read-only ``alpha`` slider too.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike
from pydrake.geometry import Cylinder, Meshcat, Rgba, Sphere
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import Context, EventStatus, LeafSystem

ROOT = "/shared_control"
COLOR_LEVELS = 5
"""Number of colour steps between grey (p = 0) and the goal's colour (p = 1)."""

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
"""Goal colours (matplotlib's tab10), shared with :mod:`drake_disamb.plotting`."""

AXIS_COLORS = ((0.9, 0.1, 0.1), (0.1, 0.8, 0.1), (0.1, 0.3, 0.95))
GRIPPER_DIM = 6
_GREY = np.array([0.7, 0.7, 0.7])


def goal_color(index: int) -> tuple[float, float, float]:
    """The display colour of goal ``index`` (cycles through :data:`GOAL_PALETTE`)."""
    return GOAL_PALETTE[index % len(GOAL_PALETTE)]


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

    Input ports:
        belief (n): goal probabilities (dimensionless, a probability vector).
        goal_poses (n * 7): goal poses ``[x, y, z, qw, qx, qy, qz]`` (m, unit quaternion) in W.
        ee_pose (7): end-effector pose in W (m, unit quaternion).
        mode (1): index of the active control mode into ``modes``.
        alpha (1): the autonomy's share of the blended command, in [0, 1].

    No output ports. A periodic publish event (every ``publish_period`` seconds, at
    initialization, and on ``ForcedPublish``) updates the scene; every update carries the context
    time so that a running Meshcat recording (``meshcat.StartRecording()``) captures it.
    Non-finite inputs are drawn as "no information" (smallest goal, no mode, alpha 0) instead of
    failing.
    """

    def __init__(
        self,
        meshcat: Meshcat,
        n_goals: int,
        modes: Sequence[Sequence[int]],
        goal_colors: Sequence[Sequence[float]] | None = None,
        publish_period: float = 1.0 / 32.0,
        min_radius: float = 0.012,
        max_radius: float = 0.05,
        alpha_bar_position: ArrayLike = (0.35, 0.25, 0.0),
        alpha_bar_height: float = 0.4,
        add_slider: bool = True,
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
        colors = [goal_color(i) for i in range(n_goals)] if goal_colors is None else list(goal_colors)
        if len(colors) != n_goals:
            raise ValueError(f"goal_colors: expected {n_goals} colours, got {len(colors)}")
        self._meshcat = meshcat
        self._n = n_goals
        self._modes = [tuple(int(d) for d in m) for m in modes]
        self._colors = [np.asarray(c, dtype=float)[:3] for c in colors]
        self._r_min = float(min_radius)
        self._r_max = float(max_radius)
        self._bar_xyz = np.asarray(alpha_bar_position, dtype=float)
        self._bar_height = float(alpha_bar_height)
        self._slider = "alpha (autonomy share)" if add_slider else None
        # What was last sent, to skip redundant messages (kept per instance; reset on init).
        self._last_level: list[int | None] = [None] * n_goals
        self._last_mode: int | None = None

        self._belief = self.DeclareVectorInputPort("belief", n_goals)
        self._goal_poses = self.DeclareVectorInputPort("goal_poses", n_goals * 7)
        self._ee_pose = self.DeclareVectorInputPort("ee_pose", 7)
        self._mode = self.DeclareVectorInputPort("mode", 1)
        self._alpha = self.DeclareVectorInputPort("alpha", 1)
        self.DeclarePeriodicPublishEvent(publish_period, 0.0, self._publish)
        self.DeclareForcedPublishEvent(self._publish)
        self.DeclareInitializationPublishEvent(self._initialize)
        self._create_objects()

    # -- scene creation -----------------------------------------------------------------------

    def _create_objects(self) -> None:
        m = self._meshcat
        m.Delete(ROOT)
        for i in range(self._n):
            for level in range(COLOR_LEVELS):
                w = (level + 1) / COLOR_LEVELS
                rgb = (1 - w) * _GREY + w * self._colors[i]
                path = f"{ROOT}/goals/g{i}/s/level{level}"
                # Unit sphere, scaled to the probability's radius on the goal's group node.
                m.SetObject(path, Sphere(1.0), Rgba(*rgb, 0.45 + 0.4 * w))
                m.SetProperty(path, "visible", level == 0)
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

    # -- events -------------------------------------------------------------------------------

    def _initialize(self, context: Context) -> EventStatus:
        self._last_level = [None] * self._n
        self._last_mode = None
        return self._publish(context)

    def _publish(self, context: Context) -> EventStatus:
        m = self._meshcat
        t = context.get_time()
        belief = np.asarray(self._belief.Eval(context), dtype=float)
        goals = np.asarray(self._goal_poses.Eval(context), dtype=float).reshape(self._n, 7)
        ee = np.asarray(self._ee_pose.Eval(context), dtype=float)
        mode_value = float(self._mode.Eval(context)[0])
        alpha = float(self._alpha.Eval(context)[0])

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
                for k in range(COLOR_LEVELS):
                    m.SetProperty(f"{path}/s/level{k}", "visible", k == level, t)
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
