"""Pure geometry of what the viewer draws, in world millimetres (no meshcat here, so it is easy to test).

World frame = board frame (origin on the board below the waist axis, +y away from the robot, +z up). Every pose is a
4x4 homogeneous transform from the part's own frame to the world. Primitive conventions follow three.js, which
meshcat uses: a cylinder's axis is its local y axis and it is centred on its origin; a box is centred on its origin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab import kinematics
from armlab.blocks import ObjectState, footprint
from armlab.camera import Camera
from armlab.lab import LabConfig
from armlab.transforms import homogeneous, matrix_from_rpy

__all__ = [
    "LINK_NAMES", "LINK_RADII_MM", "JOINT_DRUMS", "FINGER_SIZE_MM", "PALM_SIZE_MM", "MAX_GRIPPER_OPENING_MM",
    "frame_along_y", "segment_pose", "arm_part_poses", "check_opening", "board_grid_segments",
    "tag_poses", "extruded_mesh", "object_pose", "object_mesh", "frustum_corners", "frustum_segments",
    "rgbd_to_point_cloud", "ArmPoses", "frame_name",
]

# The arm's links run between consecutive points of kinematics.joint_positions(q):
# base, waist top, shoulder, elbow, wrist, wrist_rotate, tool point.
LINK_NAMES: tuple[str, ...] = ("base", "waist", "upper_arm", "forearm", "wrist", "hand")
LINK_RADII_MM: tuple[float, ...] = (45.0, 30.0, 18.0, 16.0, 14.0, 6.0)
# Joint drums (name, index in joint_positions, index of the DH frame whose z axis is the joint axis).
JOINT_DRUMS: tuple[tuple[str, int, int], ...] = (
    ("shoulder", 2, 1), ("elbow", 3, 2), ("wrist_angle", 4, 3), ("wrist_rotate", 5, 4))
DRUM_LENGTH_MM, DRUM_RADIUS_MM = 50.0, 22.0
# Gripper, in the tool frame ee_gripper_link (x = approach, y = finger opening direction). The finger pads' inner
# faces sit at y = +/- opening / 2; the palm (the manufacturer's fingers_link) is 27.575 mm behind the tool point.
FINGER_SIZE_MM = (40.0, 8.0, 20.0)          # along tool x, y, z
FINGER_CENTRE_X_MM = -12.0
PALM_SIZE_MM = (10.0, 90.0, 24.0)
PALM_CENTRE_X_MM = -27.575 - 5.0
MAX_GRIPPER_OPENING_MM = 74.0               # stock fingers: 30-74 mm (Interbotix RX200 specification)


@dataclass(frozen=True)
class ArmPoses:
    """World poses (..., 4, 4) of every drawn part of the arm, keyed by scene path relative to the arm node."""

    poses: dict[str, np.ndarray]
    points: np.ndarray  # (..., 7, 3) kinematics.joint_positions, mm


def frame_along_y(direction) -> np.ndarray:
    """Rotation(s) (..., 3, 3) whose y column is the unit vector along `direction` (..., 3).

    The x column is horizontal when possible (perpendicular to world z), so the frame turns smoothly with the arm.
    """
    d = np.asarray(direction, dtype=float)
    y = d / np.linalg.norm(d, axis=-1, keepdims=True)
    x = np.cross(y, [0.0, 0.0, 1.0])
    n = np.linalg.norm(x, axis=-1, keepdims=True)
    fallback = np.cross(y, [1.0, 0.0, 0.0])  # direction along world z: any perpendicular will do
    x = np.where(n > 1e-9, x / np.where(n > 1e-9, n, 1.0), fallback / np.linalg.norm(fallback, axis=-1, keepdims=True))
    z = np.cross(x, y)
    return np.stack([x, y, z], axis=-1)


def segment_pose(start, end) -> np.ndarray:
    """Pose(s) (..., 4, 4) placing a y-axis cylinder centred on its origin between points start and end (..., 3)."""
    start, end = np.asarray(start, dtype=float), np.asarray(end, dtype=float)
    return homogeneous(frame_along_y(end - start), (start + end) / 2)


def check_opening(gripper_opening_mm) -> np.ndarray:
    """Validate gripper opening(s) in mm: finite, within [0, MAX_GRIPPER_OPENING_MM]."""
    g = np.asarray(gripper_opening_mm, dtype=float)
    if not np.all(np.isfinite(g)):
        raise ValueError("gripper_opening_mm contains NaN or infinity")
    if np.any(g < 0) or np.any(g > MAX_GRIPPER_OPENING_MM):
        raise ValueError(f"gripper_opening_mm must lie in [0, {MAX_GRIPPER_OPENING_MM:g}] mm (the distance between "
                         f"the finger pads), got {g.min():g}..{g.max():g}")
    return g


def arm_part_poses(q, gripper_opening_mm=40.0) -> ArmPoses:
    """World poses of the arm's links, joint drums, gripper parts and frame triads for joints q (5,) or (N, 5) rad.

    Links are y-axis cylinders between the points of kinematics.joint_positions(q); joint drums are y-axis cylinders
    along each joint's axis; fingers and palm are boxes in the tool frame, the finger pads' inner faces at
    y = +/- opening / 2 (mm); triads are the frames of kinematics.link_frames(q) (world, DH 1..5, tool).
    Raises ValueError for a wrong shape, NaN or a joint outside its limits.
    """
    q = kinematics.check_joints(q)
    g = check_opening(gripper_opening_mm)
    frames = kinematics.link_frames(q)                 # (..., 7, 4, 4)
    points = kinematics.joint_positions(q)             # (..., 7, 3)
    batch = frames.shape[:-3]
    if g.shape not in ((), batch):
        raise ValueError(f"gripper_opening_mm must be one value or one per pose {batch}, got shape {g.shape}")
    half = np.broadcast_to(g / 2, batch)
    poses: dict[str, np.ndarray] = {}
    for i, name in enumerate(LINK_NAMES):
        poses[f"links/{name}"] = segment_pose(points[..., i, :], points[..., i + 1, :])
    for name, point, frame in JOINT_DRUMS:
        poses[f"joints/{name}"] = homogeneous(frame_along_y(frames[..., frame, :3, 2]), points[..., point, :])
    tool = frames[..., 6, :, :]
    for side, sign in (("left_finger", 1.0), ("right_finger", -1.0)):
        offset = np.zeros(batch + (3,))
        offset[..., 0] = FINGER_CENTRE_X_MM
        offset[..., 1] = sign * (half + FINGER_SIZE_MM[1] / 2)
        poses[f"gripper/{side}"] = tool @ homogeneous(None, offset)
    poses["gripper/palm"] = tool @ homogeneous(None, [PALM_CENTRE_X_MM, 0.0, 0.0])
    poses["gripper/tool_point"] = tool
    for i in range(7):
        poses[f"frames/{frame_name(i)}"] = frames[..., i, :, :]
    return ArmPoses(poses, points)


def frame_name(i: int) -> str:
    """Name of entry i of kinematics.link_frames: world, dh1..dh5, tool."""
    return "world" if i == 0 else ("tool" if i == 6 else f"dh{i}")


def board_grid_segments(lab: LabConfig, z_mm: float = 0.5) -> np.ndarray:
    """Line segments (2K, 3) of the printed grid: one line every grid_mm along x and y over the grid's extent."""
    xs = np.arange(lab.grid_x[0], lab.grid_x[1] + lab.grid_mm / 2, lab.grid_mm)
    ys = np.arange(lab.grid_y[0], lab.grid_y[1] + lab.grid_mm / 2, lab.grid_mm)
    (x0, x1), (y0, y1) = lab.grid_x, lab.grid_y
    vertical = [[(x, y0, z_mm), (x, y1, z_mm)] for x in xs]
    horizontal = [[(x0, y, z_mm), (x1, y, z_mm)] for y in ys]
    return np.asarray(vertical + horizontal, dtype=float).reshape(-1, 3)


