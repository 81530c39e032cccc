"""Hidden checks of exercise fk.euler: ZYZ Euler angles of random rotations and of the singular ones (sin theta = 0),
compared as (cos phi, sin phi, theta, cos psi, sin psi) with the reference's (armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _rotations(rng):
    # random rotations (uniform: normalised Gaussian quaternions) clear of the singularity, then singular ones
    cases = []
    for _ in range(3):
        quats = rng.normal(size=(6, 4))
        quats /= np.linalg.norm(quats, axis=1, keepdims=True)
        w, x, y, z = quats.T
        R = np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
                      np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
                      np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], -2)
        keep = np.hypot(R[:, 0, 2], R[:, 1, 2]) > 1e-3
        T = np.tile(np.eye(4), (int(keep.sum()), 1, 1))
        T[:, :3, :3], T[:, :3, 3] = R[keep], rng.uniform(-300, 300, (int(keep.sum()), 3))
        cases.append([[t.tolist()] for t in T])
    singular = []
    for a, flip in zip(rng.uniform(-3, 3, 4), (0.0, np.pi, 0.0, np.pi)):
        c, s = np.cos(a), np.sin(a)
        Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        Ry = np.diag([np.cos(flip), 1.0, np.cos(flip)])
        T = np.eye(4)
        T[:3, :3] = Rz @ Ry
        singular.append([T.tolist()])
    cases.append(singular)
    return cases


def _judge_euler(call, T):
    """(cos phi, sin phi, theta, cos psi, sin psi) of the child's angles: no wrap ambiguity at phi = +/- pi."""
    phi, theta, psi = (float(x) for x in np.asarray(call(T), dtype=float).ravel())
    return [np.cos(phi), np.sin(phi), theta, np.cos(psi), np.sin(psi)]


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("euler_angles_from_T", _rotations, atol=1e-7, judge=_judge_euler,
                                            prelude="definitions", what="the Euler angles",
                                            parts=(("cos phi", ""), ("sin phi", ""), ("theta", "rad"), ("cos psi", ""),
                                                   ("sin psi", ""))),)
FORBIDDEN: tuple[str, ...] = (
    "transforms.rpy_from_matrix", "scipy.spatial.transform.Rotation",
)
