"""A top face's square: the fit to its outline (centre, sides, yaw from the outline's chords) and the sub-pixel
refinement of every cube's sides on the image edges (colour-distance profiles across each side, one batched pass
over all faces). Units: mm and rad in the world (board) frame, pixels.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from armlab.camera import Camera
from armlab.detection.colour_region import FACE_COLOR_LEVEL
from armlab.detection.segment import Face

__all__ = ["MeasuredFace", "fit_square", "edge_direction", "refine_yaws", "plane_homographies", "EDGE_LEVEL",
           "EDGE_SEARCH_MM", "CUBE_SIZE_SLACK"]


_CORNER_COS = np.cos(np.radians(80))   # edge_direction: chords within 20 deg of theta (80 deg at four times the angle)


def edge_direction(points: np.ndarray, theta: float, span: int = 4, free: np.ndarray | None = None) -> float:
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
    w = length * ((quad * np.exp(-4j * theta)).real > _CORNER_COS)
    if free is not None:
        w = w * (free & np.concatenate([free[span:], free[:span]]))
    if w.sum() <= 0:
        return theta
    mean = (w * quad).sum()
    return float(np.arctan2(mean.imag, mean.real) / 4)                # np.angle's arithmetic, without its wrapper


def fit_square(points: np.ndarray, blocked: np.ndarray, pixel_mm: float, edge_hint: float | None,
                edges=(25.0, 38.0)):
    """Centre (2,), side lengths (2,) mm and angle (rad) of the rectangle of a face's world outline (N, 2) mm.

    Outline points next to an occluder (`blocked`) are not the face's edge: when there are any, the rectangle's
    orientation comes from the free points, and along each side direction the centre is set from the edges the
    free points show (both: their middle; one: half an edge, `edge_hint`, inside it, the face going on towards what
    hides it: _seen_edge_is_low). With no hint (None), the edge
    is the lab edge (`edges`, mm) nearest to a side length the free points show whole (else the largest)."""
    n_blocked = int(np.count_nonzero(blocked))
    if n_blocked > 0.8 * len(points) or len(points) - n_blocked < 12:
        blocked, n_blocked = np.zeros(len(points), bool), 0   # too little free outline to tell: the whole outline
    free = points[~blocked] if n_blocked else points
    (cx, cy), (w, h), angle = cv2.minAreaRect(free.astype(np.float32))
    # The outline runs through the centres of the boundary pixels: half a pixel inside the true edge on each side.
    sides = np.array([w, h]) + pixel_mm
    theta = np.radians(angle)
    if not n_blocked or n_blocked / len(points) < 0.02:        # (the blocked share, as blocked.mean() has it)
        return np.array([cx, cy]), sides, edge_direction(points, theta), True
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
    hidden = (points[blocked] - [cx, cy]) @ axes.T       # where the occluders hide the face, in the same axes
    for i in range(2):
        if both[i] and hi[i] - lo[i] > 0.85 * edge_hint:
            centre_local[i] = (lo[i] + hi[i]) / 2
        else:
            complete = False
            centre_local[i] = (lo[i] + (edge_hint - pixel_mm) / 2 if _seen_edge_is_low(hidden[:, i], lo[i], hi[i],
                                                                                     n_lo[i], n_hi[i])
                               else hi[i] - (edge_hint - pixel_mm) / 2)
            sides[i] = edge_hint
    return np.array([cx, cy]) + centre_local @ axes, sides, theta, complete


def _seen_edge_is_low(hidden: np.ndarray, lo: float, hi: float, n_lo: int, n_hi: int) -> bool:
    """For a side direction the free outline does not span whole (its coordinates along it from lo to hi, mm, with
    n_lo and n_hi points near each end): whether the edge it shows is its low end, so that the face goes on past hi.
    The face goes on under what hides it: towards the blocked outline points (`hidden`, their coordinates along the
    direction, mm) when their mean lies off the free span's middle by more than a sixth of the span; otherwise the
    end with more free points near it (a straight edge) is the seen one."""
    if len(hidden):
        off = float(hidden.mean()) - (lo + hi) / 2
        if abs(off) > (hi - lo) / 6:
            return off > 0
    return bool(n_lo >= n_hi)


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
EDGE_STEP_HALF_PX = 2.0   # a blurred edge's levels are read this far (px) inside and outside it (the step's half-width)
SIDE_FACE_MIN_READ_PX = 0.75   # beyond a side whose own side face is in view, the level is read at the side face's
                               # middle, at least this far out (px): a narrower side face is blurred into the edge
                               # (measured on seeds 0-23: 0.5 px reads cubes 0.04 mm small, 1 px 0.12 mm large)
EDGE_MIDPOINT_ITERATIONS = 3   # steps of the half level's fixed point
EDGE_RISE_MM = 1.5   # a side's direction: from the level at most this far beyond its first crossing (_edge_offsets)
_PROFILE_T = np.linspace(-0.8, 0.8, EDGE_SAMPLES)
_PROFILE_S = np.arange(-EDGE_SEARCH_MM, EDGE_SEARCH_MM + 1e-9, EDGE_STEP_MM)
_QUARTER_TURNS = np.arange(4) * (np.pi / 2)   # (4,) rad: a face's sides' outward normals from its yaw


def plane_homographies(camera: Camera, centres, z, reach) -> np.ndarray:
    """(F, 3, 3) homographies from world (x, y) on the planes z (F,) mm to pixels, each exact at four points `reach`
    (F,) mm around its centre (F, 2): the pinhole part of a plane's image is a homography, and the lens distortion
    over a block's few centimetres is smooth enough that the four-point fit stays within a hundredth of a pixel. One
    projection of four points per plane instead of one per sample."""
    centres = np.asarray(centres, float).reshape(-1, 2)
    n = len(centres)
    z, reach = np.broadcast_to(np.asarray(z, float), (n,)), np.broadcast_to(np.asarray(reach, float), (n,))
    square = centres[:, None] + reach[:, None, None] * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float)
    uv = camera.project(np.column_stack([square.reshape(-1, 2), np.repeat(z, 4)])).reshape(n, 4, 2)
    square32, uv32 = square.astype(np.float32), uv.astype(np.float32)
    return np.array([cv2.getPerspectiveTransform(sq, p) for sq, p in zip(square32, uv32)]).reshape(n, 3, 3)


def _fit_points(t: np.ndarray, w: np.ndarray):
    """The part of least-squares lines through the rows of t (S, M) that depends only on which points are used, w
    (S, M) bool, shared by every y fitted with the same points (_line_fits): the point counts n (S,), n at least 1
    (S,), the used t's mean (S,), their deviations from it (S, M; 0 where unused) and the sum of their squares
    (S,)."""
    n = w.sum(axis=1)
    nz = np.maximum(n, 1)
    tm = np.where(w, t, 0.0).sum(axis=1) / nz
    dt = np.where(w, t - tm[:, None], 0.0)
    return n, nz, tm, dt, (dt * dt).sum(axis=1)


def _line_fits(t: np.ndarray, y: np.ndarray, w: np.ndarray, points=None) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares lines y = a + b t through the rows of t, y (S, M) using the points where w (S, M) bool: slopes b
    (S,) and intercepts a (S,). points: _fit_points(t, w), when the caller has it (several y with the same points)."""
    _, nz, tm, dt, sxx = _fit_points(t, w) if points is None else points
    ym = np.where(w, y, 0.0).sum(axis=1) / nz
    b = (dt * np.where(w, y - ym[:, None], 0.0)).sum(axis=1) / np.maximum(sxx, 1e-9)
    return b, ym - b * tm


