"""The simulated RGB-D camera against geometry: board depth, block tops, occlusion by the arm, AprilTags, realism."""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from armlab.blocks import LAB_RGB, ObjectState
from armlab.calibration.tags import pupil_detector
from armlab.camera import Camera
from armlab.gripper_geometry import GRIPPER
from armlab.kinematics import joint_positions
from armlab.lab import lab_config
from armlab.sim.board_texture import BOARD_RGB
from armlab.sim.camera import CameraRealism, SimCamera, true_camera
from armlab.sim.faces import ARM_RGB, shade
from armlab.sim.render import render, render_exact

SLEEP = np.array([0.0, -1.80, 1.55, 0.8, 0.0])
# the realistic camera's geometry (intrinsics, distortion, mount error) without any image or depth noise
EXACT_DISTORTED = replace(CameraRealism.ideal(), **{k: getattr(CameraRealism(), k) for k in (
    "mount_offset_mm", "mount_rotvec_rad", "focal_scale", "principal_offset_px", "distortion")})


def cube(color, x, y, edge=38.0, z0=0.0, yaw=0.3, id=0):
    return ObjectState(color, "large" if edge > 30 else "small", edge, [x, y, z0 + edge / 2], yaw, id=id)


def stand_ins(objects=(), q=SLEEP, opening=40.0, time_s=1.5):
    world = SimpleNamespace(objects=list(objects), time_s=time_s)
    arm = SimpleNamespace(q_true=np.asarray(q, float), gripper_opening_mm=opening, gripper_geometry=GRIPPER)
    return world, arm


@pytest.fixture(scope="module", params=["ideal", "distorted"])
def camera(request) -> Camera:
    return true_camera(CameraRealism.ideal() if request.param == "ideal" else EXACT_DISTORTED)


def pixel_grid(camera, step=37, border=3):
    u, v = np.meshgrid(np.arange(border, camera.width - border, step), np.arange(border, camera.height - border, step))
    return np.column_stack([u.ravel(), v.ravel()]).astype(float)


def test_board_depth_is_the_plane_everywhere(camera):
    rgb, depth = render(camera, [])
    assert rgb.shape == (720, 1280, 3) and rgb.dtype == np.uint8
    assert depth.shape == (720, 1280) and depth.dtype == np.float32
    assert not np.isnan(depth).any()
    uv = pixel_grid(camera)
    expected = camera.depth_of(camera.pixel_to_plane(uv, 0.0))
    got = depth[uv[:, 1].astype(int), uv[:, 0].astype(int)]
    assert np.max(np.abs(got - expected)) < 0.02          # mm, over the whole image (~800-1100 mm)


def test_board_points_have_board_and_grid_colours(camera):
    lab = lab_config()
    rgb, _ = render(camera, [])
    cells = np.array([[x + 25, y + 25, 0] for x in (-400, -200, 0, 150, 300) for y in (-125, 75, 275, 375)], float)
    uv = np.rint(camera.project(cells)).astype(int)
    assert np.abs(rgb[uv[:, 1], uv[:, 0]].astype(int) - BOARD_RGB).max() <= 2
    crossings = lab.grid_points()[::7]
    tags = np.array(list(lab.tags.centres_mm.values()))
    crossings = crossings[np.min(np.linalg.norm(crossings[:, None, :2] - tags, axis=2), axis=1) > 30]  # not on a tag
    uv = np.rint(camera.project(crossings)).astype(int)
    inside = (uv[:, 0] >= 0) & (uv[:, 0] < 1280) & (uv[:, 1] >= 0) & (uv[:, 1] < 720)
    values = rgb[uv[inside, 1], uv[inside, 0]].mean(axis=1)
    assert np.all(values < np.mean(BOARD_RGB) - 40)        # the printed grid lines are dark


