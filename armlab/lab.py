"""The lab station's fixed facts (board, AprilTags, nominal camera mount, block sizes) from `data/lab.json`.

World (board) frame: origin on the board surface directly below the waist axis, +y from the robot towards the far
side of the board, +x to the right looking along +y, +z up. Millimetres.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armlab._paths import data_path
from armlab.files import read_json

__all__ = ["LabConfig", "TagLayout", "load_lab", "lab_config"]

_ROBOT_BASE_HALF_MM = (55.0, 60.0)   # the arm's base plate when data/lab.json does not say (x, y half sizes, mm)


@dataclass(frozen=True)
class TagLayout:
    """AprilTags on the board: family name, black-square edge (mm) and centres (x, y) on the board (mm)."""

    family: str
    size_mm: float
    centres_mm: dict[int, tuple[float, float]]

    def corners_world(self, tag_id: int) -> np.ndarray:
        """World corners (4, 3) mm of a tag's black square, in pupil-apriltags order: with the tag upright as seen
        from above (its top edge towards +y): bottom-left, bottom-right, top-right, top-left."""
        cx, cy = self.centres_mm[tag_id]
        h = self.size_mm / 2
        return np.array([[cx - h, cy - h, 0], [cx + h, cy - h, 0], [cx + h, cy + h, 0], [cx - h, cy + h, 0]])


@dataclass(frozen=True)
class LabConfig:
    """Board extents and grid (mm), tag layout, nominal camera mount, factory intrinsics, block edges (mm)."""

    board_x: tuple[float, float]
    board_y: tuple[float, float]
    grid_mm: float
    grid_x: tuple[float, float]          # first and last grid line along x (mm)
    grid_y: tuple[float, float]          # first and last grid line along y (mm)
    tags: TagLayout
    image_size: tuple[int, int]          # (width, height) px
    camera_position_mm: np.ndarray       # (3,) world
    camera_look_at_mm: np.ndarray        # (3,) world
    factory_K: np.ndarray                # (3, 3)
    factory_dist: np.ndarray             # (5,) Brown-Conrady k1, k2, p1, p2, k3
    block_edges_mm: dict[str, float]     # {"large": 38, "small": 25}
    robot_base_half_mm: tuple[float, float] = _ROBOT_BASE_HALF_MM  # the arm's base plate (x, y half sizes) at 0

    def grid_points(self) -> np.ndarray:
        """World points (N, 3) of the printed grid (every grid_mm from grid_x/grid_y's first to last line, z = 0)."""
        xs = np.arange(self.grid_x[0], self.grid_x[1] + self.grid_mm / 2, self.grid_mm)
        ys = np.arange(self.grid_y[0], self.grid_y[1] + self.grid_mm / 2, self.grid_mm)
        X, Y = np.meshgrid(xs, ys)
        return np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], axis=1)

    def on_robot_base(self, xy, margin_mm: float = 0.0) -> np.ndarray:
        """Boolean (...,) telling which world points (..., 2 or 3) lie over the arm's base plate (plus a margin)."""
        xy = np.asarray(xy, dtype=float)
        hx, hy = self.robot_base_half_mm
        return (np.abs(xy[..., 0]) <= hx + margin_mm) & (np.abs(xy[..., 1]) <= hy + margin_mm)

    def on_board(self, xy) -> np.ndarray:
        """Boolean (...,) telling which world points (..., 2 or 3) lie over the board."""
        xy = np.asarray(xy, dtype=float)
        return ((xy[..., 0] >= self.board_x[0]) & (xy[..., 0] <= self.board_x[1])
                & (xy[..., 1] >= self.board_y[0]) & (xy[..., 1] <= self.board_y[1]))


def load_lab(path: Path | str | None = None) -> LabConfig:
    """Read and validate a lab config (JSON); the default is `data/lab.json`. Errors name the file and the key."""
    path = Path(path or data_path("lab.json"))
    raw = read_json(path, "lab config")
    try:
        board, tags, cam, blocks = raw["board"], raw["tags"], raw["camera"], raw["blocks"]
        cfg = LabConfig(
            board_x=(float(board["x_min_mm"]), float(board["x_max_mm"])),
            board_y=(float(board["y_min_mm"]), float(board["y_max_mm"])),
            grid_mm=float(board["grid_mm"]),
            grid_x=(float(board["grid_x_mm"][0]), float(board["grid_x_mm"][1])),
            grid_y=(float(board["grid_y_mm"][0]), float(board["grid_y_mm"][1])),
            tags=TagLayout(str(tags["family"]), float(tags["size_mm"]),
                           {int(k): (float(v[0]), float(v[1])) for k, v in tags["centres_mm"].items()}),
            image_size=(int(cam["width"]), int(cam["height"])),
            camera_position_mm=np.array(cam["position_mm"], float),
            camera_look_at_mm=np.array(cam["look_at_mm"], float),
            factory_K=np.array(cam["factory_K"], float),
            factory_dist=np.array(cam["factory_dist"], float),
            block_edges_mm={"large": float(blocks["large_mm"]), "small": float(blocks["small_mm"])},
            robot_base_half_mm=tuple(float(v) for v in
                                     raw.get("robot_base", {}).get("half_extent_mm", _ROBOT_BASE_HALF_MM)),
        )
    except KeyError as e:
        raise ValueError(f"{path}: missing key {e}") from None
    except (TypeError, ValueError, IndexError) as e:
        raise ValueError(f"{path}: malformed value ({e})") from None
    if cfg.factory_K.shape != (3, 3) or cfg.factory_dist.shape != (5,):
        raise ValueError(f"{path}: camera.factory_K must be 3x3 and camera.factory_dist must have 5 values")
    return cfg


@functools.lru_cache(maxsize=1)
def lab_config() -> LabConfig:
    """The default lab config (loaded once)."""
    return load_lab()
