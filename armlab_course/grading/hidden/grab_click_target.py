"""Hidden checks of exercise grab.click_target: clicks on random boards of turned blocks,
small blocks stacked off-centre on large ones, and bare board, compared with the reference's answer
(armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec

_EDGES = {"large": 38.0, "small": 25.0}


def _inside(point, top, yaw, edge, slack) -> bool:
    """Whether the x-y point lies within the turned square face (edge + 2 slack mm) centred at top."""
    c, s = np.cos(yaw), np.sin(yaw)
    d = np.asarray(point[:2], float) - top[:2]
    return max(abs(c * d[0] + s * d[1]), abs(-s * d[0] + c * d[1])) <= edge / 2 + slack


def _board(rng):
    """3-6 blocks 80 mm or more apart, yaws in [-pi/4, pi/4); some large ones carry a small one, off-centre and
    turned, listed before or after it: (tops (n, 3), yaws (n,), edges (n,))."""
    tops, yaws, edges = [], [], []
    while len(tops) < int(rng.integers(3, 7)):
        xy = np.array([rng.uniform(-250, 250), rng.uniform(80, 330)])
        if any(np.hypot(*(xy - t[:2])) < 80 for t in tops):
            continue
        size = str(rng.choice(["large", "small"]))
        tops.append(np.array([xy[0], xy[1], _EDGES[size]]))
        yaws.append(float(rng.uniform(-np.pi / 4, np.pi / 4)))
        edges.append(_EDGES[size])
        if size == "large" and rng.random() < 0.5:             # a small block on it, off-centre by up to 5 mm
            on = np.array([*(xy + rng.uniform(-5, 5, 2)), _EDGES["large"] + _EDGES["small"]])
            k = len(tops) - (rng.random() < 0.5)              # before or after the block it stands on
            tops.insert(k, on)
            yaws.insert(k, float(rng.uniform(-np.pi / 4, np.pi / 4)))
            edges.insert(k, _EDGES["small"])
    return np.array(tops), np.array(yaws), np.array(edges)


def _click(rng, tops, yaws, edges):
    """A click the camera could see: near a face's corner, anywhere on a face, on bare board beside a face's side or
    anywhere on the board; never within 2 mm inside or 4 mm outside a face's outline (where the answer would hang on
    the last millimetre of the 3 mm margin); at the height of the highest face under it (what the camera sees there)
    or the board's, with 1 mm of depth noise."""
    for _ in range(1000):
        i, mode = int(rng.integers(len(tops))), rng.random()
        if mode < 0.45:                          # near a face's corner: outside its square if the yaw is ignored
            a, b = rng.choice([-1.0, 1.0], 2) * rng.uniform(edges[i] / 2 - 6.0, edges[i] / 2 - 2.2, 2)
        elif mode < 0.65:                        # anywhere on a face
            a, b = rng.uniform(-edges[i] / 2, edges[i] / 2, 2)
        elif mode < 0.85:                        # bare board beside a face's side, in the face's own axes
            a, b = rng.choice([-1.0, 1.0]) * (edges[i] / 2 + rng.uniform(8.0, 11.0)), rng.uniform(-0.3, 0.3) * edges[i]
        else:                                    # anywhere on the board
            a, b = rng.uniform(-300, 300) - tops[i, 0], rng.uniform(50, 380) - tops[i, 1]
        c, s = (np.cos(yaws[i]), np.sin(yaws[i])) if mode < 0.85 else (1.0, 0.0)
        xy = tops[i, :2] + [c * a - s * b, s * a + c * b]
        if any(_inside(xy, t, y, e, 4.0) and not _inside(xy, t, y, e, -2.0) for t, y, e in zip(tops, yaws, edges)):
            continue
        z = max((t[2] for t, y, e in zip(tops, yaws, edges) if _inside(xy, t, y, e, 0.0)), default=0.0)
        return [float(xy[0]), float(xy[1]), float(z + rng.uniform(-1, 1))]
    raise RuntimeError("no click found")


def _click_scenes(rng):
    # three hidden checks of ten clicks each, every click on a board of its own
    checks = []
    for _ in range(3):
        calls = []
        for _ in range(10):
            tops, yaws, edges = _board(rng)
            calls.append([_click(rng, tops, yaws, edges), tops.tolist(), yaws.tolist(), edges.tolist()])
        checks.append(calls)
    return checks


SPECS = (HiddenSpec("click_target", _click_scenes, atol=0, prelude="definitions",
                    what="the index of the block hit"),)
FORBIDDEN = ("tasks.click_grab", "click.click_world", "ClickToGrab",
             "blocks.footprint", "blocks.ObjectState.footprint_world", "sim.geometry.polygons_overlap")
