"""Quaternions and orientation errors (pure numpy).

Conventions (see CONTRIBUTING.md):

- Quaternions are ``[qw, qx, qy, qz]`` arrays (Drake's w-first order) and every function
  broadcasts over any number of leading dimensions: a quaternion argument has shape ``(..., 4)``,
  a rotation vector ``(..., 3)``.
- Rotation vectors are axis * angle (rad). Angular velocities and orientation errors are
  expressed in the world frame W, so a world-frame rotation ``r`` acts on an orientation ``q`` by
  left multiplication: ``quat_from_rotvec(r) (x) q``.
- Twists are in the paper's order ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s), world frame.

Public functions validate their inputs and raise ``ValueError`` naming the argument and the
offending shape or value. The underscore-prefixed helpers skip validation; they are used inside
vectorised loops (the disambiguation forward projection) whose inputs were validated once.
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core._validation import all_finite

_SMALL_ANGLE = 1e-8
"""Below this angle (rad) the series expansions of sin(a)/a are used instead of the quotient."""


# ----------------------------------------------------------------------------------------------
# Validation
# ----------------------------------------------------------------------------------------------


def _check_last(x: ArrayLike, size: int, name: str) -> NDArray[np.float64]:
    """``x`` as a float array whose last axis has ``size`` entries, all finite."""
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: expected an array of numbers, got {x!r}") from exc
    if a.ndim == 0 or a.shape[-1] != size:
        raise ValueError(f"{name}: expected shape (..., {size}), got shape {a.shape}")
    if not all_finite(a):
        raise ValueError(f"{name}: expected finite numbers, got {a.tolist()!r}")
    return a


def _check_quat(q: ArrayLike, name: str) -> NDArray[np.float64]:
    """``q`` validated as quaternions (shape ``(..., 4)``, finite, non-zero) and normalised."""
    a = _check_last(q, 4, name)
    norm = np.sqrt(np.add.reduce(a * a, axis=-1, keepdims=True))  # what np.linalg.norm computes
    if norm.size and np.minimum.reduce(norm, axis=None) < 1e-12:  # np.any, minus its wrapper
        raise ValueError(f"{name}: a quaternion has (near) zero norm, got {a.tolist()!r}")
    return a / norm


# ----------------------------------------------------------------------------------------------
# Unchecked kernels (for hot vectorised loops)
# ----------------------------------------------------------------------------------------------


@functools.lru_cache(maxsize=256)
def _batch_shape(*shapes: tuple[int, ...]) -> tuple[int, ...]:
    """``np.broadcast_shapes`` (pure Python, slow next to a small step), memoised on the shapes."""
    return np.broadcast_shapes(*shapes)


def _norm3(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Euclidean norm over a last axis of length 3, keepdims (component arithmetic: numpy's
    reductions over a short last axis are several times slower)."""
    x, y, z = v[..., 0:1], v[..., 1:2], v[..., 2:3]
    return np.sqrt(x * x + y * y + z * z)


def _component_major(a: NDArray[np.float64], batch: tuple[int, ...]) -> NDArray[np.float64]:
    """``a`` (``(..., k)``) broadcast to ``(*batch, k)`` and copied component-major.

    The result has shape ``(*batch, k)`` but is a view of a C-ordered ``(k, *batch)`` array, so
    each component ``a[..., i]`` is one contiguous block. Element-wise numpy on such components
    runs one long inner loop; on broadcast or interleaved components (a short last axis) it runs
    many short ones, several times slower.
    """
    a = a.reshape((1,) * (len(batch) + 1 - a.ndim) + a.shape)
    out = np.empty((a.shape[-1], *batch))
    out[...] = a.transpose((a.ndim - 1, *range(a.ndim - 1)))
    return out.transpose((*range(1, out.ndim), 0))


