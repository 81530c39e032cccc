"""Planning speed and quality: Cartesian segments solved in one IK batch vs one IK call per knot; plan costs.

Prints one table from one run (same process, so the ratios compare):
- Cartesian descent (130 mm, top-down): the knots of armlab.planning.cartesian_line solved by one vectorised
  kinematics.ik_batch call vs kinematics.ik called knot by knot; the number of knots and the largest distance of the
  tool from the line between knots (mm), and the knots a long sweep needs for two tolerances.
- Whole plans: plan_pick and plan_pick_place (with and without a stack to clear), and the clearance check alone.

    .venv/bin/python benchmarks/planning.py
"""

from __future__ import annotations

import time

import numpy as np

from armlab import kinematics as k
from armlab import planning
from armlab.robot import rx200


def ms(fn, repeat: int = 20) -> float:
    """Best wall-clock time (ms) of `repeat` calls of fn()."""
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return 1e3 * best


def main() -> None:
    robot = rx200()
    p0, p1 = np.array([150.0, 250.0, 150.0]), np.array([150.0, 250.0, 20.0])
    seg = planning.cartesian_line(p0, p1, np.pi / 2, 0.3)
    pts = k.fk(seg.knots)[:, :3, 3]
    t_batch = ms(lambda: k.ik_batch(pts, np.pi / 2, 0.3))
    t_loop = ms(lambda: [k.ik(p, np.pi / 2, 0.3)[0] for p in pts])
    t_line = ms(lambda: planning.cartesian_line(p0, p1, np.pi / 2, 0.3))
    sweeps = [planning.cartesian_line([-200, 150, 60], [200, 300, 60], np.pi / 2, 0.0, tol_mm=tol)
              for tol in (0.5, 0.05)]

    print("Cartesian descent, 130 mm top-down")
    print(f"{'':44} {'ms':>8} {'ratio':>7}")
    print(f"{'IK of the ' + str(len(pts)) + ' knots, one ik_batch call':44} {t_batch:8.3f} {1.0:7.1f}")
    print(f"{'IK of the same knots, kinematics.ik per knot':44} {t_loop:8.3f} {t_loop / t_batch:7.1f}")
    print(f"{'cartesian_line (knots, checks, timing)':44} {t_line:8.3f} {t_line / t_batch:7.1f}")
    print(f"tool off the line between knots: {seg.max_deviation_mm:.3f} mm ({len(pts)} knots, tolerance 0.5 mm)")
    for tol, sw in zip((0.5, 0.05), sweeps):
        print(f"427 mm horizontal sweep, tolerance {tol} mm: {len(sw.knots)} knots, {sw.max_deviation_mm:.3f} mm off")

    tower = [planning.Obstacle(0, 320, 152, 27)]
    start = robot.sleep
    rows = [
        ("plan_pick, open board", lambda: planning.plan_pick(start, [-200, 250, 38], 0.2, 38)),
        ("plan_pick_place, open board",
         lambda: planning.plan_pick_place(start, [-200, 250, 38], 0.2, 38, [200, 250, 0])),
        ("plan_pick_place over a 152 mm stack",
         lambda: planning.plan_pick_place(start, [-200, 250, 38], 0.2, 38, [200, 250, 0], obstacles=tower)),
    ]
    base = None
    print("\nWhole plans")
    print(f"{'':44} {'ms':>8} {'ratio':>7} {'plan s':>7}")
    for name, fn in rows:
        t = ms(fn, repeat=5)
        base = base or t
        print(f"{name:44} {t:8.2f} {t / base:7.1f} {fn().duration:7.2f}")
    transit = planning.joint_move(robot.home, robot.sleep)
    t = ms(lambda: planning.transit_clearance(transit, tower * 20))
    print(f"{'clearance check, 20 obstacles, one transit':44} {t:8.2f} {t / base:7.1f}")


if __name__ == "__main__":
    main()
