"""SharedControlVisualizer: goals sized/coloured by probability, mode axes, alpha, recording."""

from __future__ import annotations

import numpy as np
import pytest
from pydrake.geometry import Meshcat, MeshcatParams

from drake_disamb.systems.visualization import (
    COLOR_LEVELS,
    ROOT,
    SharedControlVisualizer,
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
        assert meshcat.HasPath(f"{ROOT}/goals/g{i}/s/level0")
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
        self.sliders: dict[str, float] = {}

    def Delete(self, path: str) -> None:
        self.objects = {p for p in self.objects if not p.startswith(path)}

    def SetObject(self, path: str, shape, rgba=None) -> None:
        self.objects.add(path)

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
            assert fake.properties[(f"{ROOT}/goals/g{i}/s/level{k}", "visible")][0] == (k == level)
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
