"""The headless demo behind `make demo` (a kinematics walkthrough until the whole pipeline is in place)."""

from __future__ import annotations

import numpy as np

from armlab import kinematics
from armlab.robot import rx200


def run_demo(out_dir: str = "out", seed: int = 0) -> int:
    """Print forward and inverse kinematics for a few board targets; returns a process exit code."""
    robot = rx200()
    print("RX200 kinematics walkthrough (world frame, mm)")
    print(f"home tool point: {np.round(kinematics.fk(robot.home)[:3, 3], 3)}")
    print(f"{'target (mm)':>24} {'pitch':>7} {'solutions':>9} {'fk(ik) error (mm)':>18}")
    rng = np.random.default_rng(seed)
    targets = np.column_stack([rng.uniform(-300, 300, 6), rng.uniform(50, 400, 6), np.full(6, 19.0)])
    for p in targets:
        pitch = kinematics.steepest_pitch(p)
        sols = kinematics.ik(p, pitch)
        err = np.abs(kinematics.fk(sols)[:, :3, 3] - p).max()
        print(f"{np.array2string(p, precision=1):>24} {np.degrees(pitch):6.1f}° {len(sols):9d} {err:18.2e}")
    return 0
