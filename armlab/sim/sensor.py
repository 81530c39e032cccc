"""What the sensor does to an exact rendering: lighting, white balance, vignetting, blur and pixel noise on colour;
noise, planar bias, quantisation and dropouts (NaN) on depth. Driven by a `CameraRealism` and a per-frame numpy
Generator, so a seed and a frame number repeat exactly.

Gaussian noise is drawn fast from random bytes through a 256-entry inverse-CDF table (quantised normal deviates).
Units: colour in 8-bit levels (DN), depth in mm (camera-frame Z), pixels in OpenCV's convention.
"""

from __future__ import annotations

import functools
from statistics import NormalDist

import cv2
import numpy as np

from armlab.sim.realism import CameraRealism

__all__ = ["apply_color_effects", "apply_depth_effects", "gaussian_field"]

# inverse normal CDF at the centres of 256 equal-probability bins: byte -> standard normal deviate (sigma ~ 0.99)
_NORMAL_LUT = np.array([NormalDist().inv_cdf((i + 0.5) / 256) for i in range(256)])
_NORMAL_LUT = (_NORMAL_LUT / _NORMAL_LUT.std()).astype(np.float32)


def gaussian_field(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Standard normal deviates (float32, quantised to 256 levels) of the given shape."""
    raw = np.frombuffer(rng.bytes(int(np.prod(shape))), np.uint8).reshape(shape)
    return cv2.LUT(raw, _NORMAL_LUT) if raw.ndim <= 3 and raw.shape[-1] <= 4 else _NORMAL_LUT[raw]


@functools.lru_cache(maxsize=8)
def _gain_map(height: int, width: int, cx: float, cy: float, realism: CameraRealism) -> np.ndarray:
    """(H, W, 3) float32 colour gains: lighting x white balance x vignetting (cos^4-like, 1 - v (r / r_corner)^2)."""
    u = (np.arange(width) - cx) / max(cx, width - cx)
    v = (np.arange(height) - cy) / max(cy, height - cy)
    r2 = (u[None, :] ** 2 + v[:, None] ** 2) / 2
    vig = 1 - realism.vignetting * r2
    gains = realism.light_gain * np.asarray(realism.white_balance)
    return (vig[..., None] * gains).astype(np.float32)


@functools.lru_cache(maxsize=8)
def _bias_map(height: int, width: int, realism: CameraRealism) -> np.ndarray:
    """(H, W) float32 planar depth bias (mm): b_u (u / W - 1/2) + b_v (v / H - 1/2) + b_0."""
    bu, bv, b0 = realism.depth_bias_mm
    u = np.arange(width) / width - 0.5
    v = np.arange(height) / height - 0.5
    return (bu * u[None, :] + bv * v[:, None] + b0).astype(np.float32)


@functools.lru_cache(maxsize=8)
def _dark_lut(dark_depth_noise: float, scale: float) -> np.ndarray:
    """Grey level (0..255) -> depth noise factor: 1 on bright targets (>= 160), up to 1 + dark_depth_noise on black."""
    lum = np.arange(256) / 160.0
    return (scale * (1 + dark_depth_noise * np.clip(1 - lum, 0, 1))).astype(np.float32)


def apply_color_effects(rgb: np.ndarray, principal_point: tuple[float, float], realism: CameraRealism,
                        rng: np.random.Generator) -> np.ndarray:
    """The recorded colour image (H, W, 3) uint8 of an exact rendering `rgb` (H, W, 3) uint8."""
    if realism.blur_sigma_px > 0:
        rgb = cv2.GaussianBlur(rgb, (0, 0), realism.blur_sigma_px)
    H, W = rgb.shape[:2]
    gain = _gain_map(H, W, float(principal_point[0]), float(principal_point[1]), realism)
    flicker = 1.0 + realism.flicker * float(rng.standard_normal()) if realism.flicker > 0 else 1.0
    out = cv2.multiply(rgb.astype(np.float32), gain, scale=flicker)
    if realism.pixel_noise > 0:
        out = cv2.scaleAdd(gaussian_field(rng, (H, W, 3)), realism.pixel_noise, out)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)


def apply_depth_effects(depth: np.ndarray, rgb_exact: np.ndarray, realism: CameraRealism,
                        rng: np.random.Generator) -> np.ndarray:
    """The recorded depth (H, W) float32 mm of exact depth `depth` (NaN = nothing) whose surfaces have the exact
    colours `rgb_exact` (darker surfaces are noisier)."""
    H, W = depth.shape
    out = depth.copy()
    if realism.depth_noise_mm > 0:
        gray = cv2.cvtColor(rgb_exact, cv2.COLOR_RGB2GRAY)
        sigma = cv2.LUT(gray, _dark_lut(realism.dark_depth_noise, realism.depth_noise_mm * 1e-6))
        sigma = cv2.multiply(cv2.multiply(sigma, depth), depth)    # sigma_1m * (Z / 1 m)^2 * darkness
        out = cv2.scaleAdd(cv2.multiply(sigma, gaussian_field(rng, (H, W))), 1.0, out)
    if any(realism.depth_bias_mm):
        out += _bias_map(H, W, realism)
    if realism.depth_quantum_mm > 0:
        out = np.rint(out / realism.depth_quantum_mm) * np.float32(realism.depth_quantum_mm)
    drop = ~(depth >= realism.min_range_mm)
    if realism.depth_edge_dropout > 0 or realism.depth_dropout > 0:
        u = np.frombuffer(rng.bytes(H * W), np.uint8).reshape(H, W)
        filled = np.nan_to_num(depth, nan=0.0)
        kernel = np.ones((3, 3), np.uint8)
        step = (cv2.dilate(filled, kernel) - cv2.erode(filled, kernel)) > 8.0
        drop |= step & (u < 256 * realism.depth_edge_dropout)
        drop |= u < 256 * realism.depth_dropout
    out[drop] = np.nan
    return out.astype(np.float32, copy=False)
