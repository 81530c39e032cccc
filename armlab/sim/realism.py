"""How far the simulated RGB-D camera departs from an ideal pinhole: the `CameraRealism` knobs and their presets.

All values are concrete (one device in one lab). `CameraRealism()` holds documented realistic defaults taken from the
lab report and the L515's data sheet; `CameraRealism.realistic(seed)` varies them the way stations differ (mount
error of a few mm and tenths of a degree, intrinsics, lighting, depth bias); `CameraRealism.ideal()` turns
everything off (the true camera is the nominal one and images are exact). Units: mm, rad, px, 8-bit levels (DN).
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

__all__ = ["CameraRealism", "resolve_realism"]


@dataclass(frozen=True)
class CameraRealism:
    """Realism knobs of the simulated L515 (defaults: realistic).

    Geometry (used to build the TRUE camera the images are rendered with):
        mount_offset_mm: camera position error (world x, y, z) against the nominal mount in data/lab.json.
        mount_rotvec_rad: camera orientation error, a rotation vector in the camera frame (~0.2 deg).
        focal_scale: true (fx, fy) / factory (fx, fy); the lab report's checkerboard K is ~1.2 % / 1.5 % below the
            factory K.
        principal_offset_px: true (cx, cy) - factory (cx, cy) (the report: -5.5, +15.7 px).
        distortion: true Brown-Conrady (k1, k2, p1, p2, k3) of the colour lens (the device reports zeros).
    Colour image:
        light_gain: overall brightness factor; white_balance: per-channel (R, G, B) gains;
        vignetting: brightness loss at the image corners (fraction); flicker: per-frame brightness sigma (fraction);
        blur_sigma_px: optical blur (Gaussian sigma, px); pixel_noise: per-pixel noise sigma (DN).
    Depth image (mm, camera-frame Z):
        depth_noise_mm: noise sigma at 1 m on a bright target (grows with Z^2); dark_depth_noise: extra factor on
            black surfaces (sigma x (1 + dark_depth_noise) on black);
        depth_bias_mm: planar bias (per image width, per image height, constant): the tilt students correct;
        depth_edge_dropout: probability of no return (NaN) next to a depth step; depth_dropout: elsewhere;
        depth_quantum_mm: depth unit (L515: 0.25 mm); min_range_mm: nearer surfaces give no return.
    """

    mount_offset_mm: tuple[float, float, float] = (2.0, -3.0, 1.5)
    mount_rotvec_rad: tuple[float, float, float] = (0.003, -0.004, 0.002)
    focal_scale: tuple[float, float] = (0.988, 0.986)
    principal_offset_px: tuple[float, float] = (-5.5, 15.7)
    distortion: tuple[float, float, float, float, float] = (0.12, -0.30, 0.0007, -0.0004, 0.20)
    light_gain: float = 0.97
    white_balance: tuple[float, float, float] = (1.03, 1.0, 0.95)
    vignetting: float = 0.12
    flicker: float = 0.004
    blur_sigma_px: float = 0.7
    pixel_noise: float = 2.5
    depth_noise_mm: float = 2.5
    dark_depth_noise: float = 1.5
    depth_bias_mm: tuple[float, float, float] = (12.0, -16.0, 3.0)
    depth_edge_dropout: float = 0.6
    depth_dropout: float = 0.002
    depth_quantum_mm: float = 0.25
    min_range_mm: float = 250.0

    def __post_init__(self):
        for f in fields(self):
            value = np.asarray(getattr(self, f.name), dtype=float)
            if not np.all(np.isfinite(value)):
                raise ValueError(f"CameraRealism.{f.name} must be finite, got {getattr(self, f.name)!r}")
        sizes = {"mount_offset_mm": 3, "mount_rotvec_rad": 3, "focal_scale": 2, "principal_offset_px": 2,
                 "distortion": 5, "white_balance": 3, "depth_bias_mm": 3}
        for name, n in sizes.items():
            if np.size(getattr(self, name)) != n:
                raise ValueError(f"CameraRealism.{name} must hold {n} values, got {getattr(self, name)!r}")
        if min(self.focal_scale) <= 0 or self.light_gain <= 0 or min(self.white_balance) <= 0:
            raise ValueError("CameraRealism: focal_scale, light_gain and white_balance must be positive")
        for name in ("vignetting", "flicker", "blur_sigma_px", "pixel_noise", "depth_noise_mm", "dark_depth_noise",
                     "depth_quantum_mm", "min_range_mm"):
            if getattr(self, name) < 0:
                raise ValueError(f"CameraRealism.{name} must be >= 0, got {getattr(self, name)}")
        for name in ("depth_edge_dropout", "depth_dropout", "vignetting"):
            if not 0 <= getattr(self, name) <= 1:
                raise ValueError(f"CameraRealism.{name} must be within [0, 1], got {getattr(self, name)}")

    @classmethod
    def ideal(cls) -> CameraRealism:
        """Everything off: the nominal mount, the factory intrinsics without distortion, exact colours and depth."""
        return cls(mount_offset_mm=(0.0, 0.0, 0.0), mount_rotvec_rad=(0.0, 0.0, 0.0), focal_scale=(1.0, 1.0),
                   principal_offset_px=(0.0, 0.0), distortion=(0.0,) * 5, light_gain=1.0,
                   white_balance=(1.0, 1.0, 1.0), vignetting=0.0, flicker=0.0, blur_sigma_px=0.0, pixel_noise=0.0,
                   depth_noise_mm=0.0, dark_depth_noise=0.0, depth_bias_mm=(0.0, 0.0, 0.0), depth_edge_dropout=0.0,
                   depth_dropout=0.0, depth_quantum_mm=0.0, min_range_mm=0.0)

    @classmethod
    def realistic(cls, seed: int = 0) -> CameraRealism:
        """The realistic defaults varied by a seed the way stations differ: mount error (sigma 3 mm, 0.3 deg),
        focal lengths (sigma 0.3 %) and principal point (sigma 4 px) around the defaults, lighting (5 %), white
        balance (2 %), and a 20 mm planar depth bias in a random direction."""
        rng = np.random.default_rng([int(seed), 0x5CA3])
        base = cls()
        angle = rng.uniform(0, 2 * np.pi)
        return replace(
            base,
            mount_offset_mm=tuple(rng.normal(0, 3.0, 3)),
            mount_rotvec_rad=tuple(rng.normal(0, np.radians(0.3), 3)),
            focal_scale=tuple(np.asarray(base.focal_scale) * (1 + rng.normal(0, 0.003)) + rng.normal(0, 0.001, 2)),
            principal_offset_px=tuple(np.asarray(base.principal_offset_px) + rng.normal(0, 4.0, 2)),
            light_gain=float(base.light_gain * (1 + rng.normal(0, 0.05))),
            white_balance=tuple(np.asarray(base.white_balance) * (1 + rng.normal(0, 0.02, 3))),
            depth_bias_mm=(20.0 * np.cos(angle), 20.0 * np.sin(angle), float(rng.normal(0, 3.0))),
        )

    @property
    def is_ideal(self) -> bool:
        """True when no image effect is on (geometry errors aside)."""
        return (self.light_gain == 1 and all(g == 1 for g in self.white_balance) and self.vignetting == 0
                and self.flicker == 0 and self.blur_sigma_px == 0 and self.pixel_noise == 0
                and self.depth_noise_mm == 0 and not any(self.depth_bias_mm) and self.depth_edge_dropout == 0
                and self.depth_dropout == 0 and self.depth_quantum_mm == 0)


def resolve_realism(realism: str | CameraRealism, seed: int = 0) -> CameraRealism:
    """A CameraRealism from "realistic" (seeded), "ideal", or an instance (returned as is)."""
    if isinstance(realism, CameraRealism):
        return realism
    if realism == "realistic":
        return CameraRealism.realistic(seed)
    if realism == "ideal":
        return CameraRealism.ideal()
    raise ValueError(f"unknown camera realism {realism!r}: expected 'realistic', 'ideal' or a CameraRealism")