# The Hamilton product as index tables: component c of q1 (x) q2 is the sum over k, in this order,
# of _HAMILTON_SIGN[c, k] * q1[k] * q2[_HAMILTON_RIGHT[c, k]] (the textbook formula term by term).
_HAMILTON_RIGHT = np.array([[0, 1, 2, 3], [1, 0, 3, 2], [2, 3, 0, 1], [3, 2, 1, 0]])
_HAMILTON_SIGN = np.array(
    [[1.0, -1.0, -1.0, -1.0], [1.0, 1.0, 1.0, -1.0], [1.0, -1.0, 1.0, 1.0], [1.0, 1.0, -1.0, 1.0]]
)
_SMALL_BATCH = 256
"""Inputs with at most this many entries take the few-numpy-calls paths (a control loop's one pose
and a handful of goals, where numpy's per-call overhead dominates); larger batches take the
component-major paths. Both evaluate the same floating-point operations in the same order, so they
return identical numbers."""
_QUAT_CONJUGATE_SIGNS = np.array([1.0, -1.0, -1.0, -1.0])


def _quat_multiply(q1: NDArray[np.float64], q2: NDArray[np.float64]) -> NDArray[np.float64]:
    """Hamilton product; for large batches the result is component-major (see :func:`_component_major`)."""
    if q1.size + q2.size <= _SMALL_BATCH:
        # All 16 products in one call; negating a product and adding it is exactly subtracting it.
        t = q1[..., None, :] * q2[..., _HAMILTON_RIGHT] * _HAMILTON_SIGN
        return t[..., 0] + t[..., 1] + t[..., 2] + t[..., 3]
    w1, x1, y1, z1 = q1[..., 0], q1[..., 1], q1[..., 2], q1[..., 3]
    w2, x2, y2, z2 = q2[..., 0], q2[..., 1], q2[..., 2], q2[..., 3]
    out = np.empty((4, *_batch_shape(q1.shape[:-1], q2.shape[:-1])))  # component-major
    np.subtract(w1 * w2 - x1 * x2 - y1 * y2, z1 * z2, out=out[0])
    np.subtract(w1 * x2 + x1 * w2 + y1 * z2, z1 * y2, out=out[1])
    np.add(w1 * y2 - x1 * z2 + y1 * w2, z1 * x2, out=out[2])
    np.add(w1 * z2 + x1 * y2 - y1 * x2, z1 * w2, out=out[3])
    return out.transpose((*range(1, out.ndim), 0))


def _quat_conjugate(q: NDArray[np.float64]) -> NDArray[np.float64]:
    return q * _QUAT_CONJUGATE_SIGNS


def _quat_from_rotvec(rv: NDArray[np.float64]) -> NDArray[np.float64]:
    angle = _norm3(rv)
    half = 0.5 * angle
    small = angle < _SMALL_ANGLE
    # sin(a/2)/a, with its series 1/2 - a^2/48 for tiny angles.
    safe = np.where(small, 1.0, angle)
    scale = np.where(small, 0.5 - angle * angle / 48.0, np.sin(half) / safe)
    return np.concatenate((np.cos(half), rv * scale), axis=-1)


