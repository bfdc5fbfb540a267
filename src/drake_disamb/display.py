"""What the pictures of a trial share: each goal's colour, the legend and the figure's caption.

Every picture of a trial (the goal-probability figure, the Meshcat probability spheres, the
Meshcat legend and the saved recording's legend) draws goal ``i`` of stage ``k`` in the colour of
its own object in the scene (``scenario.goals[...].object.color``), so the red box is red
everywhere. The texts that explain the pictures live here once:

- :func:`legend_rows`: the Meshcat legend (intended goal, goal colours, what the spheres, the axes
  at the gripper and the alpha bar mean), shown in the Meshcat control panel of a live page
  (:class:`~drake_disamb.systems.visualization.SharedControlVisualizer`) and as an overlay on the
  saved recording (:func:`add_legend_to_html`);
- :func:`belief_caption`: the figure's caption (the intended goal, and why the belief relaxes
  when the user stops commanding).

No pydrake or matplotlib here: plain data and text.
"""

from __future__ import annotations

import html
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_disamb.core.inference import INFERENCE_METHODS, DFTInference

OKABE_ITO: dict[str, tuple[float, float, float]] = {
    "black": (0.0, 0.0, 0.0),
    "orange": (0.902, 0.624, 0.0),
    "sky_blue": (0.337, 0.706, 0.914),
    "bluish_green": (0.0, 0.62, 0.451),
    "yellow": (0.941, 0.894, 0.259),
    "blue": (0.0, 0.447, 0.698),
    "vermillion": (0.835, 0.369, 0.0),
    "reddish_purple": (0.8, 0.475, 0.655),
}
"""Okabe and Ito's colour-blind-safe palette ("Color Universal Design", 2008), ``(r, g, b)`` in
[0, 1]: the embedded tasks' objects (so every picture of a trial), the scene's axes and the
operator page's own colours."""

EXPLANATIONS = (
    "sphere size, opacity: goal probability",
    "at the gripper: the active mode",
    "arrow = translate, ring = rotate",
    "red, green, blue = x, y, z",
    "yellow ball: the gripper mode",
    "pink bar: alpha, the robot's share",
    "grey sleeve: alpha = 1",
)
"""What the Meshcat legend says about the spheres, the mode axes and the alpha bar (short lines: the
control panel is narrow)."""


@dataclass(frozen=True)
class LegendRow:
    """One line of the Meshcat legend.

    Attributes:
        text: Plain text of the line.
        color: ``(r, g, b)`` in [0, 1] of a colour swatch before the text, or ``None``.
        bold: Draw the text bold (the intended goal).
    """

    text: str
    color: tuple[float, float, float] | None = None
    bold: bool = False

    def html(self) -> str:
        """The line as HTML (text escaped; a coloured disc as the swatch)."""
        text = html.escape(self.text)
        if self.bold:
            text = f"<b>{text}</b>"
        if self.color is None:
            return text
        return f'<span style="color:{css_color(self.color)}">&#9679;</span> {text}'


def css_color(rgb: Sequence[float]) -> str:
    """``#rrggbb`` of an ``(r, g, b[, a])`` colour in [0, 1] (the alpha is dropped)."""
    r, g, b = (int(round(255 * float(np.clip(c, 0.0, 1.0)))) for c in list(rgb)[:3])
    return f"#{r:02x}{g:02x}{b:02x}"


def goal_colors(scenario: Any) -> list[list[tuple[float, float, float, float]]]:
    """``colors[k][i]``: the ``(r, g, b, a)`` of belief slot ``i`` while stage ``k`` runs (its goal's
    object's colour; :meth:`~drake_disamb.config.Scenario.belief_goals`).

    Args:
        scenario: A :class:`~drake_disamb.config.Scenario`.
    """
    return [
        [tuple(float(c) for c in g.object.color) for g in scenario.belief_goals(k)]  # type: ignore[misc]
        for k in range(scenario.n_stages)
    ]


