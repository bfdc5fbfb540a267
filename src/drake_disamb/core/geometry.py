"""Quaternions and orientation errors (numpy, with numba-compiled row kernels).

Conventions (see CONTRIBUTING.md):

- Quaternions are ``[qw, qx, qy, qz]`` arrays (Drake's w-first order) and every function
  broadcasts over any number of leading dimensions: a quaternion argument has shape ``(..., 4)``,
  a rotation vector ``(..., 3)``.
- Rotation vectors are axis * angle (rad). Angular velocities and orientation errors are
  expressed in the world frame W, so a world-frame rotation ``r`` acts on an orientation ``q`` by
  left multiplication: ``quat_from_rotvec(r) (x) q``.
- Twists are in the paper's order ``[vx, vy, vz, wx, wy, wz]`` (m/s, rad/s), world frame.

Public functions validate their inputs and raise ``ValueError`` naming the argument and the
offending shape or value (:func:`check_vectors` and :func:`normalized_quaternions` are those
checks, for the other core modules too). The ``*_unchecked`` variants skip validation; they are
used inside vectorised loops (the disambiguation forward projection) whose inputs were validated
once. The row layout of the compiled kernels is :mod:`drake_disamb.core.rows`.

The Hamilton product and the rotation vector are written once, as scalar functions compiled with
numba (``_qmul`` and ``_rotvec`` in :mod:`drake_disamb.core._kernels`); the array functions here,
and the kernels that need them (the potential field's rotational part), loop over rows calling
them. On the small arrays of a control step or a disambiguation request, numpy's cost per call
would dominate.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from drake_disamb.core._kernels import (
    _SMALL_ANGLE,
    _orientation_error_rows,
    _pose_error_rows,
    _quat_multiply_rows,
    _rotvec_rows,
    _usable_pose_rows,
)
from drake_disamb.core.rows import as_rows, batch_shape
from drake_disamb.core.validation import all_finite

# ----------------------------------------------------------------------------------------------
# Validation
# ----------------------------------------------------------------------------------------------


def check_vectors(x: ArrayLike, size: int, name: str) -> NDArray[np.float64]:
    """``x`` as a float array whose last axis has ``size`` entries, all finite."""
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:  # OverflowError: an int beyond float range
        raise ValueError(f"{name}: expected an array of numbers, got {x!r}") from exc
    if a.ndim == 0 or a.shape[-1] != size:
        raise ValueError(f"{name}: expected shape (..., {size}), got shape {a.shape}")
    if not all_finite(a):
        raise ValueError(f"{name}: expected finite numbers, got {a.tolist()!r}")
    return a


def normalized_quaternions(q: ArrayLike, name: str) -> NDArray[np.float64]:
    """``q`` validated as quaternions (shape ``(..., 4)``, finite, non-zero) and normalised.

    A quaternion whose norm is below 1e-12 or overflows (entries beyond about 1e154) is rejected:
    normalising it would give zeros, which no kernel can use.
    """
    a = check_vectors(q, 4, name)
    with np.errstate(over="ignore"):  # an overflowing norm is rejected below, with its own message
        norm = _quaternion_norms(a)
    if norm.size and np.minimum.reduce(norm, axis=None) < 1e-12:  # np.any, minus its wrapper
        raise ValueError(f"{name}: a quaternion has (near) zero norm, got {a.tolist()!r}")
    # Finite norms (each below 1.4e154) cannot sum to infinity: one sum checks them all.
    if not math.isfinite(np.add.reduce(norm, axis=None)):
        raise ValueError(f"{name}: a quaternion's norm overflows (entries too large), got {a.tolist()!r}")
    return a / norm


def _quaternion_norms(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Norms of quaternions ``(..., 4)``, keepdims (what ``np.linalg.norm`` computes)."""
    return np.sqrt(np.add.reduce(a * a, axis=-1, keepdims=True))


def poses_usable(poses: NDArray[np.float64], max_entry: float, min_quaternion_norm: float) -> bool:
    """True if the float64 poses ``[x, y, z, qw, qx, qy, qz]`` laid end to end in ``poses`` (any
    shape with 7 k entries) have every entry within ``+-max_entry`` (NaN is not) and every
    quaternion's norm at least ``min_quaternion_norm``. Compiled: a control tick checks its poses."""
    return bool(
        _usable_pose_rows(np.ascontiguousarray(poses, dtype=float).ravel(), max_entry, min_quaternion_norm**2)
    )


# ----------------------------------------------------------------------------------------------
# Unchecked helpers: row layout for the compiled kernels, quaternion arithmetic
# ----------------------------------------------------------------------------------------------


