"""armlab.detection against simulated ground truth: positions, yaw, colour, size, stacks, distractors, the arm, bad
input; and its parts (height map, stack levels, colour model files, the lab's HSV table, scoring)."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from armlab import make_station
from armlab.blocks import LAB_RGB
from armlab.calibration import board_depth, fit_depth_correction
from armlab.detection import (
    ColorModel,
    DetectionSettings,
    default_color_model,
    detect_blocks,
    detect_objects,
    edges,
    height_from_depth,
    hsv_table_classify,
    stack_levels,
)
from armlab.detection.colour_region import _fill_dropouts
from armlab.detection.detect import _planes_and_hints
from armlab.detection.heightmap import pixels_to_plane
from armlab.detection.masks import arm_mask
from armlab.detection.stacks import stack_heights
from armlab.sim.detection_eval import DetectionScore, corrected_depth, score_frame, sim_case, truth_faces, yaw_error
from armlab.sim.realism import CameraRealism
from armlab.sim.render import render_exact
from armlab.tasks import perception


@pytest.fixture(scope="module")
def ideal():
    """An exact frame (no noise, no lens error) of six scattered blocks."""
    station = make_station("sim", seed=11, scene="random", realism="ideal")
    frame = station.camera.capture()
    return station, frame


@pytest.fixture(scope="module", params=[("stacks", 201, False), ("line_up_3", 202, True), ("sort_stack_3", 203, True),
                                        ("random", 204, True)])
def case(request):
    return sim_case(*request.param)


def test_exact_frame_gives_every_block_to_a_fraction_of_a_millimetre(ideal):
    station, frame = ideal
    cam = station.camera.truth
    found = detect_blocks(frame.rgb, frame.depth, cam, station.arm.joint_positions())
    truth = station.world.blocks
    assert len(found) == len(truth) == 6
    for t in truth:
        top = np.array([t.position[0], t.position[1], t.top_z])
        b = min(found, key=lambda b: np.linalg.norm(b.position - top))
        assert np.linalg.norm(b.position - top) < 1.0
        assert yaw_error(b.yaw, t.yaw) < np.radians(EXACT_YAW_MAX_DEG)
        assert (b.color, b.size, b.levels) == (t.color, t.size, 1)
        assert -np.pi / 4 <= b.yaw < np.pi / 4
        assert np.allclose(b.pixel, cam.project(b.position[None])[0])


# An exact frame has no blur: a side is a hard staircase of whole pixels, and a small block's side (about 22 px) leans
# 2.6 deg per pixel; its fitted yaw can be a degree off whatever the detector does (measured over 180 blocks of seeds
# 11-40: the worst is 1.30 deg, the mean 0.22). Eight frames hold the mean and the worst to those figures' bounds.
EXACT_YAW_MAX_DEG = 1.5


def test_exact_frames_give_yaw_and_position_to_the_pixel_grid_limit():
    """Eight exact frames of six scattered blocks (48 blocks): yaw error mean < 0.3 deg and every one below
    EXACT_YAW_MAX_DEG; position error (top centre) mean < 0.1 mm and every one below 0.5 mm. (The renderer and
    detector before faces were filled by pixel centre and sides taken from edge pairs read 0.32 / 2.0 deg and
    0.13 / 0.57 mm on these frames.)"""
    yaw, pos = [], []
    for seed in range(11, 19):
        station = make_station("sim", seed=seed, scene="random", realism="ideal")
        frame = station.camera.capture()
        found = detect_blocks(frame.rgb, frame.depth, station.camera.truth, station.arm.joint_positions())
        assert len(found) == len(station.world.blocks) == 6
        for t in station.world.blocks:
            top = np.array([t.position[0], t.position[1], t.top_z])
            b = min(found, key=lambda b: np.linalg.norm(b.position - top))
            pos.append(np.linalg.norm(b.position - top))
            yaw.append(np.degrees(yaw_error(b.yaw, t.yaw)))
    yaw, pos = np.array(yaw), np.array(pos)
    print(f"yaw error mean {yaw.mean():.3f} max {yaw.max():.3f} deg; position mean {pos.mean():.3f} max "
          f"{pos.max():.3f} mm")
    assert yaw.mean() < 0.3 and yaw.max() < EXACT_YAW_MAX_DEG
    assert pos.mean() < 0.1 and pos.max() < 0.5


@pytest.mark.exercise("calib.tag_extrinsics", "calib.depth_plane", "detect.classify")
def test_realistic_frames_meet_the_goals(case):
    found = detect_objects(case.rgb, corrected_depth(case), case.camera, case.arm_q)
    score = DetectionScore()
    score.add(score_frame(found, case.truth))
    m = score.metrics()
    assert m["blocks"] >= 3
    assert m["recall"] == 1.0 and m["precision"] == 1.0, (case.scene, case.seed, m)
    assert m["color_acc"] == 1.0 and m["size_acc"] == 1.0 and m["levels_acc"] == 1.0
    assert m["pos_mean_mm"] < 2.0 and m["pos_max_mm"] < 5.0
    assert m["yaw_max_deg"] < 2.0


@pytest.mark.exercise("calib.tag_extrinsics", "calib.depth_plane", "detect.classify")
def test_stacks_report_their_height_and_not_the_hidden_faces():
    case = sim_case("stacks", 201)
    found = detect_blocks(case.rgb, corrected_depth(case), case.camera, case.arm_q)
    tops = [t for t in case.truth if t.visible > 0.9]
    hidden = [t for t in case.truth if t.visible == 0.0]
    assert hidden and max(t.levels for t in tops) >= 2
    for t in tops:
        b = min(found, key=lambda b: np.linalg.norm(b.position - t.centre))
        assert np.linalg.norm(b.position - t.centre) < 3.0 and b.levels == t.levels
    for t in hidden:   # nothing reported at a covered face's height
        assert all(np.linalg.norm(b.position - t.centre) > 10.0 for b in found)


def _small_on_large(x, y, dx, dy, yaw_large, yaw_small, seed=0):
    """A station whose board holds one small yellow cube standing on a large blue one, the small one's centre (dx, dy)
    mm off the large one's; and the objects the detector reports from its (realistic) frame."""
    scene = {"objects": [
        {"color": "blue", "size": "large", "position_mm": [x, y], "yaw_rad": yaw_large},
        {"color": "yellow", "size": "small", "position_mm": [x + dx, y + dy], "yaw_rad": yaw_small}]}
    from armlab.calibration import fit_depth_correction
    from armlab.detection.masks import arm_mask

    station = make_station("sim", seed=seed, scene=scene)
    frame = station.camera.capture()
    cam, q = station.camera.truth, station.arm.joint_positions()
    depth = fit_depth_correction(frame.depth, cam, exclude=arm_mask(cam, q)).apply(frame.depth)
    return station, detect_objects(frame.rgb, depth, cam, q)


