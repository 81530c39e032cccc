"""Pick-and-place accuracy on the realistic simulated station, and the lab report's six-location table.

Pick and place: random scenes ("random" preset: blocks of both sizes at random positions and yaws within reach)
seen through the calibrated camera (checkerboard intrinsics, tag extrinsics, depth correction); every detected block
is seen again just before its pick (a new look, as the tasks do: an earlier pick may have nudged it) and picked
(tasks.pick) and placed (tasks.place) at a random free spot with a random yaw; the placement error is the
placed block's true bottom-face centre minus the target. Three ways to handle the sag, on the same scenes:
  none        - plans executed as they are;
  lab rule    - every pick and place target raised by z += 0.068 r + 3 mm (r: reach, mm), the lab's correction;
  tasks.sag   - the joint-compliance model fitted from 30 measured tool points (the default in armlab.tasks).
Long reach: the same with tasks.sag, targets 340-420 mm from the waist axis, where the tool cannot always come
straight down (planning.plan_place then prefers a shorter top-down descent; else it tilts and the block lands square
to the fingers, i.e. at the arm's heading mod 90 deg, not the requested yaw). The yaw error is the placed block's true
yaw minus the requested one (mod 90 deg).
Six locations: the lab report's Table II/III experiment (click the point, reach 37 mm above it) without and with the
sag model, next to the lab report's errors.
Regions (issue 14): in front close in and at full reach, beside the base, behind the waist axis, on a stack, and
random spots over the whole board; per region: placed, refused before moving, refused mid-plan, errors.
    .venv/bin/python benchmarks/manipulation.py [stations]       # default 13 stations x 8 blocks
    .venv/bin/python benchmarks/manipulation.py regions [n]      # n spots per region (default 6)
Grid (issue 14): scenarios/board_grid.py's spots over the whole reachable board (in front close in and at full
reach, beside and behind the base, on stacks) plus seeded random spots; each spot is picked from once (a block put
there in a seeded scene) and placed at once; per region and action: done, refused before moving, refused mid-plan,
not grasped, and the errors (places: the block's true bottom-face centre minus the target, world mm; picks: the
grasped block's true centre in the tool frame minus the planned one, tool-frame mm).
    .venv/bin/python benchmarks/manipulation.py grid [n_random]  # default 8 random spots (about 3-6 minutes)
Student fuzz (issue 24, armlab.tasks.place_fuzz): seeded random scenes; look, pick a detected block 150 mm or more
out, place it at a random free spot anywhere around the arm (100-420 mm out) with a random yaw, block after block;
per sector (in front: heading within 60 deg of +y; beside; behind the waist axis: y < 0) and reach (near: under
250 mm; far): done within 3 mm, done 3 mm or more off, refused before moving, refused mid-plan (a pre-check bug).
tests/test_place_fuzz.py runs 200 of them.
    .venv/bin/python benchmarks/manipulation.py fuzz [stations] [places]   # default 10 stations x 50 places
"""

from __future__ import annotations

import dataclasses
import sys

import numpy as np

from armlab import make_station, tasks
from armlab.tasks.experiments import LAB_TABLE_III_ERROR_MM, format_table, reach_experiment
from armlab.tasks.sag import LAB_BASELINE, SagModel

from scenarios import board_grid

METHODS = ("none", "lab rule", "tasks.sag")


def lab_rule_dz(xy) -> float:
    """The lab's z correction (mm) at a horizontal position xy (mm): 0.068 r + 3."""
    a, b = LAB_BASELINE
    return float(a * np.hypot(xy[0], xy[1]) + b)


def free_spot(rng, world, keep_out_mm: float = 75.0, reach=(160.0, 330.0)):
    """A random board spot (x, y, 0) mm within `reach` (mm from the waist axis), away from every object (truth)."""
    while True:
        r, th = rng.uniform(*reach), rng.uniform(-1.2, 1.2)
        p = np.array([r * np.sin(th), r * np.cos(th), 0.0])
        if all(np.hypot(*(o.position[:2] - p[:2])) > keep_out_mm for o in world.objects):
            return p


def _recover(session: tasks.Session) -> bool:
    """After a failed pick or place: open, forget the held block, go to the camera-clear pose. False if stuck."""
    try:
        session.station.arm.open_gripper()
        session.held = None
        tasks.clear_view(session.arm)
        return True
    except Exception:
        return False