def tag_poses(lab: LabConfig, z_mm: float = 0.5) -> dict[int, np.ndarray]:
    """Pose (4, 4) of each AprilTag's black square (a box centred on the tag), keyed by tag id."""
    return {i: homogeneous(None, [cx, cy, z_mm]) for i, (cx, cy) in sorted(lab.tags.centres_mm.items())}


def extruded_mesh(polygons: list[np.ndarray], z0: float, z1: float) -> tuple[np.ndarray, np.ndarray]:
    """Triangle mesh (vertices (V, 3), faces (F, 3)) of convex polygons (each (K, 2), counter-clockwise) extruded
    from z0 to z1: bottom and top fans plus the side walls, outward-facing."""
    vertices, faces = [], []
    base = 0
    for poly in polygons:
        poly = np.asarray(poly, dtype=float)
        k = len(poly)
        vertices.append(np.column_stack([poly, np.full(k, z0)]))
        vertices.append(np.column_stack([poly, np.full(k, z1)]))
        fan = np.arange(1, k - 1)
        faces.append(np.column_stack([np.full(k - 2, base), fan + 1, fan]))                  # bottom, facing -z
        faces.append(np.column_stack([np.full(k - 2, base + k), base + k + fan, base + k + fan + 1]))  # top, +z
        i = np.arange(k)
        j = (i + 1) % k
        faces.append(np.column_stack([base + i, base + j, base + k + j]))
        faces.append(np.column_stack([base + i, base + k + j, base + k + i]))
        base += 2 * k
    return np.vstack(vertices), np.vstack(faces).astype(np.int64)


