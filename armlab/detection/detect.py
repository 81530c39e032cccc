"""detect_blocks: coloured cubes (and distractors) on the board from an aligned RGB-D frame: the pipeline.

Pipeline: depth -> world height of every pixel (the calibrated camera, heightmap.py) -> mask off-board pixels and
the arm (its pose projected into the image, masks.py) -> flat top faces (segment.py) -> per face: its pixels by
colour (colour_region.py), the square fitted to its outline on the face's plane (edges.py), the stack under it
(stacks.py) -> every cube's sides refined on the image edges in one batch (edges.py) -> shape check (cube or
distractor), size, colour (color.py) -> Block (types.py).
Positions: world mm of the top-face centre; yaw in [-pi/4, pi/4) rad about world +z.
"""

from __future__ import annotations

import warnings

import cv2
import numpy as np

from armlab.arguments import finite_array, instance_of
from armlab.camera import Camera
from armlab.detection.color import ColorModel, default_color_model
from armlab.detection.colour_region import (
    SQUARE5,
    STANDING_KERNEL,
    FrameData,
    arm_coloured,
    board_white_balance,
    refine_by_colour,
)
from armlab.detection.edges import CUBE_SIZE_SLACK, MeasuredFace, fit_square, refine_yaws
from armlab.detection.heightmap import height_from_depth, pixels_to_plane, reduced_coefficients, world_coefficients
from armlab.detection.masks import arm_mask
from armlab.detection.plausibility import NotRGBError, bgr_problem, board_problem
from armlab.detection.segment import Face, segment_faces
from armlab.detection.stacks import stack_heights, stack_levels
from armlab.detection.types import Block, DetectionSettings
from armlab.images import check_depth, check_rgb
from armlab.lab import lab_config
from armlab.transforms import wrap_quarter

__all__ = ["Block", "detect_blocks", "detect_objects", "DetectionSettings", "stack_levels", "FrameWarning",
           "NotRGBError"]


class FrameWarning(UserWarning):
    """A frame detection cannot read (no board in the colour image): no blocks are reported, and this says why."""

