"""Kinematics speed and accuracy: FK loop vs batch, closed-form IK vs the manufacturer's numerical IK.

Prints one table from one run (all timings in the same process, so the ratios are comparable):
- FK per pose: armlab.kinematics.fk called in a loop vs one vectorised call on 100 000 poses (and the PoX batch).
- IK per solve on the same 1000 reachable targets (tool poses of random in-limit joint vectors, tool above the
  board): closed form one target at a time (ik's fast single-target path, and the same targets through the batch
  machinery, _ik_general, which ik used for one target before) and as a batch, modern_robotics.IKinSpace exactly
  as the Interbotix SDK calls it (manufacturer's Slist/M in metres, seeds all-zero then waist -120/+120 deg,
  eomg = ev = 0.001, answer wrapped to (-pi, pi] and checked against the joint limits), and damped least squares
  (scenarios/dls_ik.py, the method notebook 03 derives) with the same seeds. Success rate and the worst tool-point
  error (mm) of the accepted answers.

    .venv/bin/python benchmarks/kinematics.py
"""

from __future__ import annotations

import time

import modern_robotics as mr
import numpy as np

from armlab import kinematics as k
from armlab.robot import rx200
from armlab.transforms import homogeneous, invert_transform, rot_z

from scenarios.dls_ik import ik_numerical

N_FK = 100_000
N_IK = 1000
SEED = 0

# The manufacturer's description (interbotix_xs_modules/xs_robot/mr_descriptions.py): base_link frame, metres.
MR_SLIST = np.array([[0, 0, 1, 0, 0, 0], [0, 1, 0, -0.10457, 0, 0], [0, 1, 0, -0.30457, 0, 0.05],
                     [0, 1, 0, -0.30457, 0, 0.25], [1, 0, 0, 0, 0.30457, 0]], float).T
MR_M = homogeneous(None, [0.408575, 0.0, 0.30457])
T_WORLD_BASE = homogeneous(rot_z(np.pi / 2))   # base_link = world turned -90 deg about z, same origin
SDK_SEEDS = np.array([[0.0] * 5, [np.radians(-120), 0, 0, 0, 0], [np.radians(120), 0, 0, 0, 0]])


def seconds(fn, repeat: int = 1) -> float:
    """Best wall-clock time (s) of `repeat` calls of fn()."""
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def reachable_targets(n: int, rng: np.random.Generator):
    """n tool poses (world, mm) of random in-limit joint vectors with the tool point above the board."""
    robot = rx200()
    q = rng.uniform(robot.lower, robot.upper, (4 * n, 5))
    T = k.fk(q)
    keep = (T[:, 2, 3] > 0) & (np.hypot(T[:, 0, 3], T[:, 1, 3]) > 1.0)
    T, q = T[keep][:n], q[keep][:n]
    p, approach = T[:, :3, 3], T[:, :3, 0]
    radial = p[:, :2] / np.linalg.norm(p[:, :2], axis=1, keepdims=True)
    pitch = np.arctan2(-approach[:, 2], np.sum(approach[:, :2] * radial, axis=1))
    return T, p, pitch, q[:, 4]


def sdk_ik(T_world) -> np.ndarray | None:
    """The Interbotix SDK's set_ee_pose_matrix: IKinSpace from each seed until a within-limits answer (rad)."""
    robot = rx200()
    T = invert_transform(T_WORLD_BASE) @ T_world
    T[:3, 3] /= 1000.0
    for seed in SDK_SEEDS:
        q, ok = mr.IKinSpace(MR_SLIST, MR_M, T, seed, 0.001, 0.001)
        q = np.angle(np.exp(1j * q))  # the SDK wraps to (-pi, pi] before checking limits
        if ok and robot.within_limits(q):
            return q
    return None


def numerical_ik(p, pitch, roll) -> np.ndarray | None:
    """armlab's damped least squares from the SDK's seeds."""
    for seed in SDK_SEEDS:
        res = ik_numerical(p, pitch, roll, q0=seed)
        if res.success:
            return res.q
    return None


