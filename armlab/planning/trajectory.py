"""Joint-space trajectories: rest-to-rest joint moves and Cartesian straight-line segments solved by IK.

A Trajectory samples joint angles q(t) (N, 5) rad and velocities qdot(t) (N, 5) rad/s at any times t (s,
vectorised), reports its duration (s), and lists the waypoints an arm executes, one
`arm.move_to(q, moving_time, accel_time)` each. Sampling is exact for what the manufacturer's time-based profile
executes (armlab.profile), except for the quintic joint move, whose ideal curve is sampled and which is executed as
short linear pieces through it (`stream_dt`).

Cartesian segments move the tool point (ee_gripper_link, world mm) on a straight line at a fixed pitch and roll
(see armlab.kinematics.ik): knots along the line are solved with kinematics.ik_batch on one IK branch, spaced in
time by a rest-to-rest scaling of the path, and made dense enough that the tool, moving linearly in joint space
between knots, stays within `tol_mm` of the line (checked by FK at the middle of every piece).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from armlab import kinematics
from armlab.kinematics import Unreachable
from armlab.profile import ACCEL_FRACTION, MIN_MOVING_TIME_S, trapezoid_fraction
from armlab.robot import RobotModel, rx200

from .timing import check_scaling, default_accel_time, moving_time, peak_rate, quintic_fraction, time_scaling

__all__ = ["Waypoint", "Trajectory", "JointTrajectory", "PiecewiseTrajectory", "ToolSegment", "CartesianSegment",
           "JointChord", "joint_move", "cartesian_line", "joint_chord", "reverse", "DEFAULT_LINE_SPEED",
           "LINE_TOLERANCE_MM"]

DEFAULT_LINE_SPEED = 80.0    # mm/s: mean tool speed of the final approach and lift (the lab descended slowly)
LINE_TOLERANCE_MM = 0.5      # how far the tool may stray from a Cartesian line between knots
_MAX_KNOT_STEP = 0.35        # rad: a larger joint jump between neighbouring knots means the IK solution jumped


@dataclass(frozen=True)
class Waypoint:
    """One arm command: move to q (5,) rad in moving_time s with ramps of accel_time s (0 = constant speed)."""

    q: np.ndarray
    moving_time: float
    accel_time: float


def _times(t) -> np.ndarray:
    t = np.asarray(t, dtype=float)
    if t.ndim > 1:
        raise ValueError(f"sample times must be a scalar or a 1-D array (s), got shape {t.shape}")
    if not np.all(np.isfinite(t)):
        raise ValueError("sample times contain NaN or infinity")
    return np.atleast_1d(t)


class Trajectory(ABC):
    """Base class: a joint motion from `start` to `end` (5,) rad lasting `duration` s, starting and ending at rest."""

    start: np.ndarray
    end: np.ndarray
    duration: float

    @abstractmethod
    def sample(self, t) -> tuple[np.ndarray, np.ndarray]:
        """Joint angles (N, 5) rad and velocities (N, 5) rad/s at times t (N,) s (held at the ends outside)."""

    @abstractmethod
    def waypoints(self) -> list[Waypoint]:
        """The arm commands that execute this trajectory, in order."""

    def peak_speed(self, samples: int = 2001) -> np.ndarray:
        """Largest sampled |qdot| per joint (5,) rad/s."""
        _, qd = self.sample(np.linspace(0.0, self.duration, samples))
        return np.abs(qd).max(axis=0)


class JointTrajectory(Trajectory):
    """Rest-to-rest joint move q(t) = start + s(t) (end - start) with a trapezoid or quintic time scaling."""

    def __init__(self, start, end, duration: float, scaling: str = "trapezoid", accel_time: float | None = None,
                 stream_dt: float = 0.1):
        self.start = np.array(start, dtype=float)
        self.end = np.array(end, dtype=float)
        self.duration = float(duration)
        self.scaling = check_scaling(scaling)
        self.accel_time = None if scaling == "quintic" else float(
            default_accel_time(duration) if accel_time is None else accel_time)
        self.stream_dt = float(stream_dt)
        for a in (self.start, self.end):
            a.setflags(write=False)

    def sample(self, t) -> tuple[np.ndarray, np.ndarray]:
        t = _times(t)
        s, ds = time_scaling(t, self.duration, self.scaling, self.accel_time)
        dq = self.end - self.start
        return self.start + s[:, None] * dq, ds[:, None] * dq

    def waypoints(self) -> list[Waypoint]:
        if self.scaling == "trapezoid":   # exactly the driver's own profile: one command
            return [Waypoint(self.end, self.duration, self.accel_time)]
        n = max(1, int(np.ceil(self.duration / self.stream_dt)))
        t = np.linspace(0.0, self.duration, n + 1)[1:]
        q, _ = self.sample(t)
        q[-1] = self.end
        return [Waypoint(qk, self.duration / n, 0.0) for qk in q]


class PiecewiseTrajectory(Trajectory):
    """Joint motion through knots (K+1, 5) rad at times (K+1,) s, linear in joint space between knots.

    This is exactly what an arm executes for the waypoints (knot k, times[k] - times[k-1], accel_time 0).
    """

    def __init__(self, knots, times):
        knots = np.array(knots, dtype=float)
        times = np.array(times, dtype=float)
        if knots.ndim != 2 or knots.shape[1] != 5 or knots.shape[0] < 2:
            raise ValueError(f"knots must have shape (K+1, 5) with K >= 1, got {knots.shape}")
        if times.shape != (knots.shape[0],) or times[0] != 0 or not np.all(np.diff(times) > 0):
            raise ValueError("knot times must start at 0 and increase strictly, one per knot")
        self.knots, self.times = knots, times
        self.start, self.end, self.duration = knots[0], knots[-1], float(times[-1])
        for a in (knots, times):
            a.setflags(write=False)

    def sample(self, t) -> tuple[np.ndarray, np.ndarray]:
        t = _times(t)
        k = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.times) - 2)
        dt = np.diff(self.times)[k]
        dq = self.knots[k + 1] - self.knots[k]
        frac = np.clip((t - self.times[k]) / dt, 0.0, 1.0)
        moving = (t >= 0) & (t < self.duration)
        return self.knots[k] + frac[:, None] * dq, np.where(moving[:, None], dq / dt[:, None], 0.0)

    def waypoints(self) -> list[Waypoint]:
        dts = np.diff(self.times)
        return [Waypoint(q, float(dt), 0.0) for q, dt in zip(self.knots[1:], dts)]


class ToolSegment(PiecewiseTrajectory):
    """A PiecewiseTrajectory that takes the tool point from p0 to p1 (world mm), posed at pitch and roll (rad) at both
    ends; max_deviation_mm is the largest distance from the straight line p0 -> p1 found at the middles of the
    pieces. How it goes between the ends is the subclass's: CartesianSegment, JointChord."""

    def __init__(self, knots, times, p0, p1, pitch: float, roll: float, max_deviation_mm: float):
        super().__init__(knots, times)
        self.p0, self.p1 = np.array(p0, float), np.array(p1, float)
        self.pitch, self.roll, self.max_deviation_mm = float(pitch), float(roll), float(max_deviation_mm)


