"""What the operator panel says: plain data and words, no Drake, no server.

The panel (docs/operator_page.md) tells the person at the controls what the robot believes and
why, in words and numbers readable at arm's length:

- :func:`goal_rows` and :func:`leading_goal`: every goal's probability as a whole percentage, and
  the most likely goal when it stands out (:data:`LEAD_MARGIN` ahead of the next);
- :func:`mode_title` and :func:`key_actions`: the active mode in words, and what each key (and
  the gamepad) does in it now, from the interface variant's live controls
  (:attr:`~drake_disamb.interfaces.live_controls.LiveControls.live_controls`, read through
  :class:`LiveControlsLike` so that this leaf module needs nothing above it);
- :func:`why_line`: after a request or an automatic switch, one line saying why this mode, from
  the goals the mode tells apart (:func:`~drake_disamb.core.disambiguation.told_apart.told_apart`);
- the panel's own colours (``panel.css``) are Okabe and Ito's colour-blind-safe palette
  (:data:`drake_disamb.display.OKABE_ITO`), as are the tasks' objects.

Directions are named for the default view of the scene (the camera in front of the table, the
robot's base behind it): +x to the right, +y away from the viewer, +z up.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from drake_disamb.core.layout import DIM_NAMES, GRIPPER_DIM

__all__ = [
    "LEAD_MARGIN",
    "LiveControlLike",
    "LiveControlsLike",
    "STAMPS",
    "KeyAction",
    "display_name",
    "goal_rows",
    "content",
    "key_actions",
    "key_name",
    "leading_goal",
    "mode_title",
    "motion_words",
    "why_line",
]


class LiveControlLike(Protocol):
    """One live control as the panel reads it (an interface's
    :class:`~drake_disamb.interfaces.live_controls.LiveControl`): its label (empty: not shown), its
    key's code and its role (``drive+``, ``drive-``, ``next``, ``previous``, ``request``, ...)."""

    @property
    def label(self) -> str: ...

    @property
    def keycode(self) -> str: ...

    @property
    def role(self) -> str: ...


class LiveControlsLike(Protocol):
    """What the panel reads of an interface variant (any
    :class:`~drake_disamb.interfaces.registry.Interface` is one): its live controls and whether
    it has live axes."""

    @property
    def live_controls(self) -> Sequence[LiveControlLike]: ...

    @property
    def live_axes(self) -> bool: ...


LEAD_MARGIN = 0.05
"""How far (probability) the most likely goal must lead the next one to be named as the robot's
guess; closer, the panel says that no goal stands out yet."""

_AXES = ("x", "y", "z")

_DIRECTIONS: dict[int, tuple[str, str]] = {
    0: ("right", "left"),
    1: ("away from you", "toward you"),
    2: ("up", "down"),
}
"""Words of the translational dimensions' + and - directions (the default view)."""

_KEY_NAMES = {
    "ArrowLeft": "\u2190",
    "ArrowRight": "\u2192",
    "ArrowUp": "\u2191",
    "ArrowDown": "\u2193",
    "Space": "Space",
    "Enter": "Enter",
    "Escape": "Esc",
}


STAMPS = ("t", "wall")
"""The keys of a panel state that stamp it (its simulated and wall-clock time) rather than say
something."""


def content(panel: Mapping[str, Any]) -> dict[str, Any]:
    """What a panel state says: the state without its :data:`STAMPS`."""
    return {k: v for k, v in panel.items() if k not in STAMPS}


def key_name(code: str) -> str:
    """A browser ``KeyboardEvent.code`` as printed on the key: ``KeyM`` -> ``M``, ``ArrowLeft`` ->
    an arrow, ``Digit3`` -> ``3``."""
    if code in _KEY_NAMES:
        return _KEY_NAMES[code]
    for prefix in ("Key", "Digit"):
        if code.startswith(prefix) and len(code) == len(prefix) + 1:
            return code[-1]
    return code