def _spread(t: np.ndarray, w: np.ndarray, n: np.ndarray) -> np.ndarray:
    """(S,): how far apart the used t of each row of t (S, M) lie (w (S, M) bool; 0 for a row of none, n (S,) = 0)."""
    spread = np.where(w, t, -np.inf).max(axis=1) - np.where(w, t, np.inf).min(axis=1)
    return np.where(n > 0, spread, 0.0)


def _side_face_width(half: np.ndarray, plane_z: np.ndarray, toward: np.ndarray, camera_z: float) -> np.ndarray:
    """(F, 4) mm: how far a face's own side face reaches beyond each side on the face's plane, as the camera sees it.
    half (F, 2) mm: the face's half sides; plane_z (F,) mm: its height; toward (F, 4) mm: the camera's horizontal
    distance beyond each side (> 0: that side face is in view); camera_z: the camera's height (mm). A side face as
    tall as the cube's edge e, seen from a height H above the face's plane at a horizontal distance r, covers
    e r / (H + e) of the plane beyond the side."""
    e = 2 * np.sqrt(half[:, :1] * half[:, 1:])
    return e * np.maximum(toward, 0.0) / (camera_z - plane_z[:, None] + e)


def _row_starts(p: np.ndarray) -> np.ndarray:
    """The flat index of each row's first element in the C-contiguous profiles p (N, K): (N,) intp. Gathering one
    element per row through these costs a fraction of 2-d fancy indexing."""
    return np.arange(0, p.size, p.shape[-1])