@pytest.mark.parametrize("x, y, dx, dy, yaw_large, yaw_small", [
    (85.7, 232.7, 0.0, 0.0, 0.305, 0.305),       # the demo's first look (sort_stack level 3, seed 0): a ring
    (0.0, 250.0, 5.0, -4.0, 0.0, 0.0),           # off-centre: an L of the large face shows
    (0.0, 250.0, 3.0, 6.0, 0.35, -0.5),
    (-150.0, 180.0, 5.0, -4.0, 0.0, 0.0),
    (-150.0, 180.0, -6.0, 3.0, 0.35, -0.5),
])
def test_a_large_block_under_a_small_one_is_a_cube(x, y, dx, dy, yaw_large, yaw_small):
    """The visible part of a large block's top face around a small block standing on it (a ring or an L) is a cube
    face: its colour, size, stack level, the centre of the whole square and its yaw. (The small block's side faces
    rise from the face: they hide its outline, they are not its edge; a ring too thin for the colour core's erosion
    takes its colour from the seed's median, not from the mixed-in neighbours.)"""
    station, found = _small_on_large(x, y, dx, dy, yaw_large, yaw_small)
    large, small = sorted(station.world.blocks, key=lambda b: -b.edge)
    for t in (large, small):
        top = np.array([t.position[0], t.position[1], t.top_z])
        b = min(found, key=lambda b: np.linalg.norm(b.position[:2] - top[:2]) + abs(b.position[2] - top[2]))
        assert (b.shape, b.color, b.size) == ("cube", t.color, t.size), (t.color, b)
        assert b.levels == (1 if t is large else 2)
        assert np.linalg.norm(b.position[:2] - top[:2]) < 2.0 and abs(b.position[2] - top[2]) < 3.0, (b.position, top)
        assert np.degrees(yaw_error(b.yaw, t.yaw)) < 2.0