def test_block_tops_have_their_colour_and_depth(camera):
    objs = [cube("red", -200, 300, 38, id=1), cube("blue", 150, 50, 25, id=2), cube("yellow", 300, 350, 38, id=3),
            cube("green", 0, 200, 38, z0=38.0, id=4), cube("violet", 0, 200, 38, id=5)]   # green stacked on violet
    rgb, depth = render(camera, objs)
    for o in objs[:4]:
        top = np.array([[o.position[0], o.position[1], o.top_z]])
        u, v = np.rint(camera.project(top)[0]).astype(int)
        assert np.abs(rgb[v, u].astype(int) - LAB_RGB[o.color]).max() <= 1, o.color
        # depth at the pixel centre: the top plane seen through that pixel
        hit = camera.pixel_to_plane(np.array([[u, v]], float), o.top_z)
        assert depth[v, u] == pytest.approx(camera.depth_of(hit)[0], abs=0.02)
    # a side face is darker than the top (shaded by its angle to the light)
    assert shade(np.array([0.0, -1.0, 0.0])) < 0.8 < shade(np.array([0.0, 0.0, 1.0])) == pytest.approx(1.0)


def test_arm_occludes_a_block_behind_it(camera):
    q = np.array([0.4, 0.2, 0.3, 0.5, 0.0])
    P = joint_positions(q)
    mid = (P[3] + P[4]) / 2                                   # middle of the forearm, ~250 mm up
    ground = camera.pixel_to_plane(camera.project(mid[None]), 0.0)[0]
    block = cube("yellow", ground[0], ground[1], 38, yaw=0.0)
    u, v = np.rint(camera.project(mid[None])[0]).astype(int)
    rgb_free, depth_free = render(camera, [block])
    rgb_arm, depth_arm = render(camera, [block], q, 40.0, GRIPPER)
    assert np.abs(rgb_free[v, u].astype(int) - LAB_RGB["yellow"]).max() <= 1
    assert np.all(rgb_arm[v, u] <= max(ARM_RGB) + 5)           # the dark arm hides the yellow block
    assert depth_arm[v, u] < depth_free[v, u] - 150          # and it is nearer than the block's top
    assert depth_arm[v, u] == pytest.approx(camera.depth_of(mid[None])[0], abs=25)   # within the link's half width


def test_gripper_fingers_are_drawn_at_the_opening(camera):
    q = np.zeros(5)                                          # home: the tool horizontal, fingers seen from above
    from armlab.kinematics import fk
    T = fk(q)
    _, depth_open = render(camera, [], q, 62.0, GRIPPER)
    _, depth_shut = render(camera, [], q, 18.0, GRIPPER)
    for sign in (1, -1):
        tip = T[:3, 3] + T[:3, 1] * sign * (62.0 / 2 + 3.0) + T[:3, 0] * 6.0    # inside the open finger's pad
        u, v = np.rint(camera.project(tip[None])[0]).astype(int)
        assert depth_open[v, u] < depth_shut[v, u] - 50         # the finger is there only when opened that wide


def test_apriltags_detected_at_the_right_places():
    lab = lab_config()
    world, arm = stand_ins([cube("red", 0, 250, 38)])
    cam = SimCamera(world, arm, realism="realistic", seed=3)
    detector = pupil_detector("tag36h11", quad_decimate=2.0)   # raw pupil-apriltags (never one of our own: its
                                                             # __del__ crashes the interpreter now and then)
    errors = []
    for _ in range(3):
        frame = cam.capture()
        gray = np.ascontiguousarray(frame.rgb.mean(axis=2).astype(np.uint8))
        found = {d.tag_id: d.corners - 0.5 for d in detector.detect(gray) if d.hamming == 0}
        assert sorted(found) == [1, 2, 3, 4]
        for tag_id, corners in found.items():
            expected = cam.truth.project(lab.tags.corners_world(tag_id))
            errors.append(np.linalg.norm(corners - expected, axis=1).max())
    assert max(errors) < 1.0, errors


def test_sim_camera_contract():
    lab = lab_config()
    world, arm = stand_ins([cube("orange", 100, 100)], time_s=2.25)
    cam = SimCamera(world, arm)
    frame = cam.capture()
    assert frame.rgb.shape == (720, 1280, 3) and frame.rgb.dtype == np.uint8
    assert frame.depth.shape == (720, 1280) and frame.depth.dtype == np.float32
    assert frame.timestamp == 2.25
    assert np.array_equal(cam.K, lab.factory_K) and np.array_equal(cam.dist, lab.factory_dist)
    assert (cam.width, cam.height) == (1280, 720)
    rel = np.abs(np.diag(cam.truth.K)[:2] / np.diag(cam.K)[:2] - 1)
    assert np.all((rel > 0.005) & (rel < 0.025))           # true focal lengths 0.5-2.5 % off the factory values
    assert np.any(cam.truth.dist != 0)
    mount = np.linalg.norm(cam.truth.position - lab.camera_position_mm)
    assert 0 < mount < 20