def _norm3(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Euclidean norm over a last axis of length 3, keepdims (component arithmetic: numpy's
    reductions over a short last axis are several times slower)."""
    x, y, z = v[..., 0:1], v[..., 1:2], v[..., 2:3]
    return np.sqrt(x * x + y * y + z * z)


_QUAT_CONJUGATE_SIGNS = np.array([1.0, -1.0, -1.0, -1.0])


def _binary_rows(kernel, a: NDArray[np.float64], b: NDArray[np.float64], width: int) -> NDArray[np.float64]:
    """Run a row kernel on ``a`` and ``b`` (``(..., 4)`` each, broadcasting): ``(..., width)``."""
    batch = batch_shape(a.shape[:-1], b.shape[:-1])
    out = np.empty((math.prod(batch), width))
    kernel(as_rows(a, batch, (4,)), as_rows(b, batch, (4,)), out)
    return out.reshape(*batch, width)


def quat_multiply_unchecked(q1: NDArray[np.float64], q2: NDArray[np.float64]) -> NDArray[np.float64]:
    """Hamilton product ``q1 (x) q2``, broadcasting (float arrays, unchecked)."""
    return _binary_rows(_quat_multiply_rows, q1, q2, 4)


def _quat_conjugate(q: NDArray[np.float64]) -> NDArray[np.float64]:
    return q * _QUAT_CONJUGATE_SIGNS


def quat_from_rotvec_unchecked(rv: NDArray[np.float64]) -> NDArray[np.float64]:
    angle = _norm3(rv)
    half = 0.5 * angle
    small = angle < _SMALL_ANGLE
    # sin(a/2)/a, with its series 1/2 - a^2/48 for tiny angles.
    safe = np.where(small, 1.0, angle)
    scale = np.where(small, 0.5 - angle * angle / 48.0, np.sin(half) / safe)
    return np.concatenate((np.cos(half), rv * scale), axis=-1)


def _quat_to_rotvec(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation vector of unit quaternions, shortest path (angle in [0, pi])."""
    batch = q.shape[:-1]
    out = np.empty((math.prod(batch), 3))
    _rotvec_rows(as_rows(q, batch, (4,)), out)
    return out.reshape(*batch, 3)


def orientation_error_unchecked(
    q_from: NDArray[np.float64], q_to: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``rotvec(q_to (x) conj(q_from))``, broadcasting (unit quaternions, unchecked)."""
    return _binary_rows(_orientation_error_rows, q_from, q_to, 3)


# ----------------------------------------------------------------------------------------------
# Public API
# ----------------------------------------------------------------------------------------------


def quat_multiply(q1: ArrayLike, q2: ArrayLike) -> NDArray[np.float64]:
    """Hamilton product ``q1 (x) q2`` (apply ``q2`` first, then ``q1``), broadcasting."""
    a = check_vectors(q1, 4, "q1")
    b = check_vectors(q2, 4, "q2")
    return quat_multiply_unchecked(a, b)


def quat_conjugate(q: ArrayLike) -> NDArray[np.float64]:
    """Conjugate ``[qw, -qx, -qy, -qz]`` (the inverse of a unit quaternion)."""
    return _quat_conjugate(check_vectors(q, 4, "q"))


def quat_from_rotvec(rotvec: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternion of a rotation vector (axis * angle, rad), shape ``(..., 3) -> (..., 4)``."""
    return quat_from_rotvec_unchecked(check_vectors(rotvec, 3, "rotvec"))


def quat_to_rotvec(q: ArrayLike) -> NDArray[np.float64]:
    """Rotation vector (axis * angle, angle in ``[0, pi]``) of a quaternion, ``(..., 4) -> (..., 3)``.

    ``q`` and ``-q`` give the same result (the shortest rotation); ``q`` need not be unit.
    """
    return _quat_to_rotvec(normalized_quaternions(q, "q"))


def quat_to_matrix(q: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrix ``R`` (``(..., 3, 3)``) with ``R @ v`` rotating ``v`` by ``q``."""
    u = normalized_quaternions(q, "q")
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
    if _clearly_usable(q_from) and _clearly_usable(q_to):  # one pair (a simulated user's step)
        # What the checks below would let through, normalised as normalized_quaternions does
        # (numpy), without the checks, and one row for the kernel (no broadcasting layout).
        out = np.empty((1, 3))
        _orientation_error_rows(
            (q_from / _quaternion_norms(q_from)).reshape(1, 4),
            (q_to / _quaternion_norms(q_to)).reshape(1, 4),
            out,
        )
        return out[0]
    return orientation_error_unchecked(
        normalized_quaternions(q_from, "q_from"), normalized_quaternions(q_to, "q_to")
    )


_FLOAT64 = np.dtype(np.float64)


def _clearly_usable(q: object) -> bool:
    """True for a float64 array ``(4,)`` that :func:`normalized_quaternions` accepts with a margin:
    finite, its squared norm in ``[1e-20, 1e300]`` (no overflow, norm far above 1e-12)."""
    if type(q) is not np.ndarray or q.shape != (4,) or q.dtype != _FLOAT64:
        return False
    w, x, y, z = q.tolist()
    return 1e-20 <= w * w + x * x + y * y + z * z <= 1e300  # False for a NaN or infinite entry


def pose_errors(ee_pose: ArrayLike, goal_poses: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Position (m) and orientation (rad) errors between one pose and each of ``n`` goal poses.

    Args:
        ee_pose: ``[x, y, z, qw, qx, qy, qz]``.
        goal_poses: ``(n, 7)`` (or flat ``7 n``) goal poses with non-zero quaternions.

    Returns:
        ``(distances (n,), angles (n,))``: ``|x_g - x|`` and the angle of the shortest rotation
        between the orientations (``|orientation_error|``). A non-finite ``ee_pose`` or one with a
        (near) zero quaternion gives ``inf`` errors.
    """
    x = np.asarray(ee_pose, dtype=float)
    g = np.ascontiguousarray(np.asarray(goal_poses, dtype=float).reshape(-1, 7))
    n = g.shape[0]
    if x.shape != (7,):
        raise ValueError(f"ee_pose: expected 7 numbers, got shape {x.shape}")
    if not all_finite(x):
        return np.full(n, np.inf), np.full(n, np.inf)
    qw, qx, qy, qz = x[3:].tolist()  # floats: scalar arithmetic costs less than on numpy scalars
    if qw * qw + qx * qx + qy * qy + qz * qz < 1e-18:
        return np.full(n, np.inf), np.full(n, np.inf)
    dist, angle = np.empty(n), np.empty(n)
    _pose_error_rows(x, g, dist, angle)
    return dist, angle