def test_distractors_are_reported_as_distractors():
    case = sim_case("line_up_3", 202)
    found = detect_objects(case.rgb, corrected_depth(case), case.camera, case.arm_q)
    pairs = score_frame(found, case.truth).pairs
    shapes = [(d.shape, t.obj.shape) for d, t in pairs if t.visible > 0.5]
    distractors = [s for s in shapes if s[1] != "cube"]
    assert len(distractors) >= 2
    assert all((d == "cube") == (t == "cube") for d, t in shapes)


def test_thin_distractors_are_found_and_not_called_blocks():
    # an arch's legs are 3-4 samples wide at half resolution: a 5x5 height median erased this one entirely
    case = sim_case("line_up_3", 124)
    found = detect_objects(case.rgb, corrected_depth(case), case.camera, case.arm_q)
    score = score_frame(found, case.truth)
    arches = [t for t in case.truth if t.obj.shape == "arch" and t.visible > 0.9]
    assert arches and not [t for t in score.missed if not t.is_block]
    assert all(d.shape == "distractor" for d, t in score.pairs if not t.is_block)


def test_yaw_refinement_recovers_a_turned_start():
    """The edge refinement alone turns squares started 4 deg off back onto the blocks (exact frame): to the yaws the
    detector finds from its own start (within 0.2 deg), which are within EXACT_YAW_MAX_DEG of the truth. (An exact
    frame has no blur: its edges are hard one-pixel staircases, and a small block's sides can lean up to about a
    degree from the truth whatever the start.)"""
    from armlab.detection import detect as D

    station = make_station("sim", seed=11, scene="random", realism="ideal")
    frame = station.camera.capture()
    cam = station.camera.truth
    seen = []
    real = D.refine_yaws

    def spy(camera, faces, iterations=3):
        seen.extend(faces)
        return real(camera, faces, iterations)

    D.refine_yaws = spy
    try:
        found = D.detect_blocks(frame.rgb, frame.depth, cam, station.arm.joint_positions())
    finally:
        D.refine_yaws = real
    assert len(seen) == len(found) == 6
    truth = [min(station.world.blocks, key=lambda t: np.hypot(*(t.position[:2] - m.centre))) for m in seen]
    assert all(np.hypot(*(t.position[:2] - m.centre)) < 2.0 for t, m in zip(truth, seen, strict=True))
    own = [min(found, key=lambda b: np.hypot(*(b.position[:2] - m.centre))).yaw for m in seen]
    for turn in (4.0, -4.0):
        for m, t in zip(seen, truth, strict=True):
            m.theta = t.yaw + np.radians(turn)
        yaws = real(cam, seen, iterations=3)
        assert max(np.degrees(yaw_error(y, o)) for y, o in zip(yaws, own, strict=True)) < 0.2
        assert max(np.degrees(yaw_error(y, t.yaw)) for y, t in zip(yaws, truth, strict=True)) < EXACT_YAW_MAX_DEG
    assert len(real(cam, [])) == 0


@pytest.mark.parametrize("spec", [("line_up_2", 105, True), ("line_up_3", 117, True)])
def test_yaw_of_small_blocks_whose_sides_render_nearly_straight(spec):
    """Small blocks turned about a degree off the image axes: their sides render as straight lines with at most one
    pixel step, so an edge's fit residuals understate its slope's error. With the pixel grid's variance added (and
    sides beside a visible side face counting less) these blocks' yaws stay within 1.5 deg (2.1 and 2.0 deg before,
    when the straight-looking sides outweighed the rest)."""
    case = sim_case(*spec)
    found = detect_objects(case.rgb, corrected_depth(case), case.camera, case.arm_q)
    pairs = [(d, t) for d, t in score_frame(found, case.truth).pairs
             if d.shape == "cube" and t.is_block and t.visible >= 0.5]
    assert sum(t.obj.size == "small" for _, t in pairs) >= 2
    worst = max(np.degrees(yaw_error(d.yaw, t.obj.yaw)) for d, t in pairs)
    assert worst < 1.5, (spec, worst)


