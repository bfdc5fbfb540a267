"""The pictures of a trial: every goal in its object's colour (figure lines, Meshcat spheres, legends),
the figure's layout (event strip, end of trial, stage changes, caption) and the recording's view in
a real browser (headless Chromium; skipped without it)."""

from __future__ import annotations

import shutil
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from matplotlib.colors import to_rgb
from support import screenshot_script

from drake_disamb.builder import build_shared_control_diagram
from drake_disamb.config import load_scenario, resolve_scenario
from drake_disamb.display import OKABE_ITO, add_legend_to_html, belief_caption, css_color, legend_rows
from drake_disamb.plotting import BeliefPlot, goal_probability_figure, trial_figure, trial_outcome, trial_plot
from drake_disamb.systems.visualization import AXIS_COLORS, COLOR_LEVELS, ROOT, visualizer_for_trial
from drake_disamb.trial import run_trial

sys.path.insert(0, str(Path(__file__).parent))
from test_visualization import FakeMeshcat  # noqa: E402

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module", params=["reaching", "pouring"])
def trial(request: pytest.FixtureRequest):  # noqa: ANN201
    return run_trial(load_scenario(request.param), progress=False)


def _object_rgb(scenario, stage: int) -> list[tuple[float, float, float]]:  # noqa: ANN001
    """The scenario's own object colours of ``stage`` (read here, not through drake_disamb.display)."""
    return [tuple(g.object.color[:3]) for g in scenario.goals if g.stage == stage]


def _close_figures() -> None:
    import matplotlib.pyplot as plt

    plt.close("all")


def test_figure_lines_and_meshcat_spheres_have_the_objects_colours(trial) -> None:  # noqa: ANN001
    sc = trial.scenario
    fig = trial_figure(trial)
    try:
        lines = {line.get_label(): line for line in fig.axes[0].get_lines()}
        for k in range(sc.n_stages):
            goals = sc.stage_goals(k)
            for i, rgb in enumerate(_object_rgb(sc, k)):
                label = goals[i].name + (" (intended)" if sc.user.goals[k] == i else "")
                if sc.n_stages > 1:
                    label = f"{sc.stages[k].name}: {label}"
                assert to_rgb(lines[label].get_color()) == pytest.approx(rgb), label
                assert lines[label].get_linewidth() > 2 if sc.user.goals[k] == i else True
    finally:
        _close_figures()
    # The Meshcat spheres, drawn by the visualizer the builder makes for the scenario.
    fake = FakeMeshcat()
    vis = visualizer_for_trial(fake, resolve_scenario(sc), [[0], [1], [2], [6]])  # type: ignore[arg-type]
    for k in range(sc.n_stages):
        for i, rgb in enumerate(_object_rgb(sc, k)):
            for level in range(COLOR_LEVELS):
                assert fake.colors[f"{ROOT}/goals/g{i}/s/c{k}/level{level}"][:3] == pytest.approx(rgb)
    assert (sc.n_stages > 1) == vis.HasInputPort("stage")
    # The legend rows in the control panel: each stage's intended goal bold, swatches in colour.
    marked = [row for row in fake.buttons if "<b>intended" in row]
    assert len(marked) == sc.n_stages
    for k, row in enumerate(marked):
        intended = sc.stage_goals(k)[sc.user.goals[k]]
        assert row.endswith(f": {intended.name}</b>") and css_color(intended.object.color) in row


def test_the_builder_gives_the_visualizer_the_objects_colours() -> None:
    from pydrake.geometry import Meshcat, MeshcatParams

    sc = load_scenario("pouring")
    handles = build_shared_control_diagram(sc, meshcat=Meshcat(MeshcatParams(host="localhost")))
    vis = handles.systems["visualizer"]
    assert vis.goal_colors == [[pytest.approx(c) for c in _object_rgb(sc, k)] for k in range(sc.n_stages)]
    # The stage port is wired to the task manager's stage.
    connected = {
        (
            src.get_name(),
            src.get_output_port(int(i)).get_name(),
            dst.get_name(),
            dst.get_input_port(int(j)).get_name(),
        )
        for (dst, j), (src, i) in handles.diagram.connection_map().items()
    }
    assert ("task", "stage", "visualizer", "stage") in connected


