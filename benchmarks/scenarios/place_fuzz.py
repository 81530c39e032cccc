"""Pick and place as a student does it, for the pre-check's fuzz test (tests/test_place_fuzz.py) and its benchmark
(benchmarks/manipulation.py fuzz): a seeded "random" scene on the simulated station, calibrated through the task
layer; look, pick a detected block 150 mm or more from the waist axis (tasks.pick), and place it (tasks.place) at a
random free spot anywhere around the arm (in front, beside, behind the waist axis; 100-420 mm out) with a random
yaw; again with another block, a few times a station. Each place is one of board_grid.OUTCOMES: "done" (its error:
the block's true bottom-face centre minus the target, world mm; its message notes a pick from a detection more than
DETECTION_OFF_MM from the true block: the pads centre a block across the fingers, not along them, so such a block
is carried off-centre and lands off by part of the detection's error), "refused before" (nothing sent: the block is put
back where it was picked) or "refused mid-plan" (the guarded arm had sent commands: a pre-check bug). Spots the
placement rule refuses (motion_safety.placement_problem) are not drawn: a student is told at once. Units: mm, rad.
"""

from __future__ import annotations

import numpy as np

from armlab import motion_safety, tasks
from armlab.blocks import block_edge
from armlab.kinematics import Unreachable
from armlab.station.contract import MotionRefused

from .board_grid import GridSpot, Outcome

__all__ = ["REGION", "PLACE_REACH_MM", "PICK_MIN_REACH_MM", "DETECTION_OFF_MM", "random_place_spot", "run_station"]

REGION = "student fuzz"
PLACE_REACH_MM = (100.0, 420.0)     # place spots: this far from the waist axis, any heading
PICK_MIN_REACH_MM = 150.0           # picked blocks: at least this far from the waist axis
_KEEP_OUT_MM = 60.0                 # a place spot's centre at least this far from every object's centre
DETECTION_OFF_MM = 5.0              # a done place's message notes a pick from a detection this far off its block
_IDLE_ROUNDS = 4                    # a station's trials end after this many looks in a row without a place tried


def random_place_spot(rng: np.random.Generator, objects, edge: float, yaw: float) -> np.ndarray:
    """A random spot (x, y, 0) world mm PLACE_REACH_MM from the waist axis at any heading, that the placement rule
    allows for a block of `edge` mm at `yaw` and at least _KEEP_OUT_MM from the centre of every object in `objects`
    (ground truth: what a student sees on the board)."""
    centres = np.array([o.position[:2] for o in objects]).reshape(-1, 2)
    for _ in range(10_000):
        r, heading = rng.uniform(*PLACE_REACH_MM), rng.uniform(-np.pi, np.pi)
        p = np.array([-r * np.sin(heading), r * np.cos(heading), 0.0])
        if motion_safety.placement_problem(p, edge, yaw) is None and \
                (not len(centres) or np.hypot(*(centres - p[:2]).T).min() >= _KEEP_OUT_MM):
            return p
    raise RuntimeError("no free spot to place at on this board")


def _outcome(spot: np.ndarray, action: str, sent_before: int, arm, error: Exception) -> Outcome:
    kind = "refused mid-plan" if len(arm.sent) != sent_before else "refused before"
    return Outcome(GridSpot(REGION, float(spot[0]), float(spot[1])), action, kind, message=str(error))


def _recover(session: tasks.Session) -> None:
    """After a refusal mid-plan or a failed pick: open, forget the held block, look again (arm out of view)."""
    station = session.station
    if station.arm.emergency_stopped:
        station.arm.reset()
    station.arm.open_gripper()
    session.held = session.held_in_tool = session.picked_down = None
    tasks.look(session)


def run_station(seed: int, places: int, detect_with: str | None = None) -> list[Outcome]:
    """`places` pick-then-place trials on the seeded station (module notes), in rounds: look once, then pick and
    place each detected block far enough out in turn (a student's loop over one detection), and look again after a
    failed pick or a refusal; fewer when _IDLE_ROUNDS looks in a row try no place (no block left far enough out, or
    none that can be picked). Returns the place Outcomes in order (picks that do not end with the block held are
    skipped).

    detect_with: None, the blocks the session's look detects; or the intrinsics of another calibration of the same
    station ("factory", "checkerboard": tasks.perception.calibrate_camera, its own tags and depth plane), with which
    the blocks picked are detected in a frame of their own after each look, as a student does who detects with the
    calibration notebook 04 uses and picks through a task session calibrated on its own."""
    # the simulator: imported when the trials run
    from armlab import make_station
    from armlab.tasks import perception

    session = tasks.start_session(make_station("sim", seed=seed))
    other = None if detect_with is None else perception.calibrate_camera(session.station, detect_with, arm=session)
    rng = np.random.default_rng([seed, 24])
    out: list[Outcome] = []
    idle = 0                                      # rounds in a row that tried no place
    while len(out) < places and idle < _IDLE_ROUNDS:
        seen = tasks.look(session)
        if other is not None:                     # the arm is out of view: detect again with the other calibration
            seen = perception.observe(session.station, other, session, clear=False)
        blocks = [b for b in seen.blocks if b.is_block and np.hypot(*b.position[:2]) >= PICK_MIN_REACH_MM]
        before = len(out)
        for k in rng.permutation(len(blocks)):
            if len(out) >= places or not _trial(session, blocks[k], rng, out):
                break
        idle = 0 if len(out) > before else idle + 1
    return out


def _trial(session: tasks.Session, block, rng: np.random.Generator, out: list[Outcome]) -> bool:
    """Pick `block` and place it at a random free spot, appending the place's Outcome to `out`; False when the round
    must look again (a pick that failed, a refusal)."""
    station = session.station
    seen_off = min(float(np.hypot(*(o.position[:2] - block.position[:2]))) for o in station.world.blocks)
    try:
        held = tasks.pick(session, block)
    except (MotionRefused, Unreachable):
        held = False
    if not held:
        _recover(session)
        return False
    truth = station.arm.holding[0]
    edge, yaw = block_edge(block.size), float(rng.uniform(-np.pi / 4, np.pi / 4))
    spot = random_place_spot(rng, [o for o in station.world.objects if o is not truth], edge, yaw)
    sent = len(session.arm.sent)
    try:
        tasks.place(session, spot, yaw)
    except (MotionRefused, Unreachable) as e:
        out.append(_outcome(spot, "place", sent, session.arm, e))
        if out[-1].outcome == "refused before":
            try:
                tasks.put_back(session)
                return False
            except (MotionRefused, Unreachable):
                pass
        _recover(session)
        return False
    bottom = truth.position - [0.0, 0.0, truth.edge / 2]
    note = f"picked from a detection {seen_off:.1f} mm off its block" if seen_off > DETECTION_OFF_MM else ""
    tilt = float(getattr(station.arm, "last_release", {}).get(truth.id, 0.0))
    out.append(Outcome(GridSpot(REGION, float(spot[0]), float(spot[1])), "place", "done", bottom - spot, note, tilt))
    return True
