"""The manufacturer's time-based motion profile and the lab's rule for choosing moving times.

The Interbotix driver moves every joint from start to goal in `moving_time` seconds with a trapezoidal velocity
profile whose ramps last `accel_time` seconds (accel_time <= moving_time / 2). It refuses a move whose
|dq| / moving_time exceeds a joint's velocity limit. Units: rad, s.
"""

from __future__ import annotations

import numpy as np

from armlab.robot import RobotModel, rx200

__all__ = ["trapezoid_fraction", "default_moving_time", "velocity_violations", "MIN_MOVING_TIME_S",
           "LAB_MEAN_SPEED", "ACCEL_FRACTION"]

MIN_MOVING_TIME_S = 0.4            # the lab's shortest move (the lab handout)
LAB_MEAN_SPEED = np.pi / 4         # rad/s: the lab's rule of thumb for the largest joint change
ACCEL_FRACTION = 1 / 3             # the lab's accel_time = moving_time / 3 unless the caller chooses (every default
                                   # ramp of the kit: the arms, the planner's trapezoids, default_moving_time)


def trapezoid_fraction(t, moving_time: float, accel_time: float) -> np.ndarray:
    """Fraction (0..1) of the way from start to goal at times t (s) for the time-based trapezoidal profile."""
    t = np.clip(np.asarray(t, dtype=float), 0.0, moving_time)
    if moving_time <= 0:
        return np.ones_like(t)
    Ta = min(max(accel_time, 0.0), moving_time / 2)
    if Ta == 0:
        return t / moving_time
    v = 1.0 / (moving_time - Ta)
    a = v / Ta
    return np.where(t < Ta, 0.5 * a * t**2,
                    np.where(t <= moving_time - Ta, v * (t - Ta / 2), 1.0 - 0.5 * a * (moving_time - t) ** 2))


def default_moving_time(q_from, q_to, robot: RobotModel | None = None,
                        accel_fraction: float = ACCEL_FRACTION) -> float:
    """Moving time (s) for a joint move: the largest change at the lab's pi/4 rad/s, at least 0.4 s, and long
    enough that no joint's peak speed |dq| / (T - accel_time) exceeds its velocity limit."""
    robot = robot or rx200()
    dq = np.abs(np.asarray(q_to, float) - np.asarray(q_from, float))
    peak_bound = float(np.max(dq / ((1 - accel_fraction) * robot.velocity)))
    return max(MIN_MOVING_TIME_S, float(dq.max()) / LAB_MEAN_SPEED, peak_bound)


def velocity_violations(q_from, q_to, moving_time: float, robot: RobotModel | None = None) -> list[str]:
    """The driver's refusal rule: joints whose |dq| / moving_time exceeds their velocity limit, in words."""
    robot = robot or rx200()
    if moving_time <= 0:
        return [f"moving time must be positive, got {moving_time} s"]
    speed = np.abs(np.asarray(q_to, float) - np.asarray(q_from, float)) / moving_time
    return [f"{name} would need {s:.2f} rad/s, above its {v:.2f} rad/s limit"
            for name, s, v in zip(robot.joint_names, speed, robot.velocity) if s > v + 1e-9]
