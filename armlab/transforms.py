"""SE(3) and SO(3) helpers: rotations, homogeneous transforms, Euler angles, skew matrices and exponentials.

Every function accepts a single item or a stack of them (leading batch dimensions) and is vectorised with numpy.
Lengths are in millimetres and angles in radians throughout the kit; these helpers are unit-agnostic.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "wrap_quarter",
    "rot_x",
    "rot_y",
    "rot_z",
    "homogeneous",
    "invert_transform",
    "transform_points",
    "skew",
    "exp_so3",
    "log_so3",
    "exp_se3",
    "exp_se3_from",
    "screw_matrices",
    "rotvec_to_matrix",
    "matrix_from_euler_zyz",
    "rpy_from_matrix",
    "matrix_from_rpy",
]

# Below this value of sin(beta) an Euler decomposition is treated as singular (gimbal lock).
_SINGULAR_EPS = 1e-9


def _rotation(angle, axis: int) -> np.ndarray:
    angle = np.asarray(angle, dtype=float)
    c, s = np.cos(angle), np.sin(angle)
    out = np.zeros(angle.shape + (3, 3))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    out[..., axis, axis] = 1.0
    out[..., i, i] = c
    out[..., j, j] = c
    out[..., i, j] = -s
    out[..., j, i] = s
    return out


def rot_x(angle) -> np.ndarray:
    """Rotation matrix (..., 3, 3) about the x axis by `angle` rad (right-hand rule)."""
    return _rotation(angle, 0)


def rot_y(angle) -> np.ndarray:
    """Rotation matrix (..., 3, 3) about the y axis by `angle` rad (right-hand rule)."""
    return _rotation(angle, 1)


def rot_z(angle) -> np.ndarray:
    """Rotation matrix (..., 3, 3) about the z axis by `angle` rad (right-hand rule)."""
    return _rotation(angle, 2)


def homogeneous(rotation=None, translation=None) -> np.ndarray:
    """4x4 homogeneous transform(s) from a rotation (..., 3, 3) and a translation (..., 3)."""
    rotation = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float)
    translation = np.zeros(3) if translation is None else np.asarray(translation, dtype=float)
    batch = np.broadcast_shapes(rotation.shape[:-2], translation.shape[:-1])
    out = np.zeros(batch + (4, 4))
    out[..., :3, :3] = rotation
    out[..., :3, 3] = translation
    out[..., 3, 3] = 1.0
    return out


def invert_transform(T) -> np.ndarray:
    """Inverse of rigid transform(s) (..., 4, 4) without a general matrix inverse."""
    T = np.asarray(T, dtype=float)
    R_t = np.swapaxes(T[..., :3, :3], -1, -2)
    return homogeneous(R_t, -np.einsum("...ij,...j->...i", R_t, T[..., :3, 3]))


def transform_points(T, points) -> np.ndarray:
    """Apply transform T (4, 4) to points (..., 3); returns (..., 3)."""
    T = np.asarray(T, dtype=float)
    points = np.asarray(points, dtype=float)
    return points @ T[:3, :3].T + T[:3, 3]


def skew(w) -> np.ndarray:
    """Skew-symmetric matrix (..., 3, 3) with skew(w) @ v == cross(w, v)."""
    w = np.asarray(w, dtype=float)
    out = np.zeros(w.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -w[..., 2], w[..., 1]
    out[..., 1, 0], out[..., 1, 2] = w[..., 2], -w[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -w[..., 1], w[..., 0]
    return out


def exp_so3(axis, angle) -> np.ndarray:
    """Rodrigues' formula: rotation (..., 3, 3) by `angle` rad about the unit `axis` (..., 3)."""
    K = skew(axis)
    angle = np.asarray(angle, dtype=float)[..., None, None]
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)


def rotvec_to_matrix(rotvec) -> np.ndarray:
    """Rotation matrix (..., 3, 3) from a rotation vector (..., 3): axis times angle in rad."""
    rotvec = np.asarray(rotvec, dtype=float)
    angle = np.linalg.norm(rotvec, axis=-1)
    safe = np.where(angle > 0, angle, 1.0)
    return exp_so3(rotvec / safe[..., None], angle)