def test_realistic_capture_is_deterministic_per_seed_and_frame():
    world, arm = stand_ins([cube("green", -50, 150)])
    a, b = SimCamera(world, arm, seed=7), SimCamera(world, arm, seed=7)
    fa = [a.capture() for _ in range(2)]
    fb = [b.capture() for _ in range(2)]
    for x, y in zip(fa, fb, strict=True):
        assert np.array_equal(x.rgb, y.rgb)
        assert np.array_equal(x.depth, y.depth, equal_nan=True)
    assert not np.array_equal(fa[0].rgb, fa[1].rgb)           # consecutive frames have fresh noise
    other = SimCamera(world, arm, seed=8).capture()
    assert not np.array_equal(other.rgb, fa[0].rgb)


def test_ideal_preset_has_no_noise():
    world, arm = stand_ins([cube("blue", 50, 300)])
    cam = SimCamera(world, arm, realism="ideal", seed=1)
    f1, f2 = cam.capture(), cam.capture()
    assert np.array_equal(f1.rgb, f2.rgb) and np.array_equal(f1.depth, f2.depth)
    assert not np.isnan(f1.depth).any()
    assert np.array_equal(cam.truth.K, cam.K) and not np.any(cam.truth.dist)
    # an untextured board cell is exactly the board colour, pixel for pixel
    uv = np.rint(cam.truth.project(np.array([[-400.0, 125.0, 0.0], [-350.0, 175.0, 0.0]]))).astype(int)
    patch = f1.rgb[uv[1, 1] + 3:uv[0, 1] - 3, uv[0, 0] + 3:uv[1, 0] - 3]
    assert patch.size > 300 and np.all(patch == BOARD_RGB)


def test_realistic_depth_noise_bias_and_dropouts():
    world, arm = stand_ins([cube("red", x, 200, 38, id=i) for i, x in enumerate((-300, -100, 100, 300))])
    realism = CameraRealism()
    cam = SimCamera(world, arm, realism=realism, seed=0)
    frames = [cam.capture() for _ in range(4)]
    truth = cam.truth
    uv = pixel_grid(truth, step=9, border=40)
    board = truth.pixel_to_plane(uv, 0.0)
    # board pixels well away from the blocks and the arm (found in the exact rendering)
    _, exact_depth = render(truth, world.objects, arm.q_true, arm.gripper_opening_mm, GRIPPER)
    plane = truth.depth_of(truth.pixel_to_plane(pixel_grid(truth, step=1, border=0), 0.0)).reshape(720, 1280)
    clear = cv2.erode((np.abs(exact_depth - plane) < 0.1).astype(np.uint8), np.ones((9, 9), np.uint8))
    keep = lab_config().on_board(board) & (clear[uv[:, 1].astype(int), uv[:, 0].astype(int)] > 0)
    uv, board = uv[keep], board[keep]
    iu, iv = uv[:, 0].astype(int), uv[:, 1].astype(int)
    exact = truth.depth_of(board)
    err = np.stack([f.depth[iv, iu] for f in frames]) - exact
    # planar bias: ~ b_u (u/W - 1/2) + b_v (v/H - 1/2) + b_0, about 20 mm across the image
    A = np.column_stack([iu / 1280 - 0.5, iv / 720 - 0.5, np.ones(len(iu))])
    mean_err = np.nanmean(err, axis=0)
    coef = np.linalg.lstsq(A, mean_err, rcond=None)[0]
    assert np.allclose(coef, realism.depth_bias_mm, atol=1.0)
    # noise: sigma 2.5 mm at 1 m, growing as Z^2 (bright board: no darkness factor)
    resid = (err - A @ coef) / (exact / 1000) ** 2
    assert np.nanstd(resid) == pytest.approx(realism.depth_noise_mm, rel=0.15)
    # dropouts: NaN around the blocks' edges, few elsewhere
    nan = np.isnan(frames[0].depth)
    assert 0.0005 < nan.mean() < 0.05
    assert np.isnan(err).mean() < 0.01


