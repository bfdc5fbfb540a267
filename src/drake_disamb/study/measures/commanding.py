"""What the user commands while the assistance helps and while it cannot, and how long a rotation is
commanded: behaviour estimates of :mod:`drake_disamb.study.measures.calibration` from a trial's
user command (``u_h``: ``user_vel`` in the logs, about 100 Hz without times, sample ``k`` at
``k * duration / M``; the same signal in a simulated trace), its belief (on ``t``) and its mode trace.

- **Commanding by the belief's state** (:class:`CommandingByBelief`), per interface, over the
  reaching trials (one goal, the person's, known): the seconds per trial with the belief *helping*
  (its largest entry above ``rho1 = 1.2 / n``, the blending's threshold, on the person's goal: the
  assistance moves the arm toward it) and *unsure* (below ``rho1``: no assistance), and the share
  of each that the user commands a translation (any of ``vx, vy, vz`` non-zero) and a rotation only
  (``wx, wy, wz`` and no translation). How people share the work with the autonomy: the
  assistance needs evidence, which only a command gives (the belief's drive is the user's
  command), and once it helps, it carries the arm while the user stops or steers.
- **Rotation dwells** (:class:`RotationDwells`), per interface, over all trials: each user mode
  change into a rotation mode (its dimensions all among ``wx, wy, wz``; the trace's mode just after
  the switch) until the next switch, request or the end: the share of them in which the user
  commands at all (the rest are passed through, on the way round a head array's cycle, or left at
  once), and the median seconds commanded in those that are. People tap a rotation briefly.

The trials measured are the analysed ones of the paradigms people did, as for every estimate of
:mod:`~drake_disamb.study.measures.calibration`, and the same functions measure a simulated study.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from drake_disamb.core.blending import RHO1_TIMES_N
from drake_disamb.core.layout import is_rotation_mode
from drake_disamb.study.data.folder import LoggedTrial
from drake_disamb.study.measures.course import mode_after

__all__ = [
    "CommandingByBelief",
    "RotationDwells",
    "commanding_by_belief",
    "format_commanding",
    "rotation_dwells",
    "summarize_commanding",
    "summarize_rotation_dwells",
    "user_command",
]


def user_command(trial: LoggedTrial) -> tuple[NDArray[np.float64], float]:
    """The ``(6, M)`` user command ``[vx, vy, vz, wx, wy, wz]`` and the seconds per sample
    (``duration / M``: the log has no times)."""
    u = np.asarray(trial.trace["u_h"], dtype=float).T
    return u, trial.record.duration / max(u.shape[1], 1)


@dataclass(frozen=True)
class CommandingByBelief:
    """One interface's reaching trials (module docstring): seconds per trial with the belief
    helping (``helped``) and unsure (``unsure``); the share of each with a translation commanded
    (``translate_helped``, ``translate_unsure``) and a rotation only (``rotate_helped``,
    ``rotate_unsure``); ``n`` trials. NaN shares where there is no such time."""

    helped: float
    unsure: float
    translate_helped: float
    translate_unsure: float
    rotate_helped: float
    rotate_unsure: float
    n: int


@dataclass(frozen=True)
class RotationDwells:
    """One interface's user changes into a rotation mode (module docstring): the share commanded in
    (``commanded``) of ``n``, and the median seconds commanded in those (``seconds``; NaN without)."""

    commanded: float
    seconds: float
    n: int


def commanding_by_belief(trial: LoggedTrial) -> NDArray[np.float64] | None:
    """The trial's seconds ``[helped, unsure, translation helped, translation unsure, rotation
    helped, rotation unsure]`` (module docstring), or ``None`` unless it has one intended goal and
    a usable belief and command."""
    r = trial.record
    belief = np.asarray(trial.trace["belief"], dtype=float)
    t = np.asarray(trial.trace["t"], dtype=float)
    if len(r.intended_goals) != 1 or belief.ndim != 2 or belief.shape[0] != t.size or t.size == 0:
        return None
    u, dt = user_command(trial)
    if u.shape[1] == 0:
        return None
    at = np.clip(np.searchsorted(t, np.arange(u.shape[1]) * dt, side="right") - 1, 0, t.size - 1)
    b = belief[at]
    above = np.max(b, axis=1) > RHO1_TIMES_N / b.shape[1]
    helped = above & (np.argmax(b, axis=1) == r.intended_goals[0])
    unsure = ~above
    translating = np.any(u[:3] != 0.0, axis=0)
    rotating = np.any(u[3:] != 0.0, axis=0) & ~translating
    return dt * np.array(
        [
            helped.sum(),
            unsure.sum(),
            (translating & helped).sum(),
            (translating & unsure).sum(),
            (rotating & helped).sum(),
            (rotating & unsure).sum(),
        ],
        dtype=float,
    )


def summarize_commanding(rows: Sequence[NDArray[np.float64]]) -> CommandingByBelief:
    """:class:`CommandingByBelief` of one interface's :func:`commanding_by_belief` results."""
    a = np.sum(np.asarray(rows, dtype=float).reshape(-1, 6), axis=0)
    n = len(rows)

    def share(k: int, of: int) -> float:
        return float(a[k] / a[of]) if a[of] > 0 else math.nan

    return CommandingByBelief(
        helped=float(a[0] / n) if n else math.nan,
        unsure=float(a[1] / n) if n else math.nan,
        translate_helped=share(2, 0),
        translate_unsure=share(3, 1),
        rotate_helped=share(4, 0),
        rotate_unsure=share(5, 1),
        n=n,
    )