def test_figure_layout_strip_end_line_and_caption(trial) -> None:  # noqa: ANN001
    sc = trial.scenario
    fig = trial_figure(trial)
    try:
        ax, strip = fig.axes
        assert ax.get_shared_x_axes().joined(ax, strip)
        assert [t.get_text() for t in strip.get_yticklabels()] == ["$u_h \\neq 0$", "mode switch", "request"]
        # Every probability line stays in [0, 1]; the markers and bars live in the strip.
        for line in ax.get_lines():
            y = np.asarray(line.get_ydata(), dtype=float)
            assert np.all((y >= -1e-9) & (y <= 1 + 1e-9)), line.get_label()
        assert not any(line.get_marker() == "o" for line in ax.get_lines())
        dots = {float(line.get_ydata()[0]): line for line in strip.get_lines() if line.get_marker() == "o"}
        assert sorted(dots[2.0].get_xdata()) == pytest.approx(sorted(trial.request_times))
        assert sorted(dots[1.0].get_xdata()) == pytest.approx(sorted(trial.mode_switch_times))
        # The end of the trial: a vertical line at its time, named in the legend.
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert f"goal reached ({trial.time:.1f} s)" in labels
        assert any(
            line.get_label().startswith("goal reached") and line.get_xdata()[0] == pytest.approx(trial.time)
            for line in ax.get_lines()
        )
        assert ax.get_xlim()[1] > trial.time  # the end line is inside the plot, not on its spine
        # Stage changes of a multi-step task: a dotted line in both panels.
        if sc.n_stages > 1:
            change = trial.stage_times[0]
            for a in (ax, strip):
                assert any(
                    line.get_linestyle() == ":" and line.get_xdata()[0] == pytest.approx(change)
                    for line in a.get_lines()
                )
        caption = "\n".join(t.get_text() for t in fig.texts)
        intended = sc.stage_goals(0)[sc.user.goals[0]].name
        assert intended in caption and "decay" in caption and "uniform" in caption
        assert f"tau1 = {sc.inference.dft.tau1:g} s" in caption
    finally:
        _close_figures()


def test_the_trial_figure_draws_the_trials_plot_record(trial) -> None:  # noqa: ANN001
    sc = trial.scenario
    plot = trial_plot(trial)
    t, belief = trial.logs["belief"]
    assert np.array_equal(plot.times, t) and np.array_equal(plot.belief, belief)
    assert plot.rho1 == trial.rho1 and plot.end_time == trial.time
    assert list(plot.request_times) == list(trial.request_times)
    assert list(plot.mode_switch_times) == list(trial.mode_switch_times)
    assert len(plot.stage_times) == (sc.n_stages if sc.n_stages > 1 else 0)
    figures = (trial_figure(trial), goal_probability_figure(plot))
    try:
        drawn = [
            [(line.get_label(), tuple(line.get_xdata())) for line in fig.axes[0].get_lines()]
            for fig in figures
        ]
        assert drawn[0] == drawn[1]
        assert figures[0].axes[0].get_title() == figures[1].axes[0].get_title() == plot.title
    finally:
        _close_figures()


def test_lines_of_a_stage_start_after_the_belief_reset() -> None:
    # Stage 0 ends at t = 1.0; the belief still refers to it one sample later, then resets to uniform.
    t = np.round(np.arange(0.0, 2.0, 0.1), 10)
    p = np.tile([0.9, 0.1], (len(t), 1))
    p[12:] = [0.5, 0.5]
    fig = goal_probability_figure(
        BeliefPlot(
            t,
            p,
            goal_names=[["a", "b"], ["c", "d"]],
            goal_colors=[[(1, 0, 0), (0, 1, 0)], [(0, 0, 1), (0.5, 0.5, 0.5)]],
            stage_times=[1.0, 1.9],
            stage_names=["one", "two"],
            intended_goal=[0, 1],
        )
    )
    try:
        lines = {line.get_label(): line for line in fig.axes[0].get_lines()}
        assert max(lines["one: a (intended)"].get_xdata()) == pytest.approx(1.1)
        assert min(lines["two: c"].get_xdata()) == pytest.approx(1.2)
        assert set(lines["two: c"].get_ydata()) == {0.5}
        assert to_rgb(lines["two: d (intended)"].get_color()) == (0.5, 0.5, 0.5)
    finally:
        _close_figures()


