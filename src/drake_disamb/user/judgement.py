"""How the simulated user sees the task: the goal error, arrival, each mode's remaining error,
whether the autonomy helps, and which mode to go for next (a Boltzmann choice)."""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core.geometry import orientation_error
from drake_disamb.core.validation import all_finite
from drake_disamb.user.config import UserConfig

__all__ = [
    "choose_mode",
    "dim_tolerances",
    "draw",
    "goal_error",
    "goal_reached",
    "helped",
    "mode_remaining",
    "mode_usefulness",
    "presses_to",
]


@functools.lru_cache(maxsize=64)
def dim_tolerances(config: UserConfig) -> NDArray[np.float64]:
    """``config.dim_tolerances()``, once per (frozen) configuration (read-only)."""
    t = config.dim_tolerances()
    t.setflags(write=False)
    return t


def goal_error(ee_pose: ArrayLike, goal_pose: ArrayLike, use_orientation: bool = True) -> NDArray[np.float64]:
    """World-frame 6-D error ``[x_g - x_ee, orientation_error(q_ee, q_g)]`` (m, rad).

    Poses are ``[x, y, z, qw, qx, qy, qz]``. With ``use_orientation=False`` the last 3 are 0.
    """
    ee = np.asarray(ee_pose, dtype=float)
    g = np.asarray(goal_pose, dtype=float)
    if ee.shape != (7,) or g.shape != (7,):
        raise ValueError(f"ee_pose/goal_pose: expected 7 numbers each, got shapes {ee.shape} and {g.shape}")
    err = np.zeros(6)
    err[:3] = g[:3] - ee[:3]
    if use_orientation:
        err[3:] = orientation_error(ee[3:], g[3:])
    return err


def goal_reached(error: ArrayLike, config: UserConfig) -> bool:
    """True when a 6-D goal error is within the success tolerances."""
    e = np.asarray(error, dtype=float)
    ok = np.linalg.norm(e[:3]) <= config.success_position_tolerance
    if config.use_orientation:
        ok = ok and np.linalg.norm(e[3:]) <= config.success_orientation_tolerance
    return bool(ok)


def mode_remaining(
    error: ArrayLike, modes: tuple[tuple[int, ...], ...] | list[list[int]], config: UserConfig
) -> NDArray[np.float64]:
    """Remaining error of every mode: ``max_{d in mode} |error_d| / tolerance_d`` (gripper dims 0)."""
    ratio = np.abs(np.asarray(error, dtype=float)) / dim_tolerances(config)
    ratio7 = [*ratio.tolist(), 0.0]
    return np.array([max(ratio7[d] for d in mode) for mode in modes])


def helped(belief: ArrayLike, goal_index: int, rho1: float) -> bool:
    """True when the autonomy assists toward the user's goal: argmax is it and ``p(g*) > rho1``."""
    p = np.asarray(belief, dtype=float)
    if not all_finite(p):
        return False
    g = int(np.argmax(p))
    return g == goal_index and p[g] > rho1


def misled(belief: ArrayLike, goal_index: int, rho1: float) -> bool:
    """True when the autonomy assists toward another goal: the argmax is not the user's goal and
    its probability is above ``rho1`` (the arm heads for another object)."""
    p = np.asarray(belief, dtype=float)
    if not all_finite(p):
        return False
    g = int(np.argmax(p))
    return g != goal_index and p[g] > rho1


def draw(config: UserConfig, counter: int) -> np.random.Generator:
    """The generator of the user's ``counter``-th random draw (keyed by its seed)."""
    return np.random.default_rng([int(config.seed), int(counter)])


def presses_to(
    mode: int, target: np.ndarray | int, n_modes: int, direct: bool = False, back: bool = False
) -> np.ndarray | int:
    """Mode changes (presses) from ``mode`` to ``target``: forward cycling, the shorter way round
    with ``back`` (an interface that also steps back, ``Interface.steps_back``), or with ``direct``
    selection (``InterfaceConfig.mode_selection == "direct"``) one for any other mode."""
    if direct:
        return (
            (np.asarray(target) != mode).astype(int)
            if isinstance(target, np.ndarray)
            else int(target != mode)
        )
    forward = (
        (np.asarray(target) - mode) % n_modes if isinstance(target, np.ndarray) else (target - mode) % n_modes
    )
    return np.minimum(forward, n_modes - forward) if back else forward


def mode_usefulness(
    remaining: ArrayLike, mode: int, n_modes: int, press_cost: float, direct: bool = False, back: bool = False
) -> NDArray[np.float64]:
    """Expected usefulness of each arm mode: its remaining error as a share of the largest (0..1),
    minus ``press_cost`` per press it takes to reach it from ``mode`` (:func:`presses_to`; arm modes
    only: the gripper mode, last, is left out of ``remaining``)."""
    r = np.asarray(remaining, dtype=float)
    top = float(np.max(r)) if r.size else 0.0
    share = r / top if top > 0 else np.zeros_like(r)
    return share - press_cost * presses_to(mode, np.arange(r.size), n_modes, direct, back)


def choose_mode(
    remaining: ArrayLike,
    mode: int,
    n_modes: int,
    config: UserConfig,
    rng: np.random.Generator | None,
    exclude_current: bool = False,
    direct: bool = False,
    back: bool = False,
) -> int:
    """The arm mode the user goes for next: Boltzmann choice over :func:`mode_usefulness`.

    ``remaining`` holds the arm modes' remaining errors (:func:`mode_remaining` without the gripper
    mode). With ``config.mode_choice.mode_temperature == 0`` (or no ``rng``) it is the mode with the most
    remaining error (ties to the lowest index); else mode ``m`` has probability proportional to
    ``exp(usefulness_m / temperature)``. ``exclude_current`` leaves ``mode`` out. ``direct``: the
    interface selects modes directly (every other mode one press away, :func:`presses_to`);
    ``back``: it also steps back (the shorter way round).
    """
    r = np.asarray(remaining, dtype=float).copy()
    if exclude_current and mode < r.size:
        r[mode] = -np.inf
    choice = config.mode_choice
    if choice.mode_temperature == 0 or rng is None:
        return int(np.argmax(r))
    ok = np.isfinite(r)
    u = mode_usefulness(np.where(ok, r, 0.0), mode, n_modes, choice.press_cost, direct, back)
    logits = np.where(ok, u / choice.mode_temperature, -np.inf)
    w = np.exp(logits - np.max(logits))
    return int(rng.choice(r.size, p=w / w.sum()))
