"""Hidden checks of exercise fk.fk_from_table: fresh inputs from the grader's seed, compared with the reference's
results (armlab.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _fk_tables(rng):
    # DH tables that are not the RX200's: kinematics.fk_pox (the RX200) cannot stand in for the chain
    return [[[rng.uniform(-np.pi, np.pi, 5).tolist(), np.column_stack(
        [rng.uniform(-1, 1, 5), rng.uniform(-50, 150, 5), rng.uniform(0, 250, 5), rng.uniform(-np.pi, np.pi, 5)]
    ).tolist()] for _ in range(3)] for _ in range(4)]


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("fk_from_table", _fk_tables, atol=1e-6),)
FORBIDDEN: tuple[str, ...] = (
    "kinematics.fk_pox", "kinematics.fk", "kinematics.fk_dh", "kinematics.dh_frames", "kinematics.link_frames",
    "kinematics.dh_link_transform"
)
