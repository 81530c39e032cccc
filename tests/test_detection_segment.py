"""segment_faces (armlab.detection.segment) by what it promises, through its public signature only: every flat top
face of a height map is found once, at its height, within its block's outline, and nothing else is (the depth's
speckle, ramps, pixels outside `valid`); the same on simulated camera frames of the perception set; and the atlas
helpers it builds on (armlab.detection.box_atlas) do to many boxes what OpenCV does to each."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from armlab.detection import DetectionSettings, box_atlas
from armlab.detection.heightmap import height_from_depth, pixels_to_plane
from armlab.detection.masks import arm_mask
from armlab.detection.segment import segment_faces
from armlab.lab import lab_config
from armlab.sim.detection_eval import case_specs, corrected_depth, sim_case

TOPS_MM = (12.0, 25.0, 38.0, 50.0, 63.0)
MIN_PIXELS = 20


def _rect_mask(shape, rect) -> np.ndarray:
    y, x, h, w = rect
    m = np.zeros(shape, bool)
    m[y:y + h, x:x + w] = True
    return m


def _random_board(rng, shape=(90, 130)):
    """A noisy board (0.6 mm) with up to six separate blocks, some carrying a smaller block (a stack), speckle and
    NaN away from them, and a few invalid pixels everywhere. Returns the map, the valid mask and the expected tops
    as (rect of the block's silhouette, rect of its top face or of what stands on it, height mm)."""
    h = rng.normal(0.0, 0.6, shape).astype(np.float32)
    taken = np.zeros(shape, bool)
    tops = []
    for _ in range(int(rng.integers(0, 7))):
        a, b = (int(v) for v in rng.integers(8, 24, 2))
        y, x = int(rng.integers(0, shape[0] - a)), int(rng.integers(0, shape[1] - b))
        rect = (y, x, a, b)
        grown = _rect_mask(shape, (max(y - 4, 0), max(x - 4, 0), a + 8, b + 8))
        if (grown & taken).any():
            continue
        taken |= grown
        base = float(rng.choice(TOPS_MM[:3]))
        h[y:y + a, x:x + b] = base + rng.normal(0, 0.6, (a, b)).astype(np.float32)
        tops.append((rect, rect, base))
        if a >= 16 and b >= 16 and rng.random() < 0.5:                 # a smaller block standing on it
            inner = (y + 4, x + 4, a - 8, b - 8)
            upper = base + float(rng.choice((25.0, 38.0)))
            h[y + 4:y + a - 4, x + 4:x + b - 4] = upper + rng.normal(0, 0.6, (a - 8, b - 8)).astype(np.float32)
            tops.append((inner, inner, upper))
    away = ~cv2.dilate(taken.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
    speckle = (rng.random(shape) < 0.004) & away                         # the depth's isolated speckle
    h[speckle] = rng.uniform(11, 90, int(speckle.sum()))
    h[(rng.random(shape) < 0.01) & away] = np.nan
    valid = rng.random(shape) > 0.01                                     # dropouts everywhere, blocks included
    return h, valid, tops


def test_faces_are_the_blocks_tops_at_their_heights():
    rng = np.random.default_rng(2026)
    found = 0
    for trial in range(60):
        h, valid, tops = _random_board(rng)
        kw = dict(min_height_mm=10.0, min_face_pixels=MIN_PIXELS, median_px=3)
        faces = segment_faces(h, valid, **kw)
        assert len(faces) == len(tops), f"trial {trial}: {len(faces)} faces for {len(tops)} tops"
        for rect, _, height in tops:
            inside = _rect_mask(h.shape, rect)
            (face,) = [f for f in faces if abs(f.height_mm - height) < 2.0 and inside[f.pixels()].all()]
            assert abs(face.height_mm - height) < 0.5, (trial, face.height_mm, height)
            assert inside[face.pixels()].all()                           # its pixels lie on its block
            assert face.mask.sum() >= 0.5 * inside.sum()                 # and cover most of a free top
            assert face.mask.shape == face.silhouette.shape == (face.bbox[3], face.bbox[2])
        found += len(tops)
        same = segment_faces(h.astype(np.float64), valid, **kw)
        assert [(f.bbox, f.height_mm) for f in same] == [(f.bbox, f.height_mm) for f in faces]
    assert found > 100


def test_a_stacked_blocks_silhouette_holds_what_stands_on_it():
    h = np.zeros((60, 80), np.float32)
    h[20:44, 20:44] = 38.0                                  # a large block
    h[26:38, 26:38] = 63.0                                  # a small one on it
    (low, high) = sorted(segment_faces(h, np.ones(h.shape, bool), min_face_pixels=MIN_PIXELS, median_px=3),
                         key=lambda f: f.height_mm)
    assert (low.bbox, low.height_mm, high.bbox, high.height_mm) == ((20, 20, 24, 24), 38.0, (26, 26, 12, 12), 63.0)
    assert low.silhouette[6:18, 6:18].all() and not low.mask[7:17, 7:17].any()   # the upper block: silhouette only
    assert low.silhouette.sum() - 12 * 12 <= low.mask.sum() <= low.silhouette.sum() - 10 * 10   # (the corners round)


def test_nothing_but_tops_is_a_face():
    valid = np.ones((40, 50), bool)
    h = np.zeros((40, 50), np.float32)
    assert segment_faces(h, valid, min_face_pixels=20, median_px=3) == []             # nothing high
    assert segment_faces(np.full((40, 50), np.nan, np.float32), valid) == []          # no return at all
    rng = np.random.default_rng(1)
    speckle = np.where(rng.random(h.shape) < 0.01, rng.uniform(11, 90, h.shape), 0).astype(np.float32)
    assert segment_faces(speckle, valid, min_face_pixels=8, median_px=3) == []         # isolated speckle
    ramp = h.copy()
    ramp[5:25, 5:25] = 25.0 + 3.0 * np.arange(20, dtype=np.float32)[:, None]          # a side face, seen obliquely
    assert segment_faces(ramp, valid, min_face_pixels=20, median_px=3) == []
    block = h.copy()
    block[0:12, 0:12] = 25.0                                # in the corner
    block[30:40, 40:50] = 38.0                              # in the opposite corner
    for median_px in (3, 5):
        faces = segment_faces(block, valid, min_face_pixels=20, median_px=median_px)
        assert [(f.bbox, f.height_mm) for f in faces] == [((0, 0, 12, 12), 25.0), ((40, 30, 10, 10), 38.0)]
    assert segment_faces(block, ~valid, min_face_pixels=20, median_px=3) == []         # nothing valid
    hidden = valid.copy()
    hidden[:, 35:] = False
    assert [f.bbox for f in segment_faces(block, hidden, min_face_pixels=20, median_px=3)] == [(0, 0, 12, 12)]


@pytest.mark.parametrize("median_px", [3, 5])
def test_speckle_at_the_edge_of_the_objects_window_changes_nothing(median_px):
    """The map is filtered only around the objects; speckle next to that window (whose replicated border could lift
    a median) neither adds a face nor moves one."""
    h = np.zeros((60, 80), np.float32)
    h[30:40, 30:42] = 38.0
    valid = np.ones(h.shape, bool)
    want = [(f.bbox, f.height_mm) for f in segment_faces(h, valid, min_face_pixels=20, median_px=median_px)]
    assert want == [((30, 30, 12, 10), 38.0)]
    for y, x in ((42, 44), (27, 27), (0, 79), (59, 0), (45, 45)):
        speckled = h.copy()
        speckled[y, x] = speckled[max(y - 2, 0), x] = speckled[y, max(x - 2, 0)] = 80.0
        got = [(f.bbox, f.height_mm) for f in segment_faces(speckled, valid, min_face_pixels=20, median_px=median_px)]
        assert got == want, (y, x)


FRAMES = case_specs(24, 100)[::2]          # 12 frames of the perception set (seeds 100...), the arm parked


@pytest.fixture(scope="module", params=FRAMES, ids=[f"{s}-{seed}" for s, seed, _ in FRAMES])
def frame(request):
    return sim_case(*request.param)


@pytest.mark.exercise("calib.depth_plane")           # the frame's depth bias corrected by the kit's own fit
def test_every_visible_top_of_a_simulated_frame_is_a_face_at_its_height(frame):
    """On a realistic frame (noise, bias corrected, lens), at the detector's resolution and settings: every object
    top seen whole has a face under its centre pixel within 2 mm of its height, and every face is some object's
    top (the robot's base aside: the detector leaves it out by its place on the board)."""
    settings = DetectionSettings()
    s = settings.step
    height = height_from_depth(corrected_depth(frame), frame.camera, s)
    valid = (height < settings.max_height) & ~arm_mask(frame.camera, frame.arm_q, step=s)   # the arm is no block
    faces = segment_faces(height, valid, settings.min_height, median_px=3, max_slope_mm=settings.max_face_slope * s,
                          min_face_pixels=max(8, settings.min_face_pixels // s ** 2))
    owner = np.full(height.shape, -1)
    for i, f in enumerate(faces):
        owner[f.pixels()] = i
    tops = [t for t in frame.truth if t.is_block and t.visible >= 0.99]
    assert tops
    for t in tops:
        u, v = np.rint(frame.camera.project(t.centre[None])[0] / s).astype(int)
        i = owner[v, u]
        assert i >= 0, f"{frame.scene} seed {frame.seed}: no face under the top of {t.obj.color} {t.obj.shape}"
        assert abs(faces[i].height_mm - t.obj.top_z) < 3.0, (faces[i].height_mm, t.obj.top_z)
    heights = np.array([t.obj.top_z for t in frame.truth])
    for f in faces:
        rows, cols = f.pixels()
        uv = np.array([[cols.mean() * s, rows.mean() * s]])
        xy = pixels_to_plane(frame.camera, uv, f.height_mm)[0, :2]
        if lab_config().on_robot_base(xy[None], margin_mm=15.0)[0]:
            continue
        assert np.min(np.abs(heights - f.height_mm)) < 3.0, f"a face at {f.height_mm:.1f} mm, {xy} is no object's top"


def test_open_each_box_equals_opening_each_box_alone():
    rng = np.random.default_rng(11)
    kernel = np.ones((3, 3), np.uint8)
    for _ in range(100):
        b = int(rng.integers(1, 12))
        hs, ws = rng.integers(1, 25, b), rng.integers(1, 25, b)
        boxes = [(rng.random((hh, ww)) < rng.uniform(0.3, 1.0)).astype(np.uint8) for hh, ww in zip(hs, ws, strict=True)]
        top, left, shape = box_atlas.pack_boxes(hs + 2, ws + 2)
        atlas = np.zeros(shape, np.uint8)
        for t, lf, box in zip(top, left, boxes, strict=True):
            assert not atlas[t:t + box.shape[0] + 2, lf:lf + box.shape[1] + 2].any()   # the frames do not overlap
            atlas[t + 1:t + 1 + box.shape[0], lf + 1:lf + 1 + box.shape[1]] = box
        before = atlas.copy()
        opened = box_atlas.open_each_box(atlas, box_atlas.rims(top, left, hs + 2, ws + 2, shape[1]))
        assert np.array_equal(atlas, before)
        for t, lf, box in zip(top, left, boxes, strict=True):
            alone = cv2.morphologyEx(box, cv2.MORPH_OPEN, kernel)
            assert np.array_equal(opened[t + 1:t + 1 + box.shape[0], lf + 1:lf + 1 + box.shape[1]], alone)
