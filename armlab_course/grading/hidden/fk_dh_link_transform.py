"""Hidden checks of exercise fk.dh_link_transform: fresh inputs from the grader's seed, compared with the reference's
results (armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _link_batches(rng):
    return [[[rng.uniform(-np.pi, np.pi, 6).tolist(), rng.uniform(-200, 200, 6).tolist(),
              rng.uniform(-300, 300, 6).tolist(), rng.uniform(-np.pi, np.pi, 6).tolist()]] for _ in range(3)]


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("armlab.kinematics.dh_link_transform", _link_batches,
                                            what="the link transforms (rotation entries, unitless; translation, mm)"),)
FORBIDDEN: tuple[str, ...] = (
    "kinematics._dh_by_elementary_motions", "kinematics.fk_pox"
)
