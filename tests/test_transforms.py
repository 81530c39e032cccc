"""armlab.transforms: rotations, rigid transforms, exponentials and Euler angles against known answers."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armlab import transforms as tf

SETTINGS = settings(deadline=None, derandomize=True, max_examples=200)
angles = st.floats(-np.pi, np.pi, allow_nan=False)
unit_vectors = st.tuples(*[st.floats(-1, 1)] * 3).map(np.array).filter(lambda v: np.linalg.norm(v) > 1e-3) \
    .map(lambda v: v / np.linalg.norm(v))


def random_rotations(n, seed=0):
    """n rotations uniformly spread over SO(3) (from random unit quaternions)."""
    q = np.random.default_rng(seed).normal(size=(n, 4))
    w, x, y, z = (q / np.linalg.norm(q, axis=1, keepdims=True)).T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
        np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
        np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], -2)


def test_elementary_rotations_turn_axes_by_the_right_hand_rule():
    x, y, z = np.eye(3)
    np.testing.assert_allclose(tf.rot_z(np.pi / 2) @ x, y, atol=1e-15)
    np.testing.assert_allclose(tf.rot_x(np.pi / 2) @ y, z, atol=1e-15)
    np.testing.assert_allclose(tf.rot_y(np.pi / 2) @ z, x, atol=1e-15)
    np.testing.assert_allclose(tf.rot_y(0.3) @ x, [np.cos(0.3), 0, -np.sin(0.3)], atol=1e-15)


def test_rotations_are_vectorised_orthonormal_and_proper():
    a = np.linspace(-4, 4, 12).reshape(3, 4)
    for rot in (tf.rot_x, tf.rot_y, tf.rot_z):
        R = rot(a)
        assert R.shape == (3, 4, 3, 3)
        np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-15)
        np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-14)
        np.testing.assert_allclose(R[1, 2], rot(a[1, 2]))


def test_homogeneous_inverse_and_point_transform():
    R = random_rotations(50, seed=1)
    t = np.random.default_rng(2).uniform(-500, 500, (50, 3))
    T = tf.homogeneous(R, t)
    assert T.shape == (50, 4, 4)
    np.testing.assert_allclose(T @ tf.invert_transform(T), np.broadcast_to(np.eye(4), T.shape), atol=1e-12)
    np.testing.assert_allclose(tf.invert_transform(T), np.linalg.inv(T), atol=1e-12)
    # rotate (1, 0, 0) by 90 deg about z and move it by (10, 20, 30) mm
    T1 = tf.homogeneous(tf.rot_z(np.pi / 2), [10.0, 20.0, 30.0])
    np.testing.assert_allclose(tf.transform_points(T1, [[1.0, 0, 0], [0, 0, 0]]), [[10, 21, 30], [10, 20, 30]],
                               atol=1e-12)
    np.testing.assert_array_equal(tf.homogeneous(), np.eye(4))


@SETTINGS
@given(unit_vectors, st.tuples(*[st.floats(-10, 10)] * 3).map(np.array))
def test_skew_is_the_cross_product(w, v):
    np.testing.assert_allclose(tf.skew(w) @ v, np.cross(w, v), atol=1e-12)
    np.testing.assert_allclose(tf.skew(w), -tf.skew(w).T)


def test_exp_so3_matches_elementary_rotations_and_rotvec():
    for axis, rot in zip(np.eye(3), (tf.rot_x, tf.rot_y, tf.rot_z), strict=True):
        np.testing.assert_allclose(tf.exp_so3(axis, 0.7), rot(0.7), atol=1e-15)
    np.testing.assert_allclose(tf.rotvec_to_matrix([0.0, 0.0, 0.0]), np.eye(3))
    np.testing.assert_allclose(tf.rotvec_to_matrix([0.0, -1.2, 0.0]), tf.rot_y(-1.2), atol=1e-15)


@SETTINGS
@given(unit_vectors, st.floats(0, np.pi))
def test_log_so3_inverts_exp_so3_up_to_pi(axis, angle):
    R = tf.exp_so3(axis, angle)
    v = tf.log_so3(R)
    assert np.linalg.norm(v) <= np.pi + 1e-12
    np.testing.assert_allclose(tf.rotvec_to_matrix(v), R, atol=1e-12)
    if angle < np.pi - 1e-9:  # short of pi the rotation vector itself is unique
        np.testing.assert_allclose(v, axis * angle, atol=1e-9)


def test_log_so3_near_and_at_pi_batch():
    axes = np.array([[1.0, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [1, -2, 3]])
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    for angle in (np.pi, np.pi - 1e-7, np.pi - 1e-5, np.pi - 1e-4, np.pi - 2e-3):
        R = tf.exp_so3(axes, np.full(len(axes), angle))
        v = tf.log_so3(R)
        np.testing.assert_allclose(np.linalg.norm(v, axis=1), angle, atol=1e-12)
        np.testing.assert_allclose(tf.rotvec_to_matrix(v), R, atol=1e-12)
        if angle < np.pi:  # short of pi the axis' sign is defined too
            np.testing.assert_allclose(v, axes * angle, atol=1e-12)


def test_exp_se3_rotates_about_an_axis_through_a_point():
    """A revolute screw with axis w through point p: the point stays put, others turn about it (mm units)."""
    w, p = np.array([0.0, 1.0, 0.0]), np.array([100.0, 0.0, 50.0])
    screw = np.concatenate([w, -np.cross(w, p)])
    for theta in (-2.0, 0.0, 0.5, np.pi):
        T = tf.exp_se3(screw, theta)
        expected = tf.homogeneous(None, p) @ tf.homogeneous(tf.rot_y(theta)) @ tf.homogeneous(None, -p)
        np.testing.assert_allclose(T, expected, atol=1e-12)
        np.testing.assert_allclose(tf.transform_points(T, p), p, atol=1e-12)
    T = tf.exp_se3(np.broadcast_to(screw, (4, 6)), np.linspace(0, 1, 4))
    assert T.shape == (4, 4, 4)


@SETTINGS
@given(angles, angles, angles)
def test_matrix_from_euler_zyz(phi, theta, psi):
    """(ZYZ Euler angles from a matrix are exercise fk.euler's: notebook 02, not the kit's.)"""
    R = tf.matrix_from_euler_zyz([phi, theta, psi])
    np.testing.assert_allclose(R, tf.rot_z(phi) @ tf.rot_y(theta) @ tf.rot_z(psi), atol=1e-15)
    assert tf.matrix_from_euler_zyz(np.zeros((4, 2, 3))).shape == (4, 2, 3, 3)


@SETTINGS
@given(angles, st.floats(-np.pi / 2 + 1e-6, np.pi / 2 - 1e-6), angles)
def test_rpy_round_trip_regular(roll, pitch, yaw):
    R = tf.matrix_from_rpy([roll, pitch, yaw])
    np.testing.assert_allclose(R, tf.rot_z(yaw) @ tf.rot_y(pitch) @ tf.rot_x(roll), atol=1e-15)
    got = tf.rpy_from_matrix(R)
    np.testing.assert_allclose(tf.matrix_from_rpy(got), R, atol=1e-9)
    if abs(pitch) < np.pi / 2 - 1e-4:
        np.testing.assert_allclose(np.angle(np.exp(1j * (got - [roll, pitch, yaw]))), 0, atol=1e-8)


@pytest.mark.parametrize("pitch", [np.pi / 2, -np.pi / 2])
def test_rpy_singularities(pitch):
    for roll, yaw in [(0.3, 0.5), (-2.0, 1.0), (3.0, -3.0)]:
        R = tf.matrix_from_rpy([roll, pitch, yaw])
        got = tf.rpy_from_matrix(R)
        assert got[0] == 0.0
        np.testing.assert_allclose(got[1], pitch, atol=1e-7)
        np.testing.assert_allclose(tf.matrix_from_rpy(got), R, atol=1e-12)


def test_euler_conversions_are_vectorised():
    R = random_rotations(1000, seed=3)
    for to_angles, from_angles in ((tf.rpy_from_matrix, tf.matrix_from_rpy),):
        a = to_angles(R.reshape(10, 100, 3, 3))
        assert a.shape == (10, 100, 3)
        np.testing.assert_allclose(from_angles(a).reshape(-1, 3, 3), R, atol=1e-9)
        np.testing.assert_allclose(a[4, 7], to_angles(R[407]))