def _interpolate(p: np.ndarray, s: np.ndarray, x: np.ndarray, starts: np.ndarray | None = None) -> np.ndarray:
    """The profiles p (N, K), C-contiguous, sampled at offsets s (K,) mm every EDGE_STEP_MM, linearly interpolated at
    x (J, N) mm (row j: one point on each profile; clipped to the profiles' ends): (J, N). starts: _row_starts(p),
    when the caller has it."""
    K = p.shape[-1]
    f = np.clip((x - s[0]) / EDGE_STEP_MM, 0.0, K - 1.0)
    i = np.minimum(f.astype(np.intp), K - 2)
    at = (_row_starts(p) if starts is None else starts) + i
    flat = p.ravel()
    p0 = flat[at]
    return p0 + (f - i) * (flat[at + 1] - p0)


def _crossings(p: np.ndarray, s: np.ndarray, level: np.ndarray, starts: np.ndarray | None = None) -> np.ndarray:
    """Where the profiles p (N, K), C-contiguous, sampled at offsets s (K,) mm, first reach level (N,), linearly
    interpolated (mm; at the second sample when the first already does). starts: _row_starts(p), when the caller has
    it."""
    m = np.maximum((p >= level[:, None]).argmax(axis=-1), 1)
    at = (_row_starts(p) if starts is None else starts) + m
    flat = p.ravel()
    p0, p1 = flat[at - 1], flat[at]
    frac = np.minimum(np.maximum((level - p0) / np.where(p1 > p0, p1 - p0, 1.0), 0.0), 1.0)
    return s[0] + EDGE_STEP_MM * (m - 1 + frac)


