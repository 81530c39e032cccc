"""Speed of the simulated RGB-D camera: ms per 1280x720 frame (median of repeated captures, one process, one core).

    .venv/bin/python benchmarks/render.py

Rows: board only, 10 blocks, 30 blocks + arm; columns: exact geometry ("ideal" preset: no distortion, no noise),
the realistic camera's geometry without noise (distortion remap), and the full realistic preset. The last column
compares with a naive alternative: drawing the board by cv2.warpPerspective every frame instead of caching it.
"""

from __future__ import annotations

import os
import time
from dataclasses import replace
from types import SimpleNamespace

os.environ.setdefault("OMP_NUM_THREADS", "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from armlab.blocks import COLORS, ObjectState  # noqa: E402
from armlab.sim.board_texture import board_texture  # noqa: E402
from armlab.sim.camera import CameraRealism, SimCamera, true_camera  # noqa: E402
from armlab.sim.raster import view_for  # noqa: E402

cv2.setNumThreads(1)
GRIPPER = SimpleNamespace(pad_width_mm=20.0, pad_height_mm=16.0, pad_thickness_mm=6.0)


def scene(n_blocks: int, seed: int = 0) -> list[ObjectState]:
    rng = np.random.default_rng(seed)
    objs = []
    for i in range(n_blocks):
        edge = 38.0 if i % 2 else 25.0
        objs.append(ObjectState(COLORS[i % 6], "large" if i % 2 else "small", edge,
                                [rng.uniform(-420, 420), rng.uniform(-120, 440), edge / 2], rng.uniform(0, 1.5), id=i))
    return objs


def ms_per_frame(cam: SimCamera, repeats: int = 15) -> float:
    cam.capture()                      # warm the per-camera caches (lens maps, board canvas)
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        cam.capture()
        times.append(time.perf_counter() - t)
    return 1000 * float(np.median(times))


def main() -> None:
    realistic = CameraRealism()
    no_noise = replace(CameraRealism.ideal(), **{k: getattr(realistic, k) for k in (
        "mount_offset_mm", "mount_rotvec_rad", "focal_scale", "principal_offset_px", "distortion")})
    presets = {"ideal": CameraRealism.ideal(), "lens only": no_noise, "realistic": realistic}
    cases = {"board only": (0, False), "10 blocks": (10, False), "30 blocks + arm": (30, True)}
    print(f"{'scene':<18}" + "".join(f"{name:>14}" for name in presets) + f"{'(board warp)':>14}")
    view = view_for(true_camera(realistic))
    tex = board_texture()
    H = view.K @ np.column_stack([view.camera.T_cam_world[:3, 0], view.camera.T_cam_world[:3, 1],
                                  view.camera.T_cam_world[:3, 3]]) @ tex.H_world_texel
    t = time.perf_counter()
    for _ in range(5):
        cv2.warpPerspective(tex.image, H, (view.width, view.height), flags=cv2.INTER_LINEAR)
    warp_ms = 1000 * (time.perf_counter() - t) / 5
    for label, (n, with_arm) in cases.items():
        world = SimpleNamespace(objects=scene(n), time_s=0.0)
        q = np.array([0.3, -0.2, 0.3, 0.9, 0.2]) if with_arm else None
        arm = SimpleNamespace(q_true=q, gripper_opening_mm=40.0, gripper_geometry=GRIPPER) if with_arm else None
        row = [ms_per_frame(SimCamera(world, arm, realism=r, seed=0)) for r in presets.values()]
        print(f"{label:<18}" + "".join(f"{ms:>11.1f} ms" for ms in row) + f"{row[-1] + warp_ms:>11.1f} ms")
    print(f"(board warp): the realistic column plus a per-frame warpPerspective of the board texture "
          f"({warp_ms:.1f} ms), which the renderer avoids by caching the board per camera")


if __name__ == "__main__":
    main()
