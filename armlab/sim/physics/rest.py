"""The pose of a body the physics left at rest, as the kit's ObjectState (world mm; yaw and tilt in rad).

MuJoCo's contacts are soft: a block at rest sinks a few hundredths of a millimetre into what bears it, a stack started
exactly in contact sways by a tenth of a millimetre as its contacts load, and a block dropped straight drifts by
micrometres. Below the kit's resolution none of these is a motion, so an object that moved less than MOVED_MM
sideways and turned less than TURNED_RAD keeps its horizontal pose exactly (the stored notebook outputs then cannot
depend on the solver's last digits), and only falls to what bears it. An object that did move takes the physics pose.
An object resting on a face (within FLAT_RAD) is laid exactly flat, turned about +z (a cube by whichever face is down:
it is one colour), with its bottom on the top of what is under it (the caller's support height). A real tower that
is toppling moves far more than MOVED_MM before it rests, so the threshold hides no fall.
"""

from __future__ import annotations

import numpy as np

from armlab.blocks import ObjectState
from armlab.transforms import matrix_from_rpy, rpy_from_matrix

__all__ = ["MOVED_MM", "TURNED_RAD", "FLAT_RAD", "object_rotation", "flat_yaw", "apply_rest_pose", "tilt_angle",
           "tipping_shift_mm"]

MOVED_MM = 0.5
TURNED_RAD = np.radians(0.5)
FLAT_RAD = np.radians(2.0)


def object_rotation(o: ObjectState) -> np.ndarray:
    """The rotation (3, 3) of an object in the world: its tilt (roll, pitch) and yaw, as rpy."""
    return _rotation(o.yaw, o.tilt)


def tilt_angle(o: ObjectState) -> float:
    """How far (rad) an object's nearest face normal is from vertical (0 for an object lying flat on a face)."""
    R = object_rotation(o)
    axes = range(3) if o.is_block else (2,)
    return float(np.arccos(min(1.0, max(abs(R[2, i]) for i in axes))))


def tipping_shift_mm(edge_mm: float, tilt_rad: float) -> float:
    """How far (mm, horizontally) a cube of edge_mm released tilted by tilt_rad (0..pi/4) about a horizontal axis
    lands from below where it was let go, when it falls onto its lowest edge and tips flat about it: that edge lies
    (e/2)(cos t - sin t) from the centre and the centre ends e/2 beyond it, so (e/2)(1 - cos t + sin t). Measured
    through World.settle (2026-12-07): 8 deg from 2 to 7 mm up lands 1.9-2.2 mm off (this gives 2.7); the to-the-sky
    levels released at 23 and 36 deg landed 7.7 and 16.4 mm off (9.1 and 15.0)."""
    t = min(abs(float(tilt_rad)), np.pi / 4)
    return float(edge_mm / 2 * (1.0 - np.cos(t) + np.sin(t)))


def _rotation(yaw: float, tilt) -> np.ndarray:
    return matrix_from_rpy(np.array([tilt[0], tilt[1], yaw], dtype=float))


def flat_yaw(o: ObjectState, R: np.ndarray) -> float | None:
    """The yaw (rad) of an object with rotation R (3, 3) lying on a face within FLAT_RAD, else None. A cube may lie on
    any face (its yaw is then that of a horizontal body axis, taken within 45 deg of its previous yaw); another shape
    only on its base (body z up or down: the shapes are prisms)."""
    R = np.asarray(R, dtype=float)
    axes = range(3) if o.is_block else (2,)
    up = max(axes, key=lambda i: abs(R[2, i]))
    if np.arccos(min(1.0, abs(R[2, up]))) > FLAT_RAD:
        return None
    if not o.is_block:
        return float(np.arctan2(R[1, 0], R[0, 0]))
    side = R[:, (up + 1) % 3]
    yaw = float(np.arctan2(side[1], side[0]))
    return float(o.yaw + (yaw - o.yaw + np.pi / 4) % (np.pi / 2) - np.pi / 4)


def apply_rest_pose(o: ObjectState, position_mm, R, before: tuple[np.ndarray, float, np.ndarray],
                    support_top_mm=None) -> bool:
    """Update o from its physics pose at rest (position (3,) mm, rotation (3, 3)); `before` is its (position, yaw,
    tilt) before the physics ran, support_top_mm a function giving the height (mm) of what lies under o. Returns
    True when the object moved (by more than MOVED_MM or TURNED_RAD)."""
    p0, yaw0, tilt0 = before
    position_mm = np.asarray(position_mm, dtype=float)
    R0 = _rotation(yaw0, tilt0)
    turned = np.arccos(np.clip((np.trace(R0.T @ R) - 1.0) / 2.0, -1.0, 1.0))
    if np.linalg.norm(position_mm[:2] - p0[:2]) < MOVED_MM and turned < TURNED_RAD:
        o.position, o.yaw, o.tilt = p0.copy(), yaw0, tilt0.copy()     # it stayed, or fell straight down
        if abs(position_mm[2] - p0[2]) < MOVED_MM:
            return False
        o.position[2] = position_mm[2]
        R = R0
    else:
        o.position = position_mm.copy()
    yaw = flat_yaw(o, R)
    if yaw is None:
        roll, pitch, yaw_t = rpy_from_matrix(R)
        o.yaw, o.tilt = float(yaw_t), np.array([roll, pitch])
        return True
    o.yaw, o.tilt = yaw, np.zeros(2)
    if support_top_mm is not None:
        o.position[2] = support_top_mm(o) + o.edge / 2
    return True