def test_counts_are_checked() -> None:
    t, p = np.arange(3.0), np.full((3, 2), 0.5)
    with pytest.raises(ValueError, match="goal_colors: expected 2 entries"):
        goal_probability_figure(BeliefPlot(t, p, goal_colors=[(1, 0, 0)]))
    with pytest.raises(ValueError, match="goal_names: expected 2 lists"):
        goal_probability_figure(BeliefPlot(t, p, goal_names=[["a", "b"]], stage_times=[1.0, 2.0]))
    with pytest.raises(ValueError, match="intended_goal"):
        goal_probability_figure(BeliefPlot(t, p, intended_goal=[0], stage_times=[1.0, 2.0]))


def test_outcome_labels() -> None:
    def result(**kw: bool) -> SimpleNamespace:
        return SimpleNamespace(**{"interrupted": False, "done": True, "success": True, **kw})

    assert trial_outcome(result()) == "goal reached"
    assert trial_outcome(result(success=False)) == "other goal reached"
    assert trial_outcome(result(done=False, success=False)) == "time limit"
    assert trial_outcome(result(interrupted=True)) == "interrupted"


def test_caption_and_legend_texts() -> None:
    sc = load_scenario("reaching")
    caption = belief_caption(sc)
    assert "Thick line: the intended goal (red_box)" in caption and "uniform (1/5 each" in caption
    rows = legend_rows(sc)
    assert rows[0].text == "intended goal: red_box" and rows[0].bold
    assert [r.text for r in rows[1:5]] == [f"other goal: {g.name}" for g in sc.goals[1:]]
    assert any("sphere" in r.text for r in rows) and any("alpha" in r.text for r in rows)
    page = add_legend_to_html("<html><body><p>x</p></body></html>", rows, "title <1>")
    assert page.index("drake-disamb-legend") < page.index("</body>") and "title &lt;1&gt;" in page
    with pytest.raises(ValueError, match="</body>"):
        add_legend_to_html("no page", rows)


# ----------------------------------------------------------------------------------------------
# The recording in a real browser
# ----------------------------------------------------------------------------------------------


@pytest.mark.skipif(
    (shutil.which("chromium") or shutil.which("chromium-browser")) is None
    or shutil.which("chromedriver") is None,
    reason="needs chromium and chromedriver (Debian: apt-get install chromium chromium-driver)",
)
def test_recording_frames_the_table_and_shows_the_legend(tmp_path: Path) -> None:
    pytest.importorskip("selenium", reason="needs the selenium package")
    shots = screenshot_script()
    html = shots.record_demo(tmp_path)
    measured = shots.screenshot(html, tmp_path / "recording.png", at=0.6, settle=0.5)
    assert (tmp_path / "recording.png").stat().st_size > 10_000
    assert measured["table_fraction"] >= 0.5
    assert "intended goal: red_box" in measured["legend"] and "alpha" in measured["legend"]
    sc = load_scenario("reaching")
    for i, rgb in enumerate(_object_rgb(sc, 0)):
        # three.js holds colours in linear light; Meshcat sends them as 8-bit sRGB.
        shown = [shots.linear_to_srgb(c) for c in measured["spheres"][f"g{i}"]["c0"]]
        assert shown == pytest.approx(rgb, abs=1.5 / 255)


def test_every_object_and_axis_is_drawn_in_a_colour_blind_safe_colour() -> None:
    """The embedded tasks' objects (so every picture of their goals) and the scene's x, y, z axes
    are Okabe and Ito's colours, and the goals a belief covers are never two of the same colour."""
    palette = list(OKABE_ITO.values())
    for task in ("reaching", "pouring"):
        scenario = load_scenario(task)
        for goal in scenario.goals:
            assert any(np.allclose(goal.object.color[:3], c, atol=2e-3) for c in palette), (task, goal.name)
        for k in range(scenario.n_stages):
            colors = [tuple(g.object.color[:3]) for g in scenario.belief_goals(k)]
            assert len(set(colors)) == len(colors), (task, k)
    assert list(AXIS_COLORS) == [OKABE_ITO["vermillion"], OKABE_ITO["bluish_green"], OKABE_ITO["blue"]]
