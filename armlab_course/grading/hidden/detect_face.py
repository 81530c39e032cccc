"""Hidden checks of exercise detect.face: drawn squares of known centre, yaw and size,
the student's answer scored against the truth (armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _square_faces(rng):
    # filled squares drawn at random centres and yaws, a large (38 mm) or small (25 mm) cube's face within 5 % at
    # 0.7-1.6 mm per px (15-57 px across); the adapter scores the student's answer against the truth
    checks = []
    for _ in range(3):
        calls = []
        for _ in range(4):
            large, mm_per_px = bool(rng.random() < 0.5), float(rng.uniform(0.7, 1.6))
            edge = (38.0 if large else 25.0) * rng.uniform(0.95, 1.05) / mm_per_px
            calls.append([rng.uniform(45, 55, 2).tolist(), float(edge), float(rng.uniform(-3, 3)), mm_per_px])
        checks.append(calls)
    return checks


def _judge_face(call, centre, edge, yaw, mm_per_px):
    """face_geometry on a square drawn here (100 x 100 px), scored here: [centre within 1 px, yaw within 5 deg modulo
    quarter turns and in [-pi/4, pi/4), size class right] (1.0 / 0.0)."""
    import cv2

    c, s = np.cos(yaw), np.sin(yaw)
    corners = np.asarray(centre) + 0.5 * edge * np.array([[c - s, s + c], [-c - s, -s + c], [-c + s, -s - c],
                                                          [c + s, s - c]])
    mask = np.zeros((100, 100), np.uint8)
    cv2.fillPoly(mask, [np.round(corners * 16).astype(np.int32)], 1, cv2.LINE_8, shift=4)
    u, v, got_yaw, size = call(mask, float(mm_per_px))
    err = abs((float(got_yaw) - yaw + np.pi / 4) % (np.pi / 2) - np.pi / 4)
    want = "large" if edge * mm_per_px > (38.0 + 25.0) / 2 else "small"
    return [float(np.hypot(float(u) - centre[0], float(v) - centre[1]) < 1.0),
            float(err < np.radians(5) and -np.pi / 4 <= float(got_yaw) < np.pi / 4), float(size == want)]


SPECS = (HiddenSpec("face_geometry", _square_faces, atol=0, adapter="_call_face", prelude="definitions",
                    judge=_judge_face,
                    criteria=("the centre within 1 px", "the yaw within 5 deg (modulo quarter turns, in [-pi/4, pi/4))",
                              "the size class right")),)
FORBIDDEN = ("scipy.ndimage.center_of_mass", "transforms.wrap_quarter", "detect_objects", "detect_blocks")
