"""A fingerprint of what the simulator computes, to the last bit: for a refactoring or a speed-up that must change no
result (stored notebook outputs are compared by nbval, the hidden checks compare references).

    .venv/bin/python benchmarks/sim_fingerprint.py [--save FILE] [--compare FILE]

Each entry is sha256 (16 hex digits) over exact float bytes (ndarray.tobytes, with dtype and shape):
- kin: fk_pox, link_frames, joint_positions, gravity_deflection one pose at a time and in batches, the Jacobian and
  the DH chain, on 200 seeded joint vectors;
- four event runs (sort 'n stack levels 1 and 3, line up level 2, to the sky; record=True): every clock step's
  time, physical joints, motor and link angles, gripper opening and every object's pose (steps: count:hash), the final
  objects, score, time (float.hex), placement errors, the replay's arrays, a final camera frame (rgb and depth), the
  physical joints and an encoder reading;
- click-to-grab and click-to-drop on a two-block scene, and teach-and-repeat (the swap taught by hand through the
  task machine, replayed on another station).
--save writes the entries as JSON; --compare FILE prints, per entry, SAME or the differing fields (wall times aside)
and exits 1 on any difference. About 30 s on a quiet machine. Measured 2026-12-07: 612fe96 and the simspeed branch
give the same entries.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import time

import numpy as np


def digest(*arrays) -> str:
    """sha256 (16 hex digits) over the dtype, shape and bytes of each array."""
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(np.asarray(a))
        h.update(f"{a.dtype}{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()[:16]


class StepHash:
    """A world listener hashing the arm's state and every object's pose at every clock step."""

    def __init__(self, station):
        self.station, self.steps, self.hash = station, 0, hashlib.sha256()
        station.world.add_listener(self)

    def __call__(self, t: float) -> None:
        arm = self.station.arm
        self.steps += 1
        for a in (np.float64(t), arm._q_true, arm._motor, arm._link, np.float64(arm.gripper_opening_mm)):
            self.hash.update(np.asarray(a).tobytes())
        for o in self.station.world.objects:
            self.hash.update(np.concatenate([o.position, [o.yaw], np.asarray(o.tilt, float)]).tobytes())

    def __str__(self) -> str:
        return f"{self.steps}:{self.hash.hexdigest()[:16]}"


def _objects(world) -> str:
    return digest(*[np.concatenate([o.position, [o.yaw], np.asarray(o.tilt, float)]) for o in world.objects])


def _frame(station) -> str:
    f = station.camera.capture()
    return digest(f.rgb, f.depth)


def fingerprint() -> dict:
    """{entry: {field: value}} (see the module notes); each entry also has its wall time "wall_s"."""
    from armlab import kinematics, make_station, tasks
    from armlab.sim.arm import ArmRealism, gravity_deflection
    from armlab.tasks import teach
    from armlab.tasks.events import event_station, run_event

    out = {}
    Q = np.random.default_rng(5).uniform(-1.5, 1.5, (200, 5))
    t = time.perf_counter()
    out["kin"] = {
        "fk": digest(*[kinematics.fk_pox(q, check_limits=False) for q in Q[:50]],
                     kinematics.fk_pox(Q, check_limits=False)),
        "link_frames": digest(*[kinematics.link_frames(q, check_limits=False) for q in Q[:50]],
                              kinematics.link_frames(Q, check_limits=False)),
        "joint_positions": digest(*[kinematics.joint_positions(q) for q in Q[:50]], kinematics.joint_positions(Q)),
        "gravity": digest(*[gravity_deflection(q, ArmRealism(), 0.03) for q in Q[:50]],
                          gravity_deflection(Q, ArmRealism(), 0.0)),
        "jacobian": digest(kinematics.jacobian(Q[:20])), "fk_dh": digest(kinematics.fk_dh(Q[:20], check_limits=False)),
        "wall_s": round(time.perf_counter() - t, 1)}
    for event, level, seed in [("sort_stack", 1, 0), ("sort_stack", 3, 1), ("line_up", 2, 0), ("sky", 1, 0)]:
        t = time.perf_counter()
        st = event_station(event, level, seed=seed)
        steps = StepHash(st)
        r = run_event(tasks.start_session(st), event, level, seed=seed, record=True)
        rp = r.replay
        out[f"{event} {level} seed {seed}"] = {
            "steps": str(steps), "objects": _objects(st.world), "points": float(r.score.points), "time": r.time_s.hex(),
            "moves": len(r.moves), "placement": digest(r.placement_errors),
            "replay": digest(rp.times, rp.q, rp.gripper, rp.object_poses), "frame": _frame(st),
            "q_true": digest(st.arm.q_true), "encoders": digest(st.arm.joint_positions()),
            "wall_s": round(time.perf_counter() - t, 1)}

    t = time.perf_counter()
    scene = {"objects": [{"color": "red", "size": "large", "position_mm": [-150.0, 200.0], "yaw_rad": 0.4},
                         {"color": "green", "size": "small", "position_mm": [150.0, 250.0], "yaw_rad": 0.0}]}
    st = make_station("sim", seed=7, scene=scene)
    steps = StepHash(st)
    session = tasks.start_session(st)
    tasks.look(session)
    pixel = lambda p: session.calibration.camera.project(np.asarray(p, float)[None])[0]   # noqa: E731
    red = next(o for o in st.world.blocks if o.color == "red")
    done = [tasks.click_grab(session, pixel(red.position + [0, 0, red.edge / 2])),
            tasks.click_drop(session, pixel([0.0, 300.0, 0.0]))]
    out["click"] = {"steps": str(steps), "objects": _objects(st.world), "done": done, "frame": _frame(st),
                    "q_true": digest(st.arm.q_true), "wall_s": round(time.perf_counter() - t, 1)}

    t = time.perf_counter()
    st = make_station("sim", seed=0, scene="swap")
    machine = tasks.TaskMachine(tasks.Session(st, tasks.GuardedArm(st.arm)))
    poses, grip = teach.swap_waypoints()
    machine.teach_start("swap")
    for pose, state in zip(poses, grip, strict=True):
        st.arm.move_by_hand(pose)
        machine.teach_record(state)
    program = machine.teach_finish()
    st2 = make_station("sim", seed=11, scene="swap")
    steps = StepHash(st2)
    result = tasks.TaskMachine(tasks.start_session(st2)).repeat(program)
    out["teach"] = {"program": digest(program.q), "steps": str(steps), "objects": _objects(st2.world),
                    "grasps": list(result.grasps), "frame": _frame(st2), "q_true": digest(st2.arm.q_true),
                    "wall_s": round(time.perf_counter() - t, 1)}
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--save", metavar="FILE", help="write the fingerprint as JSON")
    parser.add_argument("--compare", metavar="FILE", help="compare with a saved fingerprint")
    args = parser.parse_args(argv)
    got = fingerprint()
    if args.save:
        with open(args.save, "w") as f:
            json.dump(got, f, indent=1)
    if not args.compare:
        for name, fields in got.items():
            print(f"{name:<22} " + "  ".join(f"{k} {v}" for k, v in fields.items()))
        return 0
    with open(args.compare) as f:
        saved = json.load(f)
    differ = 0
    for name in sorted(set(saved) | set(got)):
        a, b = ({k: v for k, v in d.get(name, {}).items() if k != "wall_s"} for d in (saved, got))
        diff = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
        differ += bool(diff)
        print(f"{name:<22} " + ("SAME" if not diff else "DIFFERS in " + ", ".join(diff)))
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
