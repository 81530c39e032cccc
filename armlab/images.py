"""Checks and small helpers for the images every public API takes.

Images: RGB uint8 (H, W, 3) or grayscale uint8 (H, W). Depth: float32/float64 (H, W) millimetres, camera-frame Z,
NaN where there is no return. Pixels: OpenCV's (u right, v down, integer = pixel centre).
"""

from __future__ import annotations

import warnings

import cv2
import numpy as np

from armlab.arguments import finite_array, int_in_range

__all__ = ["check_rgb", "check_gray_or_rgb", "check_depth", "check_mask", "to_gray", "sample_depth", "as_array",
           "MAX_SAMPLE_RADIUS_PX"]

MAX_SAMPLE_RADIUS_PX = 50    # sample_depth's largest window half-size (a 101 x 101 px median per pixel)


def as_array(value, name: str, what: str) -> np.ndarray:
    """np.asarray(value), or the kit's TypeError / ValueError naming `name` (None, ragged nesting, objects)."""
    if value is None:
        raise TypeError(f"{name} must be {what}, got None")
    try:
        return np.asarray(value)
    except (ValueError, TypeError) as e:
        raise ValueError(f"{name} must be {what}, got something numpy cannot read as an array ({e})") from None


def check_rgb(rgb, name: str = "rgb") -> np.ndarray:
    """Validate an RGB image: uint8, shape (H, W, 3). Raises ValueError naming the problem."""
    a = as_array(rgb, name, "a uint8 RGB image (H, W, 3)")
    if a.dtype != np.uint8:
        raise ValueError(f"{name} must be uint8 RGB (H, W, 3), got dtype {a.dtype}")
    if a.ndim != 3 or a.shape[2] != 3 or a.shape[0] == 0 or a.shape[1] == 0:
        raise ValueError(f"{name} must be an RGB image of shape (H, W, 3), got shape {a.shape}")
    return a


def check_gray_or_rgb(image, name: str = "image") -> np.ndarray:
    """Validate a uint8 grayscale (H, W) or RGB (H, W, 3) image and return it as grayscale (H, W)."""
    a = as_array(image, name, "a uint8 grayscale (H, W) or RGB (H, W, 3) image")
    if a.dtype != np.uint8:
        raise ValueError(f"{name} must be uint8 grayscale (H, W) or RGB (H, W, 3), got dtype {a.dtype}")
    if a.ndim == 2 and a.size:
        return a
    if a.ndim == 3 and a.shape[2] == 3 and a.size:
        return cv2.cvtColor(a, cv2.COLOR_RGB2GRAY)
    raise ValueError(f"{name} must have shape (H, W) or (H, W, 3), got shape {a.shape}")


def to_gray(image) -> np.ndarray:
    """Grayscale uint8 (H, W) of a grayscale or RGB uint8 image."""
    return check_gray_or_rgb(image)


def check_depth(depth, shape: tuple[int, int] | None = None, name: str = "depth_mm") -> np.ndarray:
    """Validate a depth image: float (H, W) mm, NaN allowed; optionally of the given (H, W). Returns float32, with
    zeros (a RealSense's "no return") read as NaN like every other missing depth. Raises ValueError for negative or
    infinite depths (camera-frame Z is never negative: such an image is not a depth image in mm)."""
    a = as_array(depth, name, "a float depth image (H, W) in mm")
    if not np.issubdtype(a.dtype, np.floating):
        raise ValueError(f"{name} must be a float depth image in mm (NaN = no return), got dtype {a.dtype}")
    if a.ndim != 2 or a.size == 0:
        raise ValueError(f"{name} must have shape (H, W), got shape {a.shape}")
    if shape is not None and a.shape != tuple(shape):
        raise ValueError(f"{name} has shape {a.shape} but the colour image is {tuple(shape)}: align depth to colour")
    a = a.astype(np.float32, copy=False)
    flat = a.ravel()
    lowest, highest = np.fmin.reduce(flat), np.fmax.reduce(flat)       # NaN-skipping: one fast pass each
    if highest == np.inf or lowest == -np.inf:
        raise ValueError(f"{name} contains infinity: depth is camera-frame Z in mm, NaN where there is no return")
    if lowest < 0:
        raise ValueError(f"{name} has {int((a < 0).sum())} negative values (lowest {float(lowest):.1f} mm): depth "
                         f"is camera-frame Z in mm and never negative")
    if lowest == 0:
        a = np.where(a == 0, np.float32(np.nan), a)   # zero = no return (RealSense), as NaN everywhere in the kit
    return a


def check_mask(mask, shape: tuple[int, int], name: str = "exclude") -> np.ndarray:
    """Validate a pixel mask: (H, W) = shape of booleans (or 0/1 numbers); returns it as bool."""
    a = as_array(mask, name, f"a (H, W) = {tuple(shape)} mask")
    if a.dtype.kind not in "biuf":
        raise TypeError(f"{name} must be a boolean (H, W) mask, got dtype {a.dtype}")
    if a.shape != tuple(shape):
        raise ValueError(f"{name} must be a (H, W) = {tuple(shape)} mask, got shape {a.shape}")
    return a.astype(bool, copy=False)


def sample_depth(depth: np.ndarray, uv, radius: int = 2) -> np.ndarray:
    """Median depth (N,) mm of the valid pixels within `radius` px of each pixel uv (N, 2); NaN where none.

    Pixels are rounded to the nearest pixel centre; windows are clipped at the image border.
    """
    radius = int_in_range(radius, "radius", 0, MAX_SAMPLE_RADIUS_PX, "px around each pixel")
    uv = finite_array(uv, "uv", [(2,), (None, 2)], "pixels (u, v)", allow_nan=True).reshape(-1, 2)
    h, w = depth.shape
    out = np.full(len(uv), np.nan)
    finite = np.all(np.isfinite(uv), axis=1)
    if not finite.any():
        return out
    ui = np.rint(uv[finite, 0]).astype(int)
    vi = np.rint(uv[finite, 1]).astype(int)
    offsets = np.arange(-radius, radius + 1)
    U = np.clip(ui[:, None, None] + offsets[None, None, :], 0, w - 1)
    V = np.clip(vi[:, None, None] + offsets[None, :, None], 0, h - 1)
    windows = depth[V, U].reshape(len(ui), -1)
    inside = (ui >= 0) & (ui < w) & (vi >= 0) & (vi < h)
    with warnings.catch_warnings():  # all-NaN windows give NaN, which is the answer we want
        warnings.simplefilter("ignore", RuntimeWarning)
        med = np.nanmedian(windows, axis=1)
    out[np.flatnonzero(finite)] = np.where(inside, med, np.nan)
    return out
