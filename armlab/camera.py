"""The camera model: intrinsics K, Brown-Conrady distortion, extrinsic T_cam_world; projection and back-projection.

Conventions: pixels are OpenCV's (u right, v down, integer = pixel centre). `T_cam_world` maps world points (mm)
into the camera frame (mm; z along the optical axis, x right, y down in the image). Depth values are the camera-frame
Z of the surface seen at a pixel, in mm (what the RealSense reports), not the length of the ray.
"""

from __future__ import annotations

import cv2
import numpy as np

from armlab.arguments import finite_array, int_in_range, plain
from armlab.transforms import homogeneous, invert_transform

__all__ = ["Camera", "look_at", "distort_normalized", "check_intrinsics", "MAX_IMAGE_SIDE_PX", "MAX_DISTANCE_MM"]

MAX_IMAGE_SIDE_PX = 100_000       # no camera makes images wider or taller (px)
MAX_DISTANCE_MM = 1e7             # no camera is placed 10 km from the board (mm)

# OpenCV 4 names undistortPoints with stop criteria undistortPointsIter; OpenCV 5 folds it into undistortPoints
# (same arguments by keyword).
_UNDISTORT_POINTS = getattr(cv2, "undistortPointsIter", None) or cv2.undistortPoints


def check_intrinsics(K, dist) -> tuple[np.ndarray, np.ndarray]:
    """Validate a 3x3 camera matrix (positive focal lengths, last row 0 0 1) and 4, 5 or 8 distortion terms."""
    K = finite_array(K, "camera matrix K", (3, 3), "a 3x3 matrix in px")
    dist = finite_array(dist, "distortion dist", what="Brown-Conrady k1, k2, p1, p2[, k3...]").ravel()
    if K[0, 0] <= 0 or K[1, 1] <= 0 or not np.allclose(K[2], [0, 0, 1]) or K[1, 0] != 0:
        raise ValueError("camera matrix K must be [[fx, s, cx], [0, fy, cy], [0, 0, 1]] with fx, fy > 0")
    if dist.size not in (4, 5, 8) or not np.all(np.isfinite(dist)):
        raise ValueError(f"distortion must hold 4, 5 or 8 finite Brown-Conrady terms (k1, k2, p1, p2[, k3...]), "
                         f"got {dist.size}")
    if dist.size == 4:
        dist = np.append(dist, 0.0)
    return K, dist


