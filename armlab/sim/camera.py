"""The simulated RealSense L515: `SimCamera(world, arm, realism, seed).capture()` renders the station.

The camera reports the factory intrinsics of data/lab.json (`K`, `dist`), like the real device, while it renders with
`truth`: an armlab.camera.Camera with the true intrinsics, distortion and mount (nominal pose from data/lab.json plus
the realism's mount error). Each capture draws its noise from (seed, frame number): consecutive frames differ and a
re-run repeats exactly. Units: mm, rad; images RGB uint8 (720, 1280, 3), depth float32 mm (camera-frame Z, NaN = no
return).
"""

from __future__ import annotations

import numpy as np

from armlab.camera import Camera, look_at
from armlab.lab import LabConfig, lab_config
from armlab.sim.realism import CameraRealism, resolve_realism
from armlab.sim.render import render
from armlab.station.contract import Frame, StationClosed
from armlab.transforms import invert_transform, rotvec_to_matrix

__all__ = ["SimCamera", "CameraRealism", "true_camera"]


def true_camera(realism: CameraRealism, lab: LabConfig | None = None) -> Camera:
    """The camera a realism describes: factory K scaled and shifted, its distortion, the nominal mount of the lab
    config moved by the mount error (position in world mm, rotation vector in the camera frame)."""
    lab = lab or lab_config()
    K = lab.factory_K.copy()
    K[0, 0] *= realism.focal_scale[0]
    K[1, 1] *= realism.focal_scale[1]
    K[0, 2] += realism.principal_offset_px[0]
    K[1, 2] += realism.principal_offset_px[1]
    T_world_cam = invert_transform(look_at(lab.camera_position_mm, lab.camera_look_at_mm))
    T_world_cam[:3, :3] = T_world_cam[:3, :3] @ rotvec_to_matrix(np.asarray(realism.mount_rotvec_rad))
    T_world_cam[:3, 3] += np.asarray(realism.mount_offset_mm)
    width, height = lab.image_size
    return Camera(K, np.asarray(realism.distortion), invert_transform(T_world_cam), width, height)


class SimCamera:
    """A simulated RGB-D camera looking at a simulated world and arm.

    Args:
        world: reads `world.objects` (list of armlab.blocks.ObjectState) and `world.time_s`.
        arm: reads `arm.q_true` ((5,) rad), `arm.gripper_opening_mm` and `arm.gripper_geometry`.
        realism: "realistic" (seeded variation of the realistic defaults), "ideal", or a CameraRealism.
        seed: seeds the device (realistic variation) and every frame's noise.

    Attributes:
        K, dist: intrinsics as the device reports them (factory values of data/lab.json).
        width, height: image size (px).
        truth: the Camera actually used to render (true intrinsics, distortion, extrinsic).
        realism: the CameraRealism in use.
    """

    def __init__(self, world, arm, realism: str | CameraRealism = "realistic", seed: int = 0):
        if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
            raise ValueError(f"seed must be an int, got {seed!r}")
        lab = lab_config()
        self.world, self.arm = world, arm
        self.seed = int(seed)
        self.realism = resolve_realism(realism, self.seed)
        self.K = lab.factory_K.copy()
        self.dist = lab.factory_dist.copy()
        self.width, self.height = lab.image_size
        self.truth = true_camera(self.realism, lab)
        self.frame_count = 0
        self.closed = False          # set when its station is closed: capture() then raises StationClosed

    def __repr__(self) -> str:
        return f"SimCamera({self.width}x{self.height}, seed={self.seed}, truth={self.truth!r})"

    def frame_rng(self, frame: int) -> np.random.Generator:
        """The noise generator of frame number `frame` (0, 1, ...)."""
        return np.random.default_rng([self.seed, int(frame), 0xCA3E])

    def capture(self) -> Frame:
        """Render the current scene: Frame(rgb (720, 1280, 3) uint8, depth (720, 1280) float32 mm, timestamp s)."""
        if self.closed:
            raise StationClosed("capture refused: the station is closed; open a new one with make_station('sim')")
        rng = self.frame_rng(self.frame_count)
        self.frame_count += 1
        arm = self.arm
        q = None if arm is None else np.asarray(arm.q_true, dtype=float)
        rgb, depth = render(self.truth, list(self.world.objects), q,
                            0.0 if arm is None else float(arm.gripper_opening_mm),
                            None if arm is None else arm.gripper_geometry, self.realism, rng)
        return Frame(rgb=rgb, depth=depth, timestamp=float(self.world.time_s))
