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

import cv2
import numpy as np

__all__ = ["Face", "segment_faces"]

_KERNEL = np.ones((3, 3), np.uint8)


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
    at [starts[c], starts[c] + counts[c]). Returns (component (L,), level (L,) mm), by component and, within one,
    ascending: the same values in the same order as _plateau_levels of each in turn.

    The histograms lie end to end with two empty bins between them, so one convolution smooths them all as
    np.convolve smooths each alone; a component whose histogram is shorter than the kernel (all its heights within
    one bin: np.convolve's "same" then returns the kernel's length) goes through _plateau_levels itself."""
    comp = np.repeat(np.arange(len(counts)), counts)
    lo = np.minimum.reduceat(heights, starts).astype(np.float64) - bin_mm             # float(min) - bin_mm
    bins = ((heights - lo.astype(np.float32)[comp]) / bin_mm).astype(np.intp)         # the float32 arithmetic
    lengths = np.maximum.reduceat(bins, starts) + 3                                   # of heights - lo
    offsets = np.cumsum(lengths + 2) - lengths                                        # two empty bins before each
    hist = np.bincount(offsets[comp] + bins, minlength=int(offsets[-1] + lengths[-1] + 2))
    smooth = np.convolve(hist, [1, 2, 3, 2, 1], mode="same")
    window = np.convolve(hist, [1, 1, 1], mode="same")
    # candidates: bins 1 .. length - 2 of each histogram of at least 5 bins
    long = lengths >= 5
    edge = np.zeros(len(hist) + 1, np.intp)
    np.add.at(edge, offsets[long] + 1, 1)
    np.add.at(edge, offsets[long] + lengths[long] - 1, -1)
    inner = np.cumsum(edge[:-1]) > 0
    inner[1:-1] &= (smooth[1:-1] >= smooth[:-2]) & (smooth[1:-1] > smooth[2:]) & (window[1:-1] >= min_pixels)
    peaks = np.flatnonzero(inner)
    of = np.searchsorted(offsets, peaks, side="right") - 1
    i = peaks - offsets[of]
    levels = 0.5 * ((lo[of] + bin_mm * i) + (lo[of] + bin_mm * (i + 1)))              # the bins' centres
    short = np.flatnonzero(~long)
    if len(short):
        extra = [(c, level) for c in short.tolist()
                 for level in _plateau_levels(heights[starts[c]:starts[c] + counts[c]], bin_mm, min_pixels)]
        of = np.concatenate([of, np.array([c for c, _ in extra], np.intp)])
        levels = np.concatenate([levels, np.array([level for _, level in extra], np.float64)])
        order = np.argsort(of, kind="stable")
        of, levels = of[order], levels[order]
    return of, levels


def _pack_boxes(heights: np.ndarray, widths: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """Places rectangles (B,) pixels high and wide side by side in shelves of an atlas (tallest first, so little is
    wasted), none overlapping. Returns their top rows (B,), left columns (B,) and the atlas's (height, width)."""
    width = max(int(widths.max()), int(np.ceil(np.sqrt(float(np.dot(heights, widths))))))
    top, left = np.empty(len(heights), np.intp), np.empty(len(heights), np.intp)
    x = y = shelf = 0
    for b in np.argsort(-heights, kind="stable").tolist():
        if x + widths[b] > width:
            x, y, shelf = 0, y + shelf, 0
        top[b], left[b] = y, x
        x, shelf = x + int(widths[b]), max(shelf, int(heights[b]))
    return top, left, (y + shelf, width)


def _paint_frames(shape: tuple[int, int], top: np.ndarray, left: np.ndarray, heights: np.ndarray,
                  widths: np.ndarray) -> np.ndarray:
    """An image of `shape` with 1 on the one-pixel rim of each rectangle (top, left, heights, widths: (B,) pixels,
    not overlapping) and 2 inside it, 0 elsewhere: corner marks of a 2-d difference image, summed along both axes."""
    corners = []
    for t, lf, b, r in ((top, left, top + heights, left + widths),
                        (top + 1, left + 1, top + heights - 1, left + widths - 1)):
        corners.append((np.concatenate([t, t, b, b]), np.concatenate([lf, r, lf, r]),
                        np.repeat([1, -1, -1, 1], len(t))))
    rows, cols, signs = (np.concatenate(parts) for parts in zip(*corners))
    marks = np.zeros((shape[0] + 1, shape[1] + 1), np.int32)
    np.add.at(marks, (rows, cols), signs)
    return marks.cumsum(axis=0).cumsum(axis=1)[:-1, :-1].astype(np.uint8)


