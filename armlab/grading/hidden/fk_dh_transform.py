"""Hidden checks of exercise fk.dh_transform: fresh inputs from the grader's seed, compared with the reference's
results (armlab.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _dh_params(rng, n):
    return [[float(rng.uniform(-np.pi, np.pi)), float(rng.uniform(-200, 200)), float(rng.uniform(-300, 300)),
             float(rng.uniform(-np.pi, np.pi))] for _ in range(n)]


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("dh_transform", lambda rng: [[p] for p in _dh_params(rng, 4)]),)
FORBIDDEN: tuple[str, ...] = (
    "kinematics.dh_link_transform", "kinematics._dh_by_elementary_motions", "kinematics.fk_pox", "kinematics.fk",
    "kinematics.fk_dh", "kinematics.dh_frames"
)
