"""Top faces of objects standing on the board, segmented from a height map.

Objects are pixels higher than `min_height_mm` above the board. Inside each connected object region, top faces are
flat plateaus: the heights of a horizontal face pile up in one histogram peak, while vertical side faces spread
evenly. For each peak, the region's pixels at or above that height split into silhouettes; each silhouette with
enough pixels on the peak is one face. So a stack shows its top block's face, and a lower block's face where it is
still visible (the ring of a large block around a small one on top of it), and the face's silhouette includes what
stands on it.

A top face is level, a side face is not: a side face seen obliquely (far from the camera's nadir, where it covers
as much of the image as a top face) rises by its whole edge over a few rows, so a band of it can gather enough pixels
within the tolerance of one height to pass as a plateau (seed 2's large yellow block read as a second, small one at
22.7 mm next to it). Faces whose core's heights (within half the tolerance of the face's height) rise more than
`max_slope_mm` per sample in a plane fit are left out.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import cv2
import numpy as np

from armlab.detection.box_atlas import grouped, open_each_box, pack_boxes, rims, runs

__all__ = ["Face", "segment_faces"]

_NEIGHBOURS = np.array([[1, 1, 1], [1, 0, 1], [1, 1, 1]], np.uint8)


def _object_window(height_mm: np.ndarray, valid: np.ndarray, min_height_mm: float,
                   radius: int) -> tuple[tuple[slice, slice], tuple[slice, slice]] | None:
    """The part of a height map that segment_faces must median-filter, and the part of that which can hold objects
    (pixels whose median over the (2 radius + 1)^2 window exceeds min_height_mm): (rows, columns) slices of the map,
    and of the first part. None when there can be none.

    A median above min_height_mm needs more than half of its window above it, valid and finite (the others count as
    0): "high" pixels; and more than half of a window of 3 x 3 or more always holds two 8-adjacent pixels (no more
    than a quarter of it, every other row and column, can be apart), or, where the window crosses the map's border
    (which OpenCV replicates), a high pixel on the border. So objects lie within `radius` of the box of the high
    pixels with a high neighbour or on the border (which leaves out the depth's isolated speckle); their windows lie
    within 2 `radius` of it, or meet the map's border, so filtering the map's part out to 2 `radius` (clipped to the
    map) gives their medians exactly. The whole map when min_height_mm < 0 (the invalid pixels' 0 is then an object)."""
    if not min_height_mm >= 0 or radius < 1:
        return (slice(None), slice(None)), (slice(None), slice(None))
    high = (valid & (height_mm > min_height_mm)).view(np.uint8)    # a superset when float32(v) > float32(t)
    paired = cv2.bitwise_and(high, cv2.dilate(high, _NEIGHBOURS))
    for edge in (np.s_[0], np.s_[-1], np.s_[:, 0], np.s_[:, -1]):     # OpenCV's border repeats these: their
        paired[edge] |= high[edge]                                      # copies are neighbours
    rows = np.flatnonzero(paired.any(axis=1))
    if not len(rows):
        return None
    cols = np.flatnonzero(paired.any(axis=0))
    (r0, r1), (c0, c1) = (rows[0], rows[-1] + 1), (cols[0], cols[-1] + 1)
    crop = tuple(slice(max(int(a) - 2 * radius, 0), int(b) + 2 * radius) for a, b in ((r0, r1), (c0, c1)))
    inner = tuple(slice(max(int(a) - radius, 0) - w.start, int(b) + radius - w.start)
                  for (a, b), w in zip(((r0, r1), (c0, c1)), crop))
    return crop, inner


def _objects(height_mm, valid, min_height_mm: float,
             median_px: int) -> tuple[np.ndarray, np.ndarray, tuple[int, int]] | None:
    """The height map (H, W) mm median-filtered (median_px: 3, 5, ...; invalid and non-finite pixels count as 0) and
    its objects (pixels above min_height_mm), in the part of the map that can hold objects (_object_window): (h, w)
    float32 mm, (h, w) bool, and the part's first row and column in the map; None when there is no object. The same
    values as filtering the whole map, at a fraction of its cost (objects cover a few percent of the map)."""
    height_mm, valid = np.asarray(height_mm), np.asarray(valid, bool)
    window = _object_window(height_mm, valid, min_height_mm, median_px // 2)
    if window is None:
        return None
    (wy, wx), inner = window
    height_mm, valid = height_mm[wy, wx], valid[wy, wx]
    h = np.array(height_mm, np.float32)
    np.copyto(h, 0.0, where=~(valid & np.isfinite(height_mm)))
    h = cv2.medianBlur(h, median_px)
    objects = np.zeros(h.shape, bool)
    objects[inner] = h[inner] > min_height_mm
    return h, objects, (wy.start or 0, wx.start or 0)


def _label(mask: np.ndarray) -> tuple[int, np.ndarray]:
    """cv2.connectedComponents of a uint8 0/1 image, 4-connected: the same labels (OpenCV numbers components in the
    raster order of their first pixels) by its SAUF algorithm, into 16-bit labels when fewer than 2**16 pixels are
    set: a third faster than the default algorithm into 32-bit labels."""
    ltype = cv2.CV_16U if mask.size < 1 << 16 or cv2.countNonZero(mask) < 1 << 16 else cv2.CV_32S
    return cv2.connectedComponentsWithAlgorithm(mask, 4, ltype, cv2.CCL_SAUF)


@dataclass(frozen=True)
class Face:
    """A flat top face: the bounding box (x, y, w, h) of its silhouette, its visible pixels (mask over the box),
    its height (mm), and the silhouette (mask over the box: the face plus whatever stands on it)."""

    bbox: tuple[int, int, int, int]
    mask: np.ndarray
    height_mm: float
    silhouette: np.ndarray | None = None

    def pixels(self) -> tuple[np.ndarray, np.ndarray]:
        """Row and column indices (in the full image) of the face's pixels."""
        r, c = np.nonzero(self.mask)
        return r + self.bbox[1], c + self.bbox[0]


def _median(values: np.ndarray) -> float:
    """np.median of a non-empty 1-d array without NaN (the same value, a fraction of the call's overhead)."""
    k = len(values) // 2
    if len(values) % 2:
        return float(np.partition(values, k)[k])
    part = np.partition(values, [k - 1, k])
    return float((part[k - 1] + part[k]) / 2)


def _plateau_levels(heights: np.ndarray, bin_mm: float, min_pixels: int) -> list[float]:
    """Heights (mm) of the histogram peaks that hold at least `min_pixels` pixels within +-1.5 bins."""
    lo = float(heights.min()) - bin_mm
    bins = ((heights - lo) / bin_mm).astype(np.intp)                   # bins [lo + i bin, lo + (i + 1) bin)
    hist = np.bincount(bins, minlength=int(bins.max()) + 3)             # and two empty bins above
    edges = lo + bin_mm * np.arange(len(hist) + 1)
    smooth = np.convolve(hist, [1, 2, 3, 2, 1], mode="same")
    inner = smooth[1:-1]
    peaks = np.flatnonzero((inner >= smooth[:-2]) & (inner > smooth[2:])) + 1
    window = np.convolve(hist, [1, 1, 1], mode="same")
    return [float(0.5 * (edges[i] + edges[i + 1])) for i in peaks if window[i] >= min_pixels]


def _component_levels(heights: np.ndarray, starts: np.ndarray, counts: np.ndarray, bin_mm: float,
                      min_pixels: int) -> tuple[np.ndarray, np.ndarray]:
    """_plateau_levels of every component at once: heights (N,) float32 mm of the components' pixels, component c's
    at [starts[c], starts[c] + counts[c]) (counts >= 1). Returns (component (L,), level (L,) mm), by component and,
    within one, ascending: the same values in the same order as _plateau_levels of each in turn.

    The histograms lie end to end with two empty bins between them, so one convolution smooths them all as
    np.convolve smooths each alone; a component whose histogram is shorter than the kernel (all its heights within
    one bin: np.convolve's "same" then returns the kernel's length) goes through _plateau_levels itself."""
    comp = np.repeat(np.arange(len(counts)), counts)
    lo = np.minimum.reduceat(heights, starts).astype(np.float64) - bin_mm             # float(min) - bin_mm, and
    bins = ((heights - lo.astype(np.float32)[comp]) / bin_mm).astype(np.intp)         # heights - lo in float32
    lengths = np.maximum.reduceat(bins, starts) + 3
    offsets = np.cumsum(lengths + 2) - lengths                                        # two empty bins before each
    hist = np.bincount(offsets[comp] + bins, minlength=int(offsets[-1] + lengths[-1] + 2))
    smooth = np.convolve(hist, [1, 2, 3, 2, 1], mode="same")
    window = np.convolve(hist, [1, 1, 1], mode="same")
    peaks = np.flatnonzero((smooth[1:-1] >= smooth[:-2]) & (smooth[1:-1] > smooth[2:]) & (window[1:-1] >= min_pixels))
    peaks += 1
    of = np.searchsorted(offsets, peaks, side="right") - 1
    i = peaks - offsets[of]
    inner = (i >= 1) & (i <= lengths[of] - 2) & (lengths[of] >= 5)     # bins 1 .. length - 2, not in the gaps
    of, i = of[inner], i[inner]
    levels = 0.5 * ((lo[of] + bin_mm * i) + (lo[of] + bin_mm * (i + 1)))              # the bins' centres
    short = np.flatnonzero(lengths < 5)
    if len(short):
        extra = [(c, level) for c in short.tolist()
                 for level in _plateau_levels(heights[starts[c]:starts[c] + counts[c]], bin_mm, min_pixels)]
        of = np.concatenate([of, np.array([c for c, _ in extra], np.intp)])
        levels = np.concatenate([levels, np.array([level for _, level in extra], np.float64)])
        order = np.argsort(of, kind="stable")
        of, levels = of[order], levels[order]
    return of, levels


def _plane_slopes(scc, srr, scr, scz, srz):
    """How steeply (mm per sample) least-squares planes rise, from the sums over each one's centred columns c, rows
    r and heights z (mm): c @ c, r @ r, c @ r, c @ z, r @ z (arrays or scalars); 0 where the pixels lie on one
    line. The normal equations, a tenth of np.linalg.lstsq's cost."""
    det = scc * srr - scr * scr
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = np.hypot(srr * scz - scr * srz, scc * srz - scr * scz) / det
    return np.where(det <= 1e-9 * scc * srr, 0.0, slope)


def _face_slopes(n: np.ndarray, r: np.ndarray, c: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The plane fit's slope (mm per sample, 0 for fewer than three pixels) of each face's pixels: n (F,) how many
    pixels each face has, its at [sum(n[:f]), sum(n[:f + 1])) of r, c (N,) int rows and columns in its box (in
    raster order) and z (N,) float32 heights mm. The same values as centring each face's coordinates and heights
    (np.mean) and taking the dot products for _plane_slopes: the means' sums are exact here in any order (integers;
    float32 heights >= 1 mm, all multiples of 2**-23, whose sums stay below 2**29), else each face's np.mean; the dot
    products stay one BLAS call each per face (in BLAS's own order)."""
    face = np.repeat(np.arange(len(n)), n)
    ends = np.cumsum(n)
    bounds = list(zip((ends - n).tolist(), ends.tolist()))
    z = z.astype(np.float64)
    sum_z = np.bincount(face, z, len(n))
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_r, mean_c, mean_z = np.bincount(face, r, len(n)) / n, np.bincount(face, c, len(n)) / n, sum_z / n
    if len(z) and not (z.min() >= 1.0 and sum_z.max() < 2.0 ** 29):
        mean_z = np.array([np.mean(z[a:b]) if b > a else np.nan for a, b in bounds])
    r, c, z = r - mean_r[face], c - mean_c[face], z - mean_z[face]
    fitted = np.flatnonzero(n >= 3)
    sums, dot = [], np.dot                          # np.dot of vectors: the same cblas_ddot as `@`, less overhead
    for f in fitted.tolist():
        a, b = bounds[f]
        cf, rf, zf = c[a:b], r[a:b], z[a:b]
        sums += (dot(cf, cf), dot(rf, rf), dot(cf, rf), dot(cf, zf), dot(rf, zf))
    slopes = np.zeros(len(n))
    slopes[fitted] = _plane_slopes(*np.array(sums, np.float64).reshape(-1, 5).T)
    return slopes


class _Regions(NamedTuple):
    """The object regions large enough for a face: their pixels (N,) by region, each in raster order (rows, cols in
    the filtered part of the map, heights z float32 mm), region r's at [starts[r], starts[r] + counts[r]), and their
    bounding boxes (R,) (y0, x0, box_h, box_w), pixels."""

    rows: np.ndarray
    cols: np.ndarray
    z: np.ndarray
    starts: np.ndarray
    counts: np.ndarray
    y0: np.ndarray
    x0: np.ndarray
    box_h: np.ndarray
    box_w: np.ndarray


def _regions(h: np.ndarray, objects: np.ndarray, min_pixels: int) -> _Regions | None:
    """The 4-connected regions of `objects` (bool) with at least min_pixels pixels, heights from h (float32 mm);
    None when there is none. From the object pixels only (a few percent of the map), without OpenCV's per-component
    statistics (5x the labelling's cost)."""
    n, labels = _label(objects.view(np.uint8))
    idx = np.flatnonzero(objects)
    lab = labels.ravel()[idx]
    areas = np.bincount(lab, minlength=n)
    large = areas >= min_pixels
    large[0] = False
    keep = large[lab]
    if not keep.any():
        return None
    idx, lab = idx[keep], lab[keep]
    idx = idx[grouped(lab, n)]
    counts = areas[large]
    starts = np.cumsum(counts) - counts
    rows, cols = np.divmod(idx, h.shape[1])
    y0, x0 = np.minimum.reduceat(rows, starts), np.minimum.reduceat(cols, starts)
    return _Regions(rows, cols, h.ravel()[idx], starts, counts, y0, x0,
                    np.maximum.reduceat(rows, starts) + 1 - y0, np.maximum.reduceat(cols, starts) + 1 - x0)


class _Slots(NamedTuple):
    """One slot per (region, plateau level): its region (S,), its box's place in the atlas (top, left, S,: the rim's
    corner, pixels), and the slots' pixels (M,), slot by slot: their slot, flat index in the atlas, height z (float32
    mm), whether they are on the level (after the opening) and their silhouette's label in `parts`; the atlas's
    opened on-level pixels (bool) and labelling of the pixels above the level (0: none), n_parts labels."""

    region: np.ndarray
    top: np.ndarray
    left: np.ndarray
    width: int
    slot: np.ndarray
    at: np.ndarray
    z: np.ndarray
    on: np.ndarray
    part: np.ndarray
    opened: np.ndarray
    parts: np.ndarray
    n_parts: int


def _slots(reg: _Regions, min_pixels: int, tolerance_mm: float) -> _Slots | None:
    """Each region's plateau levels (_component_levels, at least min_pixels // 2 pixels) as slots, their boxes packed
    in one atlas: the pixels within tolerance_mm of the level opened (3 x 3, each box as an image of its own) and
    those above level - tolerance_mm labelled, one OpenCV call each. None when no region has a level."""
    region, level = _component_levels(reg.z, reg.starts, reg.counts, 2.0, min_pixels // 2)
    if not len(level):
        return None
    fh, fw = reg.box_h[region] + 2, reg.box_w[region] + 2                 # each box with its rim
    top, left, shape = pack_boxes(fh, fw)
    width = shape[1]
    npix = reg.counts[region]
    rows, cols, z = reg.rows, reg.cols, reg.z
    if not np.array_equal(region, np.arange(len(reg.counts))):   # not one level per region: the slots' pixels
        pix = runs(reg.starts[region], npix)
        rows, cols, z = rows[pix], cols[pix], z[pix]
    slot = np.repeat(np.arange(len(level)), npix)
    at = (rows * width + cols) + ((top + 1 - reg.y0[region]) * width + (left + 1 - reg.x0[region]))[slot]
    atlas = np.zeros(shape, np.uint8)
    flat = atlas.reshape(-1)
    flat[at] = np.abs(z - level.astype(np.float32)[slot]) < tolerance_mm          # float32, as sub_h - level
    opened = open_each_box(atlas, rims(top, left, fh, fw, width))                  # no thin side bands
    flat[at] = z > (level - tolerance_mm).astype(np.float32)[slot]
    n_parts, parts = _label(atlas)
    return _Slots(region, top, left, width, slot, at, z, opened.reshape(-1)[at].view(bool), parts.reshape(-1)[at],
                  opened.view(bool), parts, n_parts)


def segment_faces(height_mm: np.ndarray, valid: np.ndarray, min_height_mm: float = 10.0,
                  face_tolerance_mm: float = 6.0, min_face_pixels: int = 120, median_px: int = 5,
                  max_slope_mm: float = 1.0) -> list[Face]:
    """Top faces in a height map (H, W) mm (NaN allowed) restricted to `valid` (H, W) bool pixels.

    min_face_pixels: fewest pixels of a face on its plateau (scale it with the map's resolution); median_px: the
    median filter's size (3 or 5) that removes the depth's speckle: it also erases parts of objects thinner than about
    half of it, so use 3 on a reduced map (an arch's legs are 3-4 samples wide at half resolution); max_slope_mm: the
    steepest a face's core may rise, mm per sample (scale it with the map's resolution: at half resolution a block's
    top face rises less than 0.3 mm per sample, 0.6 when the arm leaves only a few samples of it, a side face's band
    2).

    Each object region's plateau level is one "slot": the region's bounding box (its pixels, the rest empty) with
    the level's masks. All slots are batched: the histograms in one convolution (_component_levels), the boxes in one
    atlas (box_atlas) opened (box_atlas.open_each_box) and labelled by one OpenCV call each, the faces' pixels as flat
    lists; only the median and the plane fit's dot products run per face. The faces come as one box at a time would
    give them: by region (label), level (ascending), silhouette (OpenCV's raster order)."""
    found = _objects(height_mm, valid, min_height_mm, median_px)
    reg = None if found is None else _regions(found[0], found[1], min_face_pixels)
    sl = None if reg is None else _slots(reg, min_face_pixels, face_tolerance_mm)
    if sl is None:
        return []
    m = sl.n_parts
    sil = np.flatnonzero(np.bincount(sl.part[sl.on], minlength=m) >= min_face_pixels)
    sil = sil[sil > 0]
    if not len(sil):
        return []

    # each silhouette's pixels, by silhouette (label), each in raster order; its box; its face's pixels (on level)
    face_of = np.full(m, -1, np.intp)
    face_of[sil] = np.arange(len(sil))
    sp = np.flatnonzero(face_of[sl.part] >= 0)
    face = face_of[sl.part[sp]]
    o = grouped(face, len(sil))
    sp, face = sp[o], face[o]
    size = np.bincount(face, minlength=len(sil))
    first = np.cumsum(size) - size
    sr, sc = np.divmod(sl.at[sp], sl.width)
    y, x = sr[first], np.minimum.reduceat(sc, first)                     # atlas box of each silhouette
    hh, w = np.maximum.reduceat(sr, first) + 1 - y, np.maximum.reduceat(sc, first) + 1 - x
    slot = sl.slot[sp[first]]
    keep = sl.on[sp]
    fp, face, sr, sc = sp[keep], face[keep], sr[keep], sc[keep]
    fz = sl.z[fp]
    nf = np.bincount(face, minlength=len(sil))
    ends = np.cumsum(nf)
    face_h = [_median(fz[a:b]) for a, b in zip((ends - nf).tolist(), ends.tolist())]
    # level? the plane fit of the face's core (within half the tolerance of its height): a top face's pixels include
    # a band of its own side faces within the tolerance, which tilts a fit of them all
    core = np.abs(fz - np.repeat(np.array(face_h, np.float32), nf)) <= 0.5 * face_tolerance_mm
    cf = face[core]
    slopes = _face_slopes(np.bincount(cf, minlength=len(sil)), sr[core] - y[cf], sc[core] - x[cf], fz[core])

    (wy, wx), r = found[2], sl.region[slot]
    ox, oy = reg.x0[r] - sl.left[slot] - 1 + wx, reg.y0[r] - sl.top[slot] - 1 + wy   # atlas -> map
    faces: list[Face] = []
    for f in np.lexsort((sil, slot)).tolist():                          # one box at a time
        if slopes[f] > max_slope_mm:                                     # a band of a side face
            continue
        fx, fy, fwid, fhei = int(x[f]), int(y[f]), int(w[f]), int(hh[f])
        silhouette = sl.parts[fy:fy + fhei, fx:fx + fwid] == sil[f]
        faces.append(Face((int(ox[f]) + fx, int(oy[f]) + fy, fwid, fhei),
                          silhouette & sl.opened[fy:fy + fhei, fx:fx + fwid], face_h[f], silhouette))
    return faces