def _quat_to_rotvec(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation vector of unit quaternions, shortest path (angle in [0, pi])."""
    q = np.where(q[..., :1] < 0.0, -q, q)
    w = q[..., :1]
    v = q[..., 1:]
    s = _norm3(v)
    angle = 2.0 * np.arctan2(s, w)
    small = s < 0.5 * _SMALL_ANGLE
    if not np.logical_or.reduce(small, axis=None):
        return v * (angle / s)  # what the general expression below gives without tiny rotations
    # angle / s, with its series 2/w (w ~ 1 here) for tiny rotations.
    safe_s = np.where(small, 1.0, s)
    scale = np.where(small, 2.0 / np.where(small, w, 1.0), angle / safe_s)
    return v * scale


def _orientation_error(q_from: NDArray[np.float64], q_to: NDArray[np.float64]) -> NDArray[np.float64]:
    return _quat_to_rotvec(_quat_multiply(q_to, _quat_conjugate(q_from)))


# ----------------------------------------------------------------------------------------------
# Public API
# ----------------------------------------------------------------------------------------------


def quat_normalize(q: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternions ``q / |q|``, shape ``(..., 4)``. A zero quaternion is a ``ValueError``."""
    return _check_quat(q, "q")


def quat_multiply(q1: ArrayLike, q2: ArrayLike) -> NDArray[np.float64]:
    """Hamilton product ``q1 (x) q2`` (apply ``q2`` first, then ``q1``), broadcasting."""
    a = _check_last(q1, 4, "q1")
    b = _check_last(q2, 4, "q2")
    return np.ascontiguousarray(_quat_multiply(a, b))


def quat_conjugate(q: ArrayLike) -> NDArray[np.float64]:
    """Conjugate ``[qw, -qx, -qy, -qz]`` (the inverse of a unit quaternion)."""
    return _quat_conjugate(_check_last(q, 4, "q"))


def quat_from_rotvec(rotvec: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternion of a rotation vector (axis * angle, rad), shape ``(..., 3) -> (..., 4)``."""
    return _quat_from_rotvec(_check_last(rotvec, 3, "rotvec"))


def quat_to_rotvec(q: ArrayLike) -> NDArray[np.float64]:
    """Rotation vector (axis * angle, angle in ``[0, pi]``) of a quaternion, ``(..., 4) -> (..., 3)``.

    ``q`` and ``-q`` give the same result (the shortest rotation); ``q`` need not be unit.
    """
    return np.ascontiguousarray(_quat_to_rotvec(_check_quat(q, "q")))


def quat_to_matrix(q: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix ``R`` (``(..., 3, 3)``) with ``R @ v`` rotating ``v`` by ``q``."""
    u = _check_quat(q, "q")
    w, x, y, z = u[..., 0], u[..., 1], u[..., 2], u[..., 3]
    rows = (
        (1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        (2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        (2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    )
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def orientation_error(q_from: ArrayLike, q_to: ArrayLike) -> NDArray[np.float64]:
    """World-frame rotation vector ``r`` (``(..., 3)``, rad) with ``q_to = exp(r) (x) q_from``.

    The shortest rotation: ``|r| <= pi``, and ``q_to`` and ``-q_to`` give the same ``r``. Driving
    an orientation with angular velocity ``k * r`` (world frame) moves it towards ``q_to``.
    """
    return np.ascontiguousarray(_orientation_error(_check_quat(q_from, "q_from"), _check_quat(q_to, "q_to")))


def _integrate_pose(
    position: NDArray[np.float64], quat: NDArray[np.float64], twist_vw: NDArray[np.float64], dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    new_position = position + twist_vw[..., :3] * dt
    new_quat = _quat_multiply(_quat_from_rotvec(twist_vw[..., 3:6] * dt), quat)
    w, x, y, z = new_quat[..., 0:1], new_quat[..., 1:2], new_quat[..., 2:3], new_quat[..., 3:4]
    new_quat = new_quat / np.sqrt(w * w + x * x + y * y + z * z)
    return new_position, new_quat


def integrate_pose(
    position: ArrayLike, quat: ArrayLike, twist_vw: ArrayLike, dt: float
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Move a pose by a constant world-frame twist for ``dt`` seconds.

    Args:
        position: ``(..., 3)`` positions (m).
        quat: ``(..., 4)`` orientations ``[qw, qx, qy, qz]``.
        twist_vw: ``(..., 6)`` twists ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s) in W.
        dt: Duration (s), finite and >= 0.

    Returns:
        ``(position + v dt, exp(w dt) (x) quat)`` broadcast together; the quaternion is unit.
    """
    if not (np.isfinite(dt) and dt >= 0):
        raise ValueError(f"dt: expected a finite number >= 0, got {dt!r}")
    p = _check_last(position, 3, "position")
    q = _check_quat(quat, "quat")
    t = _check_last(twist_vw, 6, "twist_vw")
    new_position, new_quat = _integrate_pose(p, q, t, float(dt))
    return new_position, np.ascontiguousarray(new_quat)
