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
from dataclasses import dataclass

import cv2
import numpy as np

from armlab.sim.realism import CameraRealism

__all__ = ["apply_color_effects", "apply_depth_effects", "normal_field", "uniform_bytes", "Reuse", "POOL_MARGIN"]

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


FIXED = 64.0               # fixed-point scale of the int16 colour signal (1/64 DN)


@functools.lru_cache(maxsize=2)
def _scaled_pool(shape: tuple[int, ...], sigma: float) -> np.ndarray:
    """The normal pool of `shape` times sigma, in FIXED-point int16 (read-only)."""
    scaled = np.clip(np.rint(_pool(shape, "normal") * (sigma * FIXED)), -32767, 32767).astype(np.int16)
    scaled.flags.writeable = False
    return scaled


@dataclass
class Reuse:
    """What a frame shares with a cached one: the exact images equal `rgb`, `depth` (read-only, e.g. a camera's
    board image) except inside the image rectangles `rects` (u0, v0, u1, v1), end exclusive; `cache` is a dict owned
    by the cached frame (one per camera) in which the sensor keeps that frame's noise-free products per realism."""

    rgb: np.ndarray
    depth: np.ndarray
    rects: list[tuple[int, int, int, int]]
    cache: dict


def _grown(rect, by: int, W: int, H: int) -> tuple[int, int, int, int]:
    u0, v0, u1, v1 = rect
    return max(u0 - by, 0), max(v0 - by, 0), min(u1 + by, W), min(v1 + by, H)


def _products(reuse: Reuse | None, key, make, compute, src: tuple, base_src: tuple, reach: int, W: int, H: int):
    """Noise-free per-pixel products of a frame: outputs `make()` filled by compute(src, outs, rect) over the whole
    image; with `reuse`, those of the cached frame (made once from `base_src`, kept read-only in reuse.cache under
    `key`) copied and redone in the changed rectangles grown by `reach` px (the same values)."""
    if reuse is None:
        outs = make()
        compute(src, outs, (0, 0, W, H))
        return outs
    cached = reuse.cache.get(key)
    if cached is None:
        cached = make()
        compute(base_src, cached, (0, 0, W, H))
        for a in cached:
            a.flags.writeable = False
        reuse.cache[key] = cached
    outs = tuple(a.copy() for a in cached)
    for rect in reuse.rects:
        compute(src, outs, _grown(rect, reach, W, H))
    return outs


def _blur_ksize(sigma: float) -> int:
    """OpenCV's Gaussian kernel size for 8-bit images (what GaussianBlur picks for ksize (0, 0))."""
    return int(np.rint(sigma * 6 + 1)) | 1