def test_bad_input_is_refused():
    world, arm = stand_ins()
    with pytest.raises(ValueError, match="realism"):
        SimCamera(world, arm, realism="cinematic")
    with pytest.raises(ValueError, match="seed"):
        SimCamera(world, arm, seed=1.5)
    with pytest.raises(ValueError, match="pixel_noise"):
        CameraRealism(pixel_noise=-1.0)
    with pytest.raises(ValueError, match="distortion"):
        CameraRealism(distortion=(0.1, 0.0))
    with pytest.raises(TypeError, match="Camera"):
        render("not a camera", [])
    with pytest.raises(ValueError, match="gripper_geometry"):
        render(true_camera(CameraRealism.ideal()), [], SLEEP)


@pytest.mark.parametrize("crowded", [False, True])
def test_partial_lens_update_matches_the_whole_image(crowded):
    from armlab.sim.raster import view_for
    from armlab.sim.render import board_canvas, draw_faces, scene_faces
    camera = true_camera(EXACT_DISTORTED)
    view = view_for(camera)
    if crowded:     # 30 blocks, some at the image border, and the arm reaching across: groups split into bands
        rng = np.random.default_rng(5)
        objs = [cube(("red", "blue", "green")[i % 3], rng.uniform(-560, 560), rng.uniform(-180, 500),
                     38.0 if i % 2 else 25.0, yaw=rng.uniform(0, 1.5), id=i) for i in range(30)]
        q = np.array([0.3, -0.2, 0.3, 0.9, 0.2])
    else:
        objs = [cube("red", -300, 100, id=1), cube("blue", 200, 380, 25, id=2)]
        q = SLEEP
    canvas = board_canvas(view).copy()
    draw_faces(view, canvas, scene_faces(objs, q, 40.0, GRIPPER))
    groups = view._dirty_groups(canvas.dirty)
    rects = view._dirty_runs(canvas.dirty)
    assert len(groups) > 0 and len(rects) == len(groups)
    assert sum((u1 - u0) * (v1 - v0) for u0, v0, u1, v1 in rects) < 0.5 * camera.width * camera.height
    part = view.finish(canvas)
    canvas.dirty = None                                     # unknown changes: the lens over the whole image
    whole = view.finish(canvas)
    assert np.array_equal(part[0], whole[0]) and np.array_equal(part[2], whole[2])
    assert np.array_equal(np.isnan(part[1]), np.isnan(whole[1]))
    assert np.nanmax(np.abs(part[1] - whole[1])) < 1e-3    # mm: float rounding of the remap only
    board_only = view.finish(board_canvas(view).copy())     # nothing drawn: the cached board image itself
    assert np.array_equal(board_only[0], view.finish(board_canvas(view))[0])


def test_noise_fields_are_independent_per_pixel_and_per_frame():
    from armlab.sim.sensor import normal_field, uniform_bytes
    a, sa = normal_field(np.random.default_rng(1), (720, 1280))
    b, sb = normal_field(np.random.default_rng(2), (720, 1280))
    a2, sa2 = normal_field(np.random.default_rng(1), (720, 1280))
    assert np.array_equal(a, a2) and sa == sa2                 # the same generator state gives the same field
    assert a.shape == (720, 1280) and a.dtype == np.float32 and abs(sa) == 1.0
    assert abs(a.mean()) < 0.01 and a.std() == pytest.approx(1.0, abs=0.01)
    assert abs(np.corrcoef(a[:, :-1].ravel(), a[:, 1:].ravel())[0, 1]) < 0.01      # neighbours uncorrelated
    assert abs(np.corrcoef(a.ravel(), b.ravel())[0, 1]) < 0.01                      # other frames uncorrelated
    u = uniform_bytes(np.random.default_rng(3), (720, 1280))
    assert u.dtype == np.uint8 and np.mean(u < 64) == pytest.approx(0.25, abs=0.005)
    with pytest.raises(ValueError, match="shape"):
        normal_field(np.random.default_rng(0), (720,))


