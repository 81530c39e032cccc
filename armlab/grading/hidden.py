"""The hidden checks (instructor only: not in the student release, see RELEASE_EXCLUDES): per exercise, fresh inputs
drawn from the grader's own seed. The student's function runs in a bounded subprocess of the grading work tree
(armlab.grading.harness) and writes its results as JSON; the expected values come from the same harness run on the
reference work tree; the comparison happens here, in the grader's process, so nothing the student's code patches
can change it. A new exercise's hidden checks are one HiddenSpec in SPECS; an exercise without one is graded by its
public checks only."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["HiddenSpec", "SPECS", "cases_of", "compare"]

SEED = 20261101


@dataclass(frozen=True)
class HiddenSpec:
    """function: the name in the exercise's notebook, or 'module.function' of a package exercise; cases: from a
    numpy Generator, a list of hidden checks, each a list of argument lists (JSON-able: floats, bools, lists);
    atol: the tolerance of the comparison (in the function's units)."""

    function: str
    cases: Callable[[np.random.Generator], list[list[list]]]
    atol: float = 1e-6


def _dh_params(rng, n):
    return [[float(rng.uniform(-np.pi, np.pi)), float(rng.uniform(-200, 200)), float(rng.uniform(-300, 300)),
             float(rng.uniform(-np.pi, np.pi))] for _ in range(n)]


def _fk_tables(rng):
    # DH tables that are not the RX200's: kinematics.fk_pox (the RX200) cannot stand in for the chain
    return [[[rng.uniform(-np.pi, np.pi, 5).tolist(), np.column_stack(
        [rng.uniform(-1, 1, 5), rng.uniform(-50, 150, 5), rng.uniform(0, 250, 5), rng.uniform(-np.pi, np.pi, 5)]
    ).tolist()] for _ in range(3)] for _ in range(4)]


def _planar_targets(rng):
    # both elbow branches at random targets near the arm's working space (unreachable ones expected NaN)
    cases = []
    for elbow_up in (True, False, True, False):
        r, z, psi = rng.uniform(80, 380, 12), rng.uniform(-50, 350, 12), rng.uniform(-0.3, np.pi / 2, 12)
        cases.append([[r.tolist(), z.tolist(), psi.tolist(), elbow_up]])
    return cases


def _masks(rng):
    cases = []
    for _ in range(4):
        mask = np.zeros((60, 80), dtype=bool)
        for _ in range(3):
            u, v, w, h = rng.integers(0, 70), rng.integers(0, 50), rng.integers(3, 20), rng.integers(3, 20)
            mask[v:v + h, u:u + w] = True
        cases.append([[mask.astype(int).tolist()]])
    return cases


def _angles(rng):
    # wide angles, and angles 1e-3 rad either side of the wrap's edges (odd multiples of pi/4)
    edges = [(2 * int(k) + 1) * np.pi / 4 + s * 1e-3 for k in rng.integers(-6, 6, 10) for s in (-1, 1)]
    return [[[float(a)] for a in rng.uniform(-10, 10, 20)], [[float(a)] for a in rng.uniform(-100, 100, 20)],
            [[float(a)] for a in edges]]


def _pinhole(rng):
    K = [[900.0 + rng.uniform(-50, 50), 0.0, 640 + rng.uniform(-20, 20)],
         [0.0, 900.0 + rng.uniform(-50, 50), 360 + rng.uniform(-20, 20)], [0.0, 0.0, 1.0]]
    a = rng.uniform(-0.3, 0.3)
    T = [[1.0, 0.0, 0.0, rng.uniform(-50, 50)], [0.0, -np.cos(a), np.sin(a), rng.uniform(100, 200)],
         [0.0, -np.sin(a), -np.cos(a), rng.uniform(900, 1100)], [0.0, 0.0, 0.0, 1.0]]
    return K, T


def _projections(rng):
    cases = []
    for _ in range(3):
        K, T = _pinhole(rng)
        cases.append([[K, T, np.column_stack([rng.uniform(-300, 300, 10), rng.uniform(-100, 400, 10),
                                              rng.uniform(0, 100, 10)]).tolist()]])
    return cases


def _back_projections(rng):
    cases = []
    for _ in range(3):
        K, T = _pinhole(rng)
        cases.append([[K, T, [float(rng.uniform(0, 1280)), float(rng.uniform(0, 720))],
                       float(rng.uniform(700, 1200))] for _ in range(4)])
    return cases


def _link_batches(rng):
    return [[[rng.uniform(-np.pi, np.pi, 6).tolist(), rng.uniform(-200, 200, 6).tolist(),
              rng.uniform(-300, 300, 6).tolist(), rng.uniform(-np.pi, np.pi, 6).tolist()]] for _ in range(3)]


def _towers(rng):
    return [[[int(n)] for n in rng.integers(0, 7, 4)], [[int(n)] for n in rng.integers(8, 16, 4)], [[8], [9], [0]]]


def _homographies(rng):
    # exact pairs through a random homography (a camera looking at a plane), 4 points and more
    cases = []
    for n in (4, 4, 6, 15):
        H = np.array([[rng.uniform(0.5, 2), rng.uniform(-0.3, 0.3), rng.uniform(-300, 300)],
                      [rng.uniform(-0.3, 0.3), rng.uniform(0.5, 2), rng.uniform(-300, 300)],
                      [rng.uniform(-4e-4, 4e-4), rng.uniform(-4e-4, 4e-4), 1.0]])
        src = np.column_stack([rng.uniform(-400, 400, n), rng.uniform(-300, 300, n)])
        dst = np.column_stack([src, np.ones(n)]) @ H.T
        cases.append([[src.tolist(), (dst[:, :2] / dst[:, 2:]).tolist()]])
    return cases


def _noisy_lines(rng):
    cases = []
    for _ in range(4):
        n = int(rng.integers(6, 30))
        reach = rng.uniform(100, 500, n)
        sag = rng.uniform(-0.2, 0.2) * reach + rng.uniform(-20, 20) + rng.normal(0, rng.uniform(0.1, 3), n)
        cases.append([[reach.tolist(), sag.tolist()]])
    return cases


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


SPECS: dict[str, HiddenSpec] = {
    "calib.project_pinhole": HiddenSpec("project_pinhole", _projections, atol=1e-6),
    "calib.pixel_to_world_pinhole": HiddenSpec("pixel_to_world_pinhole", _back_projections, atol=1e-6),
    "fk.dh_transform": HiddenSpec("dh_transform", lambda rng: [[p] for p in _dh_params(rng, 4)]),
    "fk.fk_from_table": HiddenSpec("fk_from_table", _fk_tables, atol=1e-6),
    "fk.dh_link_transform": HiddenSpec("armlab.kinematics.dh_link_transform", _link_batches),
    "ik.planar_ik": HiddenSpec("planar_ik", _planar_targets, atol=1e-6),
    "detect.centroid": HiddenSpec("centroid", _masks, atol=1e-6),
    "detect.wrap_yaw": HiddenSpec("wrap_yaw", _angles, atol=1e-9),
    "events.sky_points": HiddenSpec("sky_points", _towers, atol=0),
    "calib.tag_homography": HiddenSpec("armlab.calibration.homography.dlt_homography", _homographies, atol=1e-7),
    "grab.sag_line": HiddenSpec("sag_line", _noisy_lines, atol=1e-8),
    "ik.candidates": HiddenSpec("armlab.kinematics.ik", _ik_all_solutions, atol=1e-6),
}


def cases_of(exercise_id: str) -> list[list[list]] | None:
    """The hidden checks of the exercise (each a list of argument lists), or None when it has none."""
    spec = SPECS.get(exercise_id)
    if spec is None:
        return None
    rng = np.random.default_rng([SEED, sum(map(ord, exercise_id))])
    return json.loads(json.dumps(spec.cases(rng), default=float))


def compare(exercise_id: str, student: list[dict], expected: list[dict], sizes: list[int]) -> list[tuple[bool, str]]:
    """Per hidden check (`sizes` calls each): passed, and a message naming the first call that differs."""
    atol = SPECS[exercise_id].atol
    out, k = [], 0
    for i, n in enumerate(sizes):
        message = ""
        for j in range(k, k + n):
            got, want = student[j] if j < len(student) else {"error": "no result"}, expected[j]
            if "error" in got:
                message = f"hidden check {i + 1}, call {j - k + 1}: raised {got['error']}"
                break
            try:
                a = np.asarray(got["value"], dtype=float)
                b = np.asarray(want["value"], dtype=float)
                same = a.shape == b.shape and np.allclose(a, b, rtol=0, atol=atol, equal_nan=True)
            except (ValueError, TypeError):
                same = False
            if not same:
                message = f"hidden check {i + 1}, call {j - k + 1}: the result differs from the expected value"
                break
        out.append((not message, message))
        k += n
    return out
