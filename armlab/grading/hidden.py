"""The hidden checks (instructor only: not in the student release, see RELEASE_EXCLUDES): per exercise, fresh inputs
drawn from the grader's own seed. The student's function runs in a bounded subprocess of the grading work tree
(armlab.grading.harness) and writes its results as JSON; the expected values come from the same harness run on the
reference work tree; the comparison happens here, in the grader's process, so nothing the student's code patches
can change it. A new exercise's hidden checks are one HiddenSpec (or a tuple of them) in SPECS; an exercise without
one is graded by its public checks only. FORBIDDEN lists, per exercise, the library and kit functions that would do
the exercise for the student (armlab.grading.static reads the region's text for them; nothing is run).

The adapters (`_call_*`) run in the child, never here: they build what the student's function takes (a Camera, a
colour model, a sim arm, detections) from JSON arguments and turn its result into numbers.
"""

from __future__ import annotations

import functools
import json
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

__all__ = ["HiddenSpec", "SPECS", "FORBIDDEN", "FORBIDDEN_EVERYWHERE", "specs_of", "cases_of", "compare"]

SEED = 20261101


@dataclass(frozen=True)
class HiddenSpec:
    """function: the name in the exercise's notebook, or the dotted path of a package exercise's function (or class);
    cases: from a numpy Generator, a list of hidden checks, each a list of argument lists (JSON-able: floats, bools,
    lists); atol: the tolerance of the comparison (in the function's units); adapter: the name of a `_call_*`
    function of this module the child calls as adapter(function, *args) instead of function(*args) ('' for none);
    prelude: how the child reaches a notebook function ('cells': every code cell before it runs; 'definitions':
    only their imports, definitions and literal constants, no simulator run); agree: the fraction of a result's
    numbers that must match the expected ones within atol (1.0: all)."""

    function: str
    cases: Callable[[np.random.Generator], list[list[list]]]
    atol: float = 1e-6
    adapter: str = ""
    prelude: str = "cells"
    agree: float = 1.0


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


def _camera_over_board(rng, width=1280, height=720):
    """K (3, 3) for an image of width x height px and T_cam_world (4, 4) of a camera 0.9-1.1 m over the board
    looking at a random board point."""
    from armlab.camera import look_at

    f = width * 0.7 * rng.uniform(0.95, 1.05)
    K = [[f, 0.0, width / 2 + rng.uniform(-0.02, 0.02) * width], [0.0, f, height / 2 + rng.uniform(-0.02, 0.02) *
                                                                  height], [0.0, 0.0, 1.0]]
    T = look_at([rng.uniform(-60, 60), rng.uniform(80, 260), rng.uniform(900, 1100)],
                [rng.uniform(-40, 40), rng.uniform(120, 200), 0.0])
    return K, T.tolist()


def _tag_views(rng):
    # exact board corners (z = 0) seen by random cameras, no distortion: any correct planar pose is exact here,
    # before the refinement (which the adapter leaves out) could repair a wrong one
    cases = []
    for n in (4, 8, 12, 20):
        K, T = _camera_over_board(rng)
        world = np.column_stack([rng.uniform(-400, 400, n), rng.uniform(-150, 450, n), np.zeros(n)])
        cam = world @ np.asarray(T)[:3, :3].T + np.asarray(T)[:3, 3]
        uv = cam @ np.asarray(K).T
        cases.append([[world.tolist(), (uv[:, :2] / uv[:, 2:]).tolist(), K, [0.0] * 5]])
    return cases


def _call_initial_pose(function, world, pixels, K, dist):
    """pose_from_corners without its Levenberg-Marquardt refinement: the region's own R and t."""
    from armlab.calibration import extrinsics
    from armlab.transforms import homogeneous

    refined = extrinsics._refined
    extrinsics._refined = lambda world, pixels, K, dist, R, t: homogeneous(np.asarray(R, float),
                                                                           np.asarray(t, float).ravel())
    try:
        return function(*(np.asarray(a, float) for a in (world, pixels, K, dist)))
    finally:
        extrinsics._refined = refined


def _depth_scenes(rng):
    # a small depth camera over the board: a tilted bias plane, noise, dropouts and objects 12-25 mm tall (within
    # the first guess's 30 mm, so only the refit-and-reject loop drops them)
    cases = []
    for _ in range(3):
        K, T = _camera_over_board(rng, 160, 90)
        bias = [float(rng.uniform(-0.1, 0.1)), float(rng.uniform(-0.1, 0.1)), float(rng.uniform(-15, 15))]
        cases.append([[K, T, bias, int(rng.integers(0, 2**31))]])
    return cases


