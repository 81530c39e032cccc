"""Time scaling: how far along a path (fraction s in 0..1) a rest-to-rest motion is at time t, and how fast.

Two scalings, both starting and ending at rest:
- "trapezoid": the manufacturer's time-based profile (armlab.profile.trapezoid_fraction): constant acceleration for
  `accel_time`, cruise, constant deceleration. Peak rate 1 / (T - accel_time). This is what the Interbotix driver
  and the simulator execute for one `move_to(q, moving_time, accel_time)`.
- "quintic": s(tau) = 10 tau^3 - 15 tau^4 + 6 tau^5, tau = t / T: zero velocity and acceleration at both ends.
  Peak rate 15 / (8 T) at tau = 1/2.

Moving times follow the lab's rule (armlab.profile.default_moving_time: the largest joint change at pi/4 rad/s, at
least 0.4 s), lengthened when needed so that no joint's peak speed exceeds its velocity limit. Units: s, rad.
"""

from __future__ import annotations

import numpy as np

from armlab.profile import ACCEL_FRACTION, default_moving_time, trapezoid_fraction
from armlab.robot import RobotModel, rx200

__all__ = ["SCALINGS", "ACCEL_FRACTION", "quintic_fraction", "trapezoid_rate", "time_scaling", "peak_rate",
           "default_accel_time", "moving_time", "check_scaling"]

SCALINGS: tuple[str, ...] = ("trapezoid", "quintic")
QUINTIC_PEAK = 15 / 8      # peak of ds/dtau for the quintic


def check_scaling(scaling: str) -> str:
    """Validate a time-scaling name ("trapezoid" or "quintic")."""
    if scaling not in SCALINGS:
        raise ValueError(f"unknown time scaling {scaling!r}: expected one of {SCALINGS}")
    return scaling


def quintic_fraction(tau) -> tuple[np.ndarray, np.ndarray]:
    """Quintic rest-to-rest scaling at normalised times tau (clipped to 0..1): (s, ds/dtau)."""
    tau = np.clip(np.asarray(tau, dtype=float), 0.0, 1.0)
    s = tau**3 * (10 - 15 * tau + 6 * tau**2)
    ds = 30 * tau**2 * (1 - tau) ** 2
    return s, ds


def trapezoid_rate(t, moving_time: float, accel_time: float) -> np.ndarray:
    """ds/dt (1/s) of the manufacturer's trapezoidal profile (the derivative of profile.trapezoid_fraction)."""
    t = np.asarray(t, dtype=float)
    Ta = min(max(accel_time, 0.0), moving_time / 2)
    v = 1.0 / (moving_time - Ta)
    inside = (t >= 0) & (t <= moving_time)
    if Ta == 0:
        return np.where(inside, v, 0.0)
    a = v / Ta
    rate = np.minimum(np.minimum(a * t, v), a * (moving_time - t))
    return np.where(inside, np.maximum(rate, 0.0), 0.0)


def default_accel_time(duration: float) -> float:
    """The lab's ramp time for a trapezoidal move: a third of the moving time (s)."""
    return ACCEL_FRACTION * duration


def time_scaling(t, duration: float, scaling: str = "trapezoid",
                 accel_time: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Fraction s (0..1) and rate ds/dt (1/s) at times t (s) of a rest-to-rest motion lasting `duration` s.

    Before 0 the motion is at s = 0, after `duration` at s = 1, both at rest. accel_time (trapezoid only) defaults to
    a third of the duration.
    """
    check_scaling(scaling)
    if not np.isfinite(duration) or duration <= 0:
        raise ValueError(f"duration must be a positive number of seconds, got {duration}")
    t = np.asarray(t, dtype=float)
    if scaling == "quintic":
        s, ds = quintic_fraction(t / duration)
        inside = (t >= 0) & (t <= duration)
        return s, np.where(inside, ds / duration, 0.0)
    Ta = default_accel_time(duration) if accel_time is None else accel_time
    return trapezoid_fraction(t, duration, Ta), trapezoid_rate(t, duration, Ta)


def peak_rate(duration: float, scaling: str = "trapezoid", accel_time: float | None = None) -> float:
    """Largest ds/dt (1/s) of the scaling: 15 / (8 T) for quintic, 1 / (T - accel_time) for trapezoid."""
    check_scaling(scaling)
    if scaling == "quintic":
        return QUINTIC_PEAK / duration
    Ta = default_accel_time(duration) if accel_time is None else min(max(accel_time, 0.0), duration / 2)
    return 1.0 / (duration - Ta)


def moving_time(q_from, q_to, scaling: str = "trapezoid", robot: RobotModel | None = None) -> float:
    """Moving time (s) for a rest-to-rest joint move from q_from to q_to (5,) rad.

    The lab's rule (profile.default_moving_time, which also keeps the trapezoid's peak speeds within the limits
    when accel_time = T / 3), lengthened for the quintic so that its peak speed 15 |dq| / (8 T) stays within every
    joint's velocity limit.
    """
    check_scaling(scaling)
    robot = robot or rx200()
    T = default_moving_time(q_from, q_to, robot, accel_fraction=ACCEL_FRACTION)
    if scaling == "quintic":
        dq = np.abs(np.asarray(q_to, float) - np.asarray(q_from, float))
        T = max(T, float(np.max(QUINTIC_PEAK * dq / robot.velocity)))
    return T
