"""Simulated checkerboard captures for intrinsic calibration, and the saved image set in data/checkerboard/.

A planar checkerboard (default 9 x 6 inner corners, 25 mm squares, on a white card) is held at a pose T_cam_target in
front of the simulated camera and rendered through its TRUE intrinsics and distortion with the same warp/remap path
as the board, then the realism's image noise. Target frame: origin at the card centre, x along the 9-corner rows,
y along the 6-corner columns, z into the card (the printed face looks along -z, towards the camera).
Units: mm, rad; images RGB uint8 (H, W, 3).

Every simulated station's camera has its own true intrinsics (CameraRealism.realistic varies them by seed), so each
is calibrated from its own set: `capture_checkerboard_set(sim_camera)` photographs the board with that camera, and
`sim_camera_intrinsics(sim_camera)` calibrates it (once per camera: cached). The saved set (data/checkerboard/, the
notebook's "photographs") is the set of the realistic camera of seed 0; regenerate it with
`python -m armlab.sim.checkerboard [out_dir]`.
"""

from __future__ import annotations

import functools
import sys
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from armlab._paths import data_path, data_write_path
from armlab.calibration.intrinsics import IntrinsicsResult, calibrate_intrinsics
from armlab.calibration.views import load_checkerboard_set, save_checkerboard_set
from armlab.camera import Camera
from armlab.sim.camera import true_camera
from armlab.sim.raster import Canvas, View
from armlab.sim.realism import CameraRealism
from armlab.sim.render import render
from armlab.transforms import homogeneous, rot_x, rot_y, rot_z

__all__ = ["Checkerboard", "checkerboard_poses", "render_checkerboard", "render_checkerboard_set",
           "capture_checkerboard_set", "sim_camera_intrinsics", "save_dataset", "load_dataset",
           "CHECKERBOARD_SURFACE", "SET_SIZE"]

CHECKERBOARD_SURFACE = 2
SET_SIZE = 16          # views per set: cv2.calibrateCamera recovers K within ~0.05 % from 15 synthetic views


@dataclass(frozen=True)
class Checkerboard:
    """A printed checkerboard: inner corners (columns, rows) as OpenCV counts them, square edge (mm), white margin
    around the squares (mm)."""

    pattern_size: tuple[int, int] = (9, 6)
    square_mm: float = 25.0
    margin_mm: float = 20.0

    def __post_init__(self):
        cols, rows = self.pattern_size
        if cols < 2 or rows < 2 or self.square_mm <= 0 or self.margin_mm < 0:
            raise ValueError(f"bad checkerboard {self.pattern_size}, {self.square_mm} mm squares, "
                             f"{self.margin_mm} mm margin")

    @property
    def half_extent_mm(self) -> tuple[float, float]:
        """Half width and half height (mm) of the card (squares plus margin)."""
        cols, rows = self.pattern_size
        return ((cols + 1) * self.square_mm / 2 + self.margin_mm, (rows + 1) * self.square_mm / 2 + self.margin_mm)

    def object_points(self) -> np.ndarray:
        """Inner corners (cols * rows, 3) float32 in the target frame (mm), row by row (x fastest), z = 0."""
        cols, rows = self.pattern_size
        i, j = np.meshgrid(np.arange(cols), np.arange(rows))
        x = (i.ravel() - (cols - 1) / 2) * self.square_mm
        y = (j.ravel() - (rows - 1) / 2) * self.square_mm
        return np.column_stack([x, y, np.zeros(x.size)]).astype(np.float32)

    def card_corners(self) -> np.ndarray:
        """The card's four corners (4, 3) in the target frame (mm)."""
        hx, hy = self.half_extent_mm
        return np.array([[-hx, -hy, 0], [hx, -hy, 0], [hx, hy, 0], [-hx, hy, 0]], float)


