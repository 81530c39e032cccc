"""Per-pixel world coordinates from a depth image, vectorised with per-pixel coefficients cached per camera.

For pixel (u, v) with undistorted normalised coordinates (x, y) and depth Z (camera-frame, mm), the camera-frame
point is Z (x, y, 1), so each world coordinate is an affine function of Z: X_w = Z * k(u, v) + t, where k is the
pixel's ray direction in the world (per mm of depth) and t the camera centre. The coefficients k are computed once
per camera; a frame then costs one multiply-add per coordinate and pixel. The same k also intersects a pixel's ray
with a horizontal plane z = h without any undistortion: Z = (h - t_z) / k_z.
"""

from __future__ import annotations

import numpy as np

from armlab.camera import Camera

__all__ = ["world_coefficients", "world_from_depth", "height_from_depth", "pixels_to_plane", "reduced_coefficients"]

_CACHE_ENTRIES = 2     # cameras whose coefficients are kept (about 14 MB each at 1280 x 720, with a reduced copy)
_CACHE: dict[bytes, np.ndarray] = {}
_REDUCED: dict[tuple[bytes, int], np.ndarray] = {}


def _camera_key(camera: Camera) -> bytes:
    """What the coefficients depend on, by value: image size, intrinsics, distortion and the camera's rotation. A
    camera calibrated again to the same values (a notebook cell or a demo run again) finds its coefficients; the
    cache holds no camera, so a station's camera is freed with it."""
    size = np.array([camera.width, camera.height], float)
    return b"".join(np.ascontiguousarray(a, dtype=float).tobytes()
                    for a in (size, camera.K, camera.dist, camera.T_world_cam[:3, :3]))


def _remember(cache: dict, key, value: np.ndarray) -> np.ndarray:
    """Keep value under key, dropping the least recently used entries beyond _CACHE_ENTRIES."""
    cache.pop(key, None)
    cache[key] = value
    while len(cache) > _CACHE_ENTRIES:
        del cache[next(iter(cache))]
    return value


def world_coefficients(camera: Camera) -> np.ndarray:
    """(3, H, W) float32 coefficients k with world_xyz = depth * k + T_world_cam translation (cached per camera
    value, the _CACHE_ENTRIES last used)."""
    key = _camera_key(camera)
    hit = _CACHE.get(key)
    if hit is not None:
        return _remember(_CACHE, key, hit)
    v, u = np.mgrid[0:camera.height, 0:camera.width]
    xy = camera.normalized_rays(np.column_stack([u.ravel(), v.ravel()]).astype(float))
    rays_cam = np.column_stack([xy, np.ones(len(xy))])
    k = (rays_cam @ camera.T_world_cam[:3, :3].T).T.reshape(3, camera.height, camera.width).astype(np.float32)
    k.setflags(write=False)
    return _remember(_CACHE, key, k)


def reduced_coefficients(camera: Camera, step: int) -> np.ndarray:
    """world_coefficients of every `step`-th pixel in both directions, (3, H // step, W // step) float32, as one
    contiguous array (cached per camera value and step): a strided view of the full array costs four times as much
    to multiply."""
    key = (_camera_key(camera), int(step))
    hit = _REDUCED.get(key)
    if hit is not None:
        return _remember(_REDUCED, key, hit)
    k = np.ascontiguousarray(world_coefficients(camera)[:, ::step, ::step])
    k.setflags(write=False)
    return _remember(_REDUCED, key, k)


def world_from_depth(depth_mm: np.ndarray, camera: Camera) -> np.ndarray:
    """World coordinates (3, H, W) float32 mm of every pixel (NaN where depth is NaN)."""
    k = world_coefficients(camera)
    t = camera.T_world_cam[:3, 3].astype(np.float32)
    return depth_mm[None] * k + t[:, None, None]


def height_from_depth(depth_mm: np.ndarray, camera: Camera, step: int = 1) -> np.ndarray:
    """World height z (H // step, W // step) float32 mm of every `step`-th pixel in both directions (NaN where the
    depth is NaN): the only world coordinate segmentation needs, at a fraction of world_from_depth's cost."""
    kz = reduced_coefficients(camera, step)[2] if step > 1 else world_coefficients(camera)[2]
    return depth_mm[::step, ::step] * kz + np.float32(camera.T_world_cam[2, 3])


def pixels_to_plane(camera: Camera, uv: np.ndarray, z_world) -> np.ndarray:
    """World points (N, 3) mm where the rays of integer pixels uv (N, 2) (u, v) meet the plane z = z_world (mm; one
    plane, or one per pixel (N,)); the cached equivalent of Camera.pixel_to_plane for whole pixels."""
    k = world_coefficients(camera)
    u, v = uv[:, 0].astype(np.intp), uv[:, 1].astype(np.intp)
    rays = k[:, v, u].T.astype(float)
    t = camera.T_world_cam[:3, 3]
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = (z_world - t[2]) / rays[:, 2]
    return rays * depth[:, None] + t
