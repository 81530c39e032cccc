"""detect_blocks: coloured cubes (and distractors) on the board from an aligned RGB-D frame.

Pipeline: depth -> world height of every pixel (the calibrated camera) -> mask off-board pixels and the arm (its
pose projected into the image) -> flat top faces (segment.py) -> per face: world footprint (minimum-area rectangle
of the face's world points) for centre, edge and yaw; shape check (cube or distractor); colour (color.py).
Positions: world mm of the top-face centre; yaw in [-pi/4, pi/4) rad about world +z.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from armlab.camera import Camera
from armlab.detection.color import ColorModel, white_balance_gains
from armlab.detection.heightmap import world_from_depth
from armlab.detection.masks import arm_mask
from armlab.detection.segment import Face, segment_faces
from armlab.images import check_depth, check_rgb
from armlab.lab import lab_config

__all__ = ["Block", "detect_blocks", "detect_objects", "DetectionSettings"]


@dataclass(frozen=True)
class Block:
    """A detected object's top face.

    color: one of the six block colours (nearest class), size: "large" or "small", position: (3,) world mm of the
    top-face centre, yaw: rad in [-pi/4, pi/4), pixel: (u, v) of the face centre, edge_mm: measured edge,
    shape: "cube" or "distractor", levels: how many blocks high the stack under this face is (top z / edge),
    color_margin: how clearly the colour won (larger is surer), contour: (K, 2) image outline of the face.
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

    @property
    def is_block(self) -> bool:
        return self.shape == "cube"


@dataclass(frozen=True)
class DetectionSettings:
    """Thresholds (mm unless noted). min_height: objects rise at least this above the board (half a small cube);
    max_height: higher pixels are the arm or a hand; size_split: edges above are "large" (25 vs 38 mm cubes);
    cube_edge_range: plausible cube edges; min_rectangularity: face area / its minimum rectangle (a square is 1,
    a disc 0.79, a triangle 0.5); max_aspect: longest / shortest side of a cube face."""

    min_height: float = 10.0
    max_height: float = 260.0
    size_split: float = 31.5
    cube_edge_range: tuple[float, float] = (19.0, 46.0)
    min_rectangularity: float = 0.8
    max_aspect: float = 1.3
    board_margin: float = 5.0


def _wrap_yaw(angle: float) -> float:
    """Wrap an angle to [-pi/4, pi/4): a square looks the same every quarter turn."""
    return float((angle + np.pi / 4) % (np.pi / 2) - np.pi / 4)