def test_realistic_colour_noise_level_and_averaging_over_frames():
    realism = replace(CameraRealism(), flicker=0.0)
    world, arm = stand_ins([])
    cam = SimCamera(world, None, realism=realism, seed=4)
    frames = np.stack([cam.capture().rgb for _ in range(8)]).astype(float)
    patch = frames[:, 300:420, 500:700]                       # board pixels, mostly flat
    per_pixel = patch.std(axis=0, ddof=1)
    # per-pixel sigma over frames: the pixel noise (plus rounding to whole levels)
    assert np.median(per_pixel) == pytest.approx(np.hypot(realism.pixel_noise, 12 ** -0.5), rel=0.1)
    # the mean of 8 frames keeps 1/sqrt(8) of the noise: frames' noise is independent at each pixel
    mean8 = patch.mean(axis=0)
    mean_other = np.stack([cam.capture().rgb for _ in range(8)]).astype(float)[:, 300:420, 500:700].mean(axis=0)
    assert np.std(mean8 - mean_other) / np.sqrt(2) == pytest.approx(np.median(per_pixel) / np.sqrt(8), rel=0.15)


def test_face_sets_of_a_tilted_cube_and_the_arm():
    from armlab.sim.faces import arm_faces, objects_faces
    block = cube("green", 100, 200, 30.0, yaw=0.4)
    block.tilt = np.array([0.3, -0.2])
    faces = objects_faces([block])
    assert len(faces) == 6
    centroids = faces.vertices.mean(axis=1)
    out = np.einsum("ij,ij->i", centroids - block.position, faces.normals)
    assert np.allclose(out, 15.0)                              # every face 15 mm out along its own normal
    assert np.allclose(np.linalg.norm(faces.normals, axis=1), 1.0)
    assert np.allclose(np.linalg.norm(faces.vertices - block.position, axis=2), 15.0 * np.sqrt(3))   # the corners
    arm = arm_faces(SLEEP, 40.0, GRIPPER)
    assert len(arm) == 6 * 8                                   # base, 4 links, housing, 2 fingers
    assert np.all(np.isin(arm.colors, [36, 38, 52, 54]))


def test_fill_polygons_refuses_bad_arrays():
    from armlab.sim.raster import view_for
    view = view_for(true_camera(CameraRealism.ideal()))
    canvas = view.new_canvas()
    with pytest.raises(ValueError, match="vertices"):
        view.fill_polygons(canvas, np.zeros((2, 2, 3)), np.zeros((2, 3)), np.zeros((2, 3)), np.ones(2))
    with pytest.raises(ValueError, match="normals"):
        view.fill_polygons(canvas, np.zeros((2, 4, 3)), np.zeros((3, 3)), np.zeros((2, 3)), np.ones(2))
    with pytest.raises(ValueError, match="surface"):
        view.fill_polygons(canvas, np.zeros((2, 4, 3)), np.zeros((2, 3)), np.zeros((2, 3)), np.zeros(2))
    assert not canvas.inv_depth.any()                          # nothing was drawn


@pytest.mark.parametrize("realism", [CameraRealism(), replace(CameraRealism(), depth_edge_dropout=1.0, pixel_noise=0.0,
                                                               depth_noise_mm=0.0, blur_sigma_px=1.3)])
def test_sensor_effects_reusing_the_board_products_match_the_whole_image(realism):
    from armlab.sim.render import _render_exact
    from armlab.sim.sensor import apply_color_effects, apply_depth_effects
    camera = true_camera(realism)
    rng = np.random.default_rng(5)
    objs = [cube(("red", "blue", "violet")[i % 3], rng.uniform(-560, 560), rng.uniform(-180, 500),
                 38.0 if i % 2 else 25.0, yaw=rng.uniform(0, 1.5), id=i) for i in range(30)]
    rgb, depth, reuse = _render_exact(camera, objs, np.array([0.3, -0.2, 0.3, 0.9, 0.2]), 40.0, GRIPPER, ())
    assert reuse is not None and len(reuse.rects) > 0
    pp = (camera.K[0, 2], camera.K[1, 2])
    for _ in range(2):              # the first call fills the cache, the second uses it
        a_rgb = apply_color_effects(rgb, pp, realism, np.random.default_rng(9), reuse)
        a_depth = apply_depth_effects(depth, rgb, realism, np.random.default_rng(9), reuse)
        b_rgb = apply_color_effects(rgb, pp, realism, np.random.default_rng(9))
        b_depth = apply_depth_effects(depth, rgb, realism, np.random.default_rng(9))
        assert np.array_equal(a_rgb, b_rgb)
        assert np.array_equal(a_depth, b_depth, equal_nan=True)
    assert {key[0] for key in reuse.cache if realism in key} == {"colour", "depth"}
    if realism.depth_edge_dropout == 1.0:       # certain dropout at every depth step: the blocks' outlines
        assert np.isnan(depth).sum() < np.isnan(a_depth).sum()