def log_so3(R) -> np.ndarray:
    """Rotation vector (..., 3) of rotation matrix (..., 3, 3); the angle is in [0, pi].

    The angle comes from atan2(sin, cos) (accurate everywhere, unlike arccos near 0 and pi). Near pi, where the
    antisymmetric part vanishes, the axis is read from the symmetric part and its sign from the antisymmetric one.
    """
    R = np.asarray(R, dtype=float)
    cos = (np.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0
    vee = np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    sin = np.linalg.norm(vee, axis=-1) / 2.0
    angle = np.arctan2(sin, cos)
    scale = np.where(sin > 1e-12, angle / np.where(sin > 1e-12, 2 * sin, 1.0), 0.5)
    out = vee * scale[..., None]
    near_pi = (cos < 0) & (sin < 1e-3)
    if np.any(near_pi):
        # (R + R^T)/2 = cos I + (1 - cos) a a^T: take the column with the largest diagonal of a a^T.
        Rn, cn = R[near_pi], cos[near_pi]
        aat = ((Rn + np.swapaxes(Rn, -1, -2)) / 2 - cn[:, None, None] * np.eye(3)) / (1 - cn)[:, None, None]
        k = np.argmax(np.diagonal(aat, axis1=-2, axis2=-1), axis=-1)
        col = np.take_along_axis(aat, k[:, None, None], axis=-1)[..., 0]
        axis = col / np.linalg.norm(col, axis=-1, keepdims=True)
        axis *= np.where(np.sum(axis * vee[near_pi], axis=-1) < 0, -1.0, 1.0)[:, None]
        out[near_pi] = axis * angle[near_pi][..., None]
    return out


def screw_matrices(screw) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What exp_se3 needs of revolute screws (w, v) (..., 6), unit w, that does not depend on the angle: the skew
    matrix W = [w] (..., 3, 3), its square W @ W (..., 3, 3) and v (..., 3) (in the screws' length unit).

    For screws that stay fixed (a robot's joint axes) compute this once and call exp_se3_from: the same numbers,
    bit for bit, as exp_se3, without rebuilding the matrices at every call."""
    screw = np.asarray(screw, dtype=float)
    W = skew(screw[..., :3])
    return W, W @ W, screw[..., 3:]


_EYE3 = np.eye(3)
_EYE3.setflags(write=False)


def exp_se3_from(matrices: tuple[np.ndarray, np.ndarray, np.ndarray], theta) -> np.ndarray:
    """exp_se3 of the screws whose screw_matrices are `matrices`, at angles theta (...) rad: (..., 4, 4)."""
    W, WW, v = matrices
    theta = np.asarray(theta, dtype=float)
    th = theta[..., None, None]
    sin, one_minus_cos = np.sin(th), 1.0 - np.cos(th)
    R = _EYE3 + sin * W + one_minus_cos * WW
    G = _EYE3 * th + one_minus_cos * W + (th - sin) * WW
    t = np.einsum("...ij,...j->...i", G, v)
    out = np.zeros(R.shape[:-2] + (4, 4))
    out[..., :3, :3] = R
    out[..., :3, 3] = t
    out[..., 3, 3] = 1.0
    return out


def exp_se3(screw, theta) -> np.ndarray:
    """Matrix exponential of a revolute screw: (..., 4, 4) for screw (w, v) (..., 6), unit w, angle theta (...).

    Lengths in v set the unit of the translation (mm throughout the kit). R = I + sin(theta) W + (1 - cos(theta)) W^2
    and t = (I theta + (1 - cos(theta)) W + (theta - sin(theta)) W^2) v with W = [w] (screw_matrices, exp_se3_from).
    """
    return exp_se3_from(screw_matrices(screw), theta)


def matrix_from_euler_zyz(angles) -> np.ndarray:
    """Rotation (..., 3, 3) = Rz(phi) Ry(theta) Rz(psi) from ZYZ angles (..., 3) in rad."""
    angles = np.asarray(angles, dtype=float)
    return rot_z(angles[..., 0]) @ rot_y(angles[..., 1]) @ rot_z(angles[..., 2])


def rpy_from_matrix(R) -> np.ndarray:
    """Roll, pitch, yaw (..., 3) with R = Rz(yaw) Ry(pitch) Rx(roll), pitch in [-pi/2, pi/2].

    At the singularities pitch = +/- pi/2 only yaw -/+ roll is defined: roll is set to 0 and yaw carries it.
    """
    R = np.asarray(R, dtype=float)
    cos_pitch = np.hypot(R[..., 0, 0], R[..., 1, 0])
    pitch = np.arctan2(-R[..., 2, 0], cos_pitch)
    regular = cos_pitch > _SINGULAR_EPS
    roll = np.where(regular, np.arctan2(R[..., 2, 1], R[..., 2, 2]), 0.0)
    yaw = np.where(regular, np.arctan2(R[..., 1, 0], R[..., 0, 0]), np.arctan2(-R[..., 0, 1], R[..., 1, 1]))
    return np.stack([roll, pitch, yaw], axis=-1)


def matrix_from_rpy(rpy) -> np.ndarray:
    """Rotation (..., 3, 3) = Rz(yaw) Ry(pitch) Rx(roll) from (roll, pitch, yaw) (..., 3) in rad."""
    rpy = np.asarray(rpy, dtype=float)
    return rot_z(rpy[..., 2]) @ rot_y(rpy[..., 1]) @ rot_x(rpy[..., 0])


def wrap_quarter(angle) -> np.ndarray:
    """An angle (rad) reduced modulo pi/2 into [-pi/4, pi/4): how far a square is turned from another (a cube's yaw
    looks the same every quarter turn). Works elementwise on arrays."""
    return np.mod(np.asarray(angle, dtype=float) + np.pi / 4, np.pi / 2) - np.pi / 4
