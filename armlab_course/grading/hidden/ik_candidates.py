"""Hidden checks of exercise ik.candidates: fresh inputs from the grader's seed, compared with the reference's
results (armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _ik_all_solutions(rng):
    # every solution of ik() (K, 5) at random targets the instructor's kit reaches (the harness reports an
    # unreachable target as an error): per check two with one solution in the joint limits and two with several
    # (elbow up and down, or both waist branches; about 2 % of the targets); the student's _branch_joints runs in
    # the fast single solve and in the batch it falls back to
    from armlab.kinematics import Unreachable, ik

    single, several = [], []
    while len(single) < 8 or len(several) < 8:
        heading, r = rng.uniform(-np.pi, np.pi), rng.uniform(50, 420)
        call = [[float(r * np.cos(heading)), float(r * np.sin(heading)), float(rng.uniform(-50, 350))],
                float(rng.uniform(-0.5, 2.5)), float(rng.uniform(-1, 1))]
        try:
            k = len(ik(np.array(call[0]), call[1], call[2]))
        except Unreachable:
            continue
        (single if k == 1 else several).append(call)
    return [single[i:i + 2] + several[i:i + 2] for i in range(0, 8, 2)]


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("armlab.kinematics.ik", _ik_all_solutions, atol=1e-6,
                                            what="the IK solutions' joint angles", unit="rad"),)
FORBIDDEN: tuple[str, ...] = (
    "kinematics._numerical_candidates", "IKinSpace", "IKinBody",
    "scipy.optimize.least_squares", "scipy.optimize.fsolve", "scipy.optimize.minimize"
)