def _call_depth_plane(function, K, T, bias, seed):
    from armlab.calibration.depth import board_depth
    from armlab.camera import Camera

    camera = Camera(np.asarray(K, float), np.zeros(5), np.asarray(T, float), 160, 90)
    rng = np.random.default_rng(int(seed))
    depth, _ = board_depth(camera, 1)
    v, u = np.mgrid[0:90, 0:160]
    depth = depth + bias[0] * u + bias[1] * v + bias[2] + rng.normal(0, 1.0, depth.shape)
    for _ in range(4):
        r, c = rng.integers(0, 80), rng.integers(0, 150)
        depth[r:r + 10, c:c + 10] -= rng.uniform(12, 25)
    depth[rng.random(depth.shape) < 0.05] = np.nan
    fit = function(depth.astype(np.float32), camera, step=2)
    return [fit.a, fit.b, fit.c, fit.residual_mm, fit.inliers]


def _colour_models(rng):
    # six classes whose spreads differ tenfold between classes and axes: the nearest mean alone is often wrong
    from armlab.detection.color import COLORS, color_features

    cases = []
    for _ in range(4):
        means = color_features(rng.uniform(20, 235, (6, 3)))
        stds = rng.uniform(0.005, 0.08, (6, 3))
        cases.append([[list(COLORS), means.tolist(), stds.tolist(), rng.uniform(0, 255, (25, 3)).tolist()]])
    return cases


def _call_classify(function, names, means, stds, rgb):
    """ColorModel(names, means, stds).classify(rgb): the class indices and the margins."""
    model = function(tuple(str(n) for n in names), np.asarray(means, float), np.asarray(stds, float))
    best, margin = model.classify(np.asarray(rgb, float))
    return [[float(model.names.index(b)) for b in best], np.asarray(margin, float).tolist()]


def _square_faces(rng):
    # filled squares drawn at random centres and yaws, a large (38 mm) or small (25 mm) cube's face within 5 % at
    # 0.7-1.6 mm per px (15-57 px across); the adapter scores the student's answer against the truth
    checks = []
    for _ in range(3):
        calls = []
        for _ in range(4):
            large, mm_per_px = bool(rng.random() < 0.5), float(rng.uniform(0.7, 1.6))
            edge = (38.0 if large else 25.0) * rng.uniform(0.95, 1.05) / mm_per_px
            calls.append([rng.uniform(45, 55, 2).tolist(), float(edge), float(rng.uniform(-3, 3)), mm_per_px])
        checks.append(calls)
    return checks


def _call_face(function, centre, edge, yaw, mm_per_px):
    """face_geometry on a drawn square (100 x 100 px): [centre within 1 px, yaw within 5 deg modulo quarter turns and
    in [-pi/4, pi/4), size class right] (1.0 / 0.0)."""
    import cv2

    c, s = np.cos(yaw), np.sin(yaw)
    corners = np.asarray(centre) + 0.5 * edge * np.array([[c - s, s + c], [-c - s, -s + c], [-c + s, -s - c],
                                                          [c + s, s - c]])
    mask = np.zeros((100, 100), np.uint8)
    cv2.fillPoly(mask, [np.round(corners * 16).astype(np.int32)], 1, cv2.LINE_8, shift=4)
    u, v, got_yaw, size = function(mask, float(mm_per_px))
    err = abs((float(got_yaw) - yaw + np.pi / 4) % (np.pi / 2) - np.pi / 4)
    want = "large" if edge * mm_per_px > (38.0 + 25.0) / 2 else "small"
    return [float(np.hypot(u - centre[0], v - centre[1]) < 1.0),
            float(err < np.radians(5) and -np.pi / 4 <= float(got_yaw) < np.pi / 4), float(size == want)]


def _segment_scenes(rng):
    # held-out simulator frames of other seeds (scenes with stacks and distractors, the arm over the board in some)
    from armlab.sim.detection_eval import SCENES

    return [[[str(SCENES[int(k)]), int(seed), bool(arm)]] for k, seed, arm in
            zip(rng.integers(0, len(SCENES), 3), rng.integers(5000, 9000, 3), (False, True, False))]