def _finite_rows(p: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """(N,) bool: whether the row of p (N, K) holds no NaN or inf. The first non-finite element of each row (argmax of
    the flags; the first element when there is none) decides: one gather instead of a reduction over each short row."""
    bad = ~np.isfinite(p)
    return ~bad.ravel()[starts + bad.argmax(axis=-1)]


def _prefix_min(p: np.ndarray, stop: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """(N,): the least of p[i, :stop[i]] for the rows of p (N, K) without NaN, stop (N,) in 1..K. The running minimum
    one column at a time (K ops on N elements each, not N reductions of a few elements), then one gather; a minimum
    is exact in any order."""
    n, K = p.shape
    running = np.empty((K, n), p.dtype)
    running[0] = p[:, 0]
    for j in range(1, K):
        np.minimum(running[j - 1], p[:, j], out=running[j])
    return running.ravel()[(stop - 1) * n + np.arange(n)]


def _window_max(p: np.ndarray, first: np.ndarray, reach: int, starts: np.ndarray) -> np.ndarray:
    """(N,): the greatest of p[i, first[i]:first[i] + reach + 1] (cut at the row's end) for the rows of p (N, K)
    without NaN, first (N,) in 0..K-1: reach + 1 gathers; an index past the row's end is clipped to its last element,
    which the window then holds already."""
    last = p.shape[-1] - 1
    flat = p.ravel()
    out = flat[starts + first]
    for d in range(1, reach + 1):
        np.maximum(out, flat[starts + np.minimum(first + d, last)], out=out)
    return out


def _edge_offsets(prof: np.ndarray, s: np.ndarray, inside_mm, outside_mm) -> tuple[np.ndarray, np.ndarray]:
    """Where the face ends along each profile (..., K) sampled at offsets s (K,) mm: the first sample whose colour
    distance reaches EDGE_LEVEL finds the edge, which is then placed where the profile is half-way between its level
    `inside_mm` inside and its level `outside_mm` outside that point (mm, broadcast to (...)), linearly interpolated:
    the middle of the blurred step, whatever lies farther beyond it (board, grid line). The point is a fixed point,
    EDGE_MIDPOINT_ITERATIONS steps from the first crossing. The levels must be read beyond the blurred step (about
    EDGE_STEP_HALF_PX pixels, in mm at the face: the blur spreads a step over pixels, not millimetres): a level read
    on the rise puts the half level, and the edge, inside the face (the level at most 1.5 mm beyond the first
    crossing, as before, read cubes 0.6 mm small under the simulator's 0.7 px blur, more far from the image centre),
    and one read past a narrow side face of the cube, on the board, puts it outside (refine_yaws reads that one at
    the side face's middle).

    Returns the offsets (..., 2) mm and whether each was found (...). [..., 0] is that half level's crossing, where
    the side is; [..., 1] is the crossing of the level half-way between the face's (the least before the first
    crossing) and the greatest within EDGE_RISE_MM beyond the first crossing: still on a blurred step's rise, so
    inside the side by a part of the blur, but by the same part all along a side, and the steadier of the two along
    it: a side's direction comes from these (measured on the perception frames of seeds 100-115: yaw error 0.23 deg
    mean with them, 0.29 with the half level's; as a side's position, the half level's crossings read cubes 0.06 mm
    large, these 0.6 mm small)."""
    shape, K = prof.shape[:-1], prof.shape[-1]
    p = prof.reshape(-1, K)
    inside = np.broadcast_to(np.asarray(inside_mm, float), shape).reshape(-1)
    outside = np.broadcast_to(np.asarray(outside_mm, float), shape).reshape(-1)
    starts = _row_starts(p)
    finite = _finite_rows(p, starts)
    p = p.copy()
    p[~finite] = 0.0
    k = (p >= EDGE_LEVEL).argmax(axis=-1)
    ok = finite & (k > 0)
    edge = s[0] + EDGE_STEP_MM * (k - 0.5)
    for _ in range(EDGE_MIDPOINT_ITERATIONS):
        lo, hi = _interpolate(p, s, np.stack([edge - inside, edge + outside]), starts)
        edge = _crossings(p, s, np.where(ok, 0.5 * (lo + hi), EDGE_LEVEL), starts)
    face = _prefix_min(p, np.maximum(k, 1), starts)                                 # the least before k
    rise = _window_max(p, k, int(round(EDGE_RISE_MM / EDGE_STEP_MM)), starts)       # the greatest within the reach
    steady = _crossings(p, s, np.where(ok, 0.5 * (face + rise), EDGE_LEVEL), starts)
    return np.stack([edge, steady], axis=-1).reshape(shape + (2,)), ok.reshape(shape)


@dataclass
class MeasuredFace:
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


def refine_yaws(camera: Camera, faces: list[MeasuredFace], iterations: int = 3) -> np.ndarray:
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
    tt = t.reshape(-1, t.shape[-1])                                        # (F * 4, M): one row a side
    s = _PROFILE_S
    # one plane homography per face (world (x, y) at the face's height -> pixels), from one projection of all faces'
    # corner points; then into an atlas that stacks the faces' patches (feature and occluder masks) with gaps, so
    # that each iteration samples every face in one remap
    homographies = plane_homographies(camera, centre, [m.plane_z for m in faces],
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
    origins = np.array([m.origin for m in faces], float)                   # (F, 2) px: the patches' image corners
    homographies[:, :2] -= origins[:, :, None] * homographies[:, None, 2]  # pixels of each face's patch
    size = (shapes[:, ::-1] + 0.5).astype(np.float32)                      # (F, 2) patch width, height + 0.5
    shift = np.column_stack([np.full(n_faces, gap), top]).astype(np.float32)   # (F, 2) patch origin in the atlas
    s32, t32 = s.astype(np.float32), t.astype(np.float32)
    pixel_mm = np.repeat([m.pixel_mm for m in faces], 4)
    plane_z = np.array([m.plane_z for m in faces], float)
    reach = EDGE_STEP_HALF_PX * pixel_mm.reshape(n_faces, 4)              # (F, 4) mm: the levels' reading distance
    nearest_read = SIDE_FACE_MIN_READ_PX * pixel_mm.reshape(n_faces, 4)
    f32 = np.float32                # patch pixels are small numbers: float32 is exact to 1e-5 px
    camera_xy, camera_z = camera.position[:2], camera.position[2]          # mm, world
    for _ in range(iterations):
        ang = theta[:, None] + _QUARTER_TURNS
        normal = np.stack([np.cos(ang), np.sin(ang)], axis=-1)            # (F, 4, 2) outward
        tangent = np.stack([-normal[..., 1], normal[..., 0]], axis=-1)
        # the samples' world points c + (dist + s) n + t tangent are affine in (s, t): so are their homogeneous
        # pixels, H [c + dist n, 1] + s H [n, 0] + t H [tangent, 0]
        base = np.concatenate([centre[:, None] + dist[..., None] * normal, np.ones((n_faces, 4, 1))], axis=-1)
        hb = np.einsum("fij,faj->fai", homographies, base).astype(f32)     # (F, 4, 3)
        hn = np.einsum("fij,faj->fai", homographies[:, :, :2], normal).astype(f32)
        ht = np.einsum("fij,faj->fai", homographies[:, :, :2], tangent).astype(f32)
        # each image coordinate on its own (F, 4, M, K): no (..., 3) array, and remap takes the two maps apart
        hb, hn, ht = (h[:, :, None, None] for h in (hb, hn, ht))               # (F, 4, 1, 1, 3)
        den = hb[..., 2] + s32 * hn[..., 2] + t32[..., None] * ht[..., 2]
        maps = []
        for c in range(2):
            x = hb[..., c] + s32 * hn[..., c] + t32[..., None] * ht[..., c]
            x /= den
            # a sample off its patch reads the atlas's gap around the patch, NaN (feature) and 1 (occluded), as the
            # border of a remap of the patch alone would: clipped to 1.5 px (linear) / 1 px (nearest) off the patch
            np.minimum(np.maximum(x, f32(-1.5), out=x), size[:, None, None, None, c], out=x)
            x += shift[:, None, None, None, c]
            maps.append(x.reshape(-1, len(s)))
        # (the maps stay one profile a row: OpenCV 4.14's linear remap computes the vector-wide part of each row and
        # its tail a last bit differently, so reshaping the same samples into wider rows changes the profiles)
        p = cv2.remap(feature, *maps, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=np.nan)
        hidden = cv2.remap(near, *maps, cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT, borderValue=1)
        p[hidden > 0] = np.nan
        mid = centre[:, None] + normal * dist[..., None]
        toward = np.einsum("fij,fij->fi", normal, camera_xy - mid)          # (F, 4) mm, > 0: side face in view
        sees_side = toward > 0
        outside = np.where(sees_side, np.clip(0.5 * _side_face_width(dist[:, :2], plane_z, toward, camera_z),
                                              nearest_read, reach), reach)
        edge, ok = _edge_offsets(p.reshape(n_faces, 4, len(_PROFILE_T), len(s)), s, reach[..., None],
                                 outside[..., None])
        # each side's line: its slope (and the outlier test, the residuals, the counts) from the steady crossings,
        # its intercept (where the side is) from the half level's, with the same points
        ee, okk = (x.reshape(tt.shape) for x in (edge[..., 1], ok))
        b, a = _line_fits(tt, ee, okk)
        use = okk & (np.abs(ee - (a[:, None] + b[:, None] * tt)) <= EDGE_FIT_TOL)
        points = _fit_points(tt, use)
        n, sxx, spread = points[0], points[4], _spread(tt, use, points[0])
        b, a = _line_fits(tt, ee, use, points)
        r = np.where(use, ee - (a[:, None] + b[:, None] * tt), 0.0)
        _, a = _line_fits(tt, edge[..., 0].reshape(tt.shape), use, points)
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
