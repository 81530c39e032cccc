"""Hidden checks of exercise teach.record: fresh inputs from the grader's seed, compared with the reference's
results (armlab.grading.hidden)."""

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


def _call_teach(function, seed, poses, gripper):
    """teach_program on a fresh sim arm: the recorded q (N x 5), the gripper states (1 closed) and the torque."""
    from armlab.station import make_station

    station = make_station("sim", seed=int(seed), scene="swap")
    program = function(station.arm, np.asarray(poses, float), list(gripper), name="hidden")
    return np.concatenate([np.asarray(program.q, float).ravel(), [g == "closed" for g in program.gripper],
                           [float(station.arm.torque_enabled)]])


SPECS: tuple[HiddenSpec, ...] = (HiddenSpec("teach_program", _teach_sessions, atol=1e-9, adapter="_call_teach",
                               prelude="definitions"),)
FORBIDDEN: tuple[str, ...] = (
    "teach.load_teach", "kit_recording", "data_path"
)