def _seen_again(session: tasks.Session, block, within_mm: float = 40.0):
    """The block of the same colour and size nearest to where `block` was seen, in a new look (None if none within
    within_mm)."""
    same = [b for b in tasks.look(session).blocks if (b.color, b.size) == (block.color, block.size)]
    if not same:
        return None
    near = min(same, key=lambda b: np.hypot(*(b.position[:2] - block.position[:2])))
    return near if np.hypot(*(near.position[:2] - block.position[:2])) <= within_mm else None


def pick_place_trials(method: str, seeds, blocks_per_scene: int = 8, reach=(160.0, 330.0)) -> list[dict]:
    """Run the pick-and-place trials for one sag method, targets within `reach` (mm); one dict per block: grasped,
    error (3,) mm or None, yaw_error rad or None, failure text."""
    trials = []
    for seed in seeds:
        st = make_station("sim", seed=int(seed), scene="random", n=blocks_per_scene)
        rng = np.random.default_rng(1000 + int(seed))
        session = tasks.start_session(st)
        if method != "tasks.sag":
            session.arm.sag = SagModel()
        seen = tasks.look(session).blocks
        for listed in seen:
            # look again before each pick, as the tasks do: an earlier pick's pads may have nudged this block
            block = _seen_again(session, listed)
            if block is None:
                trials.append({"grasped": False, "error": None, "yaw_error": None,
                               "failure": f"the {listed.size} {listed.color} block is not seen again"})
                continue
            truth = min(st.world.blocks, key=lambda o: np.hypot(*(o.position[:2] - block.position[:2])))
            target, yaw = free_spot(rng, st.world, reach=reach), float(rng.uniform(-np.pi / 4, np.pi / 4))
            dz = lab_rule_dz if method == "lab rule" else (lambda xy: 0.0)
            trial = {"grasped": False, "error": None, "yaw_error": None, "failure": ""}
            try:
                shifted = dataclasses.replace(block, position=block.position + [0, 0, dz(block.position)])
                trial["grasped"] = tasks.pick(session, shifted)
                if trial["grasped"]:
                    tasks.place(session, target + [0, 0, dz(target)], yaw)
                    trial["error"] = truth.position - [0, 0, truth.edge / 2] - target
                    trial["yaw_error"] = abs((truth.yaw - yaw + np.pi / 4) % (np.pi / 2) - np.pi / 4)
                else:
                    trial["failure"] = st.arm.last_grasp
            except Exception as e:      # refused motions (the board in the way) count as failures
                trial["failure"] = f"{type(e).__name__}: {str(e).splitlines()[0][:70]}"
                trials.append(trial)
                if not _recover(session):
                    break
                continue
            trials.append(trial)
    return trials


def summary_row(method: str, trials: list[dict]) -> list:
    """Table row: method, blocks, grasp rate %, placed %, placement |error| mean x/y/z and max x/y/z (mm), |yaw
    error| mean and max (deg)."""
    n = len(trials)
    grasped = sum(t["grasped"] for t in trials)
    placed = sum(t["error"] is not None for t in trials)
    errs = np.abs(np.array([t["error"] for t in trials if t["error"] is not None]).reshape(-1, 3))
    mean = errs.mean(axis=0) if len(errs) else np.full(3, np.nan)
    mx = errs.max(axis=0) if len(errs) else np.full(3, np.nan)
    yaw = np.degrees([t["yaw_error"] for t in trials if t["yaw_error"] is not None])
    yaw_stats = [yaw.mean(), yaw.max()] if len(yaw) else [np.nan, np.nan]
    return [method, str(n), f"{100 * grasped / max(n, 1):.1f}", f"{100 * placed / max(n, 1):.1f}", *mean, *mx,
            *yaw_stats]


# Regions of the board (issue 14): (name, reach range mm from the waist axis, heading range deg from +y, onto a block)
REGIONS = [
    ("in front, close in", (150.0, 200.0), (-45.0, 45.0), False),
    ("in front, full reach", (370.0, 420.0), (-30.0, 30.0), False),
    ("beside the base", (200.0, 330.0), (70.0, 110.0), False),
    ("behind the waist axis", (180.0, 330.0), (100.0, 160.0), False),
    ("on a stack", (200.0, 330.0), (-60.0, 60.0), True),
    ("random, whole board", (150.0, 420.0), (-160.0, 160.0), False),
]


