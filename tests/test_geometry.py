"""Quaternion helpers in drake_disamb.core.geometry, cross-checked against scipy and pydrake."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from support import integrate_pose

from drake_disamb.core.geometry import (
    normalized_quaternions,
    orientation_error,
    quat_conjugate,
    quat_from_rotvec,
    quat_multiply,
    quat_to_matrix,
    quat_to_rotvec,
)


def _random_quats(rng: np.random.Generator, n: int) -> np.ndarray:
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def _scipy(q_wxyz: np.ndarray) -> Rotation:
    return Rotation.from_quat(np.asarray(q_wxyz)[..., [1, 2, 3, 0]])


def _same_rotation(q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """|<q1, q2>| == 1 along the last axis (q and -q are the same rotation)."""
    return np.abs(np.sum(q1 * q2, axis=-1))


def test_matrix_matches_scipy_and_drake() -> None:
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RotationMatrix

    rng = np.random.default_rng(0)
    q = _random_quats(rng, 20)
    R = quat_to_matrix(q)
    np.testing.assert_allclose(R, _scipy(q).as_matrix(), atol=1e-12)
    for qi, Ri in zip(q, R, strict=True):
        np.testing.assert_allclose(RotationMatrix(Quaternion(qi)).matrix(), Ri, atol=1e-12)


def test_multiply_matches_matrix_product() -> None:
    rng = np.random.default_rng(1)
    a, b = _random_quats(rng, 10), _random_quats(rng, 10)
    np.testing.assert_allclose(
        quat_to_matrix(quat_multiply(a, b)), quat_to_matrix(a) @ quat_to_matrix(b), atol=1e-12
    )
    identity = quat_multiply(a, quat_conjugate(a))
    np.testing.assert_allclose(identity, np.tile([1.0, 0, 0, 0], (10, 1)), atol=1e-12)


def test_rotvec_round_trip_and_scipy() -> None:
    rng = np.random.default_rng(2)
    axis = rng.normal(size=(50, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    angle = rng.uniform(0.0, np.pi - 1e-6, size=(50, 1))
    rv = axis * angle
    q = quat_from_rotvec(rv)
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=1e-14)
    np.testing.assert_allclose(_same_rotation(q, _scipy(q).as_quat()[..., [3, 0, 1, 2]]), 1.0, atol=1e-12)
    np.testing.assert_allclose(_scipy(q).as_rotvec(), rv, atol=1e-10)
    np.testing.assert_allclose(quat_to_rotvec(q), rv, atol=1e-10)
    # -q is the same rotation: same (shortest) rotation vector.
    np.testing.assert_allclose(quat_to_rotvec(-q), rv, atol=1e-10)


def test_tiny_and_zero_rotations_are_exact_and_finite() -> None:
    for scale in (0.0, 1e-14, 1e-9, 1e-7):
        rv = np.array([1.0, -2.0, 0.5]) * scale
        q = quat_from_rotvec(rv)
        assert np.all(np.isfinite(q))
        np.testing.assert_allclose(quat_to_rotvec(q), rv, atol=1e-20, rtol=1e-8)


def test_orientation_error_is_world_frame_and_shortest() -> None:
    rng = np.random.default_rng(3)
    q_from = _random_quats(rng, 30)
    q_to = _random_quats(rng, 30)
    r = orientation_error(q_from, q_to)
    assert np.all(np.linalg.norm(r, axis=-1) <= np.pi + 1e-12)
    # q_to = exp(r) (x) q_from, up to sign.
    np.testing.assert_allclose(
        _same_rotation(quat_multiply(quat_from_rotvec(r), q_from), q_to), 1.0, atol=1e-12
    )
    # Sign of either quaternion does not matter.
    np.testing.assert_allclose(orientation_error(-q_from, q_to), r, atol=1e-12)
    np.testing.assert_allclose(orientation_error(q_from, -q_to), r, atol=1e-12)
    # Same orientation: zero error.
    np.testing.assert_allclose(orientation_error(q_from, q_from), 0.0, atol=1e-12)


def test_orientation_error_broadcasts() -> None:
    rng = np.random.default_rng(4)
    q_from = _random_quats(rng, 1)[0]
    q_to = _random_quats(rng, 6).reshape(2, 3, 4)
    r = orientation_error(q_from, q_to)
    assert r.shape == (2, 3, 3)
    np.testing.assert_allclose(r[1, 2], orientation_error(q_from, q_to[1, 2]), atol=0)


def test_integrate_pose_constant_twist() -> None:
    p0 = np.array([0.1, -0.2, 0.3])
    q0 = quat_from_rotvec([0.0, 0.0, 0.3])
    twist = np.array([0.1, 0.0, -0.05, 0.0, 0.0, 0.2])
    p, q = p0, q0
    for _ in range(10):
        p, q = integrate_pose(p, q, twist, 0.1)
    np.testing.assert_allclose(p, p0 + twist[:3] * 1.0, atol=1e-12)
    # Rotation about a fixed world axis composes exactly: total angle 0.3 + 0.2.
    np.testing.assert_allclose(quat_to_rotvec(q), [0.0, 0.0, 0.5], atol=1e-12)
    # World-frame angular velocity: left multiplication.
    q1 = quat_from_rotvec([0.4, 0.0, 0.0])
    _, q2 = integrate_pose(p0, q1, [0, 0, 0, 0, 0.5, 0], 1.0)
    np.testing.assert_allclose(
        _same_rotation(q2, quat_multiply(quat_from_rotvec([0.0, 0.5, 0.0]), q1)), 1.0, atol=1e-12
    )


def test_integrate_pose_batched() -> None:
    rng = np.random.default_rng(5)
    p = rng.normal(size=(4, 3))
    q = _random_quats(rng, 4)
    tw = rng.normal(size=(4, 6))
    pb, qb = integrate_pose(p, q, tw, 0.05)
    for i in range(4):
        pi, qi = integrate_pose(p[i], q[i], tw[i], 0.05)
        np.testing.assert_allclose(pb[i], pi, atol=0)
        np.testing.assert_allclose(qb[i], qi, atol=0)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: normalized_quaternions([1.0, 0.0, 0.0], "q"), r"q: expected shape \(\.\.\., 4\)"),
        (lambda: normalized_quaternions([0.0, 0.0, 0.0, 0.0], "q"), "zero norm"),
        (lambda: normalized_quaternions([1e200, 0.0, 0.0, 0.0], "q"), "norm overflows"),
        (lambda: quat_to_rotvec([np.nan, 0.0, 0.0, 1.0]), "q: expected finite"),
        (lambda: quat_from_rotvec([1.0, 2.0]), r"rotvec: expected shape \(\.\.\., 3\)"),
        (lambda: orientation_error([1, 0, 0, 0], [1, 0, 0]), "q_to"),
        (lambda: integrate_pose([0, 0, 0], [1, 0, 0, 0], [0, 0, 0], 0.1), "twist_vw"),
        (lambda: integrate_pose([0, 0, 0], [1, 0, 0, 0], [0] * 6, -0.1), "dt"),
        (lambda: quat_multiply("abc", [1, 0, 0, 0]), "q1"),
    ],
)
def test_bad_input_raises_value_error_naming_the_field(call, message) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(ValueError, match=message):
        call()


def test_public_results_are_c_contiguous_and_kernels_broadcast_row_by_row() -> None:
    rng = np.random.default_rng(5)
    q1, q2 = _random_quats(rng, 6), _random_quats(rng, 6)
    assert quat_multiply(q1, q2).flags.c_contiguous
    assert orientation_error(q1, q2).flags.c_contiguous
    assert quat_to_rotvec(q1).flags.c_contiguous
    assert integrate_pose(np.zeros((6, 3)), q1, rng.normal(size=(6, 6)), 0.1)[1].flags.c_contiguous
    # The compiled row kernels broadcast like numpy: a (3, 1, 4) batch against a (6, 4) one gives
    # (3, 6, ...), each entry exactly the one-pair result.
    a = _random_quats(rng, 3)[:, None, :]
    prod = quat_multiply(a, q2)
    err = orientation_error(a, q2)
    assert prod.shape == (3, 6, 4) and err.shape == (3, 6, 3)
    for i in range(3):
        for j in range(6):
            np.testing.assert_array_equal(prod[i, j], quat_multiply(a[i, 0], q2[j]))
            np.testing.assert_array_equal(err[i, j], orientation_error(a[i, 0], q2[j]))


def test_compiled_checks_agree_with_numpy() -> None:
    """all_finite and normalized_quaternions_unchecked run compiled loops on float64 arrays; they
    must give numpy's answers, and anything else goes through numpy."""
    from support import normalized_quaternions_unchecked

    from drake_disamb.core.validation import all_finite

    rng = np.random.default_rng(3)
    for special in (np.nan, np.inf, -np.inf, 1e308, -1e308, 0.0):
        for shape in ((6,), (3, 6), (2, 3, 4)):
            a = rng.normal(size=shape)
            a.flat[rng.integers(a.size)] = special
            assert all_finite(a, np.zeros(2)) == bool(np.isfinite(a).all())
            assert all_finite(a[..., ::2]) == bool(np.isfinite(a[..., ::2]).all())  # a strided view
    assert all_finite([1.0, 2.0], 3.0, np.arange(4)) and not all_finite([1.0, np.nan])
    q = rng.normal(size=(5, 4))
    expected = q / np.linalg.norm(q, axis=-1, keepdims=True)
    np.testing.assert_allclose(normalized_quaternions_unchecked(q), expected)
    assert normalized_quaternions_unchecked(q[0]).shape == (4,)
    assert normalized_quaternions_unchecked(q.reshape(5, 1, 4)).shape == (5, 1, 4)


