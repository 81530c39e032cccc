"""The pre-check against what students do (issue 24): on seeded random scenes, calibrate through the task layer, look,
pick a detected block 150 mm or more from the waist axis and place it at a random free spot anywhere around the arm
(in front, beside, behind the waist axis; 100-420 mm out) with a random yaw, block after block
(benchmarks/scenarios/place_fuzz.py). Every place is done within 3 mm or refused before anything moves, never mid-plan.
Up to 200 places here (4 stations, up to 50 each: 143 are tried, the others end when no block is left 150 mm
out); `benchmarks/manipulation.py fuzz` runs more, by sector. And, as issue 33 found them refused mid-plan, places
of blocks detected with another calibration of the same station than the session's (the factory intrinsics with the
station's own tags and depth plane, as notebook 04's detection is calibrated apart from the task session).
Measured 2026-12-07: the 143 places all done, the worst 2.35 mm off; 11 let go more than 2 deg tilted (blocks held
level, placed 386-420 mm out where no top-down descent reaches; 19 before a block picked tilted was let go level by
planning.plan_place, the worst then 2.63 mm off)."""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"
if not (BENCHMARKS / "scenarios" / "place_fuzz.py").is_file():
    pytest.skip("no benchmarks here (a student release)", allow_module_level=True)
sys.path.insert(0, str(BENCHMARKS))
from scenarios.place_fuzz import run_station  # noqa: E402

SEEDS = (240, 241, 242, 243)
PLACES_PER_STATION = 50
TOLERANCE_MM = 3.0


def test_student_places_are_done_within_3_mm_or_refused_before_moving():
    outcomes = [(seed, o) for seed in SEEDS for o in run_station(seed, PLACES_PER_STATION)]
    counts = Counter(o.outcome for _, o in outcomes)
    worst = max((float(np.abs(o.error).max()) for _, o in outcomes if o.outcome == "done"), default=0.0)
    tilted = sum(o.tilt_rad > np.radians(2.0) for _, o in outcomes if o.outcome == "done")
    print(f"student fuzz: {len(outcomes)} places: {dict(counts)}; the worst done place {worst:.2f} mm off; "
          f"{tilted} let go more than 2 deg tilted")
    assert len(outcomes) >= 0.6 * len(SEEDS) * PLACES_PER_STATION, f"only {len(outcomes)} places were tried"
    mid_plan = [f"seed {seed}, {o.spot}: {o.message}" for seed, o in outcomes if o.outcome == "refused mid-plan"]
    assert not mid_plan, "refused after the arm had moved:\n" + "\n".join(mid_plan)
    # every place done is within 3 mm: none excused (a block seen as a strip beside the arm was once measured 21.7 mm
    # off and carried 4.7 mm off-centre along the pads: detection.edges._seen_edge_is_low)
    off = [f"seed {seed}, {o.spot}: {np.round(o.error, 2)}, let go {np.degrees(o.tilt_rad):.1f} deg tilted "
           f"{o.message}" for seed, o in outcomes if o.outcome == "done" and np.abs(o.error).max() >= TOLERANCE_MM]
    assert not off, f"placed {TOLERANCE_MM} mm or more off:\n" + "\n".join(off)
    assert counts["done"] >= 0.8 * len(outcomes), [o.message for _, o in outcomes if o.outcome != "done"]


def test_places_of_blocks_detected_with_another_calibration_are_never_refused_mid_plan():
    """Measured 2026-12-06: seed 240, 50 places, all done (the worst 2.15 mm off); seed 241, 19 places, all done."""
    outcomes = run_station(240, 25, detect_with="factory")
    counts = Counter(o.outcome for o in outcomes)
    print(f"another calibration's detections: {len(outcomes)} places: {dict(counts)}")
    assert len(outcomes) >= 20, f"only {len(outcomes)} places were tried"
    assert counts["refused mid-plan"] == 0, [o.message for o in outcomes if o.outcome == "refused mid-plan"]
    # seed 240 on the physics world: one large block picked 400 mm out (a pitched grasp) and placed top-down at
    # (36, 212) was let go 8.5 deg tilted and landed 3.10 mm off (the tip on landing); released level at the pick's
    # own pitch (planning.plan_place with held_in_tool) it lands 2.35 mm off
    off = [f"{o.spot}: {np.round(o.error, 2)}, let go {np.degrees(o.tilt_rad):.1f} deg tilted" for o in outcomes
           if o.outcome == "done" and np.abs(o.error).max() >= TOLERANCE_MM]
    assert not off and counts["done"] >= 0.8 * len(outcomes), (off, dict(counts))