def test_plane_homographies_of_many_faces_match_the_lens_model(ideal):
    from armlab.detection.edges import plane_homographies

    station, _ = ideal
    cam = station.camera.truth
    centres, heights = np.array([[0.0, 150.0], [-320.0, -100.0], [300.0, 280.0]]), np.array([25.0, 38.0, 114.0])
    many = plane_homographies(cam, centres, heights, np.array([25.0, 25.0, 25.0]))
    assert many.shape == (3, 3, 3)
    for H, centre, z in zip(many, centres, heights, strict=True):     # each face's own plane, all from one call
        xy = np.asarray(centre) + np.random.default_rng(0).uniform(-25, 25, (50, 2))
        uv = cam.project(np.column_stack([xy, np.full(50, z)]))
        h = np.column_stack([xy, np.ones(50)]) @ H.T
        assert np.abs(h[:, :2] / h[:, 2:] - uv).max() < 0.02


def test_arm_mask_covers_the_finger_tips():
    from armlab.detection import arm_mask
    from armlab.gripper_geometry import GRIPPER
    from armlab.kinematics import joint_positions

    station = make_station("sim", seed=3, scene="empty", realism="ideal")
    cam = station.camera.truth
    q = np.array([0.3, 0.2, 0.3, 1.0, 0.0])
    points = joint_positions(q)
    approach = (points[-1] - points[-2]) / np.linalg.norm(points[-1] - points[-2])
    tip = points[-1] + GRIPPER.fingertip_mm * approach
    u, v = np.rint(cam.project(tip[None])[0]).astype(int)
    assert arm_mask(cam, q)[v, u]
    # the mask follows the arm: a different pose covers different pixels
    assert (arm_mask(cam, q) != arm_mask(cam, q + [0.6, 0, 0, 0, 0])).sum() > 1000


@pytest.mark.exercise("calib.tag_extrinsics", "calib.depth_plane", "detect.classify")
def test_arm_over_the_board_is_not_a_block():
    case = sim_case("random", 204, arm_over_board=True)
    found = detect_objects(case.rgb, corrected_depth(case), case.camera, case.arm_q)
    score = score_frame(found, case.truth)
    assert not score.extra and not score.missed
    # without the arm's joint angles the black arm itself is taken for objects
    unmasked = detect_objects(case.rgb, corrected_depth(case), case.camera, None)
    assert len(score_frame(unmasked, case.truth).extra) >= 1


def test_settings_change_the_result(ideal):
    station, frame = ideal
    cam = station.camera.truth
    everything = detect_blocks(frame.rgb, frame.depth, cam)
    only_large = detect_blocks(frame.rgb, frame.depth, cam, settings=DetectionSettings(min_height=30.0))
    assert {b.size for b in only_large} == {"large"}
    assert len(only_large) == sum(b.size == "large" for b in everything) < len(everything)
    full_res = detect_blocks(frame.rgb, frame.depth, cam, settings=DetectionSettings(step=1))
    assert len(full_res) == len(everything)


# -- bad input --------------------------------------------------------------------------------------------------

def test_bad_input_raises_clear_errors(ideal):
    station, frame = ideal
    cam = station.camera.truth
    with pytest.raises(ValueError, match="uint8"):
        detect_blocks(frame.rgb.astype(float), frame.depth, cam)
    with pytest.raises(ValueError, match="shape"):
        detect_blocks(frame.rgb[..., 0], frame.depth, cam)
    with pytest.raises(ValueError, match="float"):
        detect_blocks(frame.rgb, frame.depth.astype(np.uint16), cam)
    with pytest.raises(ValueError, match="align depth"):
        detect_blocks(frame.rgb, frame.depth[:-1], cam)
    with pytest.raises(ValueError, match="camera is 1280x720"):
        detect_blocks(frame.rgb[:360, :640], frame.depth[:360, :640], cam)
    with pytest.raises(ValueError, match="shape"):
        detect_blocks(np.zeros((0, 0, 3), np.uint8), np.zeros((0, 0), np.float32), cam)
    with pytest.raises(ValueError, match="arm_q"):
        detect_blocks(frame.rgb, frame.depth, cam, arm_q=[0.0, 0.0])
    with pytest.raises(ValueError, match="step"):
        DetectionSettings(step=0)