def display_name(name: str) -> str:
    """A goal's name as the panel writes it (``red_box`` -> ``red box``)."""
    return name.replace("_", " ")


def motion_words(dimension: int, sign: int) -> str:
    """What moving dimension ``dimension`` (0 = vx ... 5 = wz, 6 = gripper) in direction ``sign``
    (+1 / -1) does, in words (``move up (+z)``, ``rotate about x (-)``, ``open the gripper``)."""
    plus = sign > 0
    if dimension == GRIPPER_DIM:
        return "open the gripper" if plus else "close the gripper"
    if dimension < 3:
        words = _DIRECTIONS[dimension][0 if plus else 1]
        return f"move {words} ({'+' if plus else '-'}{_AXES[dimension]})"
    return f"rotate about {_AXES[dimension - 3]} ({'+' if plus else '-'})"


def mode_title(dims: Sequence[int]) -> str:
    """A control mode in words: ``move left/right (x), up/down (z)``, ``rotate about x, z``,
    ``gripper: open/close``."""
    dims = [int(d) for d in dims]
    if dims == [GRIPPER_DIM]:
        return "gripper: open/close"
    moves = [f"{'/'.join(_DIRECTIONS[d])} ({_AXES[d]})" for d in dims if d < 3]
    turns = [_AXES[d - 3] for d in dims if 3 <= d < GRIPPER_DIM]
    parts = []
    if moves:
        parts.append("move " + ", ".join(moves))
    if turns:
        parts.append("rotate about " + ", ".join(turns))
    return "; ".join(parts) or "no motion"


def mode_label(dims: Sequence[int]) -> str:
    """The mode's dimensions as the method's explanation names them (``{vx, vz}``)."""
    return "{" + ", ".join(DIM_NAMES[int(d)] for d in dims) + "}"


@dataclass(frozen=True)
class KeyAction:
    """One row of the panel's key list: the keys (as printed on them) and what they do now.

    Attributes:
        keys: The keys, e.g. ``"\u2190"`` or ``"A / D"``.
        action: What pressing (or holding) them does in the current mode.
        codes: The ``KeyboardEvent.code`` values of the keys (a click on the row presses the first).
    """

    keys: str
    action: str
    codes: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        return {"keys": self.keys, "action": self.action, "codes": list(self.codes)}


def _axis_action(dims: Sequence[int], axis: int) -> str:
    if axis >= len(dims):
        return "not used in this mode"
    d = dims[axis]
    return f"{motion_words(d, -1)} / {motion_words(d, +1)}"


def key_actions(
    variant: LiveControlsLike,
    modes: Sequence[Sequence[int]],
    mode: int,
    axis_keys: Sequence[tuple[str, str, str]] = (),
    requests_served: bool = True,
    mode_selection: str = "cycle",
) -> list[KeyAction]:
    """What each live control of ``variant`` does in mode ``mode`` (an index into ``modes``, the
    interface's modes, gripper last), in the order of its ``live_controls``; for a kind with
    ``live_axes``, the axis keys first (``axis_keys``: ``(name, decrement code, increment code)``
    per axis, e.g. :data:`drake_disamb.interfaces.live.AXIS_SLIDERS`) and the gamepad last.

    Args:
        requests_served: Whether a request press makes the robot choose a mode (the
            disambiguation paradigm); otherwise the request key is said to be logged only.
        mode_selection: The interface's ``mode_selection`` (``"direct"``: the joystick's mode
            button selects the mode the stick points at).
    """
    n = len(modes)
    dims = [int(d) for d in modes[mode]]
    rows: list[KeyAction] = []
    if variant.live_axes:
        for axis, (_, down, up) in enumerate(axis_keys):
            rows.append(KeyAction(f"{key_name(down)} / {key_name(up)}", _axis_action(dims, axis), (down, up)))
    for control in variant.live_controls:
        if not control.label:
            continue
        role = control.role
        if role in ("drive+", "drive-"):
            action = motion_words(dims[0], +1 if role == "drive+" else -1) + " (hold)"
        elif role == "next":
            action = f"next mode: {mode_title(modes[(mode + 1) % n])}"
            if mode_selection == "direct" and variant.live_axes:
                action = f"select the mode the axes point at (centred: {action})"
        elif role == "previous":
            action = f"previous mode: {mode_title(modes[(mode - 1) % n])}"
        elif role == "request":
            action = (
                "ask the robot to choose the mode that helps it most"
                if requests_served
                else "request (logged only in this condition: the mode is kept)"
            )
        elif role == "center":
            action = "centre the axes (stop)"
        else:
            continue
        rows.append(KeyAction(key_name(control.keycode), action, (control.keycode,)))
    if variant.live_axes:
        rows.append(KeyAction("gamepad", "left stick: the two axes; button 0: mode; button 1: request"))
    else:  # drake_disamb.interfaces.live.PAD_BUTTON_OF_KEY
        rows.append(KeyAction("gamepad", "the D-pad works as the arrow keys, button A (0) as Space"))
    return rows


