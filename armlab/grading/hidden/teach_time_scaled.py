"""Hidden checks of exercise teach.time_scaled: fresh inputs from the grader's seed, compared with the reference's
results (armlab.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _replays(rng):
    # random programs (some segments not moving at all, some long) at slow and fast speeds
    from armlab.robot import rx200

    robot = rx200()
    cases = []
    for speed in (0.3, 1.0, 2.5, 6.0):
        n = int(rng.integers(3, 9))
        q = rng.uniform(robot.lower * 0.8, robot.upper * 0.8, (n, 5))
        q[1] = q[0]                                                    # a waypoint that does not move
        cases.append([[q.tolist(), float(speed * rng.uniform(0.9, 1.1))]])
    return cases


def _call_scaled_durations(function, q, speed):
    from armlab.robot import rx200
    from armlab.tasks.teach import TeachProgram

    function.__globals__["robot"] = rx200()       # the notebook's `robot` (its cell ran definitions only)
    q = np.asarray(q, float)
    return function(TeachProgram(q, ("open",) * len(q), "hidden"), float(speed))


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("scaled_durations", _replays, atol=1e-9, adapter="_call_scaled_durations",
                                    prelude="definitions"),)
FORBIDDEN: tuple[str, ...] = (
    "TeachProgram.to_plan",
)