def test_orientation_error_of_one_pair_is_the_checked_path() -> None:
    """One pair of float quaternions goes straight to the kernel: the same numbers as the checked,
    broadcasting path (normalized_quaternions, orientation_error_unchecked), at any usable scale;
    what the checks refuse is still refused."""
    from drake_disamb.core.geometry import normalized_quaternions, orientation_error_unchecked

    rng = np.random.default_rng(3)
    for scale in (1e-9, 1e-3, 1.0, 7.0, 1e100):
        for _ in range(50):
            a, b = rng.normal(size=4) * scale, rng.normal(size=4)
            expected = orientation_error_unchecked(
                normalized_quaternions(a, "a"), normalized_quaternions(b, "b")
            )
            got = orientation_error(a, b)
            assert got.shape == (3,)
            np.testing.assert_array_equal(got, expected)
            np.testing.assert_array_equal(orientation_error(list(a), b), expected)  # a list: checked path
    for bad in (
        [0.0, 0.0, 0.0, 0.0],
        [np.nan, 0.0, 0.0, 1.0],
        [np.inf, 0.0, 0.0, 1.0],
        [1e200, 0.0, 0.0, 0.0],
    ):
        with pytest.raises(ValueError, match="q_from"):
            orientation_error(np.array(bad), np.array([1.0, 0.0, 0.0, 0.0]))