@functools.lru_cache(maxsize=4)
def _texture(board: Checkerboard, mm_per_texel: float) -> tuple[np.ndarray, np.ndarray]:
    """Grey texture (H, W) uint8 of the card and H_plane_texel (3, 3): texel (col, row, 1) -> target (x, y, 1) mm."""
    hx, hy = board.half_extent_mm
    s = mm_per_texel
    W, H = round(2 * hx / s), round(2 * hy / s)
    x = (np.arange(W) + 0.5) * s - hx
    y = (np.arange(H) + 0.5) * s - hy
    qx = np.floor(x / board.square_mm + (board.pattern_size[0] + 1) / 2).astype(int)
    qy = np.floor(y / board.square_mm + (board.pattern_size[1] + 1) / 2).astype(int)
    inside = ((qx >= 0) & (qx <= board.pattern_size[0]))[None, :] & ((qy >= 0) & (qy <= board.pattern_size[1]))[:, None]
    black = inside & (((qx[None, :] + qy[:, None]) % 2) == 0)
    img = np.where(black, 20, 235).astype(np.uint8)
    img = cv2.GaussianBlur(img, (0, 0), 1.0)      # pre-filter: bilinear sampling then does not alias the edges
    H_plane_texel = np.array([[s, 0, s / 2 - hx], [0, s, s / 2 - hy], [0, 0, 1]])
    return img, H_plane_texel


def render_checkerboard(camera: Camera, T_cam_target, realism: CameraRealism | None = None,
                        rng: np.random.Generator | None = None, board: Checkerboard | None = None,
                        objects=()) -> tuple[np.ndarray, np.ndarray]:
    """The camera's image of a checkerboard held at T_cam_target (4, 4) (target -> camera, mm) over the lab board:
    rgb (H, W, 3) uint8 and depth (H, W) float32 mm, with the realism's sensor effects (default ideal)."""
    board = board or Checkerboard()
    T = np.asarray(T_cam_target, dtype=float)
    if T.shape != (4, 4) or not np.all(np.isfinite(T)):
        raise ValueError(f"T_cam_target must be a finite 4x4 transform, got shape {T.shape}")
    texture, H_plane_texel = _texture(board, board.square_mm / 100)

    def draw(view: View, canvas: Canvas) -> None:
        view.draw_plane(canvas, texture, H_plane_texel, T, CHECKERBOARD_SURFACE, border=cv2.BORDER_CONSTANT)

    return render(camera, list(objects), None, realism=realism, rng=rng, planes=(draw,))


def checkerboard_poses(camera: Camera, n: int = 16, seed: int = 0, board: Checkerboard | None = None,
                       max_tilt_deg: float = 40.0, distance_mm: tuple[float, float] = (400.0, 750.0),
                       edge_px: float = 15.0) -> list[np.ndarray]:
    """n varied poses T_cam_target (4, 4) of a hand-held checkerboard.

    Card centres spread over the image (a jittered grid of targets, pulled towards the centre as far as needed for
    the card to fit), tilts up to max_tilt_deg about the card's x and y, a turn of up to 25 deg about its normal, at
    distance_mm from the camera; every pose keeps the whole card inside the image (edge_px from its border)."""
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    board = board or Checkerboard()
    rng = np.random.default_rng([int(seed), 0xC4EC])
    W, H = camera.width, camera.height
    cols = int(np.ceil(np.sqrt(n * W / H)))
    rows = int(np.ceil(n / cols))
    cells = [(c, r) for r in range(rows) for c in range(cols)]
    order = rng.permutation(len(cells))[:n]
    corners = board.card_corners()
    poses = []
    for k in order:
        c, r = cells[k]
        for attempt in range(2000):
            # aim the card centre into the cell of a grid over the image, drifting towards the centre if it won't fit
            pull = min(1.0, attempt / 1500)
            u = ((c + rng.uniform(0.2, 0.8)) / cols * W) * (1 - pull) + W / 2 * pull
            v = ((r + rng.uniform(0.2, 0.8)) / rows * H) * (1 - pull) + H / 2 * pull
            Z = rng.uniform(*distance_mm)
            tilt = np.radians(max_tilt_deg) * np.sqrt(rng.uniform(0.15, 1.0))
            direction = rng.uniform(0, 2 * np.pi)
            R = (rot_x(tilt * np.cos(direction)) @ rot_y(tilt * np.sin(direction))
                 @ rot_z(np.radians(rng.uniform(-25, 25))))
            centre = camera.normalized_rays(np.array([[u, v]]))[0]
            T = homogeneous(R, np.array([centre[0] * Z, centre[1] * Z, Z]))
            P = corners @ R.T + T[:3, 3]
            if np.any(P[:, 2] < 100) or R[:, 2] @ T[:3, 3] <= 0:      # the printed face must look at the camera
                continue
            uv = camera.project_camera(P)
            if np.all((uv >= edge_px) & (uv <= (W - 1 - edge_px, H - 1 - edge_px))):
                poses.append(T)
                break
        else:
            raise RuntimeError(f"no checkerboard pose fits the image near cell {(c, r)}")
    return poses