def object_pose(obj: ObjectState) -> np.ndarray:
    """Pose (4, 4) of an object's own frame in the world: at its centre, turned by yaw (and tilt while tipping)."""
    roll, pitch = np.asarray(obj.tilt, dtype=float)
    return homogeneous(matrix_from_rpy([roll, pitch, obj.yaw]), obj.position)


def object_mesh(obj: ObjectState) -> tuple[np.ndarray, np.ndarray]:
    """Mesh of an object in its own frame (centred, mm): its footprint extruded over its edge height."""
    return extruded_mesh(footprint(obj.shape, obj.edge), -obj.edge / 2, obj.edge / 2)


def frustum_corners(camera: Camera, depth_mm: float) -> np.ndarray:
    """World points (4, 3) seen by the image's corner pixels at camera-frame depth depth_mm (mm): top-left,
    top-right, bottom-right, bottom-left (pixel centres at integers, so the image edges are at -0.5 and W-0.5)."""
    if not np.isfinite(depth_mm) or depth_mm <= 0:
        raise ValueError(f"depth_mm must be a positive distance in mm, got {depth_mm}")
    w, h = camera.width, camera.height
    uv = np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])
    return camera.pixel_to_world(uv, np.full(4, float(depth_mm)))


def frustum_segments(camera: Camera, depth_mm: float) -> np.ndarray:
    """Line segments (16, 3) of the view frustum: centre to each corner, then the far rectangle."""
    corners = frustum_corners(camera, depth_mm)
    centre = camera.position
    rays = [(centre, c) for c in corners]
    rim = [(corners[i], corners[(i + 1) % 4]) for i in range(4)]
    return np.asarray(rays + rim, dtype=float).reshape(-1, 3)


def rgbd_to_point_cloud(rgb, depth_mm, camera: Camera, stride: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """World point cloud of an RGB-D frame: every `stride`-th pixel in u and v with a depth return.

    rgb (H, W, 3) uint8 and depth_mm (H, W) float mm (camera-frame Z, NaN = no return), H, W = the camera's image
    size. Returns points (N, 3) world mm (via Camera.pixel_to_world) and their colours (N, 3) uint8.
    """
    rgb, depth = np.asarray(rgb), np.asarray(depth_mm)
    if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype != np.uint8:
        raise ValueError(f"rgb must be a uint8 (H, W, 3) image, got {rgb.dtype} {rgb.shape}")
    if depth.shape != rgb.shape[:2]:
        raise ValueError(f"depth_mm must have the image's shape {rgb.shape[:2]}, got {depth.shape}")
    if not np.issubdtype(depth.dtype, np.floating):
        raise ValueError(f"depth_mm must hold float millimetres (NaN = no return), got {depth.dtype}")
    if rgb.shape[:2] != camera.image_shape:
        raise ValueError(f"the frame is {rgb.shape[1]}x{rgb.shape[0]} but the camera is {camera.width}x{camera.height}")
    if int(stride) < 1:
        raise ValueError(f"stride must be a positive number of pixels, got {stride}")
    stride = int(stride)
    v, u = np.mgrid[0:rgb.shape[0]:stride, 0:rgb.shape[1]:stride]
    z = depth[v, u]
    keep = np.isfinite(z) & (z > 0)
    uv = np.column_stack([u[keep], v[keep]]).astype(float)
    points = camera.pixel_to_world(uv, z[keep]) if len(uv) else np.zeros((0, 3))
    return points, rgb[v, u][keep]