def test_empty_or_flat_depth_gives_no_blocks(ideal):
    station, frame = ideal
    cam = station.camera.truth
    assert detect_blocks(frame.rgb, np.full(frame.depth.shape, np.nan, np.float32), cam) == []
    flat, _ = board_depth(cam)
    assert detect_blocks(frame.rgb, flat.astype(np.float32), cam) == []
    assert detect_blocks(np.zeros_like(frame.rgb), frame.depth, cam) is not None   # a black image does not crash


# -- parts ----------------------------------------------------------------------------------------------------

def test_height_map_and_plane_rays_agree_with_the_camera(ideal):
    station, _ = ideal
    cam = station.camera.truth
    depth, on_board = board_depth(cam)
    h = height_from_depth(depth.astype(np.float32), cam)
    assert np.nanmax(np.abs(h[on_board])) < 0.01
    assert height_from_depth(depth.astype(np.float32), cam, step=2).shape == (360, 640)
    uv = np.array([[0, 0], [640, 360], [1279, 719], [100, 600]])
    assert np.allclose(pixels_to_plane(cam, uv, 38.0), cam.pixel_to_plane(uv.astype(float), 38.0), atol=1e-3)


def test_one_plane_per_pixel_is_each_pixel_on_its_own_plane(ideal):
    """pixels_to_plane with a plane per pixel (all faces' outlines in one call) gives each pixel exactly what its own
    plane's call gives."""
    cam = ideal[0].camera.truth
    uv = np.array([[0, 0], [640, 360], [1279, 719], [100, 600], [33, 700]])
    z = np.array([0.0, 25.0, 38.0, 101.0, -3.5])
    together = pixels_to_plane(cam, uv, z)
    assert np.array_equal(together, np.array([pixels_to_plane(cam, uv[i:i + 1], z[i])[0] for i in range(len(uv))]))


def test_planes_and_hints_of_many_faces_are_those_of_each_face():
    """The faces' planes and edge hints in one pass equal the rule face by face: the nearest stack height, and the
    size whose stacks reach the face's height best unless both reach it within 1.5 mm."""
    settings = DetectionSettings()
    heights = stack_heights(settings.max_levels)
    edges = (25.0, 38.0)
    measured = np.array([24.1, 25.0, 37.2, 38.9, 49.3, 63.0, 75.8, 76.0, 88.4, 101.2, 114.0, 12.6, 31.5])
    planes, hints = _planes_and_hints(measured, settings)
    for h, z, hint in zip(measured, planes, hints, strict=True):
        assert z == heights[np.argmin(np.abs(heights - h))]
        misfit = [min(abs(h - e - s) for s in stack_heights(settings.max_levels, include_zero=True)) for e in edges]
        expected = None if max(misfit) - min(misfit) < 1.5 else edges[int(np.argmin(misfit))]
        assert hint == expected, (h, hint, expected)
    assert hints[measured.tolist().index(76.0)] is None            # 3 x 25 and 2 x 38: the outline decides


def test_dropouts_take_the_height_of_a_lower_face_of_the_same_colour_only():
    """A patch: the face (100 mm) on the left, a band without depth returns, then a lower surface (75 mm). The band's
    pixels take the face's height, unless the lower surface has the face's colour: then those nearer to it take its
    height (its ring would otherwise join the face across the band)."""
    height = np.full((5, 12), 100.0, np.float32)
    height[:, 5:8] = np.nan
    height[:, 8:] = 75.0
    no_return = np.isnan(height)
    for same_colour, expected in ((False, [100, 100, 100]), (True, [100, 100, 75])):
        coloured = np.ones(height.shape, bool) if same_colour else np.arange(12)[None, :].repeat(5, 0) < 8
        filled = height.copy()
        _fill_dropouts(filled, no_return, coloured, 100.0)
        assert not np.isnan(filled).any()
        assert filled[2, 5:8].tolist() == expected, (same_colour, filled[2].tolist())
        assert np.array_equal(filled[~no_return], height[~no_return])


