"""The gripper's servo as the physics drives it: how hard the finger pads squeeze and how fast they close.

The manufacturer's grasp (reference rx200.md, the Interbotix API's `gripper.grasp()`) runs the gripper's Dynamixel
in PWM mode at an effort of 150 + pressure (350 - 150) of the servo's PWM limit of 885 (its default, the ROBOTIS
e-manual's control table, address 36), default pressure 0.5: a duty of 250 / 885 = 0.28. The servo is taken as an
XL430-W250 (the ReactorX series' gripper servo; stall torque 1.5 N m and no-load speed 61 rev/min at 12 V, the
e-manual's specifications). A DC motor at a fixed duty gives duty x stall torque at standstill, less a back-EMF
torque (stall torque / no-load speed) x speed while it turns, so the horn's torque is
    tau = duty tau_stall - (tau_stall / omega_0) omega.
One horn drives both fingers through a crank and rod (r = 14 mm, L = 24 mm: rx200.md), each finger at
    x(theta) = r sin(theta) + sqrt(L^2 - r^2 cos^2(theta))
from the centre line, so by virtual work each pad squeezes with
    F = tau / (2 dx/dtheta)
and the back-EMF acts on each pad as a damper of (tau_stall / omega_0) / (2 (dx/dtheta)^2). Here x is the finger's
outer face (armlab.gripper_geometry: gap = 2 (x - pad thickness)). At the default pressure, closed on a large
(38 mm) block: 13.0 N a pad, 441 N s/m, closing at up to 30 mm/s a pad; on a small (25 mm) one 16.0 N. These are
derived from the data sheet, not weighed on the bench; friction in the servo's gears would lower them.

Units: mm and N at this module's interface (the physics model takes N s/m); angles in rad.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CRANK_MM", "ROD_MM", "PWM_LIMIT", "STALL_TORQUE_NM", "NO_LOAD_RAD_S", "MECHANICAL_TIME_S", "duty",
           "pad_force_n", "pad_damping_n_s_m", "pad_armature_kg"]

CRANK_MM = 14.0                       # r: the horn's crank (rx200.md)
ROD_MM = 24.0                         # L: the rod from the crank to the finger (rx200.md)
PWM_LIMIT = 885                       # the servo's PWM limit (its control table's default)
STALL_TORQUE_NM = 1.5                 # XL430-W250 at 12 V
NO_LOAD_RAD_S = 61.0 * 2 * np.pi / 60  # XL430-W250 at 12 V
MECHANICAL_TIME_S = 0.01              # the servo's mechanical time constant (assumed: a small geared DC servo's)


def duty(pressure: float) -> float:
    """The PWM duty (0..1) of the manufacturer's grasp at `pressure` (0..1): (150 + 200 pressure) / PWM_LIMIT."""
    p = float(pressure)
    if not 0.0 <= p <= 1.0:
        raise ValueError(f"gripper pressure must lie in [0, 1] (the manufacturer's set_pressure), got {pressure}")
    return (150.0 + 200.0 * p) / PWM_LIMIT


def _lever_m(finger_mm: float) -> float:
    """dx/dtheta (m/rad) of a finger at x = finger_mm from the centre (x^2 - 2 r x sin(theta) = L^2 - r^2)."""
    x, r, L = float(finger_mm), CRANK_MM, ROD_MM
    if not L - r < x < L + r:
        raise ValueError(f"a finger at {x:.1f} mm is outside the crank's travel ({L - r:.0f}-{L + r:.0f} mm)")
    s = (x * x + r * r - L * L) / (2.0 * r * x)
    c = np.sqrt(1.0 - s * s)
    return float(r * c * (1.0 + r * s / np.sqrt(L * L - r * r * c * c))) / 1000.0


def pad_force_n(pressure: float, finger_mm: float) -> float:
    """The force (N) each pad squeezes with at standstill, the fingers' outer faces finger_mm from the centre."""
    return duty(pressure) * STALL_TORQUE_NM / (2.0 * _lever_m(finger_mm))


def pad_damping_n_s_m(finger_mm: float) -> float:
    """The back-EMF's damping (N s/m) on each pad's closing speed, the fingers finger_mm from the centre."""
    return STALL_TORQUE_NM / NO_LOAD_RAD_S / (2.0 * _lever_m(finger_mm) ** 2)


def pad_armature_kg(finger_mm: float) -> float:
    """The servo's rotor inertia (through its gears) as a mass (kg) on each pad's slide: the mechanical time constant
    (rotor inertia x no-load speed / stall torque) times the back-EMF's damping, the fingers finger_mm from the
    centre."""
    return MECHANICAL_TIME_S * pad_damping_n_s_m(finger_mm)