def _call_segment_frame(function, scene, seed, arm_over_board):
    """The student's segment_colours with their own tuned_hsv_ranges() on a held-out white-balanced frame: [at least
    95 % of the visible faces right, under 0.5 % of the board labelled] (1.0 / 0.0)."""
    from armlab.sim.detection_eval import balanced_frame, score_segmentation, sim_case

    case = sim_case(str(scene), int(seed), arm_over_board=bool(arm_over_board))
    rgb, board = balanced_frame(case)
    score = score_segmentation(case, function(rgb, function.__globals__["tuned_hsv_ranges"]()), board)
    return [float(score.face_accuracy >= 0.95), float(score.board_labelled < 0.005)]


def _grab_scenes(rng):
    # three blocks of random sizes and yaws at random spots the arm reaches top-down or nearly (150-340 mm from the
    # waist axis, in front of the base, 90 mm apart), and a free drop spot for each nearer the robot
    checks = []
    for _ in range(3):
        blocks, spots = [], []
        while len(blocks) < 3:
            r, h = rng.uniform(170, 340), rng.uniform(np.radians(25), np.radians(155))
            xy = [float(r * np.cos(h)), float(r * np.sin(h))]
            if all(np.hypot(xy[0] - b[2][0], xy[1] - b[2][1]) > 90 for b in blocks):
                blocks.append([["red", "green", "blue", "yellow"][len(blocks)], str(rng.choice(["large", "small"])),
                               xy, float(rng.uniform(-np.pi / 4, np.pi / 4))])
        for x in rng.permutation([-240.0, 0.0, 240.0]):
            spots.append([float(x + rng.uniform(-20, 20)), float(rng.uniform(-60, 40) if x else rng.uniform(190, 230)),
                          0.0])
        checks.append([[int(rng.integers(0, 1000)), blocks, spots]])
    return checks


def _call_move_path(function, seed, blocks, spots):
    """Per block of a fresh sim scene, clicked at its detected top: [grasped, landed within 3 mm of its spot] (1.0 /
    0.0) with the student's move_path through the kit's checked runners; a refused or failed plan scores 0 for it and
    the blocks after it."""
    from armlab import tasks
    from armlab.station import make_station
    from armlab.tasks.move_path import drop_with, grab_with

    station = make_station("sim", seed=int(seed), scene={"objects": [
        {"color": c, "size": s, "position_mm": xy, "yaw_rad": yaw} for c, s, xy, yaw in blocks]})
    seen = {b.color: b for b in tasks.look(station).blocks}
    out = []
    for (color, *_), spot in zip(blocks, spots, strict=True):
        truth = next(o for o in station.world.blocks if o.color == color)
        try:
            held = grab_with(station, seen[color], path=function) and truth.id in station.world.held
            drop_with(station, np.asarray(spot, float), 0.0, path=function)
            bottom = truth.position - [0.0, 0.0, truth.edge / 2]
            landed = not station.world.held and float(np.abs(bottom - spot).max()) < 3.0
        except Exception:           # refused, unreachable or broken: this block and the rest score 0
            break
        out += [float(held), float(landed)]
    return out + [0.0] * (2 * len(blocks) - len(out))


def _teach_sessions(rng):
    # the swap's poses turned a little about the waist and the wrist (clear of the board), other gripper sequences,
    # shorter and longer programs, other sim seeds
    from armlab.tasks.teach import swap_waypoints

    poses, _ = swap_waypoints()
    cases = []
    for n in (3, 5, len(poses)):
        pick = np.sort(rng.choice(len(poses), n, replace=False))
        q = np.asarray(poses)[pick] + rng.uniform(-0.05, 0.05, (n, 5)) * [1.0, 0.0, 0.0, 0.0, 1.0]
        gripper = [str(g) for g in rng.choice(["open", "closed"], n)]
        cases.append([[int(rng.integers(0, 1000)), q.tolist(), gripper]])
    return cases


def _call_teach(function, seed, poses, gripper):
    """teach_program on a fresh sim arm: the recorded q (N x 5), the gripper states (1 closed) and the torque."""
    from armlab.station import make_station

    station = make_station("sim", seed=int(seed), scene="swap")
    program = function(station.arm, np.asarray(poses, float), list(gripper), name="hidden")
    return np.concatenate([np.asarray(program.q, float).ravel(), [g == "closed" for g in program.gripper],
                           [float(station.arm.torque_enabled)]])


def _replays(rng):
    # random programs (some segments not moving at all, some long) at slow and fast speeds
    from armlab.robot import rx200

    robot = rx200()
    cases = []
    for speed in (0.3, 1.0, 2.5, 6.0):
        n = int(rng.integers(3, 9))
        q = rng.uniform(robot.lower * 0.8, robot.upper * 0.8, (n, 5))
        q[1] = q[0]                                                    # a waypoint that does not move
        cases.append([[q.tolist(), float(speed * rng.uniform(0.9, 1.1))]])
    return cases