def main() -> None:
    rng = np.random.default_rng(SEED)
    robot = rx200()
    rows = []  # (section, method, n, success, max error mm, seconds per item)

    q = rng.uniform(robot.lower, robot.upper, (N_FK, 5))
    t_loop = seconds(lambda: [k.fk(qi) for qi in q])
    t_batch = seconds(lambda: k.fk(q), repeat=3)
    t_pox = seconds(lambda: k.fk_pox(q), repeat=3)
    err_pox = np.abs(k.fk(q)[:, :3, 3] - k.fk_pox(q)[:, :3, 3]).max()
    rows += [("FK", "fk, loop of single poses", N_FK, "", "", t_loop / N_FK),
             ("FK", "fk, one (N, 5) batch (DH)", N_FK, "", "", t_batch / N_FK),
             ("FK", "fk_pox, one (N, 5) batch", N_FK, "", f"{err_pox:.1e} vs DH", t_pox / N_FK)]

    T, P, pitch, roll = reachable_targets(N_IK, rng)

    def error(solutions):
        ok = [s for s in solutions if s is not None]
        if not ok:
            return len(ok), np.nan
        return len(ok), float(np.linalg.norm(k.fk(np.array(ok))[:, :3, 3] - P[[s is not None for s in solutions]],
                                             axis=1).max())

    def closed_form_loop(solve=k.ik):
        out = []
        for i in range(N_IK):
            try:
                out.append(solve(P[i], pitch[i], roll[i])[0])
            except k.Unreachable:
                out.append(None)
        return out

    def general_path(p, pitch_i, roll_i):
        return k._ik_general(p, pitch_i, roll_i, None, robot)

    results = {}

    def timed(name, fn, repeat: int = 1):
        """Best of `repeat` runs (s); the result of the last one kept under `name`."""
        return seconds(lambda: results.__setitem__(name, fn()), repeat)

    t_single = timed("single", closed_form_loop, repeat=5)             # ~10 ms a run: best of 5 against noise
    t_general = timed("general", lambda: closed_form_loop(general_path), repeat=3)
    t_ik_batch = seconds(lambda: results.__setitem__("batch", k.ik_batch(P, pitch, roll)), repeat=3)
    t_sdk = timed("sdk", lambda: [sdk_ik(Ti) for Ti in T])
    t_num = timed("numerical", lambda: [numerical_ik(P[i], pitch[i], roll[i]) for i in range(N_IK)])
    batch = results["batch"]
    batch_solutions = [qi if ok else None for qi, ok in zip(batch.q, batch.success)]
    for method, key, t in (("closed form ik, one target at a time", "single", t_single),
                           ("  the same through the batch machinery", "general", t_general),
                           ("closed form ik_batch, one (N, 3) call", None, t_ik_batch),
                           ("modern_robotics IKinSpace, SDK seeds", "sdk", t_sdk),
                           ("damped least squares, SDK seeds", "numerical", t_num)):
        solved, err = error(results[key] if key else batch_solutions)
        rows.append(("IK", method, N_IK, f"{solved}/{N_IK}", f"{err:.1e}", t / N_IK))

    fk_loop_us = rows[0][5]
    sdk_us = next(r[5] for r in rows if r[1].startswith("modern_robotics"))
    print(f"Kinematics benchmark (seed {SEED}; IK targets: {N_IK} tool poses of random in-limit joint vectors, "
          "tool above the board)")
    header = f"{'':3} {'method':40} {'N':>7} {'success':>10} {'max err (mm)':>17} {'us per item':>12} {'speed-up':>9}"
    print(header)
    print("-" * len(header))
    for section, method, n, success, err, per_item_s in rows:
        ref = fk_loop_us if section == "FK" else sdk_us
        speed_up = f"{ref / per_item_s:.3g}x"
        print(f"{section:3} {method:40} {n:7d} {success:>10} {err:>17} {per_item_s * 1e6:12.2f} {speed_up:>9}")
    print("speed-up: FK rows against the FK loop, IK rows against IKinSpace as the Interbotix SDK calls it")


if __name__ == "__main__":
    main()
