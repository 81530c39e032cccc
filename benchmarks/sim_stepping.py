"""The simulator's stepping: CPU time of the simulated arm's clock steps, of a taught program's replay and of a
competition event run, and whether another version of the kit computes the very same numbers.

    .venv/bin/python benchmarks/sim_stepping.py                    # this checkout's figures
    .venv/bin/python benchmarks/sim_stepping.py --against main     # and the ratio to another commit's, bit for bit

Workloads (each on a fresh station, seed fixed):
- steps: the stored swap program (data/teach/swap.json) moved joint move by joint move on a bare SimArm of the "swap"
  scene (grasps, carrying, the pads' pushes): nearly all of it is the clock's 20 ms steps (World.advance -> the arm's
  listener -> physical pose, tool pose, held objects, pads). Reported per step.
- repeat: the same program through tasks.repeat (the executor: whole-plan checks, guarded arm, then the steps).
- event: a Sort 'n stack level-3 run (start_session: camera calibration and sag fit, then run_event, record=False).

Each workload also yields a digest: sha256 over the exact bytes of the arm's physical joints at every clock step, the
objects' poses, the final score and time. With --against REF, the kit at REF (`git archive`, into a temporary
folder first on the path) runs the same workloads in a subprocess, alternating with this checkout's, `--rounds`
times each; the table gives the least CPU time of each side (process time: less sensitive than wall time to the
other jobs of a shared machine), their ratio, the least wall times, and whether the digests are equal (they must
be: a speed-up may not change a single bit of what the simulator computes).

Measured 2026-12-07 on the shared 2-core machine (simspeed branch against main 612fe96): see docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WORKLOADS = ("steps", "repeat", "event")


class _Trace:
    """A world listener hashing the arm's physical joints (exact bytes) at every clock step, and counting them."""

    def __init__(self, station):
        self.station, self.steps, self.hash = station, 0, hashlib.sha256()
        station.world.add_listener(self)

    def __call__(self, t: float) -> None:
        self.steps += 1
        self.hash.update(self.station.arm._q_true.tobytes())

    def digest(self, *extra) -> str:
        import numpy as np

        for o in self.station.world.objects:
            self.hash.update(np.concatenate([o.position, [o.yaw], o.tilt]).tobytes())
        for value in extra:
            self.hash.update(repr(value).encode())
        return self.hash.hexdigest()[:16]


def _swap_program():
    from armlab._paths import data_path
    from armlab.tasks import teach

    return teach.load_teach(data_path("teach/swap.json"))


def _steps() -> tuple[str, int]:
    from armlab import make_station

    program = _swap_program()
    st = make_station("sim", seed=11, scene="swap")
    trace = _Trace(st)
    for q, grip in zip(program.q, program.gripper, strict=True):
        st.arm.move_to(q)
        st.arm.close_gripper() if grip == "closed" else st.arm.open_gripper()
    return trace.digest(st.world.time_s), trace.steps


def _repeat() -> tuple[str, int]:
    from armlab import make_station, tasks

    st = make_station("sim", seed=11, scene="swap")
    trace = _Trace(st)
    result = tasks.repeat(st.arm, _swap_program())
    return trace.digest(result.grasps, st.world.time_s), trace.steps


def _event() -> tuple[str, int]:
    from armlab import tasks
    from armlab.tasks.events import event_station, run_event

    st = event_station("sort_stack", 3, seed=0)
    trace = _Trace(st)
    r = run_event(tasks.start_session(st), "sort_stack", 3, seed=0, record=False)
    return trace.digest(r.score.points, r.time_s, len(r.moves)), trace.steps


def measure(names=WORKLOADS) -> dict:
    """{workload: {"cpu_s", "wall_s", "steps", "digest"}} for this process's armlab (imports and a first station
    built before the clocks start)."""
    from armlab import make_station

    make_station("sim", seed=11, scene="swap")
    out = {}
    for name in names:
        wall, cpu = time.perf_counter(), time.process_time()
        digest, steps = {"steps": _steps, "repeat": _repeat, "event": _event}[name]()
        out[name] = {"cpu_s": time.process_time() - cpu, "wall_s": time.perf_counter() - wall, "steps": steps,
                     "digest": digest}
    return out


def _worker(source: Path | None, names) -> dict:
    """measure() in a fresh interpreter, with the kit at `source` first on the path (None: this checkout's)."""
    env = dict(os.environ)
    if source is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(source), *filter(None, [env.get("PYTHONPATH")])])
    run = subprocess.run([sys.executable, __file__, "--worker", *names], capture_output=True, text=True, env=env,
                         cwd=tempfile.gettempdir(), check=True)
    return json.loads(run.stdout.splitlines()[-1])


def _export(ref: str, folder: Path) -> str:
    """The kit (armlab/) at git ref `ref` unpacked into `folder`; returns the commit's short hash."""
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", ref], capture_output=True, text=True,
                            check=True).stdout.strip()
    archive = folder / "kit.tar"
    with archive.open("wb") as f:
        subprocess.run(["git", "-C", str(ROOT), "archive", commit, "armlab"], stdout=f, check=True)
    with tarfile.open(archive) as tar:
        tar.extractall(folder, filter="data")
    return commit


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--against", metavar="REF", help="also run the kit at this git ref and compare")
    parser.add_argument("--rounds", type=int, default=3, help="alternating runs per side with --against")
    parser.add_argument("--worker", nargs="*", help=argparse.SUPPRESS)
    parser.add_argument("workloads", nargs="*", help=f"some of {', '.join(WORKLOADS)} (default: all)")
    args = parser.parse_args(argv)
    unknown = set(args.workloads) - set(WORKLOADS)
    if unknown:
        parser.error(f"unknown workload(s) {sorted(unknown)}: choose from {', '.join(WORKLOADS)}")
    if args.worker is not None:
        print(json.dumps(measure(args.worker or WORKLOADS)))
        return
    names = args.workloads or list(WORKLOADS)
    here = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    if not args.against:
        for name, r in measure(names).items():
            print(f"{name:<7} {r['steps']:>6} steps  CPU {r['cpu_s']:6.2f} s  ({1e6 * r['cpu_s'] / r['steps']:5.0f} us "
                  f"a step, all included)  wall {r['wall_s']:6.2f} s  digest {r['digest']}")
        return
    with tempfile.TemporaryDirectory() as tmp:
        other = _export(args.against, Path(tmp))
        runs = {"new": [], "old": []}
        for _ in range(args.rounds):
            runs["old"].append(_worker(Path(tmp), names))
            runs["new"].append(_worker(None, names))
    print(f"this checkout ({here}, with its uncommitted changes) against {args.against} ({other}); least CPU s of "
          f"{args.rounds} alternating runs each")
    print(f"{'workload':<9} {'steps':>6} {'old CPU s':>10} {'new CPU s':>10} {'old/new':>8} {'old wall s':>11} "
          f"{'new wall s':>11}  same bits")
    for name in names:
        old, new = (min(r[name]["cpu_s"] for r in runs[side]) for side in ("old", "new"))
        old_wall, new_wall = (min(r[name]["wall_s"] for r in runs[side]) for side in ("old", "new"))
        digests = {r[name]["digest"] for side in runs.values() for r in side}
        steps = runs["new"][0][name]["steps"]
        print(f"{name:<9} {steps:>6} {old:10.2f} {new:10.2f} {old / new:8.2f} {old_wall:11.2f} {new_wall:11.2f}  "
              f"{'yes' if len(digests) == 1 else 'NO: ' + ', '.join(sorted(digests))}")


if __name__ == "__main__":
    main()
