"""Releases with clearance (issue 33): a place lets the block go RELEASE_GAP_MM above the surface it lands on, a gap
chosen from the measured disagreement between the kit's belief of the held block and the simulator's truth.

At every release of the student fuzz (benchmarks/scenarios/place_fuzz.py: seeded scenes calibrated through the task
layer, detected blocks picked and placed at random spots), right before the pads open: the belief is the lowest
corner of the block the arm was told it holds (Arm.held_blocks, recorded by the executor at the grasp) at the joints
the kit believes the arm is at (the sag model's physical angles of the last command); the truth is the lowest corner
of the object between the pads at the simulator's true joints. Measured 2026-12-06 over 233 releases (143 with the
camera's checkerboard intrinsics on seeds 240-243, 90 with its factory intrinsics, another calibration of the same
station): the truth lay up to 2.01 mm below the belief (99th percentile 1.4 mm; mean 0.4 mm above it, std 0.7 mm),
so RELEASE_GAP_MM = 3 mm leaves every released block at least a millimetre over its surface. Here: one station's
places, each released with the true block at least a millimetre above where the kit aimed it to land (with the
former 2 mm gap this station's worst release kept 0.6 mm).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from armlab import kinematics
from armlab.tasks import RELEASE_GAP_MM, GuardedArm
from armlab.transforms import matrix_from_rpy

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
if not (BENCHMARKS / "scenarios" / "place_fuzz.py").is_file():
    pytest.skip("no benchmarks here (a student release)", allow_module_level=True)
sys.path.insert(0, str(BENCHMARKS))
from scenarios.place_fuzz import run_station  # noqa: E402

CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float) / 2
SEED, PLACES = 241, 12
KEEP_MM = 1.0           # the true block clears where the kit aims it to land by at least this much at each release


def lowest_z(R: np.ndarray, centre: np.ndarray, edge: float) -> float:
    """World z (mm) of the lowest corner of a cube of `edge` mm turned by R (3, 3) with its centre at `centre`."""
    return float((R @ (CORNERS * edge).T)[2].min() + centre[2])


def belief_minus_truth(guarded: GuardedArm) -> float | None:
    """How far (mm) the truly held block's lowest corner lies below the believed one, right now; None when the arm
    holds nothing it was told of."""
    raw = guarded.arm
    if not raw.held_blocks or not raw.holding or not guarded.sent:
        return None
    told = raw.held_blocks[0]
    T = kinematics.fk_pox(guarded.sag.physical(guarded.sent[-1][1], guarded.robot)) @ told.T_tool_block
    believed = lowest_z(T[:3, :3], T[:3, 3], told.edge_mm)
    obj = raw.holding[0]
    true = lowest_z(matrix_from_rpy([*obj.tilt, obj.yaw]), obj.position, obj.edge)
    return believed - true


def test_every_release_clears_its_surface_by_the_measured_disagreement(monkeypatch):
    gaps: list[float] = []
    opening = GuardedArm.open_gripper

    def probe(self):
        d = belief_minus_truth(self)
        if d is not None:
            gaps.append(d)
        return opening(self)

    monkeypatch.setattr(GuardedArm, "open_gripper", probe)
    outcomes = run_station(SEED, PLACES)
    d = np.array(gaps)
    print(f"{len(d)} releases: the true block {d.max():.2f} mm below the belief at worst, mean {d.mean():.2f} mm, "
          f"release gap {RELEASE_GAP_MM} mm")
    assert len(d) >= len(outcomes) >= PLACES // 2, (len(d), len(outcomes))
    assert d.max() < RELEASE_GAP_MM - KEEP_MM, \
        f"a block was released only {RELEASE_GAP_MM - d.max():.2f} mm over where the kit aimed it to land"