def _call_scaled_durations(function, q, speed):
    from armlab.robot import rx200
    from armlab.tasks.teach import TeachProgram

    function.__globals__["robot"] = rx200()       # the notebook's `robot` (its cell ran definitions only)
    q = np.asarray(q, float)
    return function(TeachProgram(q, ("open",) * len(q), "hidden"), float(speed))


def _sort_stack_seeds(rng):
    # sort 'n stack at levels 2 and 3, two fresh seeds each: one hidden check per run
    return [[[level, int(seed)]] for level in (2, 3) for seed in rng.integers(100, 10_000, 2)]


def _call_sort_stack(function, level, seed):
    """The student's strategy class, SortStackStrategy(level), runs the event on a fresh seeded station: [full marks,
    within the time limit] (1.0 / 0.0), scored from the simulator's ground truth."""
    from armlab.tasks.events import event_station, run_event

    station = event_station("sort_stack", int(level), seed=int(seed))
    result = run_event(station, "sort_stack", int(level), strategy=function(int(level)), record=False)
    return [float(result.score.full_marks), float(result.within_limit)]


SPECS: dict[str, HiddenSpec | tuple[HiddenSpec, ...]] = {
    "calib.project_pinhole": HiddenSpec("project_pinhole", _projections, atol=1e-6),
    "calib.pixel_to_world_pinhole": HiddenSpec("pixel_to_world_pinhole", _back_projections, atol=1e-6),
    "fk.dh_transform": HiddenSpec("dh_transform", lambda rng: [[p] for p in _dh_params(rng, 4)]),
    "fk.fk_from_table": HiddenSpec("fk_from_table", _fk_tables, atol=1e-6),
    "fk.dh_link_transform": HiddenSpec("armlab.kinematics.dh_link_transform", _link_batches),
    "ik.planar_ik": HiddenSpec("planar_ik", _planar_targets, atol=1e-6),
    "detect.face": HiddenSpec("face_geometry", _square_faces, atol=0, adapter="_call_face", prelude="definitions"),
    "calib.tag_homography": HiddenSpec("armlab.calibration.homography.dlt_homography", _homographies, atol=1e-7),
    "ik.candidates": HiddenSpec("armlab.kinematics.ik", _ik_all_solutions, atol=1e-6),
    "calib.tag_extrinsics": HiddenSpec("armlab.calibration.extrinsics.pose_from_corners", _tag_views, atol=1e-6,
                                       adapter="_call_initial_pose"),
    "calib.depth_plane": HiddenSpec("armlab.calibration.depth.fit_depth_correction", _depth_scenes, atol=1e-6,
                                    adapter="_call_depth_plane"),
    "detect.classify": HiddenSpec("armlab.detection.color.ColorModel", _colour_models, atol=1e-9,
                                  adapter="_call_classify"),
    "detect.segment": HiddenSpec("segment_colours", _segment_scenes, atol=0, adapter="_call_segment_frame",
                                 prelude="definitions"),
    "grab.move_path": HiddenSpec("armlab.tasks.move_path.move_path", _grab_scenes, atol=0,
                                 adapter="_call_move_path"),
    "teach.record": HiddenSpec("teach_program", _teach_sessions, atol=1e-9, adapter="_call_teach",
                               prelude="definitions"),
    "teach.time_scaled": HiddenSpec("scaled_durations", _replays, atol=1e-9, adapter="_call_scaled_durations",
                                    prelude="definitions"),
    "events.sort_stack": HiddenSpec("SortStackStrategy", _sort_stack_seeds, atol=0, adapter="_call_sort_stack",
                                    prelude="definitions"),
}