def _spot(rng, reach, heading_deg, world, keep_out_mm: float = 60.0):
    """A board spot (x, y, 0) mm in the region, away from every object (truth); None after 200 tries."""
    for _ in range(200):
        r, th = rng.uniform(*reach), np.radians(rng.uniform(*heading_deg)) * rng.choice([-1.0, 1.0])
        p = np.array([-r * np.sin(th), r * np.cos(th), 0.0])
        if all(np.hypot(*(o.position[:2] - p[:2])) > keep_out_mm for o in world.objects):
            return p
    return None


def region_trials(n_per_region: int = 6, first_seed: int = 500) -> list[list]:
    """Per region: pick the first large block seen (tasks.pick) on a fresh seeded station and place it (tasks.place,
    yaw 0) at a random free spot of the region, or on top of another seen block; count placed, refused before
    moving (nothing sent), refused mid-plan (the arm had moved) and failed grasps; placement error = the block's true
    bottom-face centre minus the target (mm)."""
    rows = []
    for k, (name, reach, heading, stack) in enumerate(REGIONS):
        counts = {"placed": 0, "refused before": 0, "refused mid-plan": 0, "not grasped": 0}
        errors, examples = [], []
        for i in range(n_per_region):
            seed = first_seed + 100 * k + i
            st = make_station("sim", seed=seed, scene="random", n=4)
            rng = np.random.default_rng(seed)
            session = tasks.start_session(st)
            seen = tasks.look(session).blocks
            block = next((b for b in seen if b.size == "large"), seen[0])
            truth = min(st.world.blocks, key=lambda o: np.hypot(*(o.position[:2] - block.position[:2])))
            if stack:
                others = [b for b in seen if b is not block and reach[0] <= np.hypot(*b.position[:2]) <= reach[1]]
                if not others:
                    continue
                base = others[0]
                target = np.array([base.position[0], base.position[1], base.position[2]])
            else:
                target = _spot(rng, reach, heading, st.world)
                if target is None:
                    continue
            if not tasks.pick(session, block):
                counts["not grasped"] += 1
                continue
            sent = len(session.arm.sent)
            try:
                tasks.place(session, target, 0.0)
            except Exception as e:
                moved = len(session.arm.sent) != sent
                counts["refused mid-plan" if moved else "refused before"] += 1
                examples.append(f"({target[0]:.0f}, {target[1]:.0f}, {target[2]:.0f}): {str(e)[:110]}")
                continue
            counts["placed"] += 1
            errors.append(truth.position - [0, 0, truth.edge / 2] - target)
        e = np.abs(np.array(errors).reshape(-1, 3))
        mean = e.mean(axis=0) if len(e) else np.full(3, np.nan)
        mx = e.max(axis=0) if len(e) else np.full(3, np.nan)
        tried = sum(counts.values())
        rows.append([name, str(tried), *(str(counts[c]) for c in counts), *mean, *mx])
        for ex in examples[:2]:
            print(f"  {name}: {ex}")
    return rows


def main_regions(n_per_region: int = 6) -> None:
    rows = region_trials(n_per_region)
    print("Pick and place by region of the board (realistic simulator, tasks.sag, a large block, yaw 0)")
    print(format_table(["region", "tried", "placed", "refused before", "refused mid-plan", "not grasped",
                        "mean |x|", "mean |y|", "mean |z|", "max |x|", "max |y|", "max |z|"], rows))


def grid_rows(outcomes: list[board_grid.Outcome]) -> list[list]:
    """Table rows per (region, action) of the grid's outcomes: counts of board_grid.OUTCOMES and the |error| mean
    and max per axis (mm)."""
    rows = []
    for region in board_grid.REGIONS:
        for action in ("pick", "place"):
            mine = [o for o in outcomes if o.spot.region == region and o.action == action]
            if not mine:
                continue
            e = np.abs(np.array([o.error for o in mine if o.error is not None]).reshape(-1, 3))
            mean = e.mean(axis=0) if len(e) else np.full(3, np.nan)
            mx = e.max(axis=0) if len(e) else np.full(3, np.nan)
            rows.append([region, action, str(len(mine)), *(str(sum(o.outcome == c for o in mine))
                                                            for c in board_grid.OUTCOMES), *mean, *mx])
    return rows


