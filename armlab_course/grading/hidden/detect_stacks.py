"""Hidden checks of exercise detect.stacks: stacks of cubes ray-cast for a pinhole camera over the board (their top
faces, the sides the camera sees, mixed pixels along the outline), with depth noise and lost returns (NaN and 0),
the stack's mask given; the student's top height, levels and top-face centre compared with the reference's
(armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec
from ._common import _camera_over_board

EDGES = (38.0, 25.0)


def _stacks(rng):
    # a stack of 1-4 cubes (0-2 large under 0-2 small), each shifted by up to 2 mm and turned by up to 3 deg off the
    # stack's yaw, somewhere in a camera 0.9-1.1 m over the board; noise 0.5-1.5 mm, 5-15 % of the mask's returns lost
    checks = []
    for _ in range(3):
        calls = []
        for _ in range(4):
            K, T = _camera_over_board(rng)
            n_large, n_small = int(rng.integers(0, 3)), int(rng.integers(0, 3))
            if n_large + n_small == 0:
                n_small = 1
            sizes = [EDGES[0]] * n_large + [EDGES[1]] * n_small
            xy, yaw = [rng.uniform(-150, 150), rng.uniform(60, 260)], rng.uniform(-np.pi / 4, np.pi / 4)
            blocks = [[xy[0] + rng.uniform(-2, 2), xy[1] + rng.uniform(-2, 2), yaw + rng.uniform(-0.05, 0.05), e]
                      for e in sizes]
            calls.append([K, T, blocks, float(rng.uniform(0.5, 1.5)), float(rng.uniform(0.05, 0.15)),
                          int(rng.integers(2**31))])
        checks.append(calls)
    return checks


def render_stack(K, T, blocks, noise_mm, lost, seed, width=1280, height=720):
    """Depth (H, W) mm and the stack's mask (H, W) bool of cubes [x, y, yaw, edge] stacked from the board up, seen
    by the pinhole camera K, T (world -> camera): exact ray casting, then mixed pixels along the outline, Gaussian
    noise and a fraction `lost` of the mask's returns lost (half NaN, half 0)."""
    import cv2

    K, T = np.asarray(K, float), np.asarray(T, float)
    R, t = T[:3, :3], T[:3, 3]
    centre = -R.T @ t
    # only a window around the stack is ray-cast (the rest of the image is the board at the window's depth)
    z_top = sum(b[3] for b in blocks)
    corners = np.array([[b[0] + dx * b[3], b[1] + dy * b[3], z] for b in blocks for dx in (-1, 1) for dy in (-1, 1)
                        for z in (0.0, z_top)])
    cam = corners @ R.T + t
    uv = cam @ K.T
    uv = uv[:, :2] / uv[:, 2:]
    u_lo, v_lo = np.maximum(np.floor(uv.min(axis=0)).astype(int) - 4, 0)
    u_hi, v_hi = np.minimum(np.ceil(uv.max(axis=0)).astype(int) + 5, [width, height])
    full_width, full_height, width, height = width, height, u_hi - u_lo, v_hi - v_lo
    u, v = np.meshgrid(np.arange(u_lo, u_hi, dtype=float), np.arange(v_lo, v_hi, dtype=float))
    rays = (R.T @ np.linalg.solve(K, np.stack([u.ravel(), v.ravel(), np.ones(u.size)]))).T   # world, per mm of Z
    depth = np.full(u.size, np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        board = -centre[2] / rays[:, 2]
        hit = np.zeros(u.size, bool)
        z0 = 0.0
        for x, y, yaw, e in blocks:                                  # slabs of each cube in its own frame
            c, s = np.cos(yaw), np.sin(yaw)
            rot = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
            o = rot @ (centre - [x, y, z0 + e / 2])
            d = rays @ rot.T
            t1, t2 = (-e / 2 - o) / d, (e / 2 - o) / d
            near, far = np.minimum(t1, t2).max(axis=1), np.maximum(t1, t2).min(axis=1)
            inside = (near <= far) & (near > 0) & (near < depth)
            depth[inside], hit[inside] = near[inside], True
            z0 += e
    window = np.where(hit, depth, board).reshape(height, width)
    depth = np.full((full_height, full_width), float(np.median(board)))
    depth[v_lo:v_hi, u_lo:u_hi] = window
    mask = np.zeros((full_height, full_width), bool)
    mask[v_lo:v_hi, u_lo:u_hi] = hit.reshape(height, width)
    outline = cv2.dilate(mask.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool) & \
        ~cv2.erode(mask.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
    depth = np.where(outline, cv2.blur(depth, (3, 3)), depth)       # mixed returns between the top and the board
    rng = np.random.default_rng(seed)
    depth = depth + rng.normal(0.0, noise_mm, depth.shape)
    v, u = np.nonzero(mask)
    gone = rng.random(len(v)) < lost
    depth[v[gone], u[gone]] = np.where(rng.random(int(gone.sum())) < 0.5, np.nan, 0.0)
    return depth, mask


def _judge_stack(call, K, T, blocks, noise_mm, lost, seed):
    """The stack rendered here (render_stack); the child's [top_z mm, centre x, centre y mm, 10 x levels]."""
    depth, mask = render_stack(K, T, blocks, noise_mm, lost, seed)
    return call(depth.astype(np.float32), mask, K, T, list(EDGES))


SPECS = (HiddenSpec("stack_from_depth", _stacks, atol=2.0, adapter="_call_stack", prelude="definitions",
                    judge=_judge_stack, what="the stack",
                    parts=(("top height", "mm"), ("centre x", "mm"), ("centre y", "mm"), ("levels (x 10)", ""))),)
FORBIDDEN = ("stack_levels", "stack_heights", "detect_objects", "detect_blocks", "segment_faces",
             "height_from_depth", "world_from_depth", "pixels_to_plane")
