"""Hidden checks of exercise events.sky: the student's strategy builds the to-the-sky tower on hidden seeds (the
hand-over's jitter and the station's noise), graded by the event's own score (an open task: outcome only)
(armlab_course.grading.hidden)."""

from __future__ import annotations

from armlab.tasks.events.sky import SKY_TOWER_BLOCKS, SKY_TOWER_DEFAULT_CLEARANCE_BLOCKS

from . import HiddenSpec

GOOD_TOWER = SKY_TOWER_DEFAULT_CLEARANCE_BLOCKS     # blocks: what the kit's default 50 mm transit clearance builds
HIGH_TOWER = SKY_TOWER_BLOCKS                       # blocks: what the kit's strategy builds on every seed measured


def _sky_seeds(rng):
    # two fresh seeds: one hidden check per run
    return [[[1, int(seed)]] for seed in rng.integers(100, 10_000, 2)]


def _judge_sky(call, level, seed):
    """To the sky on the judge's own fresh seeded station (_events.run_with_child): [a tower of GOOD_TOWER blocks or
    more, of HIGH_TOWER or more, every block placed standing in it but at most one (on the physics world the last
    level, let go tilted, may tip off; one that falls and takes others with it fails), the score the tower's (30 for
    each of the first 8, 50 above), stopped only once the arm tried the next level and could not place it (put
    back), within the time limit] (1.0 / 0.0)."""
    from armlab.tasks.events.scoring import sky_points

    from ._events import run_with_child

    result, _ = run_with_child(call, "sky", level, seed)
    tower = len(result.score.lines)
    placed = sum(m.placed for m in result.moves)
    return [float(tower >= GOOD_TOWER), float(tower >= HIGH_TOWER),
            float(tower >= placed - 1 and result.score.points == sky_points(tower)),
            float(bool(result.moves) and "cannot place" in result.moves[-1].move), float(result.within_limit)]


SPECS = (HiddenSpec("SkyStrategy", _sky_seeds, atol=0, adapter="_call_strategy", judge=_judge_sky,
                    prelude="definitions", outcome=True,
                    criteria=(f"a tower of {GOOD_TOWER} blocks or more", f"a tower of {HIGH_TOWER} blocks or more",
                              "every placed block but at most one standing in the tower",
                              "stopped only by a place out of reach", "within the time limit")),)
FORBIDDEN = ("Sky", "make_strategy", "sky.EVENT", "SearchStrategy", "armlab.tasks.events.strategies")