def render_checkerboard_set(camera: Camera, realism: CameraRealism, seed: int, n: int = SET_SIZE,
                            board: Checkerboard | None = None) -> list[np.ndarray]:
    """n RGB views (H, W, 3) uint8 of a hand-held checkerboard (checkerboard_poses(camera, n, seed)) rendered through
    `camera` (the TRUE camera) with the realism's sensor effects; view i draws its noise from (seed, i)."""
    board = board or Checkerboard()
    return [render_checkerboard(camera, T, realism, np.random.default_rng([seed, i, 0xC4EC]), board)[0]
            for i, T in enumerate(checkerboard_poses(camera, n, seed, board))]


def _check_sim_camera(sim_camera) -> None:
    if not all(hasattr(sim_camera, a) for a in ("truth", "realism", "seed")):
        raise TypeError(f"expected a simulated camera (armlab.sim.camera.SimCamera, e.g. make_station('sim').camera), "
                        f"got {type(sim_camera).__name__}")


def capture_checkerboard_set(sim_camera, n: int = SET_SIZE, board: Checkerboard | None = None) -> list[np.ndarray]:
    """What a student does at a simulated station: photograph a checkerboard held in n poses with THIS camera
    (armlab.sim.camera.SimCamera: its true intrinsics, distortion and sensor noise; poses and noise seeded by the
    camera's seed, so a camera always takes the same set). Returns n RGB views (H, W, 3) uint8."""
    _check_sim_camera(sim_camera)
    return render_checkerboard_set(sim_camera.truth, sim_camera.realism, sim_camera.seed, n, board)


@functools.lru_cache(maxsize=16)
def _calibrated(realism: CameraRealism, seed: int, n: int) -> IntrinsicsResult:
    board = Checkerboard()
    views = render_checkerboard_set(true_camera(realism), realism, seed, n, board)
    return calibrate_intrinsics(views, board.pattern_size, board.square_mm)


def sim_camera_intrinsics(sim_camera, n: int = SET_SIZE) -> IntrinsicsResult:
    """The checkerboard calibration (armlab.calibration.calibrate_intrinsics) of a simulated camera's own set
    (capture_checkerboard_set): K within ~0.05 % of its true focal lengths and ~0.5 px of its principal point.
    Rendering and calibrating take ~1.5 s; the result is cached per camera (its realism and seed), so a station
    calibrated again, or a second station with the same camera, costs nothing. Do not modify the returned arrays."""
    _check_sim_camera(sim_camera)
    if n < 3:
        raise ValueError(f"a checkerboard set needs at least 3 views, got n={n}")
    return _calibrated(sim_camera.realism, int(sim_camera.seed), int(n))


def save_dataset(out_dir: Path | str | None = None, n: int = SET_SIZE, seed: int = 0) -> Path:
    """Render and save n views of the checkerboard under the realistic camera of `seed` (the camera of
    SimCamera(..., realism="realistic", seed=seed)) with armlab.calibration.save_checkerboard_set (grayscale JPEG
    quality 95, checkerboard.json with the board geometry and the true intrinsics). Returns the folder."""
    realism = CameraRealism.realistic(seed)
    camera = true_camera(realism)
    board = Checkerboard()
    notes = {
        "_comment": "Simulated L515 colour views (grayscale) of a hand-held checkerboard over the lab board; "
                    "made by armlab.sim.checkerboard.save_dataset. true_K/true_dist are the intrinsics used to "
                    "render (what calibration should recover); the device reports the factory values of lab.json.",
        "seed": seed, "true_K": camera.K.tolist(), "true_dist": camera.dist.tolist(),
    }
    return save_checkerboard_set(render_checkerboard_set(camera, realism, seed, n, board),
                                 out_dir if out_dir is not None else data_write_path("checkerboard"),
                                 board.pattern_size, board.square_mm, notes)


def load_dataset(folder: Path | str | None = None) -> tuple[list[np.ndarray], dict]:
    """The views (grayscale (H, W) uint8 each) and metadata of a saved set (default data/checkerboard/, the
    simulated seed-0 set): armlab.calibration.load_checkerboard_set."""
    return load_checkerboard_set(folder if folder is not None else data_path("checkerboard"))


if __name__ == "__main__":
    print(save_dataset(sys.argv[1] if len(sys.argv) > 1 else None))