class CartesianSegment(ToolSegment):
    """A ToolSegment whose tool point runs on the straight line p0 -> p1 at the fixed pitch and roll all the way
    (cartesian_line: within its tolerance of the line)."""


class JointChord(ToolSegment):
    """A ToolSegment moving in joint space, on a straight line between the two ends' joints (joint_chord): the tool
    is at p0 and p1 at the pitch and roll there, and bows off the line between them by up to max_deviation_mm."""


def joint_move(q_from, q_to, scaling: str = "trapezoid", duration: float | None = None,
               accel_time: float | None = None, robot: RobotModel | None = None) -> JointTrajectory:
    """A rest-to-rest joint move between two joint vectors (5,) rad within the joint limits.

    duration (s) defaults to planning.timing.moving_time (the lab's rule, long enough for every velocity limit);
    a given duration that would drive a joint past its velocity limit is refused with a ValueError naming it.
    accel_time (trapezoid only, s) defaults to a third of the duration.
    """
    robot = robot or rx200()
    check_scaling(scaling)
    q0 = kinematics.check_joints(q_from, robot)
    q1 = kinematics.check_joints(q_to, robot)
    if q0.shape != (5,) or q1.shape != (5,):
        raise ValueError(f"joint_move takes two joint vectors of shape (5,), got {q0.shape} and {q1.shape}")
    if duration is None:
        duration = moving_time(q0, q1, scaling, robot)
    if not np.isfinite(duration) or duration <= 0:
        raise ValueError(f"duration must be a positive number of seconds, got {duration}")
    if accel_time is not None and (scaling != "trapezoid" or not 0 <= accel_time <= duration / 2):
        raise ValueError(f"accel_time must be between 0 and duration / 2 = {duration / 2:.3f} s for a trapezoid "
                         f"move (and is not used by the quintic), got {accel_time}")
    speed = np.abs(q1 - q0) * peak_rate(duration, scaling, accel_time)
    too_fast = [f"{n} would peak at {s:.2f} rad/s, above its {v:.2f} rad/s limit"
                for n, s, v in zip(robot.joint_names, speed, robot.velocity) if s > v * (1 + 1e-9)]
    if too_fast:
        raise ValueError(f"a {duration:.3f} s {scaling} move is too fast: " + "; ".join(too_fast))
    return JointTrajectory(q0, q1, duration, scaling, accel_time)


