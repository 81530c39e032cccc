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
from armlab.camera import MAX_IMAGE_SIDE_PX, check_intrinsics, look_at
from armlab.files import read_json
from armlab.schemas import camera_matrix, field_error, integer, number, strict_object, vector

__all__ = ["LabConfig", "TagLayout", "load_lab", "lab_config", "lab_schema", "APRILTAG_FAMILIES"]

MAX_GRID_LINES = 10_000              # grid lines along one axis of the board
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


APRILTAG_FAMILIES = ("tag36h11", "tag25h9", "tag16h5", "tagCircle21h7", "tagCircle49h12", "tagStandard41h12",
                     "tagStandard52h13", "tagCustom48h12")   # what pupil-apriltags detects
_MM = number(minimum=-1e5, maximum=1e5)          # a world coordinate (mm): within 100 m of the robot
_SIZE_MM = number(exclusive_minimum=0.0, maximum=1e4)
_XY = vector(_MM, 2)


def lab_schema() -> dict:
    """The declared schema of lab.json (armlab.schemas): types, finite numbers, ranges, lengths, allowed keys."""
    board = strict_object({"x_min_mm": _MM, "x_max_mm": _MM, "y_min_mm": _MM, "y_max_mm": _MM,
                           "grid_mm": number(exclusive_minimum=0.0, maximum=1e4), "grid_x_mm": _XY,
                           "grid_y_mm": _XY},
                          required=("x_min_mm", "x_max_mm", "y_min_mm", "y_max_mm", "grid_mm", "grid_x_mm",
                                    "grid_y_mm"))
    tags = strict_object({"family": {"enum": list(APRILTAG_FAMILIES)}, "size_mm": _SIZE_MM,
                          "centres_mm": {"type": "object", "minProperties": 1, "maxProperties": 1000,
                                         "patternProperties": {"^[0-9]{1,6}$": _XY}, "additionalProperties": False}},
                         required=("family", "size_mm", "centres_mm"))
    camera = strict_object({"width": integer(1, MAX_IMAGE_SIDE_PX), "height": integer(1, MAX_IMAGE_SIDE_PX),
                            "position_mm": vector(_MM, 3), "look_at_mm": vector(_MM, 3),
                            "factory_K": camera_matrix(),
                            "factory_dist": vector(number(minimum=-1e3, maximum=1e3), 5)},
                           required=("width", "height", "position_mm", "look_at_mm", "factory_K", "factory_dist"))
    blocks = strict_object({"large_mm": _SIZE_MM, "small_mm": _SIZE_MM}, required=("large_mm", "small_mm"))
    base = strict_object({"half_extent_mm": vector(number(exclusive_minimum=0.0, maximum=1e4), 2)},
                         required=("half_extent_mm",))
    return strict_object({"board": board, "tags": tags, "camera": camera, "blocks": blocks, "robot_base": base},
                         required=("board", "tags", "camera", "blocks"))


def _check_lab(cfg: LabConfig, path: Path) -> None:
    """What the schema cannot say: bounds in order, the grid and tags on the board, a camera above it that looks
    somewhere, a real camera matrix, the small block smaller than the large one. ValueError naming the field."""
    def bad(field: str, problem: str) -> ValueError:
        return field_error(path, field, problem)

    for axis, (lo, hi), (g0, g1) in (("x", cfg.board_x, cfg.grid_x), ("y", cfg.board_y, cfg.grid_y)):
        if not lo < hi:
            raise bad(f"board.{axis}_min_mm", f"must be less than board.{axis}_max_mm ({hi}), got {lo}")
        if not g0 <= g1:
            raise bad(f"board.grid_{axis}_mm", f"the first grid line must not lie beyond the last, got [{g0}, {g1}]")
        if g0 < lo or g1 > hi:
            raise bad(f"board.grid_{axis}_mm", f"grid lines [{g0}, {g1}] must lie on the board [{lo}, {hi}]")
        if (g1 - g0) / cfg.grid_mm > MAX_GRID_LINES:
            raise bad("board.grid_mm", f"{cfg.grid_mm} mm gives more than {MAX_GRID_LINES} grid lines along {axis}")
    for tag_id, centre in cfg.tags.centres_mm.items():
        if not cfg.on_board(np.array(centre)):
            raise bad(f"tags.centres_mm.{tag_id}", f"tag centre {list(centre)} mm is off the board")
    if not cfg.camera_position_mm[2] > 0:
        raise bad("camera.position_mm", f"the camera must be above the board (z > 0), got z = "
                                        f"{cfg.camera_position_mm[2]} mm")
    try:
        look_at(cfg.camera_position_mm, cfg.camera_look_at_mm)
    except ValueError as e:
        raise bad("camera.look_at_mm", str(e)) from None
    try:
        check_intrinsics(cfg.factory_K, cfg.factory_dist)
    except ValueError as e:
        raise bad("camera.factory_K", str(e)) from None
    small, large = cfg.block_edges_mm["small"], cfg.block_edges_mm["large"]
    if not small < large:
        raise bad("blocks.small_mm", f"must be less than blocks.large_mm ({large}), got {small}")


def load_lab(path: Path | str | None = None) -> LabConfig:
    """Read and validate a lab config (JSON); the default is `data/lab.json`. A file that breaks the declared
    schema (lab_schema) or the lab's geometry (_check_lab) raises ValueError naming the file and the field."""
    path = Path(path or data_path("lab.json"))
    raw = read_json(path, "lab config", schema=lab_schema())
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
    _check_lab(cfg, path)
    return cfg


@functools.lru_cache(maxsize=1)
def lab_config() -> LabConfig:
    """The default lab config (loaded once)."""
    return load_lab()
