"""segment_faces's batched helpers against the straightforward per-item code they replace: the same values, bit for
bit (detections must not move), on random inputs with the edge cases (empty, one item, items at the image border,
flat regions whose histogram is shorter than the smoothing kernel, NaN and invalid pixels, several levels per
region)."""

import cv2
import numpy as np
import pytest

from armlab.detection import box_atlas
from armlab.detection import segment as seg

_KERNEL = np.ones((3, 3), np.uint8)


def _slope(heights, mask):
    """The per-face plane fit segment_faces used before batching (normal equations in centred coordinates)."""
    r, c = np.nonzero(mask)
    if len(r) < 3:
        return 0.0
    z = heights[r, c].astype(float)
    r, c, z = r - r.mean(), c - c.mean(), z - z.mean()
    scc, srr, scr, scz, srz = c @ c, r @ r, c @ r, c @ z, r @ z
    det = scc * srr - scr * scr
    if det <= 1e-9 * scc * srr:
        return 0.0
    return float(np.hypot(srr * scz - scr * srz, scc * srz - scr * scz) / det)


def _reference_segment_faces(height_mm, valid, min_height_mm=10.0, face_tolerance_mm=6.0, min_face_pixels=120,
                             median_px=5, max_slope_mm=1.0):
    """segment_faces as one loop over regions, levels and silhouettes, each box by itself (revision 5c9fe87)."""
    h = np.zeros(np.shape(height_mm), np.float32)
    np.copyto(h, height_mm, where=valid & np.isfinite(height_mm), casting="unsafe")
    h = cv2.medianBlur(h, median_px)
    n, labels, stats, _ = cv2.connectedComponentsWithStats((h > min_height_mm).view(np.uint8), connectivity=4)
    faces = []
    for k in range(1, n):
        x, y, w, hh, area = stats[k]
        if area < min_face_pixels:
            continue
        region = labels[y:y + hh, x:x + w] == k
        sub_h = h[y:y + hh, x:x + w]
        for level in seg._plateau_levels(sub_h[region], 2.0, min_face_pixels // 2):
            on_level = (region & (np.abs(sub_h - level) < face_tolerance_mm)).astype(np.uint8)
            on_level = cv2.morphologyEx(on_level, cv2.MORPH_OPEN, _KERNEL).astype(bool)
            above = (region & (sub_h > level - face_tolerance_mm)).astype(np.uint8)
            m, parts, part_stats, _ = cv2.connectedComponentsWithStats(above, connectivity=4)
            counts = np.bincount(parts[on_level], minlength=m)
            for j in np.flatnonzero(counts >= min_face_pixels):
                if j == 0:
                    continue
                fx, fy, fw, fh, _ = part_stats[j]
                sil = parts[fy:fy + fh, fx:fx + fw] == j
                mask = sil & on_level[fy:fy + fh, fx:fx + fw]
                heights = sub_h[fy:fy + fh, fx:fx + fw]
                face_h = seg._median(heights[mask])
                if _slope(heights, mask & (np.abs(heights - face_h) <= 0.5 * face_tolerance_mm)) > max_slope_mm:
                    continue
                faces.append(seg.Face((int(x + fx), int(y + fy), int(fw), int(fh)), mask, face_h, sil))
    return faces


def _assert_same_faces(got, want):
    assert len(got) == len(want)
    for a, b in zip(got, want, strict=True):
        assert a.bbox == b.bbox and type(a.height_mm) is float and a.height_mm == b.height_mm
        for field in ("mask", "silhouette"):
            u, v = getattr(a, field), getattr(b, field)
            assert u.dtype == v.dtype == bool and u.shape == v.shape and np.array_equal(u, v)


def _random_map(rng, shape=(90, 130)):
    """A noisy board with blocks (some stacked, some across the border, some flat to the last bit), ramps, NaN and
    invalid pixels."""
    h = rng.normal(0.0, 0.7, shape).astype(np.float32)
    for _ in range(rng.integers(0, 12)):
        y, x = rng.integers(-8, shape[0]), rng.integers(-8, shape[1])
        a, b = rng.integers(4, 26, 2)
        top = rng.choice([12.0, 25.0, 38.0, 50.0, 63.0, 76.0]) + rng.choice([0.0, rng.normal(0, 0.3)])
        ys, xs = slice(max(y, 0), max(y + a, 0)), slice(max(x, 0), max(x + b, 0))
        kind = rng.integers(4)
        if kind == 0:                                      # exactly flat: a histogram of one bin
            h[ys, xs] = np.float32(top)
        elif kind == 1:                                    # a ramp (a side face seen obliquely)
            rows = h[ys, xs].shape[0]
            h[ys, xs] = (top + rng.uniform(0.5, 4.0) * np.arange(rows, dtype=np.float32)[:, None]
                         + rng.normal(0, 0.3, h[ys, xs].shape)).astype(np.float32)
        else:
            h[ys, xs] = top + rng.normal(0, 0.6, h[ys, xs].shape).astype(np.float32)
    speckle = rng.random(shape) < 0.004                    # the depth's isolated speckle, and a few pairs
    speckle[:, :-1] |= speckle[:, 1:] & (rng.random((shape[0], shape[1] - 1)) < 0.2)
    h[speckle] = rng.uniform(11, 90, int(speckle.sum()))
    h[rng.random(shape) < 0.01] = np.nan
    valid = rng.random(shape) > 0.02
    if rng.random() < 0.3:
        valid[:, rng.integers(shape[1]):] = False
    return h, valid


@pytest.mark.parametrize("median_px, min_pixels, tolerance, min_height", [
    (3, 20, 6.0, 10.0), (5, 30, 6.0, 10.0), (3, 8, 3.0, 20.0), (3, 20, 6.0, 0.0), (3, 20, 6.0, -5.0)])
def test_segment_faces_equals_the_per_region_loop(median_px, min_pixels, tolerance, min_height):
    rng = np.random.default_rng(median_px * 1000 + min_pixels + int(10 * tolerance) + int(min_height))
    faces = 0
    for _ in range(60):
        h, valid = _random_map(rng)
        kw = dict(min_height_mm=min_height, face_tolerance_mm=tolerance, min_face_pixels=min_pixels,
                  median_px=median_px, max_slope_mm=float(rng.choice([0.5, 1.0, 3.0])))
        want = _reference_segment_faces(h, valid, **kw)
        _assert_same_faces(seg.segment_faces(h, valid, **kw), want)
        _assert_same_faces(seg.segment_faces(h.astype(np.float64), valid, **kw), want)
        faces += len(want)
    assert faces > 100                                     # the maps do have faces


def test_segment_faces_edge_cases():
    h = np.zeros((40, 50), np.float32)
    valid = np.ones(h.shape, bool)
    assert seg.segment_faces(h, valid, min_face_pixels=20, median_px=3) == []             # nothing high
    h[:, :] = np.nan
    assert seg.segment_faces(h, valid, min_face_pixels=20, median_px=3) == []             # no return at all
    h[:] = 0
    h[0:12, 0:12] = 25.0                                   # one flat block in the corner
    h[30:40, 40:50] = 38.0                                 # and one in the opposite corner
    for kw in (dict(min_face_pixels=20, median_px=3), dict(min_face_pixels=20, median_px=5)):
        got = seg.segment_faces(h, valid, **kw)
        _assert_same_faces(got, _reference_segment_faces(h, valid, **kw))
        assert [f.bbox for f in got] == [(0, 0, 12, 12), (40, 30, 10, 10)]
    h[0:12, 0:12] = 25.0 + np.arange(12, dtype=np.float32)[:, None] * 3   # a steep ramp: no face
    _assert_same_faces(seg.segment_faces(h, valid, min_face_pixels=20, median_px=3),
                       _reference_segment_faces(h, valid, min_face_pixels=20, median_px=3))
    assert seg.segment_faces(h, ~valid, min_face_pixels=20, median_px=3) == []            # nothing valid


def test_component_levels_equal_plateau_levels_one_component_at_a_time():
    rng = np.random.default_rng(7)
    for _ in range(300):
        k = int(rng.integers(1, 8))
        parts = []
        for _ in range(k):
            n = int(rng.integers(1, 300))
            kind = rng.integers(3)
            if kind == 0:                                  # all within one bin (a histogram shorter than 5)
                v = np.full(n, rng.uniform(10, 80), np.float32) + rng.uniform(0, 1.9, n).astype(np.float32)
            elif kind == 1:                                # a block with its top
                v = np.concatenate([rng.uniform(10, 40, n), rng.normal(40, 0.7, n)]).astype(np.float32)
            else:                                          # two plateaus (a stack)
                v = np.concatenate([rng.normal(25, 0.8, n), rng.normal(50, 0.8, n // 2)]).astype(np.float32)
            parts.append(np.maximum(v, np.float32(10.01)))
        counts = np.array([len(p) for p in parts])
        starts = np.cumsum(counts) - counts
        min_pixels = int(rng.integers(1, 40))
        comp, levels = seg._component_levels(np.concatenate(parts), starts, counts, 2.0, min_pixels)
        want = [(c, lv) for c, p in enumerate(parts) for lv in seg._plateau_levels(p, 2.0, min_pixels)]
        assert list(zip(comp.tolist(), levels.tolist(), strict=True)) == want


def test_open_each_box_equals_opening_each_box_alone():
    rng = np.random.default_rng(11)
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
            alone = cv2.morphologyEx(box, cv2.MORPH_OPEN, _KERNEL)
            assert np.array_equal(opened[t + 1:t + 1 + box.shape[0], lf + 1:lf + 1 + box.shape[1]], alone)


def test_label_numbers_components_as_opencv_default():
    rng = np.random.default_rng(5)
    threads = cv2.getNumThreads()
    try:
        for n_threads in (1, 2):
            cv2.setNumThreads(n_threads)
            for shape, p in [((1, 1), 0.5), ((7, 300), 0.5), ((360, 640), 0.05), ((360, 640), 0.6),
                             ((400, 400), 0.45)]:       # > 2**16 pixels set: 32-bit labels
                mask = (rng.random(shape) < p).astype(np.uint8)
                n, labels = seg._label(mask)
                want_n, want = cv2.connectedComponents(mask, connectivity=4)
                assert n == want_n and np.array_equal(labels.astype(np.int64), want)
    finally:
        cv2.setNumThreads(threads)


def test_face_slopes_equal_one_plane_fit_per_face():
    rng = np.random.default_rng(9)
    for _ in range(100):
        faces, rr, cc, zz, want = [], [], [], [], []
        for _ in range(int(rng.integers(0, 10))):
            hh, ww = rng.integers(1, 20, 2)
            mask = rng.random((hh, ww)) < rng.uniform(0.05, 1.0)
            if rng.random() < 0.2:                         # pixels on one line
                mask[:] = False
                mask[:, 0] = True
            if rng.random() < 0.2:                         # heights from 1e-12 to 1e3 mm: each face's np.mean
                heights = 10.0 ** rng.uniform(-12, 3, (hh, ww))
            else:
                heights = 25 + rng.uniform(0, 3) * np.arange(hh)[:, None] + rng.normal(0, 0.5, (hh, ww))
            heights = heights.astype(np.float32)
            r, c = np.nonzero(mask)
            faces.append(len(r))
            rr.append(r)
            cc.append(c)
            zz.append(heights[r, c])
            want.append(_slope(heights, mask))
        n = np.array(faces, np.intp)
        got = seg._face_slopes(n, *(np.concatenate(v) if v else np.zeros(0, t)
                                    for v, t in ((rr, np.intp), (cc, np.intp), (zz, np.float32))))
        assert got.tolist() == want


def test_object_window_holds_every_object():
    h = np.zeros((50, 60), np.float32)
    valid = np.ones(h.shape, bool)
    everything = (slice(None), slice(None))
    assert seg._object_window(h, valid, 10.0, 1) is None
    assert seg._object_window(h, valid, -1.0, 1) == (everything, everything)
    h[20:25, 30:33] = 30.0
    h[3, 55] = h[45, 5] = 40.0                             # isolated speckle: no median rises above 10 there
    crop, inner = seg._object_window(h, valid, 10.0, 2)
    assert crop == (slice(16, 29), slice(26, 37)) and inner == (slice(2, 11), slice(2, 9))
    h[3, 54] = 40.0                                        # a pair: a 5 x 5 median there could (it does not)
    assert seg._object_window(h, valid, 10.0, 1) == ((slice(1, 27), slice(28, 58)), (slice(1, 25), slice(1, 29)))
    valid[3, 54] = False
    assert seg._object_window(h, valid, 10.0, 1) == ((slice(18, 27), slice(28, 35)), (slice(1, 8), slice(1, 6)))
    h[0, 59] = 40.0                                        # on the border, which OpenCV's filters repeat
    assert seg._object_window(h, valid, 10.0, 1) == ((slice(0, 27), slice(28, 62)), (slice(0, 26), slice(1, 33)))
    assert seg._object_window(h, valid, 10.0, 0) == (everything, everything)


def test_objects_equal_filtering_the_whole_map():
    """The window's filtered heights and objects are the whole map's, even where the depth's speckle sits on the
    window's edge (where OpenCV's replicated border could lift a median above min_height: a speckle at a corner of a
    5 x 5 window counts 9 times)."""
    rng = np.random.default_rng(13)
    for _ in range(80):
        h, valid = _random_map(rng, (60, 80))
        median_px = int(rng.choice([3, 5]))
        h[30:40, 30:42] = 38.0                             # a block, so that there is a window
        valid[30:40, 30:42] = True
        crop, _ = seg._object_window(h, valid, 10.0, median_px // 2)
        y1, x1 = min(crop[0].stop, 60) - 1, min(crop[1].stop, 80) - 1
        h[y1, x1] = h[y1 - 2, x1] = h[y1, x1 - 2] = h[y1 - 2, x1 - 2] = 80.0    # speckle around the corner
        valid[y1 - 2:y1 + 1, x1 - 2:x1 + 1] = True
        full = np.zeros(h.shape, np.float32)
        np.copyto(full, h, where=valid & np.isfinite(h))
        full = cv2.medianBlur(full, median_px)
        found = seg._objects(h, valid, 10.0, median_px)
        if not (full > 10.0).any():
            assert found is None
            continue
        part, objects, (y0, x0) = found
        embedded = np.zeros(h.shape, bool)
        embedded[y0:y0 + objects.shape[0], x0:x0 + objects.shape[1]] = objects
        assert np.array_equal(embedded, full > 10.0)
        assert np.array_equal(part[objects], full[embedded])