# Calls that would do an exercise for the student: a name matches any reference to it in the region (a call, an
# attribute, an import, a string naming it), its last dotted part compared. FORBIDDEN_EVERYWHERE applies to every
# exercise: the kit's reference paths (armlab.exercises.references) are never a solution.
FORBIDDEN_EVERYWHERE: tuple[str, ...] = ("armlab.exercises.references", "with_reference")
FORBIDDEN: dict[str, tuple[str, ...]] = {
    "calib.project_pinhole": ("cv2.projectPoints", "Camera.project", "Camera.project_camera"),
    "calib.pixel_to_world_pinhole": ("Camera.pixel_to_world", "Camera.pixel_to_camera", "Camera.camera_to_world"),
    "calib.tag_homography": ("cv2.findHomography", "cv2.getPerspectiveTransform"),
    "calib.tag_extrinsics": ("cv2.solvePnP", "cv2.solvePnPRansac", "cv2.solvePnPGeneric", "cv2.solvePnPRefineLM",
                             "cv2.decomposeHomographyMat", "extrinsics._opencv_pose", "cv2.findHomography"),
    "calib.depth_plane": ("scipy.optimize.least_squares", "depth._robust_plane", "cv2.fitLine"),
    "fk.dh_transform": ("kinematics.dh_link_transform", "kinematics._dh_by_elementary_motions", "kinematics.fk_pox",
                        "kinematics.fk", "kinematics.fk_dh", "kinematics.dh_frames"),
    "fk.fk_from_table": ("kinematics.fk_pox", "kinematics.fk", "kinematics.fk_dh", "kinematics.dh_frames",
                         "kinematics.link_frames", "kinematics.dh_link_transform"),
    "fk.dh_link_transform": ("kinematics._dh_by_elementary_motions", "kinematics.fk_pox"),
    "ik.planar_ik": ("kinematics.ik", "kinematics.ik_batch", "kinematics.ik_numerical", "IKinSpace", "IKinBody",
                     "scipy.optimize.least_squares", "scipy.optimize.fsolve", "scipy.optimize.minimize"),
    "ik.candidates": ("kinematics._numerical_candidates", "kinematics.ik_numerical", "IKinSpace", "IKinBody",
                      "scipy.optimize.least_squares", "scipy.optimize.fsolve", "scipy.optimize.minimize"),
    "detect.face": ("scipy.ndimage.center_of_mass", "transforms.wrap_quarter", "wrap_quarter", "detect_objects",
                    "detect_blocks"),
    "detect.segment": ("ColorModel", "segment_by_colour_model", "default_color_model", "hsv_table_classify"),
    "detect.classify": ("ColorModel._nearest_mean",),
    "grab.move_path": ("planning.plan_pick", "planning.plan_place", "planning.plan_pick_place", "choose_grasp",
                       "kit_move_path", "grasp_height", "place_tool_height", "default_grasp_depth", "tasks.pick",
                       "tasks.place", "handling"),
    "teach.record": ("teach.load_teach", "kit_recording", "data_path"),
    "teach.time_scaled": ("TeachProgram.to_plan",),
    "events.sort_stack": ("SortStack", "make_strategy", "sort_stack.EVENT"),
}


def specs_of(exercise_id: str) -> tuple[HiddenSpec, ...]:
    """The exercise's hidden specs (none: an empty tuple)."""
    spec = SPECS.get(exercise_id, ())
    return spec if isinstance(spec, tuple) else (spec,)


@functools.cache
def cases_of(exercise_id: str) -> list[list[list[list]]] | None:
    """Per spec of the exercise, its hidden checks (each a list of argument lists), or None when it has none (drawn
    once per process; do not modify)."""
    specs = specs_of(exercise_id)
    if not specs:
        return None
    rng = np.random.default_rng([SEED, sum(map(ord, exercise_id))])
    return [json.loads(json.dumps(spec.cases(rng), default=float)) for spec in specs]


def compare(spec: HiddenSpec, student: list[dict], expected: list[dict], sizes: list[int], first: int = 1
            ) -> list[tuple[bool, str]]:
    """Per hidden check of `spec` (`sizes` calls each, numbered from `first`): passed, and a message naming the
    first call that differs."""
    out, k = [], 0
    for i, n in enumerate(sizes, start=first):
        message = ""
        for j in range(k, k + n):
            got, want = student[j] if j < len(student) else {"error": "no result"}, expected[j]
            if "error" in got:
                message = f"hidden check {i}, call {j - k + 1}: raised {got['error']}"
                break
            try:
                a = np.asarray(got["value"], dtype=float)
                b = np.asarray(want["value"], dtype=float)
                close = np.isclose(a, b, rtol=0, atol=spec.atol, equal_nan=True) if a.shape == b.shape else None
                same = close is not None and (close.all() if spec.agree >= 1 else close.mean() >= spec.agree)
            except (ValueError, TypeError):
                same = False
            if not same:
                message = f"hidden check {i}, call {j - k + 1}: the result differs from the expected value"
                if spec.agree < 1:
                    message += f" (fewer than {spec.agree:.0%} of it agrees)"
                break
        out.append((not message, message))
        k += n
    return out
