"""detect_blocks: coloured cubes (and distractors) on the board from an aligned RGB-D frame.

Pipeline: depth -> world height of every pixel (the calibrated camera) -> mask off-board pixels and the arm (its
pose projected into the image) -> flat top faces (segment.py) -> per face: world footprint (minimum-area rectangle
of the face's world points) for centre, edge and yaw; shape check (cube or distractor); colour (color.py).
Positions: world mm of the top-face centre; yaw in [-pi/4, pi/4) rad about world +z.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import cv2
import numpy as np

from armlab.camera import Camera
from armlab.detection.color import ColorModel, default_color_model, white_balance_gains
from armlab.detection.heightmap import height_from_depth, pixels_to_plane, reduced_coefficients, world_coefficients
from armlab.detection.masks import arm_mask
from armlab.detection.segment import Face, segment_faces
from armlab.images import check_depth, check_rgb
from armlab.lab import lab_config
from armlab.transforms import wrap_quarter

__all__ = ["Block", "detect_blocks", "detect_objects", "DetectionSettings", "stack_levels"]


@dataclass(frozen=True)
class Block:
    """A detected object's top face.

    color: one of the six block colours (nearest class), size: "large" or "small", position: (3,) world mm of the
    top-face centre, yaw: rad in [-pi/4, pi/4), pixel: (u, v) of the face centre, edge_mm: measured edge,
    shape: "cube" or "distractor", levels: how many blocks high the stack under this face is (top z / edge),
    color_margin: how clearly the colour won (larger is surer), contour: (K, 2) image outline of the face,
    mean_rgb: (3,) the face's mean colour as recorded, white_balance: (3,) the frame's gains from the board (the
    colour model classifies mean_rgb * white_balance).
    """

    color: str
    size: str
    position: np.ndarray
    yaw: float
    pixel: tuple[float, float]
    edge_mm: float
    shape: str = "cube"
    levels: int = 1
    color_margin: float = 0.0
    contour: np.ndarray = field(default=None, repr=False)
    mean_rgb: np.ndarray = field(default=None, repr=False)
    white_balance: np.ndarray = field(default=None, repr=False)

    @property
    def is_block(self) -> bool:
        return self.shape == "cube"


@dataclass(frozen=True)
class DetectionSettings:
    """Thresholds (mm unless noted). min_height: objects rise at least this above the board (half a small cube);
    max_height: higher pixels are the arm or a hand; size_split: edges above are "large" (25 vs 38 mm cubes);
    cube_edge_range: plausible cube edges; min_rectangularity: face area / its minimum rectangle (a square is 1,
    a disc 0.79, a triangle 0.5); max_aspect: longest / shortest side of a cube face; board_margin: ignore this
    much of the board's border; level_tolerance: a face's height must be within this of a stack of the lab's
    pieces (sums of the block edges), which rejects the oblique side faces near the image border;
    edge_tolerance: a cube's measured edge is within this of one of the lab's block edges;
    max_levels: the tallest stack (blocks) a face may top: faces at no height of such a stack are not reported,
    so raise it (and max_height) for towers (the "to the sky" event);
    min_face_pixels: fewest full-resolution pixels of a face (80: a small triangle or arch, 25 mm, far out on the
    board keeps fewer than 120 once the segmentation's median and opening have taken its corners and legs); step:
    segmentation works on every step-th pixel (each face is then measured at full resolution)."""

    min_height: float = 10.0
    max_height: float = 260.0
    size_split: float = 31.5
    cube_edge_range: tuple[float, float] = (19.0, 46.0)
    min_rectangularity: float = 0.8
    max_aspect: float = 1.15
    board_margin: float = 5.0
    min_face_pixels: int = 80
    step: int = 2
    level_tolerance: float = 4.0
    edge_tolerance: float = 4.0
    max_levels: int = 6

    def __post_init__(self):
        if not isinstance(self.max_levels, int) or self.max_levels < 1:
            raise ValueError(f"DetectionSettings.max_levels must be a positive integer, got {self.max_levels!r}")
        if not isinstance(self.step, int) or self.step < 1:
            raise ValueError(f"DetectionSettings.step must be a positive integer, got {self.step!r}")
        if not 0 < self.min_height < self.max_height:
            raise ValueError(f"DetectionSettings needs 0 < min_height < max_height, got {self.min_height}, "
                             f"{self.max_height}")


def stack_levels(top_z: float, edge_mm: float, edges=None, max_levels: int = 6) -> int:
    """How many blocks high a stack is whose top block (edge `edge_mm`) has its top face at `top_z` (mm).

    The stack is the top block over blocks at least as large (the lab stacks larger blocks below): the count of
    large and small blocks whose heights add up closest to top_z, the fewer blocks on a near tie (< 1.5 mm)."""
    edges = tuple(sorted((edges or lab_config().block_edges_mm).values(), reverse=True))
    below = top_z - edge_mm
    large_top = edge_mm > edges[-1] + 0.5 * (edges[0] - edges[-1])
    best_err, best_levels = np.inf, 1
    for height, levels in _stack_candidates(edges, max_levels, large_top):
        err = abs(below - height)
        if err < best_err - 1.5 or (abs(err - best_err) <= 1.5 and levels < best_levels):
            best_err, best_levels = err, levels
    return best_levels


@functools.lru_cache(maxsize=16)
def _stack_candidates(edges: tuple, max_levels: int, large_top: bool) -> tuple[tuple[float, int], ...]:
    """The (height below the top block, levels) of every stack stack_levels weighs, in its order of trial: large
    edges[0] and small edges[-1] blocks under the top one (no small one under a large top)."""
    return tuple((n_big * edges[0] + n_small * edges[-1], 1 + n_big + n_small)
                 for n_big in range(max_levels) for n_small in range(max_levels - n_big)
                 if not (n_small and large_top))


@functools.lru_cache(maxsize=4)
def _stack_heights(max_levels: int = 6, include_zero: bool = False) -> np.ndarray:
    """Every height (mm) a top face can have: sums of 1..max_levels of the lab's block edges (and 0 if asked: the
    heights a block can stand on)."""
    a, b = lab_config().block_edges_mm.values()
    return np.array(sorted({i * a + j * b for i in range(max_levels + 1) for j in range(max_levels + 1 - i)
                            if i + j > 0 or include_zero}))


class _Frame:
    """Per-frame data shared by the faces: images, the camera's per-pixel world rays, the arm mask (reduced
    resolution) and the reduction step."""

    def __init__(self, rgb, depth, camera, arm_small, step):
        self.rgb, self.depth, self.camera, self.arm_small, self.step = rgb, depth, camera, arm_small, step
        self.kz = world_coefficients(camera)[2]
        self.tz = np.float32(camera.T_world_cam[2, 3])


_SUM3 = np.ones((1, 3))                     # cv2.transform: the sum of three channels
_SQUARE3, _SQUARE5, _SQUARE7 = (np.ones((k, k), np.uint8) for k in (3, 5, 7))   # morphology kernels
STANDING_RISE_MM = 3.0    # a pixel not of a face's colour this far above it is something standing on the face
FACE_COLOR_LEVEL = 3.5    # a pixel this near the face's core colour (distance in core spreads) has the face's colour
BELOW_FACE_MM = 10.0      # a pixel this far below a face's height is not on it (the board, a lower face)
OCCLUDER_RISE_MM = 8.0    # a pixel this far above a face's height hides it (the arm, a block standing over it)
STANDING_KERNEL = np.ones((9, 9), np.uint8)   # outline points within 4 px of such a pixel are not the face's edge
ARM_MAX_LEVEL = 110    # the RX200 is black: its pixels are dark (max channel below this, 8-bit) ...
ARM_MAX_CHROMA = 22    # ... and grey (max - min channel below this), unlike every block colour's top face


def _arm_coloured(rgb: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels dark and grey enough to be the arm (used only inside the arm's projected mask)."""
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    hi = np.maximum(np.maximum(r, g), b)       # element-wise: far faster than a reduction over the last axis
    lo = np.minimum(np.minimum(r, g), b)
    return (hi < ARM_MAX_LEVEL) & (hi - lo < ARM_MAX_CHROMA)


