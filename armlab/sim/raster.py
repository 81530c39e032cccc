"""Rasterising planar geometry with a depth buffer in a camera's ideal (undistorted) pinhole image, then the lens.

A `View` is the undistorted pinhole canvas of one `armlab.camera.Camera`: the same focal lengths, a principal point
shifted by a margin so that the canvas covers every ray the distorted image sees. Geometry is drawn into the canvas
(flat-shaded convex polygons with `fill_polygons`, textured planes with `draw_plane`), keeping a buffer of inverse
depth 1/Z (1/mm; 0 = nothing). For a plane, 1/Z is an affine function of undistorted pixel coordinates, so it is
exact per pixel and interpolates exactly. `View.finish` applies the lens distortion with `cv2.remap` through maps
computed once per camera and returns the image the camera records: RGB uint8, depth float32 mm (camera-frame Z).

Speed: the board is drawn once per camera into a frozen canvas whose camera image (and surface-edge mask) is cached
too; a frame copies it, draws its few hundred faces (one masked z-test per face box, OpenCV fills and copies), and
redoes the lens only in the image rectangles whose source pixels a face box reaches (face boxes grouped by the
8 px cells they touch, the lens model mapping each group's box into the image).

Units: mm; pixels in OpenCV's convention (integer = pixel centre). Camera frame: x right, y down, z forward.
"""

from __future__ import annotations

import functools

import cv2
import numpy as np

from armlab.camera import Camera, distort_normalized

__all__ = ["View", "Canvas", "view_for", "NEAR_MM"]

NEAR_MM = 50.0          # geometry closer to the camera than this is clipped away


class Canvas:
    """The buffers of one render in the ideal pinhole image: colour (H, W, 3) uint8, inverse depth (H, W) float32
    (1/mm, 0 where nothing was drawn) and surface ids (H, W) uint16 (0 = nothing).

    A canvas can be frozen (read-only, e.g. the cached board); a copy of a frozen canvas remembers it as `base` and
    records in `dirty` the canvas rectangles (x0, y0, x1, y1), end exclusive, that drawing may have changed since
    (None: unknown, anywhere), so that `View.finish` redoes the lens only there."""

    def __init__(self, height: int, width: int):
        self.rgb = np.zeros((height, width, 3), np.uint8)
        self.inv_depth = np.zeros((height, width), np.float32)
        self.surface = np.zeros((height, width), np.uint16)
        self.base: Canvas | None = None
        self.dirty: list[tuple[int, int, int, int]] | None = None
        self.finished = None         # a frozen canvas caches View.finish's result here
        self.edges = None            # ... and its surface-edge mask (uint8, canvas size)
        self.lens_rects: list[tuple[int, int, int, int]] | None = None   # image rectangles finish redid (None: all)
        self.sensor_cache: dict = {}  # noise-free sensor products of a frozen canvas's image (armlab.sim.sensor)

    @property
    def frozen(self) -> bool:
        return not self.rgb.flags.writeable

    def freeze(self) -> Canvas:
        """Make the buffers read-only (returns self)."""
        for a in (self.rgb, self.inv_depth, self.surface):
            a.flags.writeable = False
        return self

    def copy(self) -> Canvas:
        """A writable copy (of a frozen canvas: with it as base and nothing dirty yet)."""
        c = Canvas.__new__(Canvas)
        c.rgb, c.inv_depth, c.surface = self.rgb.copy(), self.inv_depth.copy(), self.surface.copy()
        c.base, c.dirty, c.finished, c.edges = (self, [], None, None) if self.frozen else (None, None, None, None)
        c.lens_rects, c.sensor_cache = None, {}
        return c

    def mark_dirty(self, rect: tuple[int, int, int, int] | None) -> None:
        """Record that the rectangle (x0, y0, x1, y1) (None: anything) may have changed."""
        if rect is None or self.dirty is None:
            self.dirty = None
        else:
            self.dirty.append(rect)