def distort_normalized(xy: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Apply Brown-Conrady distortion (k1, k2, p1, p2, k3[, k4, k5, k6]) to normalised coordinates (N, 2)."""
    x, y = xy[..., 0], xy[..., 1]
    k1, k2, p1, p2, k3 = dist[:5]
    r2 = x * x + y * y
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    if dist.size == 8:
        k4, k5, k6 = dist[5:]
        radial = radial / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([xd, yd], axis=-1)


def look_at(position, target, up=(0.0, 1.0, 0.0)) -> np.ndarray:
    """T_cam_world (4, 4) for a camera at `position` (world mm) whose optical axis points at `target`.

    `up` is the world direction that should appear upwards in the image (default +y, the far side of the board).
    """
    position, target, up = (np.asarray(a, dtype=float) for a in (position, target, up))
    z = target - position
    if np.linalg.norm(z) < 1e-9:
        raise ValueError("look_at: position and target coincide")
    z /= np.linalg.norm(z)
    x = np.cross(z, up)  # image right = optical axis x up (y points down in the image)
    if np.linalg.norm(x) < 1e-9:
        raise ValueError("look_at: the up direction is parallel to the optical axis")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R_world_cam = np.stack([x, y, z], axis=1)
    return invert_transform(homogeneous(R_world_cam, position))


class Camera:
    """A calibrated pinhole camera with Brown-Conrady distortion, placed in the world.

    Args:
        K: (3, 3) intrinsic matrix (px).
        dist: distortion (k1, k2, p1, p2[, k3[, k4, k5, k6]]).
        T_cam_world: (4, 4) world (mm) -> camera (mm).
        width, height: image size in pixels.
    """

    def __init__(self, K, dist, T_cam_world, width: int = 1280, height: int = 720):
        self.K, self.dist = check_intrinsics(K, dist)
        T = finite_array(T_cam_world, "T_cam_world", (4, 4), "world mm -> camera mm")
        R = T[:3, :3]
        rigid = np.allclose(R @ R.T, np.eye(3), atol=1e-6) and np.linalg.det(R) > 0
        if not rigid or not np.allclose(T[3], [0, 0, 0, 1]) or np.abs(T[:3, 3]).max() > MAX_DISTANCE_MM:
            raise ValueError(f"T_cam_world must be a rigid transform (orthonormal rotation, last row 0 0 0 1, "
                             f"translation within {MAX_DISTANCE_MM:.0e} mm)")
        self.T_cam_world = T
        self.T_world_cam = invert_transform(T)
        self.width = _image_side(width, "width")
        self.height = _image_side(height, "height")

    def __repr__(self) -> str:
        fx, fy, cx, cy = self.K[0, 0], self.K[1, 1], self.K[0, 2], self.K[1, 2]
        pos = self.position
        return (f"Camera(fx={fx:.1f}, fy={fy:.1f}, cx={cx:.1f}, cy={cy:.1f}, {self.width}x{self.height}, "
                f"at ({pos[0]:.1f}, {pos[1]:.1f}, {pos[2]:.1f}) mm)")

    @property
    def position(self) -> np.ndarray:
        """Camera centre in the world (mm)."""
        return self.T_world_cam[:3, 3].copy()

    @property
    def image_shape(self) -> tuple[int, int]:
        """(height, width) of the images this camera makes."""
        return self.height, self.width

    # -- world <-> camera ---------------------------------------------------------------------------------------
    def world_to_camera(self, points_world) -> np.ndarray:
        """Camera-frame coordinates (N, 3) mm of world points (N, 3) mm."""
        P = _points(points_world, 3, "points_world")
        return P @ self.T_cam_world[:3, :3].T + self.T_cam_world[:3, 3]

    def camera_to_world(self, points_cam) -> np.ndarray:
        """World coordinates (N, 3) mm of camera-frame points (N, 3) mm."""
        P = _points(points_cam, 3, "points_cam")
        return P @ self.T_world_cam[:3, :3].T + self.T_world_cam[:3, 3]

    # -- projection ----------------------------------------------------------------------------------------------
    def project_camera(self, points_cam) -> np.ndarray:
        """Pixels (N, 2) of camera-frame points (N, 3) mm, with distortion. Points behind the camera give NaN."""
        P = _points(points_cam, 3, "points_cam")
        z = P[:, 2]
        front = z > 1e-9
        xy = P[:, :2] / np.where(front, z, 1.0)[:, None]
        xy = distort_normalized(xy, self.dist)
        uv = xy @ self.K[:2, :2].T + self.K[:2, 2]
        uv[~front] = np.nan
        return uv

    def project(self, points_world) -> np.ndarray:
        """Pixels (N, 2) (u right, v down) of world points (N, 3) mm; NaN for points behind the camera."""
        return self.project_camera(self.world_to_camera(points_world))

    def depth_of(self, points_world) -> np.ndarray:
        """Camera-frame Z (N,) mm of world points: the depth value a pixel seeing them would hold."""
        return self.world_to_camera(points_world)[:, 2]

    # -- back-projection -----------------------------------------------------------------------------------------
    def normalized_rays(self, uv) -> np.ndarray:
        """Undistorted normalised image coordinates (N, 2) (x/z, y/z in the camera frame) of pixels (N, 2)."""
        uv = _points(uv, 2, "uv")
        if uv.shape[0] == 0:
            return np.zeros((0, 2))
        return _UNDISTORT_POINTS(uv.reshape(-1, 1, 2), self.K, self.dist, R=None, P=None,
                                 criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)).reshape(-1, 2)

    def pixel_to_camera(self, uv, depth_mm) -> np.ndarray:
        """Camera-frame points (N, 3) mm seen at pixels uv (N, 2) with depth Z (N,) mm."""
        xy = self.normalized_rays(uv)
        depth = finite_array(depth_mm, "depth_mm", [(), (None,)], "camera-frame Z in mm, NaN = no return",
                             allow_nan=True).reshape(-1)
        if depth.shape[0] != xy.shape[0]:
            raise ValueError(f"depth_mm must hold one value per pixel: {depth.shape[0]} values, {xy.shape[0]} pixels")
        if (depth < 0).any():
            raise ValueError(f"depth_mm must not be negative (camera-frame Z in mm: a negative depth is behind the "
                             f"camera), got {plain(depth[depth < 0][0])} mm")
        depth = np.where(depth == 0, np.nan, depth)     # a zero depth is a sensor's "no return"
        return np.column_stack([xy * depth[:, None], depth])

    def pixel_to_world(self, uv, depth_mm) -> np.ndarray:
        """World points (N, 3) mm seen at pixels uv (N, 2) with depth (camera-frame Z) depth_mm (N,) mm.

        A NaN or zero depth (no return: what a RealSense reports) gives a NaN point; a negative depth is refused
        (ValueError).
        """
        return self.camera_to_world(self.pixel_to_camera(uv, depth_mm))

    def pixel_to_plane(self, uv, z_world: float = 0.0) -> np.ndarray:
        """World points (N, 3) where the rays through pixels uv (N, 2) meet the horizontal plane z = z_world (mm).

        Rays parallel to the plane or meeting it behind the camera give NaN.
        """
        xy = self.normalized_rays(uv)
        rays = np.column_stack([xy, np.ones(len(xy))]) @ self.T_world_cam[:3, :3].T
        origin = self.T_world_cam[:3, 3]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (z_world - origin[2]) / rays[:, 2]
        t = np.where(np.isfinite(t) & (t > 0), t, np.nan)
        return origin + t[:, None] * rays

    def with_pose(self, T_cam_world) -> Camera:
        """A copy of this camera with another extrinsic."""
        return Camera(self.K, self.dist, T_cam_world, self.width, self.height)

    def with_intrinsics(self, K, dist) -> Camera:
        """A copy of this camera with other intrinsics."""
        return Camera(K, dist, self.T_cam_world, self.width, self.height)


def _points(a, dim: int, name: str) -> np.ndarray:
    """Points (N, dim) from (dim,) or (N, dim) numbers; NaN rows allowed (missing points), infinity refused."""
    P = finite_array(a, name, [(dim,), (None, dim)], allow_nan=True)
    return P[None] if P.ndim == 1 else P


def _image_side(value, name: str) -> int:
    """An image width or height in px: a positive integer (an integral float such as 1280.0 is taken)."""
    if isinstance(value, (float, np.floating)) and float(value).is_integer() and abs(value) < 2**31:
        value = int(value)
    return int_in_range(value, name, 1, MAX_IMAGE_SIDE_PX, "image size in px")