def test_a_small_block_on_a_large_one_of_its_colour_is_a_small_cube():
    """Seed 117's line-up level 3: a small green block on a large green one, next to the arm. The dropout band at the
    small block's edge used to join the large one's ring to its face (29 mm, a distractor)."""
    case = sim_case("line_up_3", 117, True)
    found = detect_objects(case.rgb, corrected_depth(case, case.camera), case.camera, case.arm_q)
    truth = next(t for t in case.truth if t.obj.color == "green" and t.obj.size == "small")
    block = min(found, key=lambda b: np.linalg.norm(b.position - truth.centre))
    assert np.linalg.norm(block.position - truth.centre) < 3.0
    assert (block.shape, block.size, block.color, block.levels) == ("cube", "small", "green", 3), block
    assert abs(block.edge_mm - truth.obj.edge) < 3.0


def test_reduced_height_map_is_the_full_one_subsampled(ideal):
    station, frame = ideal
    cam = station.camera.truth
    full = height_from_depth(frame.depth, cam)
    for step in (2, 3):
        assert np.array_equal(height_from_depth(frame.depth, cam, step=step), full[::step, ::step], equal_nan=True)


def test_segment_faces_boxes_heights_and_valid_mask():
    from armlab.detection.segment import _median, segment_faces

    h = np.zeros((60, 80), np.float32)
    h[10:20, 5:15] = 25.0                       # a block
    h[30:50, 40:60] = 38.0                      # a larger block with a small one on it
    h[35:42, 45:52] = 63.0
    h[5:15, 60:70] = 25.0                       # a block outside the valid area
    h[0, 0] = np.nan
    valid = np.ones(h.shape, bool)
    valid[:, 58:] = False
    faces = segment_faces(h, valid, min_height_mm=10.0, min_face_pixels=20, median_px=3)
    got = sorted((f.bbox, round(f.height_mm, 3)) for f in faces)
    assert got == [((5, 10, 10, 10), 25.0), ((40, 30, 18, 20), 38.0), ((45, 35, 7, 7), 63.0)]
    assert segment_faces(np.zeros((20, 20), np.float32), np.ones((20, 20), bool)) == []
    rng = np.random.default_rng(3)
    for n in (1, 2, 7, 10):
        v = rng.normal(30, 2, n).astype(np.float32)
        assert _median(v) == float(np.median(v))


def test_board_white_balance_uses_the_bright_board_pixels():
    from armlab.detection.colour_region import board_white_balance

    rng = np.random.default_rng(5)
    rgb = np.empty((720, 1280, 3), np.uint8)
    rgb[:] = (200, 180, 150)
    dark = rng.random((720, 1280)) < 0.2          # grid lines: dark, outside the bright majority
    rgb[dark] = (40, 40, 40)
    height = np.zeros((360, 640), np.float32)
    height[:100] = 50.0                              # raised pixels are not board
    rgb[:200] = (0, 0, 255)
    gains = board_white_balance(rgb, height, np.ones((360, 640), bool), 2)
    assert np.allclose(gains * (200, 180, 150), np.mean((200, 180, 150)))
    assert np.array_equal(board_white_balance(rgb, np.full((360, 640), 50.0, np.float32), np.ones((360, 640), bool),
                                               2), np.ones(3))


@pytest.mark.parametrize("top, edge, levels", [(25, 25, 1), (38, 38, 1), (50, 25, 2), (63, 25, 2), (76, 38, 2),
                                               (75, 25, 3), (114, 38, 3), (88, 25, 3), (61.5, 25, 2)])
def test_stack_levels(top, edge, levels):
    assert stack_levels(top, edge) == levels


