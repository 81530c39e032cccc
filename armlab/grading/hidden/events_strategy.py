"""Hidden checks of exercise events.strategy: fresh inputs from the grader's seed, compared with the reference's
results (armlab.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _sort_scenes(rng):
    # what the robot might see: cubes on the board (z noisy by a millimetre), some under a cube or a distractor, some
    # already in a slot or beside one, a distractor; the next move's block and destination, or none
    from armlab.tasks.events.sort_stack import ROW_XY

    edges = {"large": 38.0, "small": 25.0}
    checks = []
    for _ in range(4):
        calls = []
        for _ in range(4):
            seen = []
            for _ in range(int(rng.integers(2, 7))):
                size = ["small", "large"][int(rng.integers(0, 2))]
                kind = rng.random()
                if kind < 0.3:                                     # in a slot (sorted), or 25 mm off it
                    xy = np.asarray(ROW_XY[size][int(rng.integers(0, 5))]) + rng.choice([0.0, 25.0]) * \
                        np.array([1.0, 0.0]) + rng.uniform(-5, 5, 2)
                else:
                    xy = np.array([rng.uniform(-300, 300), rng.uniform(50, 300)])
                z = edges[size] + rng.uniform(-1, 1)
                seen.append([int(rng.integers(0, 6)), size == "large", float(xy[0]), float(xy[1]), float(z), True])
                if rng.random() < 0.5:                             # a small cube or a distractor on top of it
                    seen.append([int(rng.integers(0, 6)), False, float(xy[0] + rng.uniform(-3, 3)),
                                 float(xy[1] + rng.uniform(-3, 3)), float(z + 25 + rng.uniform(-1, 1)),
                                 bool(rng.random() < 0.5)])
            if rng.random() < 0.3:
                seen.append([0, True, float(rng.uniform(-300, 300)), float(rng.uniform(50, 300)), 40.0, False])
            calls.append([seen])
        checks.append(calls)
    all_sorted = [[[int(i), True, x, y, 38.0 + 0.3 * i, True] for i, (x, y) in enumerate(ROW_XY["large"][:3])]]
    checks[-1].append(all_sorted)
    return checks


def _call_next_move(function, seen):
    """SortLevel1().next_move on detections [colour index, large, x, y, z, cube]: [index of the block moved, the
    destination (3,)], or [-1, nan, nan, nan] for no move."""
    from armlab.detection.color import COLORS
    from armlab.detection.types import Block

    blocks = [Block(COLORS[int(c)], "large" if large else "small", np.array([x, y, z], float), 0.0, (0.0, 0.0),
                    38.0 if large else 25.0, "cube" if cube else "distractor") for c, large, x, y, z, cube in seen]
    move = function().next_move(blocks)
    if move is None:
        return [-1.0, np.nan, np.nan, np.nan]
    index = next((i for i, b in enumerate(blocks) if b is move.block), -2)
    return [float(index), *np.asarray(move.to, float)[:3]]


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("SortLevel1", _sort_scenes, atol=1e-9, adapter="_call_next_move",
                                  prelude="definitions"),)
FORBIDDEN: tuple[str, ...] = (
    "SortStack",
)
