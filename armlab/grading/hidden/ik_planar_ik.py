"""Hidden checks of exercise ik.planar_ik: fresh inputs from the grader's seed, compared with the reference's
results (armlab.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _planar_targets(rng):
    # both elbow branches at random targets near the arm's working space (unreachable ones expected NaN)
    cases = []
    for elbow_up in (True, False, True, False):
        r, z, psi = rng.uniform(80, 380, 12), rng.uniform(-50, 350, 12), rng.uniform(-0.3, np.pi / 2, 12)
        cases.append([[r.tolist(), z.tolist(), psi.tolist(), elbow_up]])
    return cases


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("planar_ik", _planar_targets, atol=1e-6),)
FORBIDDEN: tuple[str, ...] = (
    "kinematics.ik", "kinematics.ik_batch", "kinematics.ik_numerical", "IKinSpace", "IKinBody",
    "scipy.optimize.least_squares", "scipy.optimize.fsolve", "scipy.optimize.minimize"
)
