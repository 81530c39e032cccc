"""The judge's side of the open tasks: what the child sends (the arm's commands of a plan, a strategy's moves) made
back into the kit's objects here, in the grader's process, so that the judge's own simulator runs them and the
event's own rules score the outcome. Units: mm, rad, s; world (board) frame."""

from __future__ import annotations

import numpy as np

__all__ = ["plan_from_plain", "block_to_plain", "MAX_STEPS", "MAX_WAYPOINTS"]

MAX_STEPS = 200            # steps of one plan at most
MAX_WAYPOINTS = 20_000     # arm commands of one plan at most


def _joints(value, what: str) -> np.ndarray:
    q = np.asarray(value, dtype=float)
    if q.shape != (5,) or not np.all(np.isfinite(q)):
        raise ValueError(f"{what} must be 5 finite joint angles (rad)")
    return q


def _seconds(value, what: str) -> float:
    t = float(value)
    if not np.isfinite(t) or t < 0:
        raise ValueError(f"{what} must be a non-negative number of seconds")
    return t


def _moves(start: np.ndarray, waypoints: list, label: str) -> list:
    """MoveSteps that send exactly these arm commands: a command with ramps is a rest-to-rest joint move from where
    the arm is, a run of constant-speed commands one piecewise-linear trajectory."""
    from armlab import planning

    steps, run, q = [], [], start
    for point in waypoints:
        target, moving, ramp = _joints(point[0], "a waypoint"), _seconds(point[1], "a moving time"), \
            _seconds(point[2], "a ramp time")
        if ramp > 0:
            if run:
                steps.append(planning.MoveStep(_piecewise(run), label))
                run = []
            steps.append(planning.MoveStep(planning.JointTrajectory(q, target, moving, "trapezoid", ramp), label))
        else:
            run = run or [(q, 0.0)]
            run.append((target, moving))
        q = target
    if run:
        steps.append(planning.MoveStep(_piecewise(run), label))
    return steps


def _piecewise(run: list):
    from armlab import planning

    return planning.PiecewiseTrajectory([q for q, _ in run], np.cumsum([t for _, t in run]))


def plan_from_plain(plain) -> object:
    """The planning.Plan whose execution sends the arm the commands the child listed (adapters.plan_to_plain);
    ValueError naming what is malformed."""
    from armlab import planning

    if not isinstance(plain, list) or len(plain) > MAX_STEPS:
        raise ValueError(f"a plan is a list of at most {MAX_STEPS} steps")
    if sum(len(s.get("waypoints", ())) for s in plain if isinstance(s, dict)) > MAX_WAYPOINTS:
        raise ValueError(f"a plan sends at most {MAX_WAYPOINTS} arm commands")
    steps = []
    for step in plain:
        if not isinstance(step, dict):
            raise ValueError("a plan step is an object")
        label = str(step.get("label", ""))[:80]
        if "gripper" in step:
            duration = _seconds(step.get("duration", planning.GRIPPER_TIME_S), "a gripper step")
            steps.append(planning.GripperStep(str(step["gripper"]), label, duration))
        else:
            steps += _moves(_joints(step["start"], "a move's start"), list(step["waypoints"]), label)
    return planning.Plan(tuple(steps))


_FIELDS = ("color", "size", "position", "yaw", "pixel", "edge_mm", "shape", "levels", "color_margin")


def block_to_plain(block) -> dict:
    """A detection.Block as plain data for the child (its contour and colours left out)."""
    out = {k: getattr(block, k) for k in _FIELDS}
    out["position"] = np.asarray(out["position"], float).tolist()
    out["pixel"] = [float(p) for p in out["pixel"]]
    for k in ("yaw", "edge_mm", "color_margin"):
        out[k] = float(out[k])
    out["levels"] = int(out["levels"])
    return out
