"""Hidden checks of exercise grab.move_path: blocks grabbed at hidden clicks and
dropped at hidden spots on the simulator with the student's plans (an open task: outcome only)
(armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _grab_scenes(rng):
    # three blocks of random sizes and yaws at random spots the arm reaches top-down or nearly (150-340 mm from the
    # waist axis, in front of the base, 90 mm apart), and a free drop spot for each nearer the robot
    checks = []
    for _ in range(3):
        blocks, spots = [], []
        while len(blocks) < 3:
            r, h = rng.uniform(170, 340), rng.uniform(np.radians(25), np.radians(155))
            xy = [float(r * np.cos(h)), float(r * np.sin(h))]
            if all(np.hypot(xy[0] - b[2][0], xy[1] - b[2][1]) > 90 for b in blocks):
                blocks.append([["red", "green", "blue", "yellow"][len(blocks)], str(rng.choice(["large", "small"])),
                               xy, float(rng.uniform(-np.pi / 4, np.pi / 4))])
        for x in rng.permutation([-240.0, 0.0, 240.0]):
            spots.append([float(x + rng.uniform(-20, 20)), float(rng.uniform(-60, 40) if x else rng.uniform(190, 230)),
                          0.0])
        checks.append([[int(rng.integers(0, 1000)), blocks, spots]])
    return checks


def _judge_move_path(call, seed, blocks, spots):
    """Per block of a fresh sim scene of the judge's, clicked at its detected top: [came straight down and grasped
    square (its faces flat on the pads, sim.gripper.off_square_rad within SQUARE_TOLERANCE_RAD: a roll that misses the
    yaw pinches it on two edges), came straight down and landed within 3 mm of its spot] (1.0 / 0.0). Each grasp and
    release asks the child for the student's plan (its arm commands), which the judge checks whole and runs on its own
    station with the kit's runners (grab_with, drop_with) and scores from its simulator's truth; a plan whose final
    approach is not a straight vertical descent (planning.approach_deviation over STRAIGHT_TOLERANCE_MM), or a refused,
    failed or unusable one, scores 0 for its block and the blocks after it."""
    from armlab import planning, tasks
    from armlab.sim.gripper import SQUARE_TOLERANCE_RAD, off_square_rad
    from armlab.station import make_station
    from armlab.tasks.move_path import drop_with, grab_with

    from ..judge import ChildGone
    from ._replay import plan_from_plain

    def path(q_start, target, yaw, edge, action):
        plan = plan_from_plain(call(np.asarray(q_start, float), np.asarray(target, float), float(yaw), float(edge),
                                    str(action)))
        # the method the exercise asks for: a straight descent (the kit's planners in the release come down on a
        # joint chord, which bows 1.2-3.5 mm off the vertical), so a plan that is not one is not run
        bow = planning.approach_deviation(plan, "close" if action == "grasp" else "open")
        if bow > planning.STRAIGHT_TOLERANCE_MM:
            raise ValueError(f"the {action} plan strays {bow:.1f} mm from a straight vertical descent")
        return plan

    station = make_station("sim", seed=int(seed), scene={"objects": [
        {"color": c, "size": s, "position_mm": xy, "yaw_rad": yaw} for c, s, xy, yaw in blocks]})
    session = tasks.start_session(station)
    seen = {b.color: b for b in tasks.look(session).blocks}
    out = []
    for (color, *_), spot in zip(blocks, spots, strict=True):
        truth = next(o for o in station.world.blocks if o.color == color)
        try:
            held = (grab_with(session, seen[color], path=path) and truth.id in station.world.held
                    and off_square_rad(station.arm.tool_pose_true(), truth) <= SQUARE_TOLERANCE_RAD)
            drop_with(session, np.asarray(spot, float), 0.0, path=path)
            bottom = truth.position - [0.0, 0.0, truth.edge / 2]
            landed = not station.world.held and float(np.abs(bottom - spot).max()) < 3.0
        except ChildGone:
            raise
        except Exception:           # refused, unreachable, broken or raised in the child: this block and the rest
            break
        out += [float(held), float(landed)]
    return out + [0.0] * (2 * len(blocks) - len(out))


SPECS = (HiddenSpec("armlab.tasks.move_path.move_path", _grab_scenes, atol=0, adapter="_call_move_path", outcome=True,
                    judge=_judge_move_path,
                    criteria=("came straight down (within 0.8 mm of the vertical) and grasped square (within 5 deg)",
                              "came straight down and landed within 3 mm of its spot"), per="block"),)
FORBIDDEN = ("planning.plan_pick", "planning.plan_place", "planning.plan_pick_place", "choose_grasp", "kit_move_path",
             "grasp_height", "place_tool_height", "default_grasp_depth", "tasks.pick", "tasks.place", "handling",
             "report_move_path", "default_path")