def check_point(p, name: str) -> np.ndarray:
    """p as a float (3,) array (x, y, z in world mm); ValueError naming `name` for a wrong shape, NaN or infinity."""
    p = np.asarray(p, dtype=float)
    if p.shape != (3,):
        raise ValueError(f"{name} must have shape (3,) (x, y, z in world mm), got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name} contains NaN or infinity")
    return p


def _fmt(p) -> str:
    return f"({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}) mm"


def _line_knots(P0, P1, s, pitch, roll, current, robot) -> np.ndarray:
    """IK knots at path fractions s along P0 -> P1 on one branch; Unreachable says where the line fails."""
    pts = P0 + s[:, None] * (P1 - P0)
    res = kinematics.ik_batch(pts, pitch, roll, current=current, robot=robot)
    head = f"straight line {_fmt(P0)} -> {_fmt(P1)} at pitch {np.degrees(pitch):.1f} deg"
    if not res.success.all():
        i = int(np.flatnonzero(~res.success)[0])
        good, bad = (s[i - 1], s[i]) if i > 0 else (None, s[0])
        while good is not None and (bad - good) * np.linalg.norm(P1 - P0) > 0.1:   # locate the edge to 0.1 mm
            mid = 0.5 * (good + bad)
            if kinematics.ik_batch(P0 + mid * (P1 - P0), pitch, roll, current=current, robot=robot).success[0]:
                good = mid
            else:
                bad = mid
        where = P0 + bad * (P1 - P0)
        try:
            kinematics.ik(where, pitch, roll, robot=robot)
            why = "no solution"
        except Unreachable as e:
            why = str(e)
        raise Unreachable(f"{head} fails {100 * bad:.0f}% of the way along, at {_fmt(where)}: {why}")
    flips = np.flatnonzero(res.branch != res.branch[0])
    if flips.size:
        i = int(flips[0])
        raise Unreachable(f"{head} would switch IK branch {100 * s[i]:.0f}% of the way along, at {_fmt(pts[i])} "
                          f"(the starting branch breaks a joint limit there)")
    step = np.abs(np.diff(res.q, axis=0)).max(axis=1)
    if step.size and step.max() > _MAX_KNOT_STEP:
        i = int(np.argmax(step)) + 1
        raise Unreachable(f"{head} passes a singularity or wraps a joint {100 * s[i]:.0f}% of the way along, at "
                          f"{_fmt(pts[i])} (the joints jump by {step.max():.2f} rad between neighbouring points)")
    return res.q


def _line_deviation(knots, P0, P1, robot) -> float:
    """Largest distance (mm) from the line P0-P1 of the tool at the middle of every joint-space piece."""
    mid = 0.5 * (knots[1:] + knots[:-1])
    p = kinematics.fk(mid, robot, check_limits=False)[:, :3, 3]
    d = P1 - P0
    L = np.linalg.norm(d)
    if L == 0:
        return float(np.linalg.norm(p - P0, axis=1).max())
    u = d / L
    rel = p - P0
    along = np.clip(rel @ u, 0.0, L)
    return float(np.linalg.norm(rel - along[:, None] * u, axis=1).max())