def goal_rows(belief: Sequence[float], names: Sequence[str], colors: Sequence[str]) -> list[dict[str, Any]]:
    """Every goal as ``{"name", "percent", "color", "leading"}`` (whole percent; a non-finite
    probability reads as 0), in the goals' order; ``leading`` marks :func:`leading_goal`."""
    p = np.nan_to_num(np.asarray(belief, dtype=float), nan=0.0, posinf=0.0, neginf=0.0)
    lead = leading_goal(p)
    return [
        {
            "name": display_name(names[i]),
            "percent": int(round(100.0 * float(np.clip(p[i], 0.0, 1.0)))),
            "color": colors[i],
            "leading": i == lead,
        }
        for i in range(len(names))
    ]


def leading_goal(belief: Sequence[float], margin: float = LEAD_MARGIN) -> int | None:
    """The most likely goal if it leads the next by at least ``margin``, else ``None``."""
    p = np.asarray(belief, dtype=float)
    if p.size == 0 or not np.all(np.isfinite(p)):
        return None
    if p.size == 1:
        return 0
    order = np.argsort(-p, kind="stable")
    return int(order[0]) if p[order[0]] - p[order[1]] >= margin else None


def why_line(
    told: Any,
    modes: Sequence[Sequence[int]],
    chosen: int | None,
    names: Sequence[str],
    automatic: bool,
) -> str:
    """One line: why the robot's mode is what it is after a request (or, ``automatic``, a switch
    the robot made by itself).

    Args:
        told: The :class:`~drake_disamb.core.disambiguation.told_apart.ToldApart` of the answer,
            or ``None`` (no probed dimension, or unusable inputs).
        modes: The arm modes the answer indexes.
        chosen: The mode the answer chose, or ``None`` when the current mode was kept.
        names: The goals' names (belief slots).
        automatic: The robot started it (the Automatic paradigm), not a request.
    """
    who = "The robot switched by itself to" if automatic else "The robot chose"
    if chosen is None:
        head = "The robot kept your mode: no other mode tells the goals apart better"
        if told is not None:
            head = f"The robot kept {mode_title(modes[told.mode])}: no mode tells the goals apart better"
    else:
        head = f"{who} {mode_title(modes[chosen])}"
    if told is None:
        return head + "."
    plus, minus = told.plus_goal, told.minus_goal
    d = told.dimension
    if plus is not None and minus is not None and plus != minus:
        return (
            f"{head}: {motion_words(d, +1)} leads toward the {display_name(names[plus])}, "
            f"{motion_words(d, -1)} toward the {display_name(names[minus])}, "
            f"so your motion tells the robot which of the two you want."
        )
    goal = plus if plus is not None else minus
    if goal is None:
        return f"{head}: moving in it changes the robot's guess little (no mode tells the goals apart)."
    sign = +1 if plus is not None else -1
    return (
        f"{head}: {motion_words(d, sign)} leads toward the {display_name(names[goal])}, "
        f"so your motion tells the robot whether you want it."
    )