def test_colour_model_file_round_trip_and_validation(tmp_path):
    model = default_color_model()
    assert set(model.names) == set(LAB_RGB)
    path = tmp_path / "m.json"
    model.save(path, note="test")
    again = ColorModel.load(path)
    assert again.names == model.names and np.allclose(again.means, model.means)
    assert not list(tmp_path.glob("*.tmp"))
    raw = json.loads(path.read_text())
    for broken, match in [("{", "corrupt"), (json.dumps({**raw, "stds": [[0, 0, 0]] * 6}),
                                             r"stds\[\d\]\[\d\]: must be greater than 0"),
                          (json.dumps({**raw, "names": ["red"] * 6}), "names: .*non-unique"),
                          (json.dumps({**raw, "means": [[1, 2]] * 6}), r"means\[\d\]: has 2 values, expected 3"),
                          (json.dumps({**raw, "means": raw["means"][:5]}), r"means: must hold one row per name \(6\)"),
                          (json.dumps({"names": raw["names"]}), "means: missing")]:
        path.write_text(broken)
        with pytest.raises(ValueError, match=match):
            ColorModel.load(path)
    with pytest.raises(ValueError, match="not found"):
        ColorModel.load(tmp_path / "missing.json")


def test_reference_colours_classify_as_themselves():
    model = ColorModel.from_reference()
    names, margin = model.classify(np.array([LAB_RGB[c] for c in model.names]))
    assert names == list(model.names) and np.all(margin > 0)


def test_lab_hsv_table_misses_red_and_confuses_blue_with_violet():
    # the lab's own mean red (hue 0) is outside its red range (140-180); a hue of 115 is claimed by blue first
    assert hsv_table_classify([LAB_RGB["red"]]) == ["none"]
    violet_ish = np.array([[60, 40, 200]])            # OpenCV hue ~ 123: inside both blue and violet ranges
    assert hsv_table_classify(violet_ish) == ["blue"]
    assert hsv_table_classify([[200, 150, 30]]) == ["yellow"]


def test_scoring_matches_and_counts(ideal):
    station, frame = ideal
    cam = station.camera.truth
    _, exact = render_exact(cam, station.world.objects)
    truth = truth_faces(station.world.objects, cam, exact)
    assert all(t.visible > 0.95 for t in truth)
    found = detect_objects(frame.rgb, frame.depth, cam, station.arm.joint_positions())
    assert len(found) == 6
    score = score_frame(found[1:], truth)           # one detection left out: one miss, no extras
    assert len(score.pairs) == 5 and len(score.missed) == 1 and not score.extra
    assert yaw_error(np.pi / 4 - 0.01, -np.pi / 4 + 0.01) == pytest.approx(0.02)


def test_towers_taller_than_six_levels_need_max_levels():
    from armlab.detection.detect import stack_levels

    assert stack_levels(8 * 38.0, 38.0) == 6                       # the default caps the count
    assert stack_levels(8 * 38.0, 38.0, max_levels=13) == 8
    with pytest.raises(ValueError, match="max_levels"):
        DetectionSettings(max_levels=0)


# -- a strong colour cast ---------------------------------------------------------------------------------------------
ALL_COLOURS = {"objects": [{"color": c, "size": size, "position_mm": [-240.0 + 100.0 * i, y], "yaw_rad": s * 0.1 * i}
                           for i, c in enumerate(("red", "orange", "yellow", "green", "blue", "violet"))
                           for size, y, s in (("large", 330.0, 1), ("small", 200.0, -1))]}


@pytest.mark.parametrize("cast, seed", [((1.25, 1.0, 0.75), 0), ((0.75, 1.0, 1.25), 1), ((0.8, 1.25, 0.8), 2),
                                        ((1.0, 0.75, 1.0), 3)])
def test_every_colour_is_right_under_a_25_percent_colour_cast(cast, seed):
    # the simulator's white-balance knob at 25 % (its realistic spread is ~2-5 %): only the board's own white
    # balance keeps all 12 blocks right (switched off, gains = 1, about 2 in 12 come out wrong under each cast)
    station = make_station("sim", seed=seed, scene=ALL_COLOURS,
                           camera_realism=replace(CameraRealism.realistic(seed), white_balance=cast))
    frame = station.camera.capture()
    cam, q = station.camera.truth, station.arm.joint_positions()
    depth = fit_depth_correction(frame.depth, cam, exclude=arm_mask(cam, q)).apply(frame.depth)
    found = detect_blocks(frame.rgb, depth, cam, q)
    assert len(found) == 12
    wrong = []
    for t in station.world.blocks:
        b = min(found, key=lambda b: np.hypot(*(b.position[:2] - t.position[:2])))
        if (b.color, b.size) != (t.color, t.size):
            wrong.append(f"{t.size} {t.color} read as {b.size} {b.color}")
    assert not wrong, f"under the cast {cast}: " + "; ".join(wrong)
    gains = found[0].white_balance
    left = gains / gains[1] * np.divide(cast, cast[1])       # what remains of the cast after the gains: the printed
    assert np.allclose(left, 1.0, atol=0.07), left           # board's own slight warmth (~5 %), not the 25 %


