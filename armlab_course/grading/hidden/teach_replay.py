"""Hidden checks of exercise teach.replay: teaching sessions on fresh sim arms (other poses, gripper sequences,
seeds), time-scaled segment times of random programs at other speeds, and the replay plans built from them; compared
with the reference's results (armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _teach_sessions(rng):
    # the swap's poses turned a little about the waist and the wrist (clear of the board), other gripper sequences,
    # shorter and longer programs, other sim seeds
    from armlab.tasks.teach import swap_waypoints

    poses, _ = swap_waypoints()
    cases = []
    for n in (3, 5, len(poses)):
        pick = np.sort(rng.choice(len(poses), n, replace=False))
        q = np.asarray(poses)[pick] + rng.uniform(-0.05, 0.05, (n, 5)) * [1.0, 0.0, 0.0, 0.0, 1.0]
        gripper = [str(g) for g in rng.choice(["open", "closed"], n)]
        cases.append([[int(rng.integers(0, 1000)), q.tolist(), gripper]])
    return cases


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


def _plans(rng):
    # programs with random gripper sequences, each segment given a moving time 5-100 % above the shortest its joints'
    # velocity limits allow (trapezoids with ramps a third of the move) and at least the driver's 0.4 s
    from armlab.robot import rx200

    velocity = rx200().velocity
    cases = []
    for n in (3, 6, 9):
        q = rng.uniform(-1, 1, (n, 5)) * [1.5, 0.8, 0.8, 1.2, 1.5]
        floor = np.maximum((np.abs(np.diff(q, axis=0)) / (2 / 3 * velocity)).max(axis=1), 0.4)
        gripper = [str(g) for g in rng.choice(["open", "closed"], n)]
        cases.append([[q.tolist(), gripper, (floor * rng.uniform(1.05, 2.0, n - 1)).tolist()]])
    return cases


SPECS: tuple[HiddenSpec, ...] = (
    HiddenSpec("teach_program", _teach_sessions, atol=1e-9, adapter="_call_teach", prelude="definitions",
               what="the taught program (joints, rad; gripper states; torque)"),
    HiddenSpec("scaled_durations", _replays, atol=1e-9, adapter="_call_scaled_durations", prelude="definitions",
               what="the segment times", unit="s"),
    HiddenSpec("scaled_plan", _plans, atol=1e-9, adapter="_call_scaled_plan", prelude="definitions",
               what="the plan's steps (kind; duration, s; end joints, rad)"),
)
FORBIDDEN: tuple[str, ...] = ("teach.load_teach", "kit_recording", "data_path", "TeachProgram.to_plan")
