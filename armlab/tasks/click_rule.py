"""The kit's click rule of click-to-grab (instructor only: left out of the student release, where it answers exercise
grab.sequence; the release's tasks.click_grab / click_drop run the stand-ins of armlab.tasks.click instead).
tasks.click.click_rule() finds it here. Units: px, mm; world (board) frame.
"""

from __future__ import annotations

import numpy as np

from armlab.blocks import block_edge

from .refusal import ClickRefused

__all__ = ["grab_target", "drop_point"]


def grab_target(blocks: list, point: np.ndarray, uv: np.ndarray):
    """The detected block (of `blocks`) a click at the surface point `point` (3,) world mm means: the one whose top-face
    centre is nearest in x, y, when it lies within one block edge; ClickRefused otherwise (`uv`, the clicked pixel,
    is not needed)."""
    d = np.array([np.hypot(*(b.position[:2] - point[:2])) for b in blocks])
    best = blocks[int(np.argmin(d))]
    if d.min() > best.edge_mm:
        raise ClickRefused(f"no block at the click ({point[0]:.0f}, {point[1]:.0f}, {point[2]:.0f}) mm: the nearest, "
                           f"the {best.color} one, is {d.min():.0f} mm away")
    return best


def drop_point(held, point: np.ndarray) -> np.ndarray:
    """Where the held block's bottom face goes for a click at the surface point `point` (3,) world mm: the point; a
    click where the held block itself stood (the frame still shows it there) puts it on what it stood on."""
    p = np.array(point, dtype=float)
    if np.hypot(*(p[:2] - held.position[:2])) < held.edge_mm / 2 and p[2] > held.position[2] - held.edge_mm / 2:
        p[2] = held.position[2] - block_edge(held.size)
    return p