def _board_white_balance(rgb: np.ndarray, height: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Gains from the board's own pixels (flat, near z = 0), sampled sparsely."""
    sample = (valid & (np.abs(height) < 4.0))[::8, ::8]
    pixels = rgb[::8, ::8][sample]
    if len(pixels) < 100:
        return np.ones(3)
    # the printed grid and tags are dark: use the bright majority of the board
    bright = pixels[pixels.sum(1) > np.percentile(pixels.sum(1), 40)]
    return white_balance_gains(bright.mean(axis=0))


def _refine_by_colour(face: Face, rgb: np.ndarray, height: np.ndarray, min_height: float, pad: int = 8):
    """The face's pixels by colour: the top face is evenly lit and brighter than the shaded sides, so pixels near the
    depth-seeded face whose colour matches the face's core colour (and that stand above the board) form the face.
    Returns the refined mask (uint8) over the padded box, the box origin (x0, y0) and the core's mean colour."""
    x, y, w, h = face.bbox
    H, W = height.shape
    x0, y0, x1, y1 = max(0, x - pad), max(0, y - pad), min(W, x + w + pad), min(H, y + h + pad)
    seed = np.zeros((y1 - y0, x1 - x0), np.uint8)
    seed[y - y0:y - y0 + h, x - x0:x - x0 + w] = face.mask
    core = cv2.erode(seed, np.ones((7, 7), np.uint8)).astype(bool)
    if core.sum() < 20:
        core = seed.astype(bool)
    patch = rgb[y0:y1, x0:x1].astype(np.float32)
    colours = patch[core]
    mean = colours.mean(axis=0)
    spread = np.maximum(colours.std(axis=0), 4.0)
    distance = np.sqrt((((patch - mean) / spread) ** 2).sum(-1))
    raised = np.nan_to_num(height[y0:y1, x0:x1], nan=0.0) > min_height
    candidate = ((distance < 3.5) & raised).astype(np.uint8)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(candidate, connectivity=4)
    if n <= 1:
        return seed, (x0, y0), mean
    overlap = np.bincount(labels[seed.astype(bool)], minlength=n)
    overlap[0] = 0
    mask = (labels == int(np.argmax(overlap))).astype(np.uint8)
    return cv2.morphologyEx(mask, cv2.MORPH_CLOSE, np.ones((3, 3), np.uint8)), (x0, y0), mean


def _describe(face: Face, camera: Camera, rgb: np.ndarray, height: np.ndarray, min_height: float):
    """Geometry and colour of one face. The face's outline (image) is intersected with the horizontal plane at the
    face's height, which gives its world footprint without the per-pixel depth noise."""
    mask_u8, origin, mean_rgb = _refine_by_colour(face, rgb, height, min_height)
    contours, _ = cv2.findContours(mask_u8, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    contour = max(contours, key=cv2.contourArea).reshape(-1, 2) + np.array(origin)
    outline = camera.pixel_to_plane(contour.astype(float), face.height_mm)[:, :2].astype(np.float32)
    (cx, cy), (w, h), angle = cv2.minAreaRect(outline)
    # The outline runs through the centres of the boundary pixels: half a pixel inside the true edge on each side.
    pixel_mm = float(camera.depth_of(np.array([[cx, cy, face.height_mm]]))[0] / camera.K[0, 0])
    area = cv2.contourArea(outline) + 0.5 * pixel_mm * cv2.arcLength(outline, True)
    w, h = w + pixel_mm, h + pixel_mm
    rectangularity = float(area / (w * h)) if w * h > 0 else 0.0
    aspect = float(max(w, h) / max(min(w, h), 1e-6))
    centre = np.array([cx, cy, face.height_mm])
    u, v = camera.project(centre[None])[0]
    return centre, float(np.sqrt(w * h)), np.radians(angle), rectangularity, aspect, mean_rgb, contour, (u, v)


def detect_objects(rgb, depth_mm, camera: Camera, arm_q=None, color_model: ColorModel | None = None,
                   settings: DetectionSettings | None = None) -> list[Block]:
    """Every object's top face: cubes and distractors (shape == "distractor"), nearest first from the robot.

    Args:
        rgb: (H, W, 3) uint8 RGB.
        depth_mm: (H, W) float depth in mm aligned to rgb (NaN = no return), already depth-corrected if you have a
            correction (calibration.DepthCorrection.apply).
        camera: the calibrated camera (intrinsics, distortion and T_cam_world).
        arm_q: the arm's joint angles (5,) rad, to mask the arm out (None: no arm masking).
        color_model: colour classes (default: the lab's reference colours).
    """
    rgb = check_rgb(rgb)
    depth = check_depth(depth_mm, rgb.shape[:2])
    if rgb.shape[:2] != camera.image_shape:
        raise ValueError(f"image is {rgb.shape[1]}x{rgb.shape[0]} but the camera is {camera.width}x{camera.height}")
    settings = settings or DetectionSettings()
    color_model = color_model or ColorModel.from_reference()
    if not np.isfinite(depth).any():
        return []
    world = world_from_depth(depth, camera)
    cfg = lab_config()
    m = settings.board_margin
    valid = ((world[0] > cfg.board_x[0] + m) & (world[0] < cfg.board_x[1] - m)
             & (world[1] > cfg.board_y[0] + m) & (world[1] < cfg.board_y[1] - m)
             & (world[2] < settings.max_height)
             & ~cfg.on_robot_base(np.moveaxis(world[:2], 0, -1), margin_mm=15.0))
    if arm_q is not None:
        valid &= ~arm_mask(camera, arm_q)
    gains = _board_white_balance(rgb, world[2], valid)
    faces = segment_faces(world[2], valid, settings.min_height)
    found: list[Block] = []
    for face in faces:
        described = _describe(face, camera, rgb, world[2], settings.min_height)
        centre, edge, angle, rectangularity, aspect, mean_rgb, contour, (u, v) = described
        lo, hi = settings.cube_edge_range
        is_cube = lo <= edge <= hi and rectangularity >= settings.min_rectangularity and aspect <= settings.max_aspect
        size = "large" if edge > settings.size_split else "small"
        names, margin = color_model.classify((mean_rgb * gains)[None])
        nominal = cfg.block_edges_mm[size]
        found.append(Block(color=names[0], size=size, position=centre,
                           yaw=_wrap_yaw(angle), pixel=(float(u), float(v)), edge_mm=edge,
                           shape="cube" if is_cube else "distractor",
                           levels=max(1, int(round(face.height_mm / nominal))), color_margin=float(margin[0]),
                           contour=contour))
    found.sort(key=lambda b: float(np.hypot(*b.position[:2])))
    return found


def detect_blocks(rgb, depth_mm, camera: Camera, arm_q=None, color_model: ColorModel | None = None,
                  settings: DetectionSettings | None = None) -> list[Block]:
    """The cubes on the board (distractors left out): see detect_objects for the arguments."""
    return [b for b in detect_objects(rgb, depth_mm, camera, arm_q, color_model, settings) if b.is_block]
