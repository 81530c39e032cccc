"""Hidden checks of exercise fk.dh_table: the tool pose of the student's DH table, at random joint angles and at arm
geometries other than the RX200's (so a table copied from data/rx200_dh.csv does not pass), chained here by the
elementary motions (not by the package's dh_link_transform, another exercise); compared with the reference table's
poses (armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _geometries(rng):
    # per check: the RX200's own geometry or a perturbed one, and a few random joint vectors (limits ignored)
    cases = []
    for k in range(4):
        geometry = [104.57, float(np.hypot(50.0, 200.0)), float(np.arctan2(50.0, 200.0)), 200.0, 158.575]
        if k:
            geometry = [float(rng.uniform(90, 120)), float(rng.uniform(180, 230)), float(rng.uniform(0.05, 0.5)),
                        float(rng.uniform(170, 230)), float(rng.uniform(130, 190))]
        cases.append([[geometry, rng.uniform(-2.5, 2.5, (6, 5)).tolist()]])
    return cases


def _judge_dh_table(call, geometry, q):
    """The tool poses (N, 3, 4) of the child's table dh_table(*geometry) at joints q (N, 5), chained here:
    Rz(q + offset) Tz(d) Tx(a) Rx(alpha), then the kit's fixed DH_TOOL_ROTATION."""
    from armlab.robot import DH_TOOL_ROTATION
    from armlab.transforms import homogeneous, rot_x, rot_z

    table = np.asarray(call(*(float(g) for g in geometry)), dtype=float)
    if table.shape != (5, 4):
        raise ValueError(f"dh_table returned shape {table.shape}, expected (5, 4)")
    out = []
    for joints in np.asarray(q, dtype=float):
        T = np.eye(4)
        for qi, (offset, d, a, alpha) in zip(joints, table, strict=True):
            T = T @ homogeneous(rot_z(qi + offset), [0.0, 0.0, d]) @ homogeneous(rot_x(alpha), [a, 0.0, 0.0])
        out.append((T @ homogeneous(DH_TOOL_ROTATION))[:3])
    return np.array(out)


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("dh_table", _geometries, atol=1e-6, judge=_judge_dh_table,
                                            prelude="definitions", what="the tool poses your table chains to "
                                            "(rotation entries, unitless; position, mm)"),)
FORBIDDEN: tuple[str, ...] = (
    "kinematics.fk_pox", "kinematics.fk", "kinematics.fk_dh", "kinematics.link_frames", "kinematics.dh_frames",
    "RobotModel.dh", "pox_of_lengths",
)