def sag_by_region(seed: int = 0, z: float = 40.0, hover_mm: float = 60.0) -> list[list]:
    """How right the fitted sag model (tasks.start_session's, fitted on calibration poses within 60 deg of straight
    ahead) is over the whole board: on the station's empty-board twin (the same arm errors), the tool goes to z mm above
    each grid spot (top-down, or the steepest pitch the spot allows) from hover_mm above it, once commanded as
    planned and once through the sag model (GuardedArm); per region the |error| of the true tool point (3-D, mm)."""
    from armlab import kinematics
    from armlab.tasks.guard import GuardedArm

    st = make_station("sim", seed=seed, scene="empty")
    sag = tasks.start_session(st).arm.sag
    reference = st.capabilities.sag_reference()
    guarded = GuardedArm(reference.arm)
    guarded.sag = sag
    rows = []
    for region in board_grid.REGIONS[:-1]:
        errors = {"none": [], "tasks.sag": []}
        for spot in (s for s in board_grid.GRID if s.region == region):
            target = np.array([spot.x, spot.y, z])
            pitch = min(np.pi / 2, kinematics.steepest_pitch(target))
            for name, arm in (("none", reference.arm), ("tasks.sag", guarded)):
                above = kinematics.ik(target + [0, 0, hover_mm], min(pitch, kinematics.steepest_pitch(
                    target + [0, 0, hover_mm])), 0.0)[0]
                arm.move_to(above)
                arm.move_to(kinematics.ik(target, pitch, 0.0, current=above)[0])
                errors[name].append(np.linalg.norm(reference.measure() - target))
                arm.move_to(above)
        rows.append([region, str(len(errors["none"])), np.mean(errors["none"]), np.max(errors["none"]),
                     np.mean(errors["tasks.sag"]), np.max(errors["tasks.sag"])])
    return rows


def main_grid(n_random: int = 8, first_seed: int = 600) -> None:
    print("The sag model over the board: |tool point error| (3-D, mm) 40 mm above the grid spots (empty-board twin)")
    print(format_table(["region", "spots", "none mean", "none max", "tasks.sag mean", "tasks.sag max"],
                       sag_by_region(), "{:.2f}"))
    spots = [*board_grid.GRID, *board_grid.random_spots(n_random, seed=7)]
    outcomes = []
    for i, (pick, place) in enumerate(board_grid.grid_pairs(spots)):
        picked, placed = board_grid.run_trial(pick, place, first_seed + i)
        outcomes += [picked] + ([] if placed is None else [placed])
        if placed is None:       # the place spot was not tried: count it as not tried through the pick's failure
            print(f"  {place.region} {place}: not placed (the pick at {pick} failed: {picked.outcome})")
    for o in outcomes:
        if o.outcome != "done":
            print(f"  {o.action} at {o.spot} ({o.spot.region}): {o.outcome}: {o.message[:160]}")
    print(f"Pick and place over the whole board ({len(spots)} spots: the grid and {n_random} random; realistic "
          f"simulator, tasks.sag); picks: grasp offset in the tool frame, places: bottom-face centre error, mm")
    print(format_table(["region", "action", "tried", *board_grid.OUTCOMES, "mean |x|", "mean |y|", "mean |z|",
                        "max |x|", "max |y|", "max |z|"], grid_rows(outcomes)))
    done = [o for o in outcomes if o.action == "place" and o.error is not None]
    e = np.abs(np.array([o.error for o in done]).reshape(-1, 3))
    if len(e):
        mean, mx = (" / ".join(f"{v:.2f}" for v in stat) for stat in (e.mean(axis=0), e.max(axis=0)))
        print(f"all places: {len(done)} of {len(spots)} done, mean |error| x / y / z {mean} mm, max {mx} mm; "
              f"refused mid-plan: {sum(o.outcome == 'refused mid-plan' for o in outcomes)}")