def test_sensor_caches_are_per_camera():
    from armlab.sim.raster import view_for
    from armlab.sim.render import board_canvas
    a, b = CameraRealism.realistic(0), CameraRealism.realistic(1)
    cam_a, cam_b = true_camera(a), true_camera(b)
    objs = [cube("red", -300, 100, id=1)]
    first = render(cam_a, objs, realism=a, rng=np.random.default_rng(3))
    render(cam_b, objs, realism=b, rng=np.random.default_rng(3))
    cache_a, cache_b = board_canvas(view_for(cam_a)).sensor_cache, board_canvas(view_for(cam_b)).sensor_cache
    assert cache_a is not cache_b
    assert {k[0] for k in cache_a if a in k} == {k[0] for k in cache_b if b in k} == {"colour", "depth"}
    assert all(not (x is y or np.shares_memory(x[0], y[0])) for x in cache_a.values() for y in cache_b.values())
    # camera a's frame again, after camera b filled its own cache: the same image
    again = render(cam_a, objs, realism=a, rng=np.random.default_rng(3))
    assert np.array_equal(first[0], again[0]) and np.array_equal(first[1], again[1], equal_nan=True)
    other = render(cam_b, objs, realism=b, rng=np.random.default_rng(3))
    assert not np.array_equal(first[0], other[0])


def _centre_inside(P, U, V, margin):
    """Pixel centres (U, V) strictly inside the convex polygon P (K, 2) by more than `margin` px (+1), outside by
    more than `margin` (-1), or within `margin` of an edge (0)."""
    area = np.sum(P[:, 0] * np.roll(P, -1, 0)[:, 1] - P[:, 1] * np.roll(P, -1, 0)[:, 0])
    dist = np.full(U.shape, np.inf)
    for a, b in zip(P, np.roll(P, -1, 0), strict=True):
        d = b - a
        dist = np.minimum(dist, np.sign(area) * (d[0] * (V - a[1]) - d[1] * (U - a[0])) / np.hypot(*d))
    return np.where(dist > margin, 1, np.where(dist < -margin, -1, 0))


def test_faces_cover_the_pixels_whose_centres_are_inside():
    """Random convex polygons (3-6 corners, either winding, 1-30 px across, fronto-parallel) cover exactly the pixels
    whose centres lie inside them, against 8x8 supersampled coverage: every pixel wholly inside is drawn, every
    pixel wholly outside is not, and a pixel cut by one straight edge is drawn when more than half of it is covered
    (its centre is inside)."""
    from armlab.sim.raster import view_for
    K = np.array([[600.0, 0, 100], [0, 600.0, 80], [0, 0, 1]])
    view = view_for(Camera(K, np.zeros(5), np.eye(4), 200, 160))
    rng = np.random.default_rng(3)
    sub = (np.arange(8) + 0.5) / 8 - 0.5
    for trial in range(60):
        n = int(rng.integers(3, 7))
        angles = np.sort(rng.uniform(0, 2 * np.pi, n))[::rng.choice([-1, 1])]
        radius = rng.uniform(0.5, 15.0)
        P = rng.uniform(40, 120, 2) + radius * np.column_stack([np.cos(angles),
                                                                rng.uniform(0.2, 1.0) * np.sin(angles)])
        Z = 500.0
        vertices = np.column_stack([(P - K[:2, 2]) / K[0, 0] * Z, np.full(n, Z)])
        canvas = view.new_canvas()
        view.fill_polygons(canvas, vertices[None], np.array([[0.0, 0.0, -1.0]]), np.array([[200.0, 0, 0]]),
                           np.array([1]))
        drawn = canvas.surface > 0
        V, U = np.mgrid[0:view.height, 0:view.width].astype(float)
        centre = _centre_inside(P, U, V, 1e-3)
        assert not np.any(drawn & (centre < 0)) and np.all(drawn[centre > 0]), trial
        # supersampled coverage of the pixels near the polygon
        x0, y0 = np.floor(P.min(axis=0)).astype(int) - 1
        x1, y1 = np.ceil(P.max(axis=0)).astype(int) + 2
        Vs, Us = np.mgrid[y0:y1, x0:x1].astype(float)
        Us = Us[:, None, :, None] + sub[None, None, None, :]
        Vs = Vs[:, None, :, None] + sub[None, :, None, None]
        Us, Vs = np.broadcast_arrays(Us, Vs)
        cover = (_centre_inside(P, Us, Vs, 0.0) >= 0).reshape(y1 - y0, 8, x1 - x0, 8).mean(axis=(1, 3))
        box = drawn[y0:y1, x0:x1]
        assert np.all(box[cover == 1.0]) and not np.any(box[cover == 0.0]), trial
        # a pixel away from the corners (only one edge crosses it) is drawn exactly when its centre is inside
        corner_far = np.min(np.hypot(Us.reshape(y1 - y0, 8, x1 - x0, 8)[:, :1, :, :1, None] - P[:, 0],
                                     Vs.reshape(y1 - y0, 8, x1 - x0, 8)[:, :1, :, :1, None] - P[:, 1]), axis=-1)
        one_edge = (corner_far[:, 0, :, 0] > 1.5) & (np.abs(cover - 0.5) > 0.05)
        assert np.array_equal(box[one_edge], cover[one_edge] > 0.5), trial