def rotation_dwells(trial: LoggedTrial) -> list[float]:
    """The seconds commanded in each of the trial's user changes into a rotation mode (module
    docstring; 0 for one passed through)."""
    r = trial.record
    own = sorted(x for x in r.mode_switch_times if x > 0)
    u, dt = user_command(trial)
    commanding = np.any(u != 0.0, axis=0)
    ends = np.sort(np.asarray([*own, *trial.request_switch_times.tolist(), *r.request_times, r.duration]))
    out = []
    for x, dims in zip(own, mode_after(trial, own), strict=False):  # (no trace: no modes after)
        if dims is None or not is_rotation_mode(dims):
            continue
        later = ends[ends > x + 1e-6]
        end = float(later[0]) if later.size else r.duration  # (a switch at or after the end)
        out.append(float(commanding[int(x / dt) + 1 : int(end / dt)].sum() * dt))
    return out


def summarize_rotation_dwells(rows: Sequence[Sequence[float]]) -> RotationDwells:
    """:class:`RotationDwells` of one interface's :func:`rotation_dwells` results (per trial)."""
    seconds = np.asarray([s for row in rows for s in row], dtype=float)
    used = seconds[seconds > 0.0]
    return RotationDwells(
        commanded=float(used.size / seconds.size) if seconds.size else math.nan,
        seconds=float(np.median(used)) if used.size else math.nan,
        n=int(seconds.size),
    )


def format_commanding(
    by_belief: Mapping[str, CommandingByBelief], rotations: Mapping[str, RotationDwells]
) -> list[str]:
    """The two lines of ``study calibrate``: commanding by the belief's state, rotation dwells."""
    return [
        f"{'commanding by belief':<28} "
        + "; ".join(
            f"{k.replace('_', ' ')} helped {c.helped:.1f} s (translation {c.translate_helped:.2f}, "
            f"rotation {c.rotate_helped:.3f}), unsure {c.unsure:.1f} s ({c.translate_unsure:.2f}, "
            f"{c.rotate_unsure:.3f})"
            for k, c in by_belief.items()
        )
        + " (reaching, per trial; the shares of that time commanding a translation and a rotation only)",
        f"{'rotation dwells':<28} "
        + ", ".join(
            f"{k.replace('_', ' ')} {d.commanded:.2f} commanded (n={d.n}), median {d.seconds:.2f} s"
            for k, d in rotations.items()
        )
        + " (user changes into a rotation mode: the share commanded in, and the seconds commanded)",
    ]
