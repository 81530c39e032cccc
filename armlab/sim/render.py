"""The simulated RGB-D camera's renderer: what an L515 above the board sees, as a pure function of the scene.

`render(camera, objects, q, gripper_opening_mm, gripper_geometry, realism, rng)` draws the table and board (grid,
AprilTags) as one textured plane z = 0, the objects (blocks and distractors, flat-shaded by their faces' angle to the
light) and the RX200 (dark boxes along its links, the gripper fingers at the opening) with a depth buffer in the
camera's ideal pinhole image, applies the lens distortion (a remap, redone per frame only where faces were drawn),
then the sensor effects of `realism`. The board's canvas and camera image are cached per camera.

Inputs: `camera` the TRUE camera (armlab.camera.Camera: K, distortion, T_cam_world); objects: armlab.blocks.
ObjectState-like (footprint_world(), bottom_z, top_z, color, position); q (5,) rad or None (no arm); mm everywhere.
Outputs: rgb (H, W, 3) uint8 and depth (H, W) float32 mm = camera-frame Z of the visible surface, NaN = no return.
"""

from __future__ import annotations

import functools

import cv2
import numpy as np

from armlab.camera import Camera
from armlab.sim.board_texture import board_texture
from armlab.sim.faces import FaceSet, arm_faces, objects_faces
from armlab.sim.raster import Canvas, View, view_for
from armlab.sim.realism import CameraRealism
from armlab.sim.sensor import Reuse, apply_color_effects, apply_depth_effects

__all__ = ["render", "render_exact", "scene_faces", "board_canvas", "BOARD_SURFACE", "FIRST_FACE_SURFACE"]

BOARD_SURFACE = 1          # surface id of the table/board plane
FIRST_FACE_SURFACE = 16    # faces get ids from here on (lower ids are for textured planes)


@functools.lru_cache(maxsize=8)
def board_canvas(view: View) -> Canvas:
    """The canvas of a view with only the table and board drawn (cached: the board never moves)."""
    canvas = view.new_canvas()
    tex = board_texture()
    view.draw_plane(canvas, tex.image, tex.H_world_texel, view.camera.T_cam_world, BOARD_SURFACE,
                    border=cv2.BORDER_REPLICATE, z_test=False)
    return canvas.freeze()


def scene_faces(objects, q=None, gripper_opening_mm: float = 0.0, gripper_geometry=None) -> FaceSet:
    """World faces of the objects and (when q is given) the arm."""
    sets = [objects_faces(objects)]
    if q is not None:
        if gripper_geometry is None:
            raise ValueError("gripper_geometry is needed to draw the arm (pad_width_mm, pad_height_mm, "
                             "pad_thickness_mm)")
        sets.append(arm_faces(q, gripper_opening_mm, gripper_geometry))
    return FaceSet.concat(sets)


def draw_faces(view: View, canvas: Canvas, faces: FaceSet) -> None:
    """Rasterise world faces into a canvas of the view (z-buffered, shaded); face i gets surface id
    FIRST_FACE_SURFACE + i."""
    if len(faces) + FIRST_FACE_SURFACE > np.iinfo(np.uint16).max:
        raise ValueError(f"too many faces to draw ({len(faces)})")
    R, t = view.camera.T_cam_world[:3, :3], view.camera.T_cam_world[:3, 3]
    view.fill_polygons(canvas, faces.vertices @ R.T + t, faces.normals @ R.T, faces.shaded_colors(),
                       FIRST_FACE_SURFACE + np.arange(len(faces)))


def render_exact(camera: Camera, objects, q=None, gripper_opening_mm: float = 0.0, gripper_geometry=None,
                 planes=()) -> tuple[np.ndarray, np.ndarray]:
    """The exact image of the scene through the camera (no sensor effects): rgb (H, W, 3) uint8, depth (H, W)
    float32 mm. `planes`: extra callables drawing into the canvas, each called as plane(view, canvas)."""
    rgb, depth, _ = _render_exact(camera, objects, q, gripper_opening_mm, gripper_geometry, planes)
    return rgb, depth


def _render_exact(camera: Camera, objects, q, gripper_opening_mm: float, gripper_geometry,
                  planes) -> tuple[np.ndarray, np.ndarray, Reuse | None]:
    """render_exact, and (when the lens was redone only in parts of the image) what the frame shares with the
    camera's cached board image, for the sensor effects."""
    view = view_for(camera)
    base = board_canvas(view)
    canvas = base.copy()
    for draw in planes:
        draw(view, canvas)
    draw_faces(view, canvas, scene_faces(objects, q, gripper_opening_mm, gripper_geometry))
    rgb, depth, _ = view.finish(canvas)
    reuse = None
    if canvas.base is base and canvas.lens_rects is not None and base.finished is not None:
        reuse = Reuse(base.finished[0], base.finished[1], canvas.lens_rects, base.sensor_cache)
    return rgb, depth, reuse


def _check_camera(camera) -> None:
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be an armlab.camera.Camera, got {type(camera).__name__}")


def render(camera: Camera, objects, q=None, gripper_opening_mm: float = 0.0, gripper_geometry=None,
           realism: CameraRealism | None = None, rng: np.random.Generator | None = None,
           planes=()) -> tuple[np.ndarray, np.ndarray]:
    """What the RGB-D camera records: rgb (H, W, 3) uint8 and depth (H, W) float32 mm (camera-frame Z, NaN = no
    return) of the board, `objects`, and the arm at joint angles q (5,) rad (None: no arm) with its fingers
    `gripper_opening_mm` apart. `realism` (default ideal) adds the sensor effects, drawn from `rng` (per frame)."""
    _check_camera(camera)
    realism = realism if realism is not None else CameraRealism.ideal()
    if not realism.is_ideal and rng is None:
        raise ValueError("a numpy Generator `rng` is needed for a realism with noise")
    rgb, depth, reuse = _render_exact(camera, objects, q, gripper_opening_mm, gripper_geometry, planes)
    if realism.is_ideal:
        return rgb, depth
    rgb_out = apply_color_effects(rgb, (camera.K[0, 2], camera.K[1, 2]), realism, rng, reuse)
    depth_out = apply_depth_effects(depth, rgb, realism, rng, reuse)
    return rgb_out, depth_out