def apply_color_effects(rgb: np.ndarray, principal_point: tuple[float, float], realism: CameraRealism,
                        rng: np.random.Generator, reuse: Reuse | None = None) -> np.ndarray:
    """The recorded colour image (H, W, 3) uint8 of an exact rendering `rgb` (H, W, 3) uint8.

    The noise-free signal (blur, then lighting, white balance and vignetting) is kept in 1/64 DN (int16) and the
    noise added in one pass; with `reuse`, the signal of the cached frame is made once and redone only around the
    changed rectangles."""
    H, W = rgb.shape[:2]
    gain = _gain_map(H, W, float(principal_point[0]), float(principal_point[1]), realism)
    sigma = realism.blur_sigma_px
    k = _blur_ksize(sigma) if sigma > 0 else 1

    def compute(src, outs, rect):
        u0, v0, u1, v1 = rect
        if sigma > 0:
            U0, V0, U1, V1 = _grown(rect, k // 2, W, H)
            part = cv2.GaussianBlur(src[0][V0:V1, U0:U1], (k, k), sigma)[v0 - V0:v1 - V0, u0 - U0:u1 - U0]
        else:
            part = src[0][v0:v1, u0:u1]
        cv2.multiply(part, gain[v0:v1, u0:u1], dst=outs[0][v0:v1, u0:u1], scale=FIXED, dtype=cv2.CV_16S)

    (signal,) = _products(reuse, ("colour", realism, float(principal_point[0]), float(principal_point[1])),
                          lambda: (np.empty((H, W, 3), np.int16),), compute, (rgb,),
                          None if reuse is None else (reuse.rgb,), k // 2, W, H)
    flicker = 1.0 + realism.flicker * float(rng.standard_normal()) if realism.flicker > 0 else 1.0
    if realism.pixel_noise <= 0:
        return cv2.convertScaleAbs(signal, alpha=flicker / FIXED)        # (the signal is >= 0) rounds, saturates
    oy, ox = rng.integers(0, POOL_MARGIN + 1, 2).tolist()
    noise = _scaled_pool((H, W, 3), float(realism.pixel_noise))[oy:oy + H, ox:ox + W]
    sign = float(rng.integers(0, 2) * 2 - 1)
    return cv2.addWeighted(signal, flicker / FIXED, noise, sign / FIXED, 0.0, dtype=cv2.CV_8U)


def _thresholds(p: float) -> int:
    """Dropout with probability p on a uniform byte u: u < threshold (256 = always)."""
    return int(np.ceil(256 * p))


def apply_depth_effects(depth: np.ndarray, rgb_exact: np.ndarray, realism: CameraRealism,
                        rng: np.random.Generator, reuse: Reuse | None = None) -> np.ndarray:
    """The recorded depth (H, W) float32 mm of exact depth `depth` (NaN = nothing) whose surfaces have the exact
    colours `rgb_exact` (darker surfaces are noisier).

    Noise-free products first (depth + bias with NaN where there is certainly no return, the noise sigma x Z^2, the
    per-pixel dropout threshold: higher next to a depth step); with `reuse`, those of the cached frame are made once
    and redone only around the changed rectangles. Then one pass each for noise, quantisation and dropouts."""
    H, W = depth.shape
    noisy = realism.depth_noise_mm > 0
    t_edge = _thresholds(max(realism.depth_edge_dropout, realism.depth_dropout))
    t_all = _thresholds(realism.depth_dropout)
    drops = t_edge > 0
    bias = _bias_map(H, W, realism) if any(realism.depth_bias_mm) else None
    lut = _dark_lut(realism.dark_depth_noise, realism.depth_noise_mm * 1e-6)
    kernel = np.ones((3, 3), np.uint8)

    def make():
        outs = [np.empty((H, W), np.float32)]
        if noisy:
            outs.append(np.empty((H, W), np.float32))
        if drops:
            outs.append(np.empty((H, W), np.uint8))
        return tuple(outs)

    def compute(src, outs, rect):
        d_all, rgb = src
        u0, v0, u1, v1 = rect
        d = d_all[v0:v1, u0:u1]
        mean = outs[0][v0:v1, u0:u1]
        if bias is not None:
            cv2.add(d, bias[v0:v1, u0:u1], dst=mean)
        else:
            mean[:] = d
        gone = ~(d >= realism.min_range_mm)
        if noisy:
            # sigma_1m * darkness * (Z / 1 m)^2
            sigma = cv2.LUT(cv2.cvtColor(rgb[v0:v1, u0:u1], cv2.COLOR_RGB2GRAY), lut)
            cv2.multiply(sigma, cv2.multiply(d, d), dst=outs[1][v0:v1, u0:u1])
        if drops:
            U0, V0, U1, V1 = _grown(rect, 1, W, H)
            filled = cv2.patchNaNs(d_all[V0:V1, U0:U1].copy(), 0.0)
            grad = cv2.morphologyEx(filled, cv2.MORPH_GRADIENT, kernel)[v0 - V0:v1 - V0, u0 - U0:u1 - U0]
            step = cv2.compare(grad, 8.0, cv2.CMP_GT)                       # 255 next to a depth step, else 0
            lo, hi = min(t_all, 255), min(t_edge, 255)
            cv2.addWeighted(step, (hi - lo) / 255, step, 0.0, lo, dst=outs[-1][v0:v1, u0:u1])
            if t_edge > 255:                # certain dropout next to steps
                gone |= step > 0
            if t_all > 255:
                gone[:] = True
        np.copyto(mean, np.float32(np.nan), where=gone)

    outs = _products(reuse, ("depth", realism), make, compute, (depth, rgb_exact),
                     None if reuse is None else (reuse.depth, reuse.rgb), 1, W, H)
    out = outs[0]
    if noisy:
        noise, sign = normal_field(rng, (H, W))
        cv2.add(out, cv2.multiply(outs[1], noise, scale=sign), dst=out)
    if realism.depth_quantum_mm > 0:
        q = np.float32(realism.depth_quantum_mm)
        np.rint(np.divide(out, q, out=out), out=out)
        out *= q
    if drops:
        u = uniform_bytes(rng, (H, W))
        np.copyto(out, np.float32(np.nan), where=cv2.compare(u, outs[-1], cv2.CMP_LT).view(bool))
    return out