class View:
    """The undistorted pinhole canvas of a camera and the lens maps from it to the camera's (distorted) image.

    Attributes:
        camera: the camera (true intrinsics, distortion, extrinsic).
        K: (3, 3) canvas intrinsics (the camera's K with the principal point moved by the margin).
        width, height: canvas size (px).
        identity: True when the camera has no distortion: the canvas is the image itself and no remap is needed.
    """

    def __init__(self, camera: Camera):
        self.camera = camera
        W, H = camera.width, camera.height
        self.identity = not np.any(camera.dist)
        if self.identity:
            self.K = camera.K.copy()
            self.width, self.height = W, H
            self.map_x = self.map_y = None
        else:
            u, v = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
            xy = camera.normalized_rays(np.column_stack([u.ravel(), v.ravel()])).reshape(H, W, 2)
            K = camera.K
            cu = K[0, 0] * xy[..., 0] + K[0, 1] * xy[..., 1]
            cv = K[1, 1] * xy[..., 1]
            # margin so that every sampled canvas coordinate (plus the bilinear neighbour) lies inside the canvas
            left = int(np.ceil(max(0.0, -(cu.min() + K[0, 2])))) + 2
            top = int(np.ceil(max(0.0, -(cv.min() + K[1, 2])))) + 2
            right = int(np.ceil(max(0.0, cu.max() + K[0, 2] - (W - 1)))) + 2
            bottom = int(np.ceil(max(0.0, cv.max() + K[1, 2] - (H - 1)))) + 2
            self.K = K.copy()
            self.K[0, 2] += left
            self.K[1, 2] += top
            self.width, self.height = W + left + right, H + top + bottom
            map_x = (cu + self.K[0, 2]).astype(np.float32)
            map_y = (cv + self.K[1, 2]).astype(np.float32)
            self.map_x, self.map_y = map_x, map_y
            # fixed-point maps: faster remaps; the nearest maps pick the canvas pixel whose centre is closest
            self._fixed = cv2.convertMaps(map_x, map_y, cv2.CV_16SC2)
            self._nearest = cv2.convertMaps(np.rint(map_x), np.rint(map_y), cv2.CV_16SC2, nninterpolation=True)[0]
        self._u = np.arange(self.width, dtype=np.float32)
        self._v = np.arange(self.height, dtype=np.float32)
        self._grid_cache: tuple[np.ndarray, np.ndarray] | None = None
        R, t = camera.T_cam_world[:3, :3], camera.T_cam_world[:3, 3]
        self._H_world = self.K @ np.column_stack([R[:, 0], R[:, 1], t])   # board plane (x, y, 1) -> canvas pixel

    @property
    def _grid(self) -> tuple[np.ndarray, np.ndarray]:
        """Canvas pixel coordinates u, v as two (H, W) float32 grids (made on first use, read-only)."""
        if self._grid_cache is None:
            U, V = np.meshgrid(self._u, self._v)
            U.flags.writeable = V.flags.writeable = False
            self._grid_cache = (U, V)
        return self._grid_cache

    # -- geometry helpers -------------------------------------------------------------------------------------------
    def inverse_depth_plane(self, normal, offset: float) -> tuple[float, float, float]:
        """Coefficients (a, b, c) with 1/Z = a u + b v + c on the canvas for the camera-frame plane n . X = offset."""
        n = np.asarray(normal, dtype=float)
        fx, s, cx = self.K[0]
        fy, cy = self.K[1, 1], self.K[1, 2]
        # x = (u - cx - s y) / fx, y = (v - cy) / fy; 1/Z = (n_x x + n_y y + n_z) / offset
        ky = n[1] / fy - n[0] * s / (fx * fy)
        a = n[0] / fx / offset
        b = ky / offset
        c = (n[2] - n[0] * cx / fx - ky * cy) / offset
        return a, b, c

    def plane_inverse_depth(self, normal, offset: float) -> np.ndarray:
        """Inverse depth (H, W) float32 of the camera-frame plane n . X = offset over the whole canvas (0 behind)."""
        a, b, c = self.inverse_depth_plane(normal, offset)
        w = (a * self._u)[None, :] + (b * self._v + c)[:, None]
        return np.where(w > 0, w, 0).astype(np.float32)

    # -- drawing ---------------------------------------------------------------------------------------------------
    def new_canvas(self) -> Canvas:
        return Canvas(self.height, self.width)

    def draw_plane(self, canvas: Canvas, texture: np.ndarray, H_plane_texel: np.ndarray, T_cam_plane: np.ndarray,
                   surface: int, border: int = cv2.BORDER_REPLICATE, z_test: bool = True) -> None:
        """Draw a textured plane: texel (col, row, 1) -> plane (x, y, 1) mm by `H_plane_texel`, plane frame -> camera
        by `T_cam_plane` (the plane is z = 0 of its frame). Pixels outside the texture repeat its border
        (BORDER_REPLICATE: an infinite plane) or are not drawn (BORDER_CONSTANT: a finite card)."""
        R, t = T_cam_plane[:3, :3], T_cam_plane[:3, 3]
        H = self.K @ np.column_stack([R[:, 0], R[:, 1], t]) @ H_plane_texel
        size = (self.width, self.height)
        w = self.plane_inverse_depth(R[:, 2], float(R[:, 2] @ t))
        if border == cv2.BORDER_CONSTANT:
            inside = cv2.warpPerspective(np.ones(texture.shape[:2], np.uint8), H, size, flags=cv2.INTER_NEAREST,
                                         borderMode=cv2.BORDER_CONSTANT, borderValue=0).astype(bool)
            rgb = cv2.warpPerspective(texture, H, size, flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        else:
            inside = w > 0
            rgb = cv2.warpPerspective(texture, H, size, flags=cv2.INTER_LINEAR, borderMode=border)
        draw = inside & (w > 0)
        if z_test:
            draw &= w > canvas.inv_depth
        if rgb.ndim == 2:
            rgb = cv2.cvtColor(rgb, cv2.COLOR_GRAY2RGB)
        canvas.mark_dirty(None)
        canvas.rgb[draw] = rgb[draw]
        canvas.inv_depth[draw] = w[draw]
        canvas.surface[draw] = surface

    def fill_polygons(self, canvas: Canvas, vertices: np.ndarray, normals: np.ndarray, colors: np.ndarray,
                      surfaces: np.ndarray) -> None:
        """Z-buffered flat-shaded convex polygons (back faces culled, clipped at NEAR_MM): vertices (N, K, 3) camera
        mm (a polygon with fewer corners repeats its last one), outward unit normals (N, 3) camera frame, colours
        (N, 3) RGB 0..255, surface ids (N,) >= 1 (used to find depth edges; give faces of different planes
        different ids).

        A face covers the pixels whose centres lie inside its projected polygon (edges included, within
        `_EDGE_TOL_PX`): the rows' spans of every face are found at once (`_row_spans`); over its pixel box, the face's
        float32 inverse depth plane replaces the buffer's wherever it covers and is nearer."""
        V = np.asarray(vertices, dtype=float)
        if V.ndim != 3 or V.shape[2] != 3 or V.shape[1] < 3:
            raise ValueError(f"vertices must be (N, K >= 3, 3) camera mm, got shape {V.shape}")
        N = len(V)
        normals = np.asarray(normals, dtype=float)
        colors = np.asarray(colors, dtype=float)
        surfaces = np.asarray(surfaces)
        if normals.shape != (N, 3) or colors.shape != (N, 3) or surfaces.shape != (N,):
            raise ValueError(f"normals and colours must be ({N}, 3) and surfaces ({N},), got {normals.shape}, "
                             f"{colors.shape} and {surfaces.shape}")
        if N == 0:
            return
        if surfaces.min() < 1 or surfaces.max() > np.iinfo(np.uint16).max:
            raise ValueError("surface ids must be within 1..65535")
        surfaces = surfaces.astype(np.uint16)
        K = self.K
        Hc, Wc = self.height, self.width
        offsets = np.einsum("nj,nj->n", normals, V[:, 0])
        front = offsets < -1e-9                      # the camera is in front of the face's plane
        needs_clip = np.any(V[:, :, 2] < NEAR_MM, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            uvw = V @ K.T
            uv = uvw[..., :2] / uvw[..., 2:3]
            # inverse depth planes 1/Z = a u + b v + c of all faces at once
            fx, s, cx = K[0]
            fy, cy = K[1, 1], K[1, 2]
            ky = normals[:, 1] / fy - normals[:, 0] * s / (fx * fy)
            A = (normals[:, 0] / fx / offsets).tolist()
            B = (ky / offsets).tolist()
            C = ((normals[:, 2] - normals[:, 0] * cx / fx - ky * cy) / offsets).tolist()
        # pixel boxes [x0, x1) x [y0, y1) within the canvas and the covered span of every box row of the faces that
        # need no near clipping
        simple = front & ~needs_clip
        uv_s = np.where(simple[:, None, None], uv, 0.0)
        box = np.column_stack([np.floor(uv_s.min(axis=1)), np.ceil(uv_s.max(axis=1)) + 1])
        box = np.clip(box, 0, [Wc, Hc, Wc, Hc]).astype(np.int64)
        span_first, span_last, span_start = _row_spans(uv_s[simple], box[simple])
        span_of = np.zeros(N, np.int64)
        span_of[simple] = np.arange(int(simple.sum()))
        span_of = span_of.tolist()
        boxes = box.tolist()
        palette = np.clip(np.rint(colors), 0, 255).astype(int).tolist()
        mask_buf = np.empty((Hc, Wc), np.uint8)
        surface_buf = np.empty((Hc, Wc), np.uint16)
        color_buf = np.empty((Hc, Wc, 3), np.uint8)
        grid_u, grid_v = self._grid
        for i in np.flatnonzero(front).tolist():
            if needs_clip[i]:
                P = _clip_near(V[i], NEAR_MM)
                if len(P) < 3:
                    continue
                P2 = P @ K.T
                P2 = P2[:, :2] / P2[:, 2:3]
                x0, y0 = np.floor(P2.min(axis=0)).astype(int).tolist()
                x1, y1 = (np.ceil(P2.max(axis=0)) + 1).astype(int).tolist()
                x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, Wc), min(y1, Hc)
                if x0 >= x1 or y0 >= y1:
                    continue
                first, last, _ = _row_spans(P2[None], np.array([[x0, y0, x1, y1]]))
            else:
                x0, y0, x1, y1 = boxes[i]
                if x0 >= x1 or y0 >= y1:
                    continue
                j = span_of[i]
                first = span_first[span_start[j]:span_start[j + 1]]
                last = span_last[span_start[j]:span_start[j + 1]]
            mask = mask_buf[y0:y1, x0:x1]
            cols = _COLS[:x1 - x0]
            np.logical_and(cols >= first[:, None], cols <= last[:, None], out=mask.view(bool))
            # float32 inverse depth of the face's plane over the box; the winners: inside and nearer
            w = cv2.addWeighted(grid_u[y0:y1, x0:x1], A[i], grid_v[y0:y1, x0:x1], B[i], C[i])
            zb = canvas.inv_depth[y0:y1, x0:x1]
            win = cv2.bitwise_and(cv2.compare(w, zb, cv2.CMP_GT), mask)
            cv2.copyTo(w, win, zb)
            tile = surface_buf[y0:y1, x0:x1]
            tile.fill(surfaces[i])
            cv2.copyTo(tile, win, canvas.surface[y0:y1, x0:x1])
            cv2.rectangle(color_buf, (x0, y0), (x1 - 1, y1 - 1), palette[i], -1)
            cv2.copyTo(color_buf[y0:y1, x0:x1], win, canvas.rgb[y0:y1, x0:x1])
            canvas.mark_dirty((x0, y0, x1, y1))

    # -- the lens ----------------------------------------------------------------------------------------------------
    def finish(self, canvas: Canvas) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The camera's image of a canvas: rgb (h, w, 3) uint8, depth (h, w) float32 mm (NaN where nothing was
        drawn) and a boolean (h, w) mask of pixels next to a surface change (a depth edge or a crease).

        With distortion, a copy of a frozen canvas reuses its base's image and redoes the lens only in the image
        rectangles whose source pixels lie near a dirty rectangle (same result, pixel for pixel, as the whole
        image)."""
        if self.identity:
            rgb, inv, edge = canvas.rgb, canvas.inv_depth, _surface_edges(canvas.surface).view(bool)
            depth = cv2.divide(1.0, inv)           # 0 where inv is 0
            depth[inv <= 0] = np.nan
            return rgb, depth, edge
        base = canvas.base
        W, H = self.camera.width, self.camera.height
        if base is None or canvas.dirty is None:
            canvas.lens_rects = None
            rgb = np.empty((H, W, 3), np.uint8)
            depth = np.empty((H, W), np.float32)
            edge = np.empty((H, W), np.uint8)
            edge_canvas = _surface_edges(canvas.surface)
            self._lens(canvas, edge_canvas, rgb, depth, edge, [(0, 0, W, H)])
        else:
            if base.finished is None:
                self.finish(base)                  # caches it
            rgb, depth, edge = (a.copy() for a in base.finished)
            groups = self._dirty_groups(canvas.dirty)
            canvas.lens_rects = self._group_images(groups)
            if len(groups):
                # the surface-edge mask of the canvas: the base's, redone where the surface ids may have changed
                edge_canvas = base.edges.copy()
                Hc, Wc = self.height, self.width
                for x0, y0, x1, y1 in groups.tolist():
                    X0, Y0, X1, Y1 = max(x0 - 1, 0), max(y0 - 1, 0), min(x1 + 1, Wc), min(y1 + 1, Hc)
                    part = _surface_edges(canvas.surface[Y0:Y1, X0:X1])
                    edge_canvas[y0:y1, x0:x1] = part[y0 - Y0:y1 - Y0, x0 - X0:x1 - X0]
                self._lens(canvas, edge_canvas, rgb, depth, edge, canvas.lens_rects)
        edge = edge.view(bool)
        if canvas.frozen:
            canvas.finished = (rgb, depth, edge.view(np.uint8))
            for a in canvas.finished:
                a.flags.writeable = False
            if base is None and canvas.dirty is None:
                edge_canvas.flags.writeable = False
                canvas.edges = edge_canvas
        return rgb, depth, edge

    def _lens(self, canvas: Canvas, edge_canvas: np.ndarray, rgb: np.ndarray, depth: np.ndarray, edge: np.ndarray,
              rects) -> None:
        """Write the distorted image of `canvas` (whose surface-edge mask is `edge_canvas`) into the image
        rectangles (u0, v0, u1, v1) of rgb, depth, edge."""
        m1, m2 = self._fixed
        for u0, v0, u1, v1 in rects:
            f1, f2, near = m1[v0:v1, u0:u1], m2[v0:v1, u0:u1], self._nearest[v0:v1, u0:u1]
            cv2.remap(canvas.rgb, f1, f2, cv2.INTER_LINEAR, dst=rgb[v0:v1, u0:u1])
            inv = cv2.remap(canvas.inv_depth, f1, f2, cv2.INTER_LINEAR)
            e = cv2.remap(edge_canvas, near, None, cv2.INTER_NEAREST, dst=edge[v0:v1, u0:u1])
            # next to a surface change bilinear mixing of two surfaces is wrong: take the nearest canvas pixel there
            cv2.copyTo(cv2.remap(canvas.inv_depth, near, None, cv2.INTER_NEAREST), e, inv)
            d = cv2.divide(1.0, inv, dst=depth[v0:v1, u0:u1])           # 0 where inv is 0
            d[inv <= 0] = np.nan

    def _dirty_runs(self, dirty: list[tuple[int, int, int, int]]) -> list[tuple[int, int, int, int]]:
        """Image rectangles (u0, v0, u1, v1), end exclusive, covering every image pixel whose lens output can depend
        on a dirty canvas rectangle (through its bilinear neighbours and the 3x3 surface-edge test): the canvas
        groups of `_dirty_groups` mapped through the lens (their borders, sampled)."""
        return self._group_images(self._dirty_groups(dirty))

    def _dirty_groups(self, dirty: list[tuple[int, int, int, int]]) -> np.ndarray:
        """Canvas rectangles (G, 4) (x0, y0, x1, y1), end exclusive, covering the dirty rectangles grown by the reach
        of the lens (4 px before, 3 after): rectangles that touch the same LENS_CELL_PX cells (8-connected) form a
        group, which gives its bounding box, or, when it fills less than three quarters of that (the arm's
        diagonal), one box per band of LENS_BAND_CELLS cell rows."""
        if not dirty:
            return np.empty((0, 4), np.int64)
        W, H = self.width, self.height
        box = np.clip(np.asarray(dirty, np.int64) + (-4, -4, 3, 3), 0, [W, H, W, H])
        box = box[(box[:, 0] < box[:, 2]) & (box[:, 1] < box[:, 3])]
        if not len(box):
            return np.empty((0, 4), np.int64)
        c, band = LENS_CELL_PX, LENS_BAND_CELLS
        rows, cols = -(-H // c), -(-W // c)
        cells = np.zeros((rows, cols), np.uint8)
        cb = np.column_stack([box[:, :2] // c, -(-box[:, 2:] // c)])
        for cx0, cy0, cx1, cy1 in cb.tolist():
            cells[cy0:cy1, cx0:cx1] = 1
        n, labels, stats, _ = cv2.connectedComponentsWithStats(cells, connectivity=8)
        owner = labels[cb[:, 1], cb[:, 0]]
        ext = np.empty((n, 4), np.int64)
        ext[:, :2], ext[:, 2:] = np.iinfo(np.int64).max, np.iinfo(np.int64).min
        for j, fn in enumerate((np.minimum, np.minimum, np.maximum, np.maximum)):
            fn.at(ext[:, j], owner, box[:, j])
        sparse = (4 * stats[:, cv2.CC_STAT_AREA] < 3 * stats[:, cv2.CC_STAT_WIDTH] * stats[:, cv2.CC_STAT_HEIGHT]) \
            & (stats[:, cv2.CC_STAT_HEIGHT] > band)
        sparse[0] = False
        out = [ext[1:][~sparse[1:]]]
        if sparse.any():
            # per band of cell rows and sparse group: the first and last cell column it covers
            r, q = np.nonzero(sparse[labels])
            k = labels[r, q]
            nb = -(-rows // band)
            first = np.full((nb, n), cols, np.int64)
            last = np.full((nb, n), -1, np.int64)
            np.minimum.at(first, (r // band, k), q)
            np.maximum.at(last, (r // band, k), q)
            bi, ki = np.nonzero(last >= 0)
            e = ext[ki]
            out.append(np.column_stack([np.maximum(e[:, 0], first[bi, ki] * c), np.maximum(e[:, 1], bi * band * c),
                                        np.minimum(e[:, 2], (last[bi, ki] + 1) * c),
                                        np.minimum(e[:, 3], (bi + 1) * band * c)]))
        return np.concatenate(out)

    def _group_images(self, groups: np.ndarray) -> list[tuple[int, int, int, int]]:
        """Image rectangles (u0, v0, u1, v1), end exclusive, holding every image pixel whose lens source lies in one
        of the canvas rectangles `groups` (G, 4)."""
        if not len(groups):
            return []
        W, H = self.camera.width, self.camera.height
        r = groups.astype(float)
        t = np.linspace(0.0, 1.0, 6)
        x0, y0, x1, y1 = (r[:, i, None] for i in range(4))
        ones = np.ones_like(t)
        xs = np.concatenate([x0 + (x1 - x0) * t, x0 + (x1 - x0) * t, x0 * ones, x1 * ones], axis=1)
        ys = np.concatenate([y0 * ones, y1 * ones, y0 + (y1 - y0) * t, y0 + (y1 - y0) * t], axis=1)
        img = self._canvas_to_image(np.stack([xs, ys], axis=-1))
        box = np.column_stack([np.floor(img.min(axis=1)) - 1, np.ceil(img.max(axis=1)) + 2])
        box = np.clip(box, 0, [W, H, W, H]).astype(np.int64)
        return [tuple(b) for b in box[(box[:, 0] < box[:, 2]) & (box[:, 1] < box[:, 3])].tolist()]

    def _canvas_to_image(self, uv: np.ndarray) -> np.ndarray:
        """Image pixels (..., 2) of canvas pixels (..., 2): the lens model forward (inverse of the remap maps)."""
        fx, s, cx = self.K[0]
        fy, cy = self.K[1, 1], self.K[1, 2]
        y = (uv[..., 1] - cy) / fy
        x = (uv[..., 0] - cx - s * y) / fx
        xd = distort_normalized(np.stack([x, y], axis=-1), np.asarray(self.camera.dist, float).ravel())
        K = self.camera.K
        return np.stack([K[0, 0] * xd[..., 0] + K[0, 1] * xd[..., 1] + K[0, 2], K[1, 1] * xd[..., 1] + K[1, 2]],
                        axis=-1)


LENS_CELL_PX = 8             # cells grouping the image rectangles of the partial lens update
LENS_BAND_CELLS = 4          # band height (cells) of a sparse group's boxes


_EDGE_TOL_PX = 1e-4          # a pixel centre this close outside a face's edge counts as inside (faces sharing an
                             # edge, computed from its two directions, leave no pixel to neither)
_COLS = np.arange(1 << 16, dtype=np.int32)


def _row_spans(uv: np.ndarray, box: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pixels whose centres lie inside convex polygons, row by row within their pixel boxes.

    uv: (M, K, 2) polygon corners (canvas px, either winding; repeated corners allowed), box: (M, 4) integer pixel
    boxes (x0, y0, x1, y1), end exclusive. Returns first, last, start: polygon m's box row y0 + r covers the box
    columns first[start[m] + r] .. last[start[m] + r] (box-relative, inclusive; empty when first > last)."""
    box = np.asarray(box, np.int64)
    rows = np.maximum(box[:, 3] - box[:, 1], 0)
    start = np.zeros(len(box) + 1, np.int64)
    np.cumsum(rows, out=start[1:])
    total = int(start[-1])
    face = np.repeat(np.arange(len(box)), rows)
    v = (np.arange(total) - start[face] + box[face, 1]).astype(float)        # canvas row of every span
    a, b = uv, np.roll(uv, -1, axis=1)
    d = b - a
    length = np.hypot(d[..., 0], d[..., 1])
    area = np.sum(a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0], axis=1)
    sign = np.where(area < 0, -1.0, 1.0)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        # inside edge (a -> b): su u + sv v + s0 >= 0 (unit normal, px; 0, 0, 0 for a repeated corner)
        su = np.where(length > 0, -d[..., 1] * sign / length, 0.0)
        sv = np.where(length > 0, d[..., 0] * sign / length, 0.0)
    s0 = -(su * a[..., 0] + sv * a[..., 1])
    lo = np.full(total, -np.inf)
    hi = np.full(total, np.inf)
    for k in range(uv.shape[1]):
        cu, cv_, c0 = su[face, k], sv[face, k], s0[face, k]
        rest = cv_ * v + c0 + _EDGE_TOL_PX            # cu u + rest >= 0
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = -rest / cu
        flat = np.abs(cu) < 1e-12
        lo = np.where(cu >= 1e-12, np.maximum(lo, bound), lo)
        hi = np.where(cu <= -1e-12, np.minimum(hi, bound), hi)
        hi = np.where(flat & (rest < 0), -np.inf, hi)
    x0 = box[face, 0]
    width = box[face, 2] - x0
    first = np.clip(np.ceil(lo), x0, x0 + width) - x0
    last = np.clip(np.floor(hi), x0 - 1, x0 + width - 1) - x0
    return first.astype(np.int32), last.astype(np.int32), start


