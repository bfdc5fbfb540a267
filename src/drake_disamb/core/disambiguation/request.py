"""A disambiguation request: what every mode-selection method is given, checked once.

:func:`make_request` checks the arguments of a request (belief, end-effector pose, goal poses,
control modes, current mode, configuration) and returns a :class:`DisambiguationRequest`, the one
type every method's ``select`` takes; a bad argument is a ``ValueError`` naming it and its value.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core.disambiguation.config import DEFAULT_CONFIG, DisambiguationConfig
from drake_disamb.core.geometry import check_vectors, normalized_quaternions
from drake_disamb.core.validation import MAX_GOALS

MAX_POSITION = 1e3
"""Largest accepted absolute coordinate (m) of the end-effector and goal positions of a request:
far beyond any arm's reach, yet small enough that no distance or potential computed from them
overflows."""


def validate_modes(modes: Sequence[Sequence[int]]) -> tuple[tuple[int, ...], ...]:
    """``modes`` as tuples of dimension indices; ``ValueError`` naming the bad entry."""
    # Fast path for the usual lists/tuples of plain ints: validated once per distinct value.
    if modes and type(modes) in (list, tuple) and all(type(m) in (list, tuple) for m in modes):
        key = tuple(tuple(m) for m in modes)
        if all(type(k) is int for m in key for k in m):
            return _validate_int_modes(key)
    return _validate_modes(modes)


@functools.lru_cache(maxsize=256)
def _validate_int_modes(modes: tuple[tuple[int, ...], ...]) -> tuple[tuple[int, ...], ...]:
    return _validate_modes(modes)


def _validate_modes(modes: Sequence[Sequence[int]]) -> tuple[tuple[int, ...], ...]:
    if isinstance(modes, str | bytes) or not isinstance(modes, Sequence) or len(modes) == 0:
        raise ValueError(f"modes: expected a non-empty list of lists of dimension indices, got {modes!r}")
    out = []
    for i, m in enumerate(modes):
        if isinstance(m, str | bytes) or not isinstance(m, Sequence | np.ndarray):
            raise ValueError(f"modes[{i}]: expected a list of dimension indices 0..5, got {m!r}")
        dims = []
        for k in m:
            if isinstance(k, bool) or not isinstance(k, int | np.integer) or not 0 <= int(k) <= 5:
                raise ValueError(f"modes[{i}]: expected dimension indices 0..5, got {list(m)!r}")
            dims.append(int(k))
        if len(set(dims)) != len(dims):
            raise ValueError(f"modes[{i}]: repeated dimension index in {dims!r}")
        out.append(tuple(dims))
    return tuple(out)


@functools.lru_cache(maxsize=256)
def _membership(modes: tuple[tuple[int, ...], ...], dimensions: tuple[int, ...]) -> NDArray[np.float64]:
    """``(n_modes, n_k)`` matrix: 1 where the mode contains the probed dimension (read-only)."""
    index = {k: i for i, k in enumerate(dimensions)}
    member = np.zeros((len(modes), len(dimensions)))
    for m, dims in enumerate(modes):
        for k in dims:
            if k in index:
                member[m, index[k]] = 1.0
    return frozen(member)


def _validate_belief(belief: ArrayLike, n: int) -> NDArray[np.float64]:
    p = check_vectors(belief, n, "belief")
    if p.ndim != 1:
        raise ValueError(f"belief: expected a vector of {n} probabilities, got shape {p.shape}")
    total = p.sum()
    if (p < 0).any() or abs(total - 1.0) > 1e-6:
        raise ValueError(f"belief: expected non-negative entries summing to 1, got {p.tolist()!r}")
    return p / total


def _check_positions(a: NDArray[np.float64], name: str) -> None:
    """``ValueError`` naming the first row of ``a`` (finite, ``(3,)`` or ``(n, 3)``) with an entry
    beyond :data:`MAX_POSITION`."""
    if not np.maximum.reduce(np.abs(a), axis=None) <= MAX_POSITION:
        rows = a.reshape(-1, 3)
        i = int(np.argmax(np.abs(rows).max(axis=1) > MAX_POSITION))
        label, row = (name, a) if a.ndim == 1 else (f"{name}[{i}]", rows[i])
        raise ValueError(f"{label}: expected coordinates within +/-{MAX_POSITION:g} m, got {row.tolist()!r}")


def frozen(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """``a``, made read-only (a cached array that callers share)."""
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class DisambiguationRequest:
    """One disambiguation request, checked (:func:`make_request`): what every method is given.

    Attributes:
        belief: ``p(t_a)``, ``(n,)``, a probability vector.
        position: End-effector position ``(3,)`` (m, world frame).
        orientation: End-effector orientation ``[qw, qx, qy, qz]`` (unit).
        goal_positions: ``(n, 3)`` goal positions (m).
        goal_orientations: ``(n, 4)`` goal orientations (unit quaternions).
        modes: The control modes (dimension indices 0 = vx ... 5 = wz); a result's mode indexes them.
        current_mode: Index of the mode in use (may be past the end of ``modes``, e.g. the gripper
            mode), or ``None``.
        config: The forward projection's configuration.
    """

    belief: NDArray[np.float64]
    position: NDArray[np.float64]
    orientation: NDArray[np.float64]
    goal_positions: NDArray[np.float64]
    goal_orientations: NDArray[np.float64]
    modes: tuple[tuple[int, ...], ...]
    current_mode: int | None
    config: DisambiguationConfig

    @property
    def membership(self) -> NDArray[np.float64]:
        """``(n_modes, n_k)``: 1 where a mode contains a probed dimension (read-only)."""
        return _membership(self.modes, self.config.dimensions)


def make_request(
    belief: ArrayLike,
    position: ArrayLike,
    goal_positions: ArrayLike,
    modes: Sequence[Sequence[int]],
    config: DisambiguationConfig | None = None,
    *,
    orientation: ArrayLike | None = None,
    goal_orientations: ArrayLike | None = None,
    current_mode: int | None = None,
) -> DisambiguationRequest:
    """Check a request's arguments and return the :class:`DisambiguationRequest`.

    Args:
        belief: Current belief ``p(t_a)`` over the ``n`` goals (non-negative, sums to 1).
        position: End-effector position ``(3,)`` (m, world frame), each coordinate within
            ``+/- MAX_POSITION`` (1 km).
        goal_positions: ``(n, 3)`` goal positions (m), same bound, ``1 <= n <= MAX_GOALS`` (100).
        modes: Control modes, each a list of dimension indices (0 = vx ... 5 = wz); a result's
            mode is an index into this list.
        config: The forward projection's configuration (default: the ``mico`` preset).
        orientation: End-effector orientation ``[qw, qx, qy, qz]`` (default identity); any
            quaternion whose norm neither vanishes (< 1e-12) nor overflows, normalised here.
        goal_orientations: ``(n, 4)`` goal orientations (default: the end-effector's, i.e. no
            orientation preference between goals).
        current_mode: Index of the mode in use (may be past the end of ``modes``, e.g. the
            gripper mode); kept on ties.

    Raises:
        ValueError: An input out of its bounds, naming the argument and the value.
    """
    cfg = DEFAULT_CONFIG if config is None else config
    mode_dims = validate_modes(modes)
    x = check_vectors(position, 3, "position")
    if x.ndim != 1:
        raise ValueError(f"position: expected 3 numbers, got shape {x.shape}")
    _check_positions(x, "position")
    gp = check_vectors(goal_positions, 3, "goal_positions")
    if gp.ndim != 2 or not 1 <= gp.shape[0] <= MAX_GOALS:
        raise ValueError(
            f"goal_positions: expected shape (n, 3) with 1 <= n <= {MAX_GOALS} (MAX_GOALS), got {gp.shape}"
        )
    _check_positions(gp, "goal_positions")
    n = gp.shape[0]
    p = _validate_belief(belief, n)
    q = (
        np.array([1.0, 0.0, 0.0, 0.0])
        if orientation is None
        else normalized_quaternions(orientation, "orientation")
    )
    if q.ndim != 1:
        raise ValueError(f"orientation: expected 4 numbers, got shape {q.shape}")
    if goal_orientations is None:
        gq = np.broadcast_to(q, (n, 4))
    else:
        gq = normalized_quaternions(goal_orientations, "goal_orientations")
        if gq.shape != (n, 4):
            raise ValueError(f"goal_orientations: expected shape ({n}, 4), got {gq.shape}")
    if current_mode is not None and (
        isinstance(current_mode, bool) or not isinstance(current_mode, int | np.integer) or current_mode < 0
    ):
        raise ValueError(f"current_mode: expected a non-negative integer or None, got {current_mode!r}")
    cfg.inference.check_goal_count(n)
    return DisambiguationRequest(
        belief=p,
        position=x,
        orientation=q,
        goal_positions=gp,
        goal_orientations=gq,
        modes=mode_dims,
        current_mode=None if current_mode is None else int(current_mode),
        config=cfg,
    )