def _board_white_balance(rgb: np.ndarray, height_small: np.ndarray, valid: np.ndarray, step: int) -> np.ndarray:
    """Gains from the board's own pixels (flat, near z = 0), sampled sparsely."""
    h = height_small[::4, ::4]
    with np.errstate(invalid="ignore"):
        sample = valid[::4, ::4] & (h < 4.0) & (h > -4.0)
    n = int(np.count_nonzero(sample))
    if n < 100:
        return np.ones(3)
    # the printed grid and tags are dark: use the bright majority of the board (brightness R + G + B at or above
    # its 40th percentile, linearly interpolated as numpy's percentile)
    sub = rgb[::4 * step, ::4 * step].astype(np.float32)
    total = cv2.transform(sub, _SUM3)
    values = total[sample]
    q = 0.4 * (n - 1)
    lo = int(q)
    hi = min(lo + 1, n - 1)
    part = np.partition(values, [lo, hi])
    threshold = part[lo] + (q - lo) * (part[hi] - part[lo])
    bright = (sample & (total >= threshold)).view(np.uint8)
    return white_balance_gains(np.array(cv2.mean(sub, mask=bright)[:3]))


def _refine_by_colour(face: Face, f: _Frame, pad: int = 6):
    """The face's full-resolution pixels by colour. The top face is evenly lit and brighter than the shaded sides, so
    pixels near the depth-seeded face whose colour matches the face's core colour, and that are not clearly below
    the face, form the face. Returns the refined mask (uint8), the patch origin (x0, y0), the core's mean colour,
    the occluders of the patch (bool): pixels clearly above the face (what stands on it, or the arm), the pixels of
    what stands on it that rise less (bool: not of the face's colour, above it by more than STANDING_RISE_MM, not
    occluders: the foot of a block's side faces), and the patch's colour distance to the core colour (float32, in
    core spreads: small on the face, large off it)."""
    s = f.step
    x, y, w, h = (v * s for v in face.bbox)
    H, W = f.depth.shape
    x0, y0, x1, y1 = max(0, x - pad), max(0, y - pad), min(W, x + w + pad), min(H, y + h + pad)
    seed = np.zeros((y1 - y0, x1 - x0), np.uint8)
    big = face.mask.view(np.uint8)
    if s > 1:
        big = cv2.resize(big, None, fx=s, fy=s, interpolation=cv2.INTER_NEAREST)   # each sample becomes s x s
    seed[y - y0:y - y0 + big.shape[0], x - x0:x - x0 + big.shape[1]] = big[:y1 - y, :x1 - x]
    core = cv2.erode(seed, _SQUARE7)
    rgb = f.rgb[y0:y1, x0:x1]
    if cv2.countNonZero(core) >= 20:
        mean, spread = (v.ravel() for v in cv2.meanStdDev(rgb, mask=core))
    else:
        # a thin face (the ring of a block under a smaller one): no core survives the erosion and the seed's pixels
        # mix in the neighbours' colours (the block on it, the face's own shaded sides), so the colour is the seed's
        # median and the spread its median absolute deviation (as a standard deviation)
        pixels = rgb[seed.view(bool)].astype(np.float32)
        mean = np.median(pixels, axis=0)
        spread = 1.4826 * np.median(np.abs(pixels - mean), axis=0)
    spread = np.maximum(spread, 4.0)
    # the colour distance in core spreads: one affine transform per channel, then the root of the squares' sum
    affine = np.zeros((3, 4))
    affine[[0, 1, 2], [0, 1, 2]] = 1 / spread
    affine[:, 3] = -mean / spread
    scaled = cv2.transform(rgb.astype(np.float32), affine)
    distance = cv2.sqrt(cv2.transform(scaled * scaled, _SUM3))
    height = f.depth[y0:y1, x0:x1] * f.kz[y0:y1, x0:x1] + f.tz
    no_return = np.isnan(height)
    cv2.patchNaNs(height, face.height_mm)        # no return: neither below nor above
    height = cv2.medianBlur(height, 5)
    not_below = height > face.height_mm - BELOW_FACE_MM
    occluder = height > face.height_mm + OCCLUDER_RISE_MM
    if f.arm_small is not None:
        arm = f.arm_small[(y0 // s):(y1 + s - 1) // s, (x0 // s):(x1 + s - 1) // s]
        if arm.any():
            if s > 1:
                arm = cv2.resize(arm.view(np.uint8), None, fx=s, fy=s, interpolation=cv2.INTER_NEAREST)
            arm = arm.view(bool)[y0 % s:, x0 % s:][:y1 - y0, :x1 - x0]
            # the arm's dark grey is never the face; it hides the face where it is above it (occluder, from the
            # heights) or where it gave no return (unless the pixel has the face's colour: a dark face's dropouts)
            arm = arm & _arm_coloured(rgb)
            not_below &= ~arm
            occluder |= arm & no_return & (distance >= FACE_COLOR_LEVEL)
    candidate = ((distance < FACE_COLOR_LEVEL) & not_below).astype(np.uint8)
    # what stands on the face: pixels not of its colour that rise above it (a block's side faces rise from the face,
    # so they are above it by less than `occluder` asks right next to it)
    standing = (height > face.height_mm + STANDING_RISE_MM) & ~occluder & (distance >= FACE_COLOR_LEVEL)
    n, labels = cv2.connectedComponents(candidate, connectivity=4)
    if n <= 1:
        return seed, (x0, y0), mean, occluder, standing, distance
    overlap = np.bincount(labels[seed.view(bool)], minlength=n)
    overlap[0] = 0
    mask = (labels == int(np.argmax(overlap))).astype(np.uint8)
    return cv2.morphologyEx(mask, cv2.MORPH_CLOSE, _SQUARE3), (x0, y0), mean, occluder, standing, distance


def _edge_direction(points: np.ndarray, theta: float, span: int = 4, free: np.ndarray | None = None) -> float:
    """The square's yaw (rad) from its outline (N, 2) mm: the mean of the outline's chord directions with the
    angles multiplied by four (a square's four sides then agree), weighted by chord length; chords around the
    corners (more than 20 deg off `theta`, the minimum-area rectangle's angle) are left out, and so are chords with
    an end that is not `free` (N,) bool (next to an occluder), when given."""
    if len(points) < 4 * span:
        return theta
    d = np.concatenate([points[span:], points[:span]]) - points      # chords to the point `span` ahead
    z = d[:, 0] + 1j * d[:, 1]
    length = np.abs(z)
    quad = (z / np.where(length > 0, length, 1.0)) ** 4              # unit vectors at four times the chord angles
    w = length * ((quad * np.exp(-4j * theta)).real > np.cos(np.radians(80)))
    if free is not None:
        w = w * (free & np.concatenate([free[span:], free[:span]]))
    if w.sum() <= 0:
        return theta
    return float(np.angle((w * quad).sum()) / 4)


def _fit_square(points: np.ndarray, blocked: np.ndarray, pixel_mm: float, edge_hint: float | None,
                edges=(25.0, 38.0)):
    """Centre (2,), side lengths (2,) mm and angle (rad) of the rectangle of a face's world outline (N, 2) mm.

    Outline points next to an occluder (`blocked`) are not the face's edge: when there are any, the rectangle's
    orientation comes from the free points, and along each side direction the centre is set from the edges the
    free points show (both: their middle; one: half an edge, `edge_hint`, inside it). With no hint (None), the edge
    is the lab edge (`edges`, mm) nearest to a side length the free points show whole (else the largest)."""
    if blocked.sum() > 0.8 * len(points) or len(points) - blocked.sum() < 12:
        blocked = np.zeros(len(points), bool)   # too little free outline to tell: measure the whole outline
    free = points[~blocked] if blocked.any() else points
    (cx, cy), (w, h), angle = cv2.minAreaRect(free.astype(np.float32))
    # The outline runs through the centres of the boundary pixels: half a pixel inside the true edge on each side.
    sides = np.array([w, h]) + pixel_mm
    theta = np.radians(angle)
    if not blocked.any() or blocked.mean() < 0.02:
        return np.array([cx, cy]), sides, _edge_direction(points, theta), True
    axes = np.array([[np.cos(theta), np.sin(theta)], [-np.sin(theta), np.cos(theta)]])
    local = (free - [cx, cy]) @ axes.T
    centre_local = np.zeros(2)
    complete = True
    lo, hi = local.min(axis=0), local.max(axis=0)
    n_lo, n_hi = np.sum(local < lo + 1.5, axis=0), np.sum(local > hi - 1.5, axis=0)
    both = (np.minimum(n_lo, n_hi) >= 0.4 * np.maximum(n_lo, n_hi)) & (hi - lo > 0.85 * min(edges))
    if edge_hint is None and both.any():   # a side seen whole: the face's edge is the lab edge nearest to it
        seen = float(np.max((hi - lo)[both])) + pixel_mm
        edge_hint = min(edges, key=lambda e: abs(e - seen))
    elif edge_hint is None:
        edge_hint = max(edges)
    for i in range(2):
        if both[i] and hi[i] - lo[i] > 0.85 * edge_hint:
            centre_local[i] = (lo[i] + hi[i]) / 2
        else:
            complete = False
            centre_local[i] = (lo[i] + (edge_hint - pixel_mm) / 2 if n_lo[i] >= n_hi[i]
                               else hi[i] - (edge_hint - pixel_mm) / 2)
            sides[i] = edge_hint
    return np.array([cx, cy]) + centre_local @ axes, sides, theta, complete


EDGE_SEARCH_MM = 3.5    # the side refinement looks this far inside and outside each fitted side
CUBE_SIZE_SLACK = (2.0, 0.15)   # a face this near (edge mm, aspect) to cube-sized by its colour outline is refined and
                                # judged again on its image edges (the outline can take or leave a boundary pixel)
EDGE_STEP_MM = 0.5      # sampling step across a side
EDGE_SAMPLES = 21       # profiles along each side (its middle 80 %: corners are rounded by blur)
EDGE_FIT_TOL = 0.6      # edge points farther than this (mm) from a side's first line fit are left out of the refit
EDGE_QUANT_PX = 12 ** -0.5   # an edge's position error from the pixel grid (px, a uniform one-pixel step's spread)
SEEN_SIDE_VAR = 1.4         # a side whose own side face is in view beyond it: its slope's variance counts 1.4 times
                            # (measured: its squared slope error over its variance is 1.4 times a silhouette's, on
                            # seeds 300-315 with the renderer filling faces by pixel centre)
EDGE_LEVEL = FACE_COLOR_LEVEL   # the face ends where the colour distance to its core colour first reaches this
_PROFILE_T = np.linspace(-0.8, 0.8, EDGE_SAMPLES)
_PROFILE_S = np.arange(-EDGE_SEARCH_MM, EDGE_SEARCH_MM + 1e-9, EDGE_STEP_MM)


def _plane_homographies(camera: Camera, centres, z, reach) -> np.ndarray:
    """(F, 3, 3) homographies from world (x, y) on the planes z (F,) mm to pixels, each exact at four points `reach`
    (F,) mm around its centre (F, 2): the pinhole part of a plane's image is a homography, and the lens distortion
    over a block's few centimetres is smooth enough that the four-point fit stays within a hundredth of a pixel. One
    projection of four points per plane instead of one per sample."""
    centres = np.asarray(centres, float).reshape(-1, 2)
    n = len(centres)
    z, reach = np.broadcast_to(np.asarray(z, float), (n,)), np.broadcast_to(np.asarray(reach, float), (n,))
    square = centres[:, None] + reach[:, None, None] * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float)
    uv = camera.project(np.column_stack([square.reshape(-1, 2), np.repeat(z, 4)])).reshape(n, 4, 2)
    return np.array([cv2.getPerspectiveTransform(sq.astype(np.float32), p.astype(np.float32))
                     for sq, p in zip(square, uv)]).reshape(n, 3, 3)


def _line_fits(t: np.ndarray, y: np.ndarray, w: np.ndarray):
    """Least-squares lines y = a + b t through the rows of t, y (S, M) using the points where w (S, M) bool: slopes b
    (S,), intercepts a (S,), point counts n (S,), spread of the used t (S,) and sum of squared t deviations (S,)."""
    n = w.sum(axis=1)
    nz = np.maximum(n, 1)
    tm = np.where(w, t, 0.0).sum(axis=1) / nz
    ym = np.where(w, y, 0.0).sum(axis=1) / nz
    dt = np.where(w, t - tm[:, None], 0.0)
    sxx = (dt * dt).sum(axis=1)
    b = (dt * np.where(w, y - ym[:, None], 0.0)).sum(axis=1) / np.maximum(sxx, 1e-9)
    spread = np.where(w, t, -np.inf).max(axis=1) - np.where(w, t, np.inf).min(axis=1)
    return b, ym - b * tm, n, np.where(n > 0, spread, 0.0), sxx


def _edge_offsets(prof: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where the face ends along each profile (..., K) sampled at offsets s (K,) mm: the first sample whose colour
    distance reaches EDGE_LEVEL finds the edge, which is then placed half-way between the face's level (inside) and
    the level just beyond (within 1.5 mm), linearly interpolated: the middle of a blurred step, whatever lies beyond
    it (board, grid line, the face's own shaded side). Returns the offsets (...) mm and whether each was found."""
    shape, K = prof.shape[:-1], prof.shape[-1]
    p = prof.reshape(-1, K)
    finite = np.isfinite(p).all(axis=-1)
    p = np.where(finite[:, None], p, 0.0)
    k = (p >= EDGE_LEVEL).argmax(axis=-1)
    ok = finite & (k > 0)
    rows = np.arange(len(p))
    reach = int(round(1.5 / EDGE_STEP_MM))
    # inside: the least level before sample k (a running minimum); beyond: the greatest within reach from k on
    inside = np.where(k > 0, np.minimum.accumulate(p, axis=-1)[rows, np.maximum(k - 1, 0)], np.inf)
    padded = np.concatenate([p, np.full((len(p), reach), -np.inf, p.dtype)], axis=-1)
    window = padded[:, :K].copy()
    for d in range(1, reach + 1):
        np.maximum(window, padded[:, d:d + K], out=window)
    beyond = window[rows, k]
    with np.errstate(invalid="ignore"):
        half = np.where(ok, 0.5 * (inside + beyond), EDGE_LEVEL)
    m = np.maximum((p >= half[:, None]).argmax(axis=-1), 1)
    p0, p1 = p[rows, m - 1], p[rows, m]
    frac = np.minimum(np.maximum((half - p0) / np.where(p1 > p0, p1 - p0, 1.0), 0.0), 1.0)
    return (s[0] + EDGE_STEP_MM * (m - 1 + frac)).reshape(shape), ok.reshape(shape)


@dataclass
class _Measured:
    """One face measured on its own (before the batched refinement): the fitted square (centre (2,) mm, sides (2,) mm,
    theta rad; the refinement moves them onto the image edges), whether the outline was complete and the face
    cube-sized (before the refinement: near enough to be refined and judged again), the square fitted to the colour
    outline itself (outline_centre, outline_sides: what the outline's rectangularity is measured against), and what the
    refinement and the Block need."""

    face: Face
    centre: np.ndarray
    sides: np.ndarray
    theta: float
    complete: bool
    cube_sized: bool
    outline: np.ndarray
    outline_centre: np.ndarray
    outline_sides: np.ndarray
    blocked: np.ndarray
    pixel_mm: float
    contour: np.ndarray
    mean_rgb: np.ndarray
    feature: np.ndarray
    near: np.ndarray
    origin: tuple[int, int]
    plane_z: float


def _refine_yaws(camera: Camera, faces: list[_Measured], iterations: int = 3) -> np.ndarray:
    """The faces' yaws (F,) rad refined on the full-resolution image edges of their top faces, all faces at once.

    Across each side of a face's fitted square, profiles of the colour distance to the face's colour (EDGE_SAMPLES
    positions t along the side, offsets s across it) give edge points (_edge_offsets); each side's points get a line
    fit s = a + b t (points more than EDGE_FIT_TOL off the first fit dropped, then refitted), whose slope says how far
    the side is turned: a square turned by d (counterclockwise) puts its side at s = -d t. A face's turn is the mean
    of its sides' turns weighted by the inverse variance of their slopes: the fit's own variance plus the pixel grid's
    (EDGE_QUANT_PX px over the side's length: the renderer and the sensor draw edges on whole pixels, so a side turned
    by less than a pixel over its length looks straight and its residuals say nothing of it), and SEEN_SIDE_VAR times
    that for a side whose own side face is in view beyond it (a softer edge against a face of the same colour, seen
    to err a little more than a silhouette against the board). Sharp, long, unhidden silhouettes count most and sides
    next to occluders not at all. A face keeps its yaw when no side shows a usable edge, or only one side whose own
    side face is in view beyond it or with fewer than 8 edge points. The result is the middle of the last two
    iterations' yaws. The fits' intercepts a (where each side's edge is, at its middle) also move the squares: every
    iteration, a pair of opposite sides that both show an edge sets the face's centre and side length along them, and
    the faces' centre and sides are left at the last iteration's (in place)."""
    n_faces = len(faces)
    if n_faces == 0:
        return np.zeros(0)
    centre = np.array([m.centre for m in faces], float)
    theta = np.array([m.theta for m in faces], float)
    half = np.array([m.sides for m in faces], float) / 2
    dist = half[:, [0, 1, 0, 1]]                                           # (F, 4) centre to side
    t = _PROFILE_T[None, None] * half[:, [1, 0, 1, 0], None]               # (F, 4, M) along each side
    s = _PROFILE_S
    # one plane homography per face (world (x, y) at the face's height -> pixels), from one projection of all faces'
    # corner points; then into an atlas that stacks the faces' patches (feature and occluder masks) with gaps, so
    # that each iteration samples every face in one remap
    homographies = _plane_homographies(camera, centre, [m.plane_z for m in faces],
                                       half.max(axis=1) + EDGE_SEARCH_MM)
    gap = 4                                                                # >= 3 px
    shapes = np.array([m.feature.shape for m in faces])
    top = gap + np.concatenate([[0], np.cumsum(shapes[:, 0] + gap)[:-1]])
    feature = np.full((int(top[-1] + shapes[-1, 0] + gap), int(shapes[:, 1].max() + 2 * gap)), np.nan, np.float32)
    near = np.ones(feature.shape, np.uint8)
    for i, m in enumerate(faces):
        h, w = m.feature.shape
        feature[top[i]:top[i] + h, gap:gap + w] = m.feature
        near[top[i]:top[i] + h, gap:gap + w] = m.near
        homographies[i, :2] -= np.outer(m.origin, homographies[i, 2])     # pixels of the face's patch
    size = (shapes[:, ::-1] + 0.5).astype(np.float32)                      # (F, 2) patch width, height + 0.5
    shift = np.column_stack([np.full(n_faces, gap), top]).astype(np.float32)   # (F, 2) patch origin in the atlas
    s32, t32 = s.astype(np.float32), t.astype(np.float32)
    prof = np.empty((n_faces, 4, len(_PROFILE_T), len(s)), np.float32)
    pixel_mm = np.repeat([m.pixel_mm for m in faces], 4)
    for _ in range(iterations):
        ang = theta[:, None] + np.arange(4) * (np.pi / 2)
        normal = np.stack([np.cos(ang), np.sin(ang)], axis=-1)            # (F, 4, 2) outward
        tangent = np.stack([-normal[..., 1], normal[..., 0]], axis=-1)
        # the samples' world points c + (dist + s) n + t tangent are affine in (s, t): so are their homogeneous
        # pixels, H [c + dist n, 1] + s H [n, 0] + t H [tangent, 0]
        base = np.concatenate([centre[:, None] + dist[..., None] * normal, np.ones((n_faces, 4, 1))], axis=-1)
        f32 = np.float32                # patch pixels are small numbers: float32 is exact to 1e-5 px
        hb = np.einsum("fij,faj->fai", homographies, base).astype(f32)     # (F, 4, 3)
        hn = np.einsum("fij,faj->fai", homographies[:, :, :2], normal).astype(f32)
        ht = np.einsum("fij,faj->fai", homographies[:, :, :2], tangent).astype(f32)
        hom = (hb[:, :, None, None] + s32[:, None] * hn[:, :, None, None]
               + t32[..., None, None] * ht[:, :, None, None])             # (F, 4, M, K, 3)
        px = hom[..., :2] / hom[..., 2:]                                   # patch pixels
        # a sample off its patch reads the atlas's gap around the patch, NaN (feature) and 1 (occluded), as the
        # border of a remap of the patch alone would: clipped to 1.5 px (linear) / 1 px (nearest) off the patch
        np.minimum(np.maximum(px, f32(-1.5), out=px), size[:, None, None, None], out=px)
        px += shift[:, None, None, None]
        px = px.reshape(-1, len(s), 2)
        p = cv2.remap(feature, px, None, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=np.nan)
        hidden = cv2.remap(near, px, None, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=1)
        p[hidden > 0] = np.nan
        prof[:] = p.reshape(prof.shape)
        edge, ok = _edge_offsets(prof, s)
        mid = centre[:, None] + normal * dist[..., None]
        sees_side = np.einsum("fij,fij->fi", normal, camera.position[:2] - mid) > 0
        tt, ee, okk = (x.reshape(-1, t.shape[-1]) for x in (t, edge, ok))
        b, a, _, _, _ = _line_fits(tt, ee, okk)
        use = okk & (np.abs(ee - (a[:, None] + b[:, None] * tt)) <= EDGE_FIT_TOL)
        b, a, n, spread, sxx = _line_fits(tt, ee, use)
        r = np.where(use, ee - (a[:, None] + b[:, None] * tt), 0.0)
        sigma = np.maximum(np.sqrt((r * r).sum(axis=1) / np.maximum(n - 2, 1)), 0.1)
        good = ((n >= 5) & (spread >= 4.0)).reshape(n_faces, 4)
        turns = -np.arctan(b).reshape(n_faces, 4)
        # each side's slope variance: the fit's own (its residuals) plus the pixel grid's, which a straight-looking
        # staircase hides (a side turned less than a pixel over its length renders as a straight edge)
        var = sigma ** 2 / np.maximum(sxx, 1e-9) + (EDGE_QUANT_PX * pixel_mm / np.maximum(spread, 1e-9)) ** 2
        weights = np.where(good, 1.0 / (var.reshape(n_faces, 4) * np.where(sees_side, SEEN_SIDE_VAR, 1.0)), 0.0)
        n_good = good.sum(axis=1)
        fewest = np.where(good, n.reshape(n_faces, 4), 99).min(axis=1)
        lone = (n_good == 1) & ((good & sees_side).any(axis=1) | (fewest < 8))
        total = weights.sum(axis=1)
        turn = (np.where(good, turns, 0.0) * weights).sum(axis=1) / np.maximum(total, 1e-12)
        # the sides where they are: a pair of opposite sides that both show an edge moves the centre to their middle
        # and sets the side length between them (the edges' sub-pixel positions: unbiased, unlike the colour
        # outline, whose threshold leaves out the blurred boundary pixel on a side against the board)
        a4 = a.reshape(n_faces, 4)
        pair = good[:, :2] & good[:, 2:]                                   # (F, 2) sides 0 + 2, 1 + 3
        move = np.where(pair, 0.5 * (a4[:, :2] - a4[:, 2:]), 0.0)
        centre = centre + move[:, 0, None] * normal[:, 0] + move[:, 1, None] * normal[:, 1]
        dist = dist + np.where(pair, 0.5 * (a4[:, :2] + a4[:, 2:]), 0.0)[:, [0, 1, 0, 1]]
        previous, theta = theta, theta + np.where((n_good > 0) & ~lone & (total > 0), turn, 0.0)
    for m, c, d in zip(faces, centre, dist):
        m.centre, m.sides = c, 2 * d[:2]
    # the last step can swing between two readings of a jagged side: take the middle of the last two
    return 0.5 * (previous + theta) if iterations > 1 else theta


def _measure(face: Face, f: _Frame, settings: DetectionSettings) -> _Measured:
    """A face's outline, intersected with the horizontal plane at the face's height (its world footprint without the
    per-pixel depth noise), and the square fitted to it."""
    mask_u8, origin, mean_rgb, occluder, standing, feature = _refine_by_colour(face, f)
    contours, _ = cv2.findContours(mask_u8, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    contour = max(contours, key=cv2.contourArea).reshape(-1, 2)
    near = cv2.dilate(occluder.view(np.uint8), _SQUARE5)
    blocked = (near | cv2.dilate(standing.view(np.uint8), STANDING_KERNEL))[contour[:, 1], contour[:, 0]] > 0
    contour = contour + np.array(origin)
    # the face's plane: the height of the lab's stack nearest to its measured height (faces are kept only within
    # level_tolerance of one), which the depth reads a little low and, far out on the board, up to a few mm off; the
    # image outline and edges are intersected with it (a plane 3 mm off moves a point 3 mm x its distance from the
    # camera's nadir / the camera's height: 1-1.5 mm at the board's far corners)
    heights = _stack_heights(settings.max_levels)
    plane_z = float(heights[np.argmin(np.abs(heights - face.height_mm))])
    outline = pixels_to_plane(f.camera, contour, plane_z)[:, :2]
    cam = f.camera
    centre_guess = outline.mean(axis=0)
    pixel_mm = float((cam.T_cam_world[2, :2] @ centre_guess + cam.T_cam_world[2, 2] * plane_z
                      + cam.T_cam_world[2, 3]) / cam.K[0, 0])                     # the face's depth / fx
    edges = lab_config().block_edges_mm
    # a hint for the edge when part of the face is hidden: the size whose stacks reach this height best (None when
    # both sizes' stacks reach it within 1.5 mm, as 3 x 25 and 2 x 38 do: then the free outline decides)
    sizes = tuple(edges.values())
    below = face.height_mm - np.array(sizes)[:, None] - _stack_heights(settings.max_levels, include_zero=True)
    misfit = dict(zip(sizes, np.abs(below).min(axis=1).tolist()))
    hint = min(misfit, key=misfit.get)
    if max(misfit.values()) - min(misfit.values()) < 1.5:
        hint = None
    centre_xy, sides, theta, complete = _fit_square(outline, blocked, pixel_mm, hint, tuple(edges.values()))
    centre_xy, sides = np.asarray(centre_xy, float), np.asarray(sides, float)
    return _Measured(face, centre_xy.copy(), sides.copy(), float(theta), bool(complete),
                     _cube_sized(sides, settings, CUBE_SIZE_SLACK), outline, centre_xy, sides, blocked, pixel_mm,
                     contour, mean_rgb, feature, near, origin, plane_z)


def _cube_sized(sides, settings: DetectionSettings, slack: tuple[float, float] = (0.0, 0.0)) -> bool:
    """Whether a face's square (sides (2,) mm) is a cube's: its edge (the root of the sides' product) within the
    settings' range and tolerance of a lab edge, its aspect at most max_aspect; each loosened by slack (mm, aspect)."""
    w, h = sides
    edge = float(np.sqrt(w * h))
    aspect = float(max(w, h) / max(min(w, h), 1e-6))
    lo, hi = settings.cube_edge_range
    nominal = min(abs(edge - e) for e in lab_config().block_edges_mm.values())
    return bool(lo - slack[0] <= edge <= hi + slack[0] and nominal <= settings.edge_tolerance + slack[0]
                and aspect <= settings.max_aspect + slack[1])


def _describe(measured: list[_Measured], f: _Frame, settings: DetectionSettings, color_model: ColorModel,
              gains: np.ndarray) -> list[Block]:
    """The Blocks of the measured faces (yaws already refined): shape check, size, colour, stack. The colours and
    pixels of all faces in one call each."""
    if not measured:
        return []
    names, margins = color_model.classify(np.array([m.mean_rgb * gains for m in measured]))
    centres = np.array([[m.centre[0], m.centre[1], m.face.height_mm] for m in measured], float)
    pixels = f.camera.project(centres)
    block_edges = lab_config().block_edges_mm
    out = []
    for m, name, margin, centre, (u, v) in zip(measured, names, margins, centres, pixels):
        (w, h), theta, centre_xy, pixel_mm = m.outline_sides, m.theta, m.outline_centre, m.pixel_mm
        edge = float(np.sqrt(np.prod(m.sides)))
        if m.complete:
            o32 = m.outline.astype(np.float32)
            area = cv2.contourArea(o32) + 0.5 * pixel_mm * cv2.arcLength(o32, True)
            rectangularity = float(area / (w * h)) if w * h > 0 else 0.0
        else:   # the free outline's distance to the fitted square's sides
            axes = np.array([[np.cos(theta), np.sin(theta)], [-np.sin(theta), np.cos(theta)]])
            local = np.abs((m.outline[~m.blocked] - centre_xy) @ axes.T)
            off = np.min(np.abs(local - (np.array([w, h]) - pixel_mm) / 2), axis=1)
            rectangularity = float(np.mean(off < 2.5))
        is_cube = m.cube_sized and rectangularity >= settings.min_rectangularity
        size = "large" if edge > settings.size_split else "small"
        out.append(Block(color=name, size=size, position=centre, yaw=float(wrap_quarter(theta)),
                         pixel=(float(u), float(v)),
                         edge_mm=edge, shape="cube" if is_cube else "distractor",
                         levels=stack_levels(m.face.height_mm, block_edges[size], max_levels=settings.max_levels),
                         color_margin=float(margin), contour=m.contour, mean_rgb=m.mean_rgb, white_balance=gains))
    return out


def _on_board(height_small: np.ndarray, valid: np.ndarray, f: _Frame, settings: DetectionSettings) -> np.ndarray:
    """`valid` without the raised pixels whose world (x, y) is off the board (margin) or over the robot's base.
    Only raised pixels are turned into world points: a fraction of the image."""
    idx = np.flatnonzero(valid & (height_small > settings.min_height))
    if len(idx) == 0:
        return valid
    s = f.step
    rows, cols = np.divmod(idx, valid.shape[1])
    k = reduced_coefficients(f.camera, s).reshape(3, -1) if s > 1 else world_coefficients(f.camera).reshape(3, -1)
    z = f.depth[rows * s, cols * s]
    t = f.camera.T_world_cam[:3, 3]
    xy = np.stack([k[0, idx] * z + t[0], k[1, idx] * z + t[1]], axis=-1)
    cfg = lab_config()
    m = settings.board_margin
    bad = ((xy[:, 0] < cfg.board_x[0] + m) | (xy[:, 0] > cfg.board_x[1] - m) | (xy[:, 1] < cfg.board_y[0] + m)
           | (xy[:, 1] > cfg.board_y[1] - m) | cfg.on_robot_base(xy, margin_mm=15.0))
    out = valid.copy()
    out.ravel()[idx[bad]] = False
    return out


def detect_objects(rgb, depth_mm, camera: Camera, arm_q=None, color_model: ColorModel | None = None,
                   settings: DetectionSettings | None = None) -> list[Block]:
    """Every object's top face: cubes and distractors (shape == "distractor"), nearest first from the robot.

    Args:
        rgb: (H, W, 3) uint8 RGB.
        depth_mm: (H, W) float depth in mm aligned to rgb (NaN = no return), already depth-corrected if you have a
            correction (calibration.DepthCorrection.apply).
        camera: the calibrated camera (intrinsics, distortion and T_cam_world).
        arm_q: the arm's joint angles (5,) rad, to mask the arm out (None: no arm masking).
        color_model: colour classes (default: data/color_model.json if present, else the lab's reference colours).
    Returns [] when the depth image holds no return at all. Raises ValueError for images of the wrong type or size.
    """
    rgb = check_rgb(rgb)
    depth = check_depth(depth_mm, rgb.shape[:2])
    if rgb.shape[:2] != camera.image_shape:
        raise ValueError(f"image is {rgb.shape[1]}x{rgb.shape[0]} but the camera is {camera.width}x{camera.height}")
    settings = settings or DetectionSettings()
    color_model = color_model or default_color_model()
    arm_small = None if arm_q is None else arm_mask(camera, arm_q, step=settings.step)
    f = _Frame(rgb, depth, camera, arm_small, settings.step)
    height = height_from_depth(depth, camera, settings.step)
    valid = height < settings.max_height            # False where there is no return (NaN)
    if not valid.any():      # no return (or nothing below max_height) among the sampled pixels: nothing to find
        return []
    if arm_small is not None:   # inside the arm's reach in the image, only the arm's own dark grey is masked
        rows, cols = np.flatnonzero(arm_small.any(axis=1)), np.flatnonzero(arm_small.any(axis=0))
        if len(rows):
            s, (r0, r1), (c0, c1) = settings.step, rows[[0, -1]], cols[[0, -1]]
            box = arm_small[r0:r1 + 1, c0:c1 + 1]
            box &= _arm_coloured(rgb[r0 * s:(r1 + 1) * s:s, c0 * s:(c1 + 1) * s:s])
        valid &= ~arm_small
    valid = _on_board(height, valid, f, settings)
    gains = _board_white_balance(rgb, height, valid, settings.step)
    faces = segment_faces(height, valid, settings.min_height,
                          min_face_pixels=max(8, settings.min_face_pixels // settings.step ** 2),
                          median_px=5 if settings.step == 1 else 3)
    heights = _stack_heights(settings.max_levels)
    faces = [face for face in faces if np.min(np.abs(heights - face.height_mm)) <= settings.level_tolerance]
    measured = [_measure(face, f, settings) for face in faces]
    # what cannot be a cube is not worth refining; what is near enough is judged again on its refined square
    cubes = [m for m in measured if m.cube_sized]
    for m, theta in zip(cubes, _refine_yaws(camera, cubes)):
        m.theta = float(theta)
        m.cube_sized = _cube_sized(m.sides, settings)
    found = _describe(measured, f, settings, color_model, gains)
    found.sort(key=lambda b: float(np.hypot(*b.position[:2])))
    return found


def detect_blocks(rgb, depth_mm, camera: Camera, arm_q=None, color_model: ColorModel | None = None,
                  settings: DetectionSettings | None = None) -> list[Block]:
    """The cubes on the board (distractors left out): see detect_objects for the arguments."""
    return [b for b in detect_objects(rgb, depth_mm, camera, arm_q, color_model, settings) if b.is_block]