def _surface_edges(surface: np.ndarray) -> np.ndarray:
    """uint8 (0/1) mask of the pixels whose 3x3 neighbourhood holds more than one surface id."""
    kernel = np.ones((3, 3), np.uint8)
    return (cv2.dilate(surface, kernel) != cv2.erode(surface, kernel)).view(np.uint8)


def _clip_near(P: np.ndarray, near: float) -> np.ndarray:
    """Sutherland-Hodgman clip of a convex polygon (K, 3) to the half-space z >= near."""
    out = []
    for i in range(len(P)):
        a, b = P[i], P[(i + 1) % len(P)]
        ina, inb = a[2] >= near, b[2] >= near
        if ina:
            out.append(a)
        if ina != inb:
            t = (near - a[2]) / (b[2] - a[2])
            out.append(a + t * (b - a))
    return np.array(out).reshape(-1, 3)


@functools.lru_cache(maxsize=8)
def _cached_view(K_bytes: bytes, dist_bytes: bytes, T_bytes: bytes, width: int, height: int) -> View:
    K = np.frombuffer(K_bytes).reshape(3, 3)
    dist = np.frombuffer(dist_bytes)
    T = np.frombuffer(T_bytes).reshape(4, 4)
    return View(Camera(K, dist, T, width, height))


def view_for(camera: Camera) -> View:
    """The (cached) View of a camera: the lens maps are computed once per distinct camera."""
    return _cached_view(np.ascontiguousarray(camera.K, float).tobytes(),
                        np.ascontiguousarray(camera.dist, float).tobytes(),
                        np.ascontiguousarray(camera.T_cam_world, float).tobytes(), camera.width, camera.height)