def cartesian_line(p0, p1, pitch: float, roll: float = 0.0, current=None, scaling: str = "quintic",
                   speed: float = DEFAULT_LINE_SPEED, tol_mm: float = LINE_TOLERANCE_MM,
                   robot: RobotModel | None = None) -> CartesianSegment:
    """Move the tool point on the straight line p0 -> p1 (world mm) at a fixed pitch and roll (rad).

    Knots are placed at equal time steps of a rest-to-rest scaling ("quintic" or "trapezoid") of the path, solved by
    kinematics.ik_batch on the branch best for `current` (default home), and doubled until the tool stays within
    tol_mm of the line between knots. The duration is the longest of: length / speed (mean tool speed, mm/s), the
    lab's 0.4 s minimum, and what keeps every joint's speed within its velocity limit. Raises Unreachable naming
    where along the line the arm cannot follow it (out of reach, joint limit, branch switch or singularity).
    """
    robot = robot or rx200()
    check_scaling(scaling)
    P0, P1 = check_point(p0, "p0"), check_point(p1, "p1")
    for name, v in (("pitch", pitch), ("roll", roll), ("speed", speed), ("tol_mm", tol_mm)):
        if not np.isfinite(v):
            raise ValueError(f"{name} must be finite, got {v}")
    if speed <= 0 or tol_mm <= 0:
        raise ValueError(f"speed ({speed} mm/s) and tol_mm ({tol_mm} mm) must be positive")
    if current is not None:
        current = kinematics.check_joints(current, robot, check_limits=False)
    length = float(np.linalg.norm(P1 - P0))
    n = max(2, int(np.ceil(length / 10.0)))
    while True:
        tau = np.linspace(0.0, 1.0, n + 1)
        s = quintic_fraction(tau)[0] if scaling == "quintic" else trapezoid_fraction(tau, 1.0, ACCEL_FRACTION)
        knots = _line_knots(P0, P1, s, pitch, roll, current, robot)
        deviation = _line_deviation(knots, P0, P1, robot)
        if deviation <= tol_mm:
            break
        if n >= 8192:
            raise Unreachable(f"straight line {_fmt(P0)} -> {_fmt(P1)}: the tool strays {deviation:.2f} mm from "
                              f"the line even with {n} knots (near a singularity)")
        n *= 2
    return CartesianSegment(knots, tau * _segment_duration(knots, length, speed, robot), P0, P1, pitch, roll,
                            deviation)


def _segment_duration(knots: np.ndarray, length: float, speed: float, robot: RobotModel) -> float:
    """A tool segment's duration (s): the longest of length / speed (mean tool speed), the lab's minimum moving time
    and what keeps every joint's speed between the equally timed knots within its velocity limit."""
    joint_bound = float(np.max(np.abs(np.diff(knots, axis=0)) / robot.velocity)) * (len(knots) - 1)
    return max(MIN_MOVING_TIME_S, length / speed, joint_bound)


def joint_chord(p0, p1, pitch: float, roll: float = 0.0, current=None, speed: float = DEFAULT_LINE_SPEED,
                robot: RobotModel | None = None) -> JointChord:
    """Move the tool from p0 to p1 (world mm), posed at pitch and roll (rad) at both ends, in joint space: the joints
    solved at each end (kinematics.ik_batch, one IK branch, the best for `current`) and interpolated linearly between
    them with a quintic time scaling. Cheaper than cartesian_line and not straight: the tool bows off the line
    between the ends (max_deviation_mm). Timed as cartesian_line (mean tool speed, the lab's minimum, the velocity
    limits). Raises Unreachable naming the end the arm cannot reach, or when the ends need two IK branches."""
    robot = robot or rx200()
    P0, P1 = check_point(p0, "p0"), check_point(p1, "p1")
    for name, v in (("pitch", pitch), ("roll", roll), ("speed", speed)):
        if not np.isfinite(v):
            raise ValueError(f"{name} must be finite, got {v}")
    if speed <= 0:
        raise ValueError(f"speed must be positive, got {speed} mm/s")
    if current is not None:
        current = kinematics.check_joints(current, robot, check_limits=False)
    res = kinematics.ik_batch(np.array([P0, P1]), pitch, roll, current=current, robot=robot)
    for i, P in enumerate((P0, P1)):
        if not res.success[i]:
            raise Unreachable(f"joint chord {_fmt(P0)} -> {_fmt(P1)}: {_fmt(P)} is out of reach at pitch "
                              f"{np.degrees(pitch):.1f} deg")
    if res.branch[0] != res.branch[1]:
        raise Unreachable(f"joint chord {_fmt(P0)} -> {_fmt(P1)}: its ends need two IK branches")
    length = float(np.linalg.norm(P1 - P0))
    n = max(2, int(np.ceil(length / 10.0)))
    tau = np.linspace(0.0, 1.0, n + 1)
    knots = res.q[0] + quintic_fraction(tau)[0][:, None] * (res.q[1] - res.q[0])
    duration = _segment_duration(knots, length, speed, robot)
    return JointChord(knots, tau * duration, P0, P1, pitch, roll, _line_deviation(knots, P0, P1, robot))


def reverse(segment: PiecewiseTrajectory) -> PiecewiseTrajectory:
    """The same path run backwards in the mirrored timing (a tool segment stays one of its kind)."""
    knots, times = segment.knots[::-1], segment.duration - segment.times[::-1]
    if isinstance(segment, ToolSegment):
        return type(segment)(knots, times, segment.p1, segment.p0, segment.pitch, segment.roll,
                             segment.max_deviation_mm)
    return PiecewiseTrajectory(knots, times)