def _measure_all(faces: list[Face], f: FrameData, settings: DetectionSettings) -> list[MeasuredFace]:
    """Every face's outline (its pixels by colour, refine_by_colour), intersected with the horizontal plane at the
    face's height (its world footprint without the per-pixel depth noise), and the square fitted to it. The image
    work runs per face on its patch; the planes, edge hints and the outlines' world points for all faces at once."""
    if not faces:
        return []
    regions, contours, blocked, nears = [], [], [], []
    for face in faces:
        region = refine_by_colour(face, f)
        found, _ = cv2.findContours(region.mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
        contour = max(found, key=cv2.contourArea).reshape(-1, 2)
        if region.occluder.any() or region.standing.any():   # outline points next to an occluder are not the edge
            near = cv2.dilate(region.occluder.view(np.uint8), SQUARE5)
            margin = near | cv2.dilate(region.standing.view(np.uint8), STANDING_KERNEL)
            blocked.append(margin[contour[:, 1], contour[:, 0]] > 0)
        else:                                                # nothing hides the face: the dilations' zeros
            near = np.zeros(region.occluder.shape, np.uint8)
            blocked.append(np.zeros(len(contour), bool))
        regions.append(region)
        nears.append(near)
        contours.append(contour + np.array(region.origin))
    counts = [len(c) for c in contours]
    plane_z, hints = _planes_and_hints(np.array([face.height_mm for face in faces], float), settings)
    outline_xyz = pixels_to_plane(f.camera, np.concatenate(contours), np.repeat(plane_z, counts))
    cam, sizes = f.camera, tuple(lab_config().block_edges_mm.values())
    out = []
    for i, (face, region, start, n) in enumerate(zip(faces, regions, np.cumsum(counts) - counts, counts)):
        outline, z = outline_xyz[start:start + n, :2], float(plane_z[i])
        centre_guess = outline.sum(axis=0) / n                       # np.mean's value, without its overhead
        pixel_mm = float((cam.T_cam_world[2, :2] @ centre_guess + cam.T_cam_world[2, 2] * z
                          + cam.T_cam_world[2, 3]) / cam.K[0, 0])                     # the face's depth / fx
        centre_xy, sides, theta, complete = fit_square(outline, blocked[i], pixel_mm, hints[i], sizes)
        centre_xy, sides = np.asarray(centre_xy, float), np.asarray(sides, float)
        out.append(MeasuredFace(face, centre_xy.copy(), sides.copy(), float(theta), bool(complete),
                                _cube_sized(sides, settings, CUBE_SIZE_SLACK), outline, centre_xy, sides, blocked[i],
                                pixel_mm, contours[i], region.mean_rgb, region.distance, nears[i], region.origin, z))
    return out


def _planes_and_hints(height_mm: np.ndarray, settings: DetectionSettings) -> tuple[np.ndarray, list[float | None]]:
    """Per face of measured heights (F,) mm: its plane (F,) mm and the hint for its edge (mm, or None).

    The plane is the height of the lab's stack nearest to the measured height (faces are kept only within
    level_tolerance of one), which the depth reads a little low and, far out on the board, up to a few mm off; the
    image outline and edges are intersected with it (a plane 3 mm off moves a point 3 mm x its distance from the
    camera's nadir / the camera's height: 1-1.5 mm at the board's far corners). The hint, for when part of the face
    is hidden, is the block size whose stacks reach the height best (None when both sizes' stacks reach it within
    1.5 mm, as 3 x 25 and 2 x 38 do: then the free outline decides)."""
    heights = stack_heights(settings.max_levels)
    plane_z = heights[np.argmin(np.abs(heights - height_mm[:, None]), axis=1)]
    sizes = np.array(tuple(lab_config().block_edges_mm.values()))
    below = height_mm[:, None, None] - sizes[:, None] - stack_heights(settings.max_levels, include_zero=True)
    misfit = np.abs(below).min(axis=2)                                     # (F, sizes)
    fits = np.ptp(misfit, axis=1) >= 1.5
    return plane_z, [float(sizes[k]) if fit else None for k, fit in zip(np.argmin(misfit, axis=1), fits)]


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


def _describe(measured: list[MeasuredFace], f: FrameData, settings: DetectionSettings, color_model: ColorModel,
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


def _on_board(height_small: np.ndarray, valid: np.ndarray, f: FrameData, settings: DetectionSettings) -> np.ndarray:
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
    Returns [] when the depth image holds no return at all, and [] with a FrameWarning when the colour image does
    not show the board where the depth does (all black, all white, noise: detection.plausibility). Raises
    ValueError for images of the wrong type or size, and NotRGBError (a ValueError) when the cubes' colours say the
    image is BGR.
    """
    rgb = check_rgb(rgb)
    depth = check_depth(depth_mm, rgb.shape[:2])
    instance_of(camera, "camera", Camera, "the calibrated camera: calibration.camera")
    if rgb.shape[:2] != camera.image_shape:
        raise ValueError(f"image is {rgb.shape[1]}x{rgb.shape[0]} but the camera is {camera.width}x{camera.height}")
    if arm_q is not None:
        arm_q = finite_array(arm_q, "arm_q", (5,), "the arm's joint angles in rad")
    settings = DetectionSettings() if settings is None else instance_of(settings, "settings", DetectionSettings)
    color_model = default_color_model() if color_model is None else instance_of(color_model, "color_model",
                                                                                 ColorModel)
    arm_small = None if arm_q is None else arm_mask(camera, arm_q, step=settings.step)
    f = FrameData(rgb, depth, camera, arm_small, settings.step)
    height = height_from_depth(depth, camera, settings.step)
    valid = height < settings.max_height            # False where there is no return (NaN)
    if not valid.any():      # no return (or nothing below max_height) among the sampled pixels: nothing to find
        return []
    if arm_small is not None:   # inside the arm's reach in the image, only the arm's own dark grey is masked
        rows, cols = np.flatnonzero(arm_small.any(axis=1)), np.flatnonzero(arm_small.any(axis=0))
        if len(rows):
            s, (r0, r1), (c0, c1) = settings.step, rows[[0, -1]], cols[[0, -1]]
            box = arm_small[r0:r1 + 1, c0:c1 + 1]
            box &= arm_coloured(rgb[r0 * s:(r1 + 1) * s:s, c0 * s:(c1 + 1) * s:s])
        valid &= ~arm_small
    valid = _on_board(height, valid, f, settings)
    s4 = 4 * settings.step                      # the board's pixels, sampled as board_white_balance samples them
    with np.errstate(invalid="ignore"):
        board = valid[::4, ::4] & (np.abs(height[::4, ::4]) < 4.0)
    rows, cols = rgb[::s4], np.arange(0, rgb.shape[1], s4)
    problem = board_problem(rows[:, cols], rows[:, np.minimum(cols + 1, rgb.shape[1] - 1)], board)
    if problem is not None:
        warnings.warn(f"detect: no blocks reported: {problem}", FrameWarning, stacklevel=2)
        return []
    gains = board_white_balance(rgb, height, valid, settings.step)
    faces = segment_faces(height, valid, settings.min_height,
                          min_face_pixels=max(8, settings.min_face_pixels // settings.step ** 2),
                          median_px=5 if settings.step == 1 else 3,
                          max_slope_mm=settings.max_face_slope * settings.step)
    heights = stack_heights(settings.max_levels)
    faces = [face for face in faces if np.min(np.abs(heights - face.height_mm)) <= settings.level_tolerance]
    measured = _measure_all(faces, f, settings)
    # what cannot be a cube is not worth refining; what is near enough is judged again on its refined square
    cubes = [m for m in measured if m.cube_sized]
    for m, theta in zip(cubes, refine_yaws(camera, cubes)):
        m.theta = float(theta)
        m.cube_sized = _cube_sized(m.sides, settings)
    found = _describe(measured, f, settings, color_model, gains)
    swapped = bgr_problem(np.array([b.mean_rgb * gains for b in found if b.is_block]).reshape(-1, 3),
                          color_model.common_distances)
    if swapped is not None:
        raise NotRGBError(f"rgb: {swapped}")
    found.sort(key=lambda b: float(np.hypot(*b.position[:2])))
    return found


def detect_blocks(rgb, depth_mm, camera: Camera, arm_q=None, color_model: ColorModel | None = None,
                  settings: DetectionSettings | None = None) -> list[Block]:
    """The cubes on the board (distractors left out): see detect_objects for the arguments."""
    return [b for b in detect_objects(rgb, depth_mm, camera, arm_q, color_model, settings) if b.is_block]
