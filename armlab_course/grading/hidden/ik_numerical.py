"""Hidden checks of exercise ik.numerical: the Jacobian and the pose error at fresh random poses, compared with the
reference's; the damped least squares iteration graded on its outcome from hidden starts to hidden reachable targets
(another correct iteration may land on other joint angles, so q itself is never compared)
(armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _limits():
    from armlab.robot import rx200

    robot = rx200()
    return robot.lower, robot.upper


def _jacobian_poses(rng):
    # random joint angles within the limits, one per call
    lower, upper = _limits()
    return [[[rng.uniform(lower, upper).tolist()] for _ in range(4)] for _ in range(3)]


def _rotation(axis, angle):
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def _pose_pairs(rng):
    # (T, T_target): a random pose and another turned by a random rotation (small to 2.5 rad, clear of the half
    # turn's sign ambiguity) about a random world axis, and moved by a random offset
    from armlab.kinematics import fk

    lower, upper = _limits()
    cases = []
    for angles in ((1e-8, 0.05, 0.4, 1.2), (2.0, 2.5, 0.0, 0.8)):
        calls = []
        for angle in angles:
            T = fk(rng.uniform(lower, upper))
            target = np.eye(4)
            target[:3, :3] = _rotation(rng.normal(size=3), angle) @ T[:3, :3]
            target[:3, 3] = T[:3, 3] + rng.uniform(-50, 50, 3)
            calls.append([T.tolist(), target.tolist()])
        cases.append(calls)
    return cases


def _dls_runs(rng):
    # a hidden reachable target (fk of joint angles inside the limits) and a start up to 0.3 rad from them per joint
    from armlab.kinematics import fk

    lower, upper = _limits()
    cases = []
    for _ in range(3):
        calls = []
        for _ in range(3):
            q_true = rng.uniform(0.85 * lower, 0.85 * upper)
            q0 = np.clip(q_true + rng.uniform(-0.3, 0.3, 5), lower, upper)
            calls.append([fk(q_true).tolist(), q0.tolist()])
        cases.append(calls)
    return cases


def _judge_dls(call, T_target, q0):
    """The outcome of the student's solve_ik_dls from q0 to T_target, checked here on the joints it reached: [tool
    within 0.01 mm of the target, tool orientation within 1e-4 (rotation matrix entries), joints within the limits]
    as 1.0 / 0.0."""
    from armlab.kinematics import fk

    T_target = np.asarray(T_target, dtype=float)
    q = np.asarray(call(T_target, q0), dtype=float).ravel()
    lower, upper = _limits()
    T = fk(q, check_limits=False)
    return [float(np.abs(T[:3, 3] - T_target[:3, 3]).max() < 1e-2),
            float(np.abs(T[:3, :3] - T_target[:3, :3]).max() < 1e-4),
            float(q.shape == (5,) and bool(np.all((q >= lower - 1e-9) & (q <= upper + 1e-9))))]


SPECS: tuple[HiddenSpec, ...] = (
    # exact: the DH and the PoX frames agree to 1e-12; finite differences of fk reach 1e-8 at best
    HiddenSpec("tool_jacobian", _jacobian_poses, atol=1e-10, prelude="definitions",
               what="the Jacobian's entries (linear rows, mm per rad; angular rows, rad per rad)"),
    HiddenSpec("pose_error", _pose_pairs, atol=1e-7, prelude="definitions",
               what="the pose error (position part, mm; rotation part, rad)"),
    HiddenSpec("solve_ik_dls", _dls_runs, atol=0.0, adapter="_call_dls", prelude="definitions",
               judge=_judge_dls, criteria=("the tool within 0.01 mm of the target",
                                           "the tool's orientation within 1e-4 (rotation matrix entries)",
                                           "the joints within their limits")),
)
FORBIDDEN: tuple[str, ...] = (
    "kinematics.jacobian", "kinematics.ik", "kinematics.ik_branches",
    "kinematics.ik_batch", "kinematics._ik_candidates", "kinematics._numerical_candidates", "kinematics._ik_one",
    "kinematics.steepest_pitch", "transforms.log_so3", "scipy.spatial.transform.Rotation", "scipy.optimize",
    "JacobianSpace", "JacobianBody", "IKinSpace", "IKinBody",
)