def _crop_camera(camera, x0, y0, n, scale):
    """The camera's pinhole (no distortion) image of pixels x0..x0+n-1, y0..y0+n-1, `scale` x `scale` samples per
    pixel (sample centres evenly inside each pixel)."""
    K = camera.K.copy()
    K[:2] *= scale
    K[0, 2] = scale * (camera.K[0, 2] - x0 + 0.5) - 0.5
    K[1, 2] = scale * (camera.K[1, 2] - y0 + 0.5) - 0.5
    return Camera(K, np.zeros(5), camera.T_cam_world, n * scale, n * scale)


@pytest.mark.parametrize("x, y, edge, yaw", [(150.0, -80.0, 25.0, 0.0), (190.0, -150.0, 38.0, 0.0),
                                             (-230.0, 120.0, 25.0, 0.4), (60.0, 300.0, 38.0, 1.2)])
def test_top_face_edge_next_to_its_side_face_matches_supersampling(x, y, edge, yaw):
    """A cube's top face where it meets its own visible side face (and the board): every pixel the top face covers
    wholly is drawn as top, none it misses is, a pixel more than 60 % covered is top and one less than 40 % is not;
    the top's area is the supersampled one within the half pixel per edge pixel that rounding can take."""
    from armlab.detection.heightmap import world_from_depth
    truth = true_camera(CameraRealism.ideal())
    o = cube("orange", x, y, edge, yaw=yaw)
    u, v = truth.project(np.array([[x, y, edge]]))[0]
    n = 48
    x0, y0 = int(round(u)) - n // 2, int(round(v)) - n // 2

    def top(scale):
        cam = _crop_camera(truth, x0, y0, n, scale)
        _, depth = render_exact(cam, [o])
        return np.abs(world_from_depth(depth, cam)[2] - edge) < 0.3

    drawn = top(1)
    cover = top(8).reshape(n, 8, n, 8).mean(axis=(1, 3))
    assert np.all(drawn[cover == 1.0]) and not np.any(drawn[cover == 0.0])
    # away from the top's corners a pixel is cut by one straight edge: drawn when more than half of it is covered
    a = yaw + np.pi / 4 * np.array([1, 3, 5, 7])
    c = np.asarray(o.position[:2]) + edge / np.sqrt(2) * np.column_stack([np.cos(a), np.sin(a)])
    corners = truth.project(np.column_stack([c, np.full(4, edge)])) - (x0, y0)
    V, U = np.mgrid[0:n, 0:n]
    far = np.min(np.hypot(U[..., None] - corners[:, 0], V[..., None] - corners[:, 1]), axis=-1) > 1.5
    assert np.all(drawn[far & (cover > 0.6)]) and not np.any(drawn[far & (cover < 0.4)])
    rim = (cover > 0) & (cover < 1)
    assert abs(drawn.sum() - cover.sum()) < 0.25 * rim.sum()
