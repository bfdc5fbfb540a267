"""SharedControlVisualizer: goals sized/coloured by probability, mode axes, alpha, recording."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.geometry import Meshcat, MeshcatParams

from drake_disamb.display import LegendRow
from drake_disamb.systems.visualization import (
    COLOR_LEVELS,
    MAX_OPACITY,
    MIN_OPACITY,
    ROOT,
    SharedControlVisualizer,
    frame_workspace,
    illustration_bounds,
    probability_level,
)

MODES = [[0], [1], [2], [3], [4], [5], [6]]


@pytest.fixture(scope="module")
def meshcat() -> Meshcat:
    return Meshcat(MeshcatParams(host="localhost"))


def _context(vis: SharedControlVisualizer, belief, mode: float, alpha: float, t: float = 0.0):
    n = len(belief)
    ctx = vis.CreateDefaultContext()
    ctx.SetTime(t)
    goals = np.zeros((n, 7))
    goals[:, 0] = np.linspace(-0.3, 0.3, n)
    goals[:, 1] = -0.5
    goals[:, 3] = 1.0
    vis.GetInputPort("belief").FixValue(ctx, np.asarray(belief, dtype=float))
    vis.GetInputPort("goal_poses").FixValue(ctx, goals.ravel())
    vis.GetInputPort("ee_pose").FixValue(ctx, [0.0, -0.3, 0.3, 1, 0, 0, 0])
    vis.GetInputPort("mode").FixValue(ctx, [mode])
    vis.GetInputPort("alpha").FixValue(ctx, [alpha])
    return ctx


def test_ports(meshcat: Meshcat) -> None:
    vis = SharedControlVisualizer(meshcat, 3, MODES)
    sizes = {
        vis.get_input_port(i).get_name(): vis.get_input_port(i).size() for i in range(vis.num_input_ports())
    }
    assert sizes == {"belief": 3, "goal_poses": 21, "ee_pose": 7, "mode": 1, "alpha": 1}
    assert vis.num_output_ports() == 0


def test_probability_level() -> None:
    assert probability_level(0.0) == 0
    assert probability_level(1.0) == COLOR_LEVELS - 1
    assert probability_level(0.5) == COLOR_LEVELS // 2
    assert probability_level(float("nan")) == 0


def test_publish_draws_goals_mode_and_alpha(meshcat: Meshcat) -> None:
    vis = SharedControlVisualizer(meshcat, 3, MODES)
    ctx = _context(vis, [0.1, 0.2, 0.7], mode=1, alpha=0.6)
    vis.ForcedPublish(ctx)
    for i in range(3):
        assert meshcat.HasPath(f"{ROOT}/goals/g{i}/s/c0/level0")
    for d in range(7):
        assert meshcat.HasPath(f"{ROOT}/mode/d{d}")
    assert meshcat.HasPath(f"{ROOT}/alpha/bar/cyl")
    assert meshcat.GetSliderValue("alpha (autonomy share)") == pytest.approx(0.6)


def test_nan_inputs_do_not_raise(meshcat: Meshcat) -> None:
    vis = SharedControlVisualizer(meshcat, 2, MODES, add_slider=False)
    ctx = _context(vis, [np.nan, np.nan], mode=np.nan, alpha=np.nan)
    vis.ForcedPublish(ctx)


def test_recording_captures_frames(meshcat: Meshcat, tmp_path) -> None:
    vis = SharedControlVisualizer(meshcat, 2, MODES, add_slider=False)
    meshcat.StartRecording(frames_per_second=32.0, set_visualizations_while_recording=False)
    for k, p in enumerate(np.linspace(0.5, 0.95, 5)):
        vis.ForcedPublish(_context(vis, [p, 1 - p], mode=k % 7, alpha=p / 2, t=0.1 * k))
    meshcat.StopRecording()
    assert meshcat.get_mutable_recording().frames_per_second() == pytest.approx(32.0)
    empty = len(meshcat.StaticHtml())
    meshcat.PublishRecording()
    html = meshcat.StaticHtml()
    assert len(html) > empty  # the animation is embedded
    out = tmp_path / "rec.html"
    out.write_text(html)
    assert out.stat().st_size > 10_000 and "<html" in html.lower()
    meshcat.DeleteRecording()


def test_bad_construction(meshcat: Meshcat) -> None:
    with pytest.raises(ValueError, match="meshcat"):
        SharedControlVisualizer(None, 2, MODES)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="n_goals"):
        SharedControlVisualizer(meshcat, 0, MODES)
    with pytest.raises(ValueError, match=r"modes\[0\]"):
        SharedControlVisualizer(meshcat, 2, [[9]])
    with pytest.raises(ValueError, match="goal_colors"):
        SharedControlVisualizer(meshcat, 2, MODES, goal_colors=[(1, 0, 0)])


class FakeMeshcat:
    """Records the calls a visualizer makes (Meshcat offers no getters for transforms/properties)."""

    def __init__(self) -> None:
        self.properties: dict[tuple[str, str], tuple[object, float | None]] = {}
        self.transforms: dict[str, tuple[np.ndarray, float | None]] = {}
        self.objects: set[str] = set()
        self.colors: dict[str, tuple[float, float, float, float]] = {}
        self.sliders: dict[str, float] = {}
        self.buttons: list[str] = []
        self.camera: tuple[np.ndarray, np.ndarray] | None = None

    def Delete(self, path: str) -> None:
        self.objects = {p for p in self.objects if not p.startswith(path)}

    def SetObject(self, path: str, shape, rgba=None) -> None:
        self.objects.add(path)
        if rgba is not None:
            self.colors[path] = (rgba.r(), rgba.g(), rgba.b(), rgba.a())

    def AddButton(self, name: str, keycode: str = "") -> None:
        if name not in self.buttons:
            self.buttons.append(name)

    def DeleteButton(self, name: str, strict: bool = True) -> bool:
        if name in self.buttons:
            self.buttons.remove(name)
            return True
        return False

    def SetCameraPose(self, camera, target) -> None:
        self.camera = (np.asarray(camera), np.asarray(target))

    def SetTransform(self, path: str, X, time_in_recording: float | None = None) -> None:
        self.transforms[path] = (np.asarray(X.translation()), time_in_recording)

    def SetProperty(self, path: str, prop: str, value, time_in_recording: float | None = None) -> None:
        self.properties[(path, prop)] = (value, time_in_recording)

    def GetSliderNames(self) -> list[str]:
        return list(self.sliders)

    def AddSlider(self, name: str, lo: float, hi: float, step: float, value: float) -> float:
        self.sliders[name] = value
        return value

    def SetSliderValue(self, name: str, value: float) -> float:
        self.sliders[name] = value
        return value


def test_sizes_colours_mode_and_alpha_follow_inputs() -> None:
    fake = FakeMeshcat()
    vis = SharedControlVisualizer(fake, 3, MODES, min_radius=0.01, max_radius=0.05)  # type: ignore[arg-type]
    ctx = _context(vis, [0.05, 0.25, 0.7], mode=4, alpha=0.5, t=1.25)
    vis.ForcedPublish(ctx)
    for i, p in enumerate([0.05, 0.25, 0.7]):
        scale, t = fake.properties[(f"{ROOT}/goals/g{i}/s", "scale")]
        assert scale == pytest.approx([0.01 + 0.04 * p] * 3) and t == pytest.approx(1.25)
        level = probability_level(p)
        for k in range(COLOR_LEVELS):
            assert fake.properties[(f"{ROOT}/goals/g{i}/s/c0/level{k}", "visible")][0] == (k == level)
    np.testing.assert_allclose(fake.transforms[f"{ROOT}/goals/g2"][0], [0.3, -0.5, 0.0])
    # Mode 4 is wy: only d4 (the ring about y) is visible, at the gripper.
    for d in range(7):
        assert fake.properties[(f"{ROOT}/mode/d{d}", "visible")][0] == (d == 4)
    np.testing.assert_allclose(fake.transforms[f"{ROOT}/mode"][0], [0.0, -0.3, 0.3])
    bar, t = fake.properties[(f"{ROOT}/alpha/bar", "scale")]
    assert bar[2] == pytest.approx(0.5 * 0.4) and t == pytest.approx(1.25)
    assert fake.sliders["alpha (autonomy share)"] == pytest.approx(0.5)
    # A joystick-style two-dimension mode shows both of its axes.
    vis2 = SharedControlVisualizer(fake, 3, [[0, 1], [0, 2], [3, 5], [4], [6]])  # type: ignore[arg-type]
    vis2.ForcedPublish(_context(vis2, [0.3, 0.3, 0.4], mode=2, alpha=0.0))
    assert [fake.properties[(f"{ROOT}/mode/d{d}", "visible")][0] for d in range(7)] == [
        False, False, False, True, False, True, False,
    ]  # fmt: skip


def test_spheres_take_the_given_colours_and_opacity_grows_with_probability() -> None:
    fake = FakeMeshcat()
    colors = [(0.85, 0.25, 0.2, 1.0), (0.2, 0.7, 0.3, 1.0), (0.2, 0.4, 0.85, 0.5)]
    vis = SharedControlVisualizer(fake, 3, MODES, goal_colors=colors)  # type: ignore[arg-type]
    assert vis.num_input_ports() == 5  # one colour set: no stage port
    for i, rgba in enumerate(colors):
        opacities = []
        for level in range(COLOR_LEVELS):
            r, g, b, a = fake.colors[f"{ROOT}/goals/g{i}/s/c0/level{level}"]
            assert (r, g, b) == pytest.approx(rgba[:3])
            opacities.append(a)
        assert opacities == sorted(opacities) and opacities[0] == pytest.approx(MIN_OPACITY)
        assert opacities[-1] == pytest.approx(MAX_OPACITY)
    assert vis.goal_colors == [[pytest.approx(c[:3]) for c in colors]]


def test_stage_port_switches_the_colour_set() -> None:
    fake = FakeMeshcat()
    stages = [[(1.0, 0.0, 0.0), (0.0, 1.0, 0.0)], [(0.0, 0.0, 1.0), (0.5, 0.5, 0.5)]]
    vis = SharedControlVisualizer(fake, 2, MODES, goal_colors=stages, add_slider=False)  # type: ignore[arg-type]
    assert vis.GetInputPort("stage").size() == 1
    for k, stage in enumerate(stages):
        for i, rgb in enumerate(stage):
            assert fake.colors[f"{ROOT}/goals/g{i}/s/c{k}/level0"][:3] == pytest.approx(rgb)
    ctx = _context(vis, [0.5, 0.5], mode=0, alpha=0.0, t=2.0)
    for stage, shown in ((0, [True, False]), (1, [False, True]), (7, [False, True]), (np.nan, [True, False])):
        vis.GetInputPort("stage").FixValue(ctx, [stage])
        vis.ForcedPublish(ctx)
        for i in range(2):
            assert [fake.properties[(f"{ROOT}/goals/g{i}/s/c{k}", "visible")][0] for k in range(2)] == shown


def test_legend_rows_go_to_the_control_panel_once() -> None:
    fake = FakeMeshcat()
    rows = [LegendRow("intended goal: a<b>", (1.0, 0.0, 0.0), bold=True), LegendRow("spheres: probability")]
    SharedControlVisualizer(fake, 2, MODES, legend=rows)  # type: ignore[arg-type]
    assert fake.buttons == [row.html() for row in rows]
    assert "a&lt;b&gt;" in fake.buttons[0] and "#ff0000" in fake.buttons[0]  # escaped, with its swatch


def test_bad_colours_are_named() -> None:
    fake = FakeMeshcat()
    with pytest.raises(ValueError, match="goal_colors: expected 2 colours"):
        SharedControlVisualizer(fake, 2, MODES, goal_colors=[[(1, 0, 0)] * 3])  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"goal_colors: expected entries in \[0, 1\]"):
        SharedControlVisualizer(fake, 1, MODES, goal_colors=[(2.0, 0, 0)])  # type: ignore[arg-type]


def test_frame_workspace_looks_at_the_table_and_lowers_the_grid() -> None:
    fake = FakeMeshcat()
    lower, upper = np.array([-0.7, -0.8, -0.74]), np.array([0.7, 0.2, 0.6])
    camera, target = frame_workspace(fake, lower, upper, work_height=0.0)  # type: ignore[arg-type]
    np.testing.assert_allclose(fake.camera[0], camera)
    np.testing.assert_allclose(target[:2], [0.0, -0.3])
    assert 0.0 < target[2] < 0.6 and camera[1] < lower[1] and camera[2] > upper[2]  # in front, above
    grid = fake.transforms["/Grid"][0]
    np.testing.assert_allclose(grid, [0.0, 0.0, -0.74])
    assert fake.properties[("/Cameras/default/rotated/<object>", "zoom")][0] > 1.0
    with pytest.raises(ValueError, match="lower/upper"):
        frame_workspace(fake, upper, lower)  # type: ignore[arg-type]


def test_illustration_bounds_cover_the_table_and_objects() -> None:
    from drake_disamb.builder import build_shared_control_diagram
    from drake_disamb.config import load_scenario

    handles = build_shared_control_diagram(load_scenario("reaching"))
    lower, upper = illustration_bounds(handles.plant, handles.station.scene_graph)
    # The table is 1.4 m x 1.0 m, its top at z = 0, its legs reach z = -0.74 (models/mico/table.sdf).
    np.testing.assert_allclose(lower, [-0.7, -0.8, -0.74], atol=1e-9)
    assert upper[0] == pytest.approx(0.7) and upper[1] >= 0.2 and upper[2] >= 0.412  # the blue tower