def test_sub_pixel_sides_read_cubes_at_their_true_size():
    """The cubes' edges over four realistic frames (seeds 0-3, the faces wholly in view): the mean error within
    +-0.15 mm. The camera's blur (0.7 px) spreads each side's step over about four pixels; the old edge finder took
    the step's upper level 1.5 mm beyond where it starts to rise, still on the rise, which put the half level and the
    side inside the face: cubes read 0.6 mm small on these frames (more far from the image centre)."""
    errors = []
    for seed in range(4):
        case = sim_case("random", seed)
        pairs = score_frame(detect_blocks(case.rgb, corrected_depth(case), case.camera, case.arm_q), case.truth).pairs
        errors += [d.edge_mm - t.obj.edge for d, t in pairs if t.visible > 0.99]
    errors = np.array(errors)
    assert len(errors) >= 20
    assert abs(errors.mean()) < 0.15, f"cubes read {errors.mean():+.2f} mm (sd {errors.std():.2f}) off their size"
    assert np.abs(errors).max() < 1.0, errors


def test_a_side_face_is_not_read_as_a_second_block(monkeypatch):
    """Seed 2 seen through the camera a student calibrates (tasks.perception): the large yellow block far out on the
    board (y = -134 mm) shows a side face 19 mm deep to the camera, and a band of it within the plateau tolerance of
    22.7 mm passed as the top face of a small yellow block 16 mm beside it. Faces that are not level (their heights
    rise 2 mm per sample there, 4 times a top face) are left out. The band is also a face seen in part, hidden by the
    block's top, and such a face now goes on under what hides it (edges._seen_edge_is_low), onto the block itself:
    with both rules off (the old side rule, by which end of the free outline has more points) the phantom comes back."""
    station = make_station("sim", seed=2)
    calib = perception.calibrate_camera(station)
    frame = station.camera.capture()
    depth = calib.depth_correction.apply(frame.depth)
    q = station.arm.joint_positions()
    cam, arm = station.camera.truth, station.arm
    _, exact = render_exact(cam, station.world.objects, arm.q_true, arm.gripper_opening_mm, arm.gripper_geometry)
    truth = truth_faces(station.world.objects, cam, exact)
    found = detect_blocks(frame.rgb, depth, calib.camera, q)
    score = score_frame(found, truth)
    assert len(found) == len(station.world.blocks) == 6 and not score.extra and not score.missed, found
    monkeypatch.setattr(edges, "_seen_edge_is_low", lambda hidden, lo, hi, n_lo, n_hi: bool(n_lo >= n_hi))
    phantom = detect_blocks(frame.rgb, depth, calib.camera, q, settings=DetectionSettings(max_face_slope=1e3))
    extra = score_frame(phantom, truth).extra
    assert len(extra) == 1 and (extra[0].color, extra[0].size) == ("yellow", "small"), extra


def test_segment_faces_leaves_out_faces_that_are_not_level():
    """A level 20 x 20 sample face at 25 mm is a face; a 10-row band rising 3 mm per row through 25 mm (a side face
    seen obliquely) is not, unless max_slope_mm allows it."""
    from armlab.detection.segment import segment_faces

    h = np.zeros((60, 60), np.float32)
    h[5:25, 5:25] = 25.0
    h[35:45, 5:45] = 10.0 + 3.0 * np.arange(10, dtype=np.float32)[:, None]
    valid = np.ones(h.shape, bool)
    faces = segment_faces(h, valid, min_face_pixels=20, median_px=3)
    assert [f.bbox[:2] for f in faces] == [(5, 5)] and faces[0].height_mm == pytest.approx(25.0)
    steep = segment_faces(h, valid, min_face_pixels=20, median_px=3, max_slope_mm=5.0)
    assert len(steep) == 2