def main(n_stations: int = 13) -> None:
    seeds = range(n_stations)
    rows, failures = [], {}
    for method in METHODS:
        trials = pick_place_trials(method, seeds)
        rows.append(summary_row(method, trials))
        failures[method] = [t["failure"] for t in trials if not t["grasped"] or t["error"] is None]
    long_reach = pick_place_trials("tasks.sag", seeds, reach=(340.0, 420.0))
    rows.append(summary_row("tasks.sag, 340-420 mm", long_reach))
    failures["tasks.sag, 340-420 mm"] = [t["failure"] for t in long_reach if not t["grasped"] or t["error"] is None]
    print("Pick and place, realistic simulator (sag, backlash, offsets, camera and depth errors); z is measured after\n"
          "the block settles (0 on the board: the arm's own z accuracy is in the six-location table)")
    print(format_table(["sag handling", "blocks", "grasp %", "placed %", "mean |x|", "mean |y|", "mean |z|", "max |x|",
                        "max |y|", "max |z|", "mean |yaw| deg", "max |yaw| deg"], rows))
    for method, fails in failures.items():
        if fails:
            print(f"  {method}: {len(fails)} failed, e.g. {fails[0]}")

    st = make_station("sim", seed=0, scene="empty")
    session = tasks.start_session(st)
    tasks.look(session)
    measure = lambda: st.arm.tool_pose_true()[:3, 3]    # noqa: E731
    six = {name: reach_experiment(session, arm, measure)
           for name, arm in (("none", st.arm), ("tasks.sag", session.arm))}
    lab = LAB_TABLE_III_ERROR_MM
    print("\nSix locations (lab report Table III), |error| mm at z = 37 mm")
    table = []
    for i, row in enumerate(six["none"]):
        table.append([f"({row.desired[0]:.0f}, {row.desired[1]:.0f})", *lab[i], *row.error, *six["tasks.sag"][i].error])
    mean = lambda name: np.mean([r.error for r in six[name]], axis=0)   # noqa: E731
    table.append(["average", *lab.mean(axis=0), *mean("none"), *mean("tasks.sag")])
    print(format_table(["location", "lab x", "lab y", "lab z", "none x", "none y", "none z", "sag x", "sag y",
                        "sag z"], table))


def _sector(x: float, y: float) -> str:
    heading = np.degrees(abs(np.arctan2(-x, y)))
    side = "in front" if heading <= 60 else ("behind" if y < 0 else "beside")
    return f"{side}, {'near' if np.hypot(x, y) < 250 else 'far'}"


def main_fuzz(n_stations: int = 10, places: int = 50) -> None:
    from scenarios.place_fuzz import run_station

    kinds = ("done < 3 mm", "done >= 3 mm", "refused before", "refused mid-plan")
    counts: dict[str, dict[str, int]] = {}
    examples = []
    for seed in range(1000, 1000 + n_stations):
        for o in run_station(seed, places):
            kind = o.outcome
            if kind == "done":
                kind = "done < 3 mm" if np.abs(o.error).max() < 3.0 else "done >= 3 mm"
            row = counts.setdefault(_sector(o.spot.x, o.spot.y), dict.fromkeys(kinds, 0))
            row[kind] += 1
            if kind != "done < 3 mm":
                examples.append(f"  seed {seed}, {o.spot}: {kind}: {o.message or np.round(o.error, 2)}")
    rows = [[name, *row.values()] for name, row in sorted(counts.items())]
    rows.append(["all", *(sum(r[k] for r in counts.values()) for k in kinds)])
    print(f"Student fuzz: {n_stations} seeded stations, up to {places} places each (armlab.tasks.place_fuzz)")
    print(format_table(["sector", *kinds], rows, floatfmt="{:d}"))
    print("\n".join(examples[:20]))


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "fuzz":
        main_fuzz(*(int(v) for v in sys.argv[2:4]))
    elif len(sys.argv) > 1 and sys.argv[1] == "regions":
        main_regions(int(sys.argv[2]) if len(sys.argv) > 2 else 6)
    elif len(sys.argv) > 1 and sys.argv[1] == "grid":
        main_grid(int(sys.argv[2]) if len(sys.argv) > 2 else 8)
    else:
        main(int(sys.argv[1]) if len(sys.argv) > 1 else 13)
