"""Speed of the world's contact physics (armlab.sim.physics): the time of one MuJoCo step with 30 blocks on one
core, and its ratio to real time (issue 36 asks for at least 5x faster than real time).

    .venv/bin/python benchmarks/physics.py [--repeats N] [--seconds S]

Time is the process's CPU time (time.process_time: one core's work, which other processes on a shared machine do
not inflate) and, beside it, the wall time. Scenes of 30 large and small blocks on the board: "resting" (a grid of
30 single blocks, every one in contact with the board), "stacked" (ten stacks of three) and "falling" (20 single
blocks and a tower of ten, each level 10 mm further out, toppling: the busiest contact pattern the world meets).
Each runs S seconds of physics; the figure is the minimum over the repeats of the time per step (the machines are
shared: the minimum is the least disturbed run), and "x real time" is the physics time step over the CPU time per
step. MuJoCo steps on one thread; OpenMP is held to one too. The last rows: one World.settle (a block released onto
a block, run to rest) and one World.grip (the pads closing on a block and the test lift) in the 30-block world, in ms.

Measured 2026-12-06 (MuJoCo 3.17.0, 2 ms steps; two cores at a load average of 19): CPU per step resting 126 us
(15.9x real time), stacked 169 us (11.9x), falling 148 us (13.5x); wall 846, 1040, 946 us under that load; one
settle 15.8 ms CPU. Again 2026-12-07 with condim 3 (materials.py; load average 2.9): resting 97 us (20.6x real
time), stacked 131 us (15.3x), falling 113 us (17.8x), wall the same; one settle 12.6 ms CPU. With grasps by contact
(load average 3.5): resting 97 us (20.6x), stacked 126 us (15.9x), falling 110 us (18.1x); one settle 13.3 ms, one
grasp 45.2 ms CPU.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from armlab.blocks import COLORS, ObjectState, block_edge  # noqa: E402
from armlab.sim import World  # noqa: E402
from armlab.sim.physics import CONTACT, Physics  # noqa: E402


def _block(k: int, x: float, y: float, z_level: int = 0, size: str = "large") -> ObjectState:
    e = block_edge(size)
    z = z_level * block_edge("large") + e / 2
    return ObjectState(COLORS[k % 6], size, e, np.array([x, y, z]), 0.0, "cube", k)


def resting() -> list[ObjectState]:
    """30 single blocks on a 6 x 5 grid, every other one small."""
    return [_block(k, -250.0 + 100.0 * (k % 6), 50.0 + 90.0 * (k // 6), 0, ("large", "small")[k % 2])
            for k in range(30)]


def stacked() -> list[ObjectState]:
    """Ten stacks of three large blocks."""
    return [_block(3 * j + i, -250.0 + 110.0 * (j % 5), 100.0 + 200.0 * (j // 5), i) for j in range(10)
            for i in range(3)]


def falling() -> list[ObjectState]:
    """20 single blocks and a tower of ten, each level 10 mm further out than the one below (it topples)."""
    singles = [_block(k, -250.0 + 100.0 * (k % 5), 300.0 + 90.0 * (k // 5) - 200.0, 0) for k in range(20)]
    return singles + [_block(20 + i, 250.0 + 10.0 * i, 250.0, i) for i in range(10)]


def step_seconds(objects: list[ObjectState], seconds: float) -> tuple[float, float]:
    """(CPU, wall) seconds per physics step over `seconds` of physics from the scene's poses."""
    physics = Physics(objects)
    n = int(round(seconds / CONTACT.timestep_s))
    cpu, wall = time.process_time(), time.perf_counter()
    physics.step(n)
    return (time.process_time() - cpu) / n, (time.perf_counter() - wall) / n


def settle_seconds() -> float:
    """CPU seconds of one World.settle: a large block released 2 mm over a stack in the 30-block resting scene."""
    objects = resting()
    world = World(objects)
    top = ObjectState("red", "large", 38.0, objects[0].position + [0.0, 0.0, 0.5 * 38.0 + 0.5 * objects[0].edge + 2],
                      0.0, "cube", 99)
    world._objects.append(top)                            # the released block, as the arm's open_gripper leaves it
    start = time.process_time()
    world.settle(top)
    return time.process_time() - start


def grasp_seconds() -> float:
    """CPU seconds of one World.grip: the pads closing from wide open on a large block of the 30-block resting scene,
    top-down, and the test lift (what SimArm.close_gripper runs)."""
    from armlab.gripper_geometry import GRIPPER

    objects = resting()
    world = World(objects)
    block = next(o for o in objects if o.size == "large")
    T = np.eye(4)
    T[:3, :3] = np.column_stack([[0, 0, -1], [1, 0, 0], [0, -1, 0]])      # top-down, closing along +x
    T[:3, 3] = block.position
    start = time.process_time()
    world.grip(block, T, GRIPPER, GRIPPER.max_opening_mm, block.edge, 0.5)
    return time.process_time() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=2.0, help="physics seconds per run")
    args = parser.parse_args()
    dt = CONTACT.timestep_s
    print(f"{'scene (30 blocks)':20} {'CPU us/step':>12} {'x real time':>12} {'wall us/step':>13}")
    for name, build in (("resting", resting), ("stacked", stacked), ("falling", falling)):
        runs = [step_seconds(build(), args.seconds) for _ in range(args.repeats)]
        cpu, wall = min(r[0] for r in runs), min(r[1] for r in runs)
        print(f"{name:20} {cpu * 1e6:12.0f} {dt / cpu:12.1f} {wall * 1e6:13.0f}", flush=True)
    best = min(settle_seconds() for _ in range(args.repeats))
    print(f"{'one settle':20} {best * 1e3:9.1f} ms CPU")
    best = min(grasp_seconds() for _ in range(args.repeats))
    print(f"{'one grasp':20} {best * 1e3:9.1f} ms CPU")


if __name__ == "__main__":
    main()
