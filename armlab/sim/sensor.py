"""What the sensor does to an exact rendering: lighting, white balance, vignetting, blur and pixel noise on colour;
noise, planar bias, quantisation and dropouts (NaN) on depth. Driven by a `CameraRealism` and a per-frame numpy
Generator, so a seed and a frame number repeat exactly.

Per-pixel random fields are windows of cached pools instead of fresh draws (drawing ~4 M deviates costs more than
the rest of a frame): a pool is a field of independent standard normal (or uniform byte) values `POOL_MARGIN` pixels
larger than the image each way, drawn once per process from a fixed seed; each frame takes the window at an offset
drawn from its Generator (and, for normal noise, a random sign). Within a frame every pixel's value is an independent
draw with the exact distribution; two frames share values only shifted by the difference of their offsets, so frames
still differ pixel by pixel and averaging frames still averages the noise away.
Units: colour in 8-bit levels (DN), depth in mm (camera-frame Z), pixels in OpenCV's convention.
"""

from __future__ import annotations

import functools

import cv2
import numpy as np

from armlab.sim.realism import CameraRealism

__all__ = ["apply_color_effects", "apply_depth_effects", "normal_field", "uniform_bytes", "POOL_MARGIN"]

POOL_MARGIN = 128          # pool size beyond the image (px, each axis): (POOL_MARGIN + 1)^2 windows per pool
_POOL_SEED = 0x5EED_F1E1D


@functools.lru_cache(maxsize=4)
def _pool(shape: tuple[int, ...], kind: str) -> np.ndarray:
    """Read-only pool for fields of `shape`: (H + M, W + M, ...) standard normal float32 or uniform uint8."""
    rng = np.random.default_rng([_POOL_SEED, len(shape), *shape, kind == "normal"])
    size = (shape[0] + POOL_MARGIN, shape[1] + POOL_MARGIN) + tuple(shape[2:])
    pool = rng.standard_normal(size, dtype=np.float32) if kind == "normal" else rng.integers(0, 256, size, np.uint8)
    pool.flags.writeable = False
    return pool


def _window(rng: np.random.Generator, shape: tuple[int, ...], kind: str) -> np.ndarray:
    if len(shape) < 2 or min(shape) < 1:
        raise ValueError(f"a random field needs a shape (H, W[, C]) of positive sizes, got {shape}")
    oy, ox = rng.integers(0, POOL_MARGIN + 1, 2).tolist()
    return _pool(tuple(int(n) for n in shape), kind)[oy:oy + shape[0], ox:ox + shape[1]]


def normal_field(rng: np.random.Generator, shape: tuple[int, ...]) -> tuple[np.ndarray, float]:
    """A read-only (H, W[, C]) float32 field of standard normal deviates and a random sign (+1.0 or -1.0) to scale
    it by (a window of the cached pool, chosen by `rng`)."""
    field = _window(rng, shape, "normal")
    return field, float(rng.integers(0, 2) * 2 - 1)


def uniform_bytes(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """A read-only (H, W[, C]) uint8 field of independent uniform values 0..255 (a window of the cached pool)."""
    return _window(rng, shape, "uniform")


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
    if realism.pixel_noise <= 0:
        return cv2.multiply(rgb, gain, scale=flicker, dtype=cv2.CV_8U)      # rounds to nearest and saturates
    lit = cv2.multiply(rgb, gain, scale=flicker, dtype=cv2.CV_32F)
    noise, sign = normal_field(rng, (H, W, 3))
    return cv2.addWeighted(lit, 1.0, noise, sign * realism.pixel_noise, 0.0, dtype=cv2.CV_8U)


def apply_depth_effects(depth: np.ndarray, rgb_exact: np.ndarray, realism: CameraRealism,
                        rng: np.random.Generator) -> np.ndarray:
    """The recorded depth (H, W) float32 mm of exact depth `depth` (NaN = nothing) whose surfaces have the exact
    colours `rgb_exact` (darker surfaces are noisier)."""
    H, W = depth.shape
    out = cv2.add(depth, _bias_map(H, W, realism)) if any(realism.depth_bias_mm) else depth.copy()
    if realism.depth_noise_mm > 0:
        gray = cv2.cvtColor(rgb_exact, cv2.COLOR_RGB2GRAY)
        sigma = cv2.LUT(gray, _dark_lut(realism.dark_depth_noise, realism.depth_noise_mm * 1e-6))
        noise, sign = normal_field(rng, (H, W))
        # out += sigma_1m * darkness * (Z / 1 m)^2 * noise
        cv2.accumulateProduct(cv2.multiply(sigma, noise, scale=sign), cv2.multiply(depth, depth), out)
    if realism.depth_quantum_mm > 0:
        q = np.float32(realism.depth_quantum_mm)
        np.rint(np.divide(out, q, out=out), out=out)
        out *= q
    drop = ~(depth >= realism.min_range_mm)
    if realism.depth_edge_dropout > 0 or realism.depth_dropout > 0:
        u = uniform_bytes(rng, (H, W))
        filled = cv2.patchNaNs(depth.copy(), 0.0)
        kernel = np.ones((3, 3), np.uint8)
        step = cv2.subtract(cv2.dilate(filled, kernel), cv2.erode(filled, kernel)) > 8.0
        drop |= step & (u < 256 * realism.depth_edge_dropout)
        drop |= u < 256 * realism.depth_dropout
    out[drop] = np.nan
    return out