def _rgb(goal: Any) -> tuple[float, float, float]:
    r, g, b = (float(c) for c in goal.object.color[:3])
    return r, g, b


def legend_rows(scenario: Any) -> list[LegendRow]:
    """The Meshcat legend of ``scenario``: per stage its goals in their colours, the intended one
    first and marked, then :data:`EXPLANATIONS`.

    Args:
        scenario: A :class:`~drake_disamb.config.Scenario` (``scenario.user.goals`` names the
            intended goal of each stage).
    """
    rows: list[LegendRow] = []
    multi = scenario.n_stages > 1
    for k in range(scenario.n_stages):
        goals = scenario.stage_goals(k)
        intended = int(scenario.user.goals[k])
        if multi:
            rows.append(LegendRow(f"stage {k + 1}, {scenario.stages[k].name}:"))
        word = "" if multi else " goal"
        rows.append(LegendRow(f"intended{word}: {goals[intended].name}", _rgb(goals[intended]), True))
        for i in range(len(goals)):
            if i != intended:
                rows.append(LegendRow(f"other{word}: {goals[i].name}", _rgb(goals[i])))
    rows.extend(LegendRow(text) for text in EXPLANATIONS)
    return rows


LEGEND_ID = "drake-disamb-legend"
"""``id`` of the legend's ``<div>`` in a saved recording."""


def legend_html(rows: Sequence[LegendRow], title: str = "") -> str:
    """A small fixed overlay (top left of the page) holding ``rows``, as one ``<div>``."""
    lines = "".join(f"<div>{row.html()}</div>" for row in rows)
    head = f"<div style='font-weight:bold;margin-bottom:3px'>{html.escape(title)}</div>" if title else ""
    return (
        f'<div id="{LEGEND_ID}" style="position:fixed;left:8px;top:8px;max-width:34em;z-index:10;'
        "padding:6px 9px;background:rgba(255,255,255,0.82);border-radius:5px;"
        'font:12px/1.45 sans-serif;color:#222;pointer-events:none">'
        f"{head}{lines}</div>"
    )


def add_legend_to_html(page: str, rows: Sequence[LegendRow], title: str = "") -> str:
    """``page`` (a Meshcat ``StaticHtml``) with :func:`legend_html` inserted before ``</body>``.

    Raises:
        ValueError: ``page`` has no ``</body>``.
    """
    at = page.rfind("</body>")
    if at < 0:
        raise ValueError("page: expected an HTML page with a </body> tag")
    return page[:at] + legend_html(rows, title) + "\n" + page[at:]


def belief_caption(scenario: Any) -> str:
    """The figure's caption: which line is the intended goal, and why the belief relaxes.

    With the field-theoretic inference (the default) the belief rises for the goals the user's
    command points at and otherwise decays toward uniform (1/n each): while the user pauses,
    switches modes or moves along one axis that points at several goals alike, the intended goal's
    probability falls back.
    """
    intended = [scenario.stage_goals(k)[int(g)].name for k, g in enumerate(scenario.user.goals)]
    n = scenario.n_goals
    first = (
        f"Thick line: the intended goal ({' then '.join(intended)}). "
        "Bottom strip: disambiguation requests, manual mode switches and the stretches where the user "
        "commands the arm (u_h \u2260 0)."
    )
    if not issubclass(INFERENCE_METHODS.get(scenario.inference.method), DFTInference):
        return first
    dft = scenario.inference.dft
    held = ""
    if dft.proximity:
        held = f"; goals within {dft.R:g} m of the gripper keep a share (proximity term)"
    return (
        f"{first}\nThe DFT belief rises for the goals the current command points at and otherwise decays "
        f"toward uniform (1/{n} each, time constant tau1 = {dft.tau1:g} s): while the user pauses, switches "
        f"modes or moves along one axis that points at several goals alike, the intended goal's "
        f"probability falls back{held}."
    )