def _open_each_box(on: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """cv2.MORPH_OPEN (3 x 3) of each box of an atlas (uint8 0/1 pixels; frames: _paint_frames's image) as if the box
    were an image of its own: OpenCV's erosion and dilation leave an image's border out, so the rim is 1 for the
    erosion (which takes minima) and 0 for the dilation (maxima). Returns the opened atlas (uint8 0/1) inside the
    boxes (the rims hold anything)."""
    inside = (frames == 2).view(np.uint8)
    eroded = cv2.erode(on | (frames == 1).view(np.uint8), _KERNEL)
    return cv2.dilate(eroded & inside, _KERNEL)


def _slope_of_centred(c: np.ndarray, r: np.ndarray, z: np.ndarray) -> float:
    """How steeply (mm per sample) the least-squares plane through heights z (n,) mm at columns c and rows r rises,
    all three centred (float64, n >= 3): the normal equations, a tenth of np.linalg.lstsq's cost (0 for pixels on
    one line)."""
    scc, srr, scr, scz, srz = c @ c, r @ r, c @ r, c @ z, r @ z
    det = scc * srr - scr * scr
    if det <= 1e-9 * scc * srr:
        return 0.0
    return float(np.hypot(srr * scz - scr * srz, scc * srz - scr * scz) / det)


def _face_slopes(face: np.ndarray, r: np.ndarray, c: np.ndarray, z: np.ndarray, n_faces: int) -> np.ndarray:
    """The plane fit's slope (mm per sample, 0 for fewer than three pixels) of each face's pixels: face (N,) their
    face's index (ascending), r, c (N,) int rows and columns in its box (raster order within a face), z (N,) float32
    heights mm. The same values as centring each face's coordinates and heights (np.mean) and calling
    _slope_of_centred: the means' sums are exact here in any order (integers; float32 heights >= 1 mm whose sum
    stays below 2**29, all multiples of 2**-23), else each face's np.mean; the dot products stay per face (BLAS's
    order)."""
    n = np.bincount(face, minlength=n_faces)
    z = z.astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_r = np.bincount(face, r, n_faces) / n
        mean_c = np.bincount(face, c, n_faces) / n
        mean_z = np.bincount(face, z, n_faces) / n
    ends = np.cumsum(n)
    bounds = list(zip((ends - n).tolist(), ends.tolist()))
    if len(z) and not (z.min() >= 1.0 and float(mean_z[n > 0].max() * n.max()) < 2.0 ** 29):
        mean_z = np.array([np.mean(z[a:b]) if b > a else np.nan for a, b in bounds])
    r, c, z = r - mean_r[face], c - mean_c[face], z - mean_z[face]
    return np.array([_slope_of_centred(c[a:b], r[a:b], z[a:b]) if b - a >= 3 else 0.0 for a, b in bounds])


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

    Each object region's plateau levels are one "slot": its bounding box (the region's pixels, the rest empty) with
    the level's masks. All slots are batched: the histograms in one convolution (_component_levels), the boxes in one
    atlas (_pack_boxes) opened (_open_each_box) and labelled by one OpenCV call each, the faces' pixels as flat
    lists; only the median and the plane fit's dot products run per face. The faces come in the order of one box at a
    time: by region (label), level (ascending), silhouette (OpenCV's raster order)."""
    h = np.zeros(np.shape(height_mm), np.float32)
    np.copyto(h, height_mm, where=valid & np.isfinite(height_mm), casting="unsafe")
    h = cv2.medianBlur(h, median_px)
    objects = h > min_height_mm
    n, labels = cv2.connectedComponents(objects.view(np.uint8), connectivity=4)
    if n <= 1:
        return []
    # the pixels of regions large enough for a face, by region, each in raster order, from the object pixels only
    # (a few percent of the map), without OpenCV's per-component statistics (5x the labelling's cost)
    idx = np.flatnonzero(objects)
    lab = labels.ravel()[idx]
    areas = np.bincount(lab, minlength=n)
    large = areas >= min_face_pixels
    large[0] = False
    keep = large[lab]
    if not keep.any():
        return []
    idx = idx[keep][np.argsort(lab[keep], kind="stable")]
    counts = areas[large]
    starts = np.cumsum(counts) - counts
    rows, cols = np.divmod(idx, h.shape[1])
    z = h.ravel()[idx]
    y0, x0 = np.minimum.reduceat(rows, starts), np.minimum.reduceat(cols, starts)
    box_h, box_w = np.maximum.reduceat(rows, starts) + 1 - y0, np.maximum.reduceat(cols, starts) + 1 - x0

    # slots: one per (region, plateau level), each a box with a one-pixel rim in the atlas
    region, level = _component_levels(z, starts, counts, 2.0, min_face_pixels // 2)
    if not len(level):
        return []
    sy, sx, sh, sw = y0[region], x0[region], box_h[region], box_w[region]
    top, left, shape = _pack_boxes(sh + 2, sw + 2)
    npix = counts[region]
    pix = np.arange(int(npix.sum())) + np.repeat(starts[region] - (np.cumsum(npix) - npix), npix)
    ar = rows[pix] + np.repeat(top + 1 - sy, npix)                       # the slots' pixels in the atlas
    ac = cols[pix] + np.repeat(left + 1 - sx, npix)
    zp = z[pix]
    on = np.abs(zp - np.repeat(level.astype(np.float32), npix)) < face_tolerance_mm
    above = zp > np.repeat((level - face_tolerance_mm).astype(np.float32), npix)

    atlas = np.zeros(shape, np.uint8)
    atlas[ar, ac] = on
    on = _open_each_box(atlas, _paint_frames(shape, top, left, sh + 2, sw + 2))[ar, ac].view(bool)   # no thin
    atlas[ar, ac] = above                                                                           # side bands
    m, parts, stats, _ = cv2.connectedComponentsWithStats(atlas, connectivity=4)
    part = parts[ar, ac]
    sil = np.flatnonzero(np.bincount(part[on], minlength=m) >= min_face_pixels)
    sil = sil[sil > 0]
    slot_of = np.zeros(m, np.intp)
    slot_of[part] = np.repeat(np.arange(len(level)), npix)
    sil = sil[np.lexsort((sil, slot_of[sil]))]                            # one box at a time
    if not len(sil):
        return []

    # each face's pixels (on its level and its silhouette), by face, in raster order
    face_of = np.full(m, -1, np.intp)
    face_of[sil] = np.arange(len(sil))
    fp = np.flatnonzero(on & (face_of[part] >= 0))
    fp = fp[np.argsort(face_of[part[fp]], kind="stable")]
    face, fz = face_of[part[fp]], zp[fp]
    nf = np.bincount(face, minlength=len(sil))
    ends = np.cumsum(nf)
    face_h = [_median(fz[a:b]) for a, b in zip((ends - nf).tolist(), ends.tolist())]
    # level? the plane fit of the face's core (within half the tolerance of its height): a top face's pixels include
    # a band of its own side faces within the tolerance, which tilts a fit of them all
    core = np.abs(fz - np.repeat(np.array(face_h, np.float32), nf)) <= 0.5 * face_tolerance_mm
    fx, fy, fw, fhh = (stats[sil, i] for i in range(4))
    cf = face[core]
    slopes = _face_slopes(cf, ar[fp][core] - fy[cf], ac[fp][core] - fx[cf], fz[core], len(sil))

    opened = np.zeros(shape, bool)
    opened[ar[on], ac[on]] = True
    faces: list[Face] = []
    slot = slot_of[sil]
    ox, oy = sx[slot] - left[slot] - 1, sy[slot] - top[slot] - 1        # atlas -> image
    for f in np.flatnonzero(~(slopes > max_slope_mm)).tolist():         # not a band of a side face
        x, y, w, hh = int(fx[f]), int(fy[f]), int(fw[f]), int(fhh[f])
        silhouette = parts[y:y + hh, x:x + w] == sil[f]
        faces.append(Face((int(ox[f]) + x, int(oy[f]) + y, w, hh), silhouette & opened[y:y + hh, x:x + w],
                          face_h[f], silhouette))
    return faces
