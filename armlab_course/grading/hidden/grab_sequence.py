"""Hidden checks of exercise grab.sequence: scripted clicks on the judge's own seeded station, each run by the kit's
tasks.click_with with the student's ClickSequence asked in the child what the click means (an open task: outcome
only, scored from the judge's simulator's truth) (armlab_course.grading.hidden)."""

from __future__ import annotations

import numpy as np

from . import HiddenSpec


def _scenes(rng):
    # three scenes: a block A of either size, a small block B and a large block C, turned up to 40 deg, 170-300 mm
    # from the waist axis in front of the base and 100 mm apart; per scene a bare spot, A's drop spot, and click
    # offsets inside A's and B's top faces (up to 0.35 of an edge along each of its axes) and near C's top centre
    checks = []
    for _ in range(3):
        places = []
        while len(places) < 5:
            r, h = rng.uniform(170, 300), rng.uniform(np.radians(30), np.radians(150))
            xy = [float(r * np.cos(h)), float(r * np.sin(h))]
            if all(np.hypot(xy[0] - p[0], xy[1] - p[1]) > 100 for p in places):
                places.append(xy)
        sizes = [str(rng.choice(["large", "small"])), "small", "large"]
        blocks = [[c, s, xy, float(rng.uniform(-0.7, 0.7))] for c, s, xy in zip(("red", "blue", "green"), sizes,
                                                                                 places[:3], strict=True)]
        offsets = rng.uniform(-0.35, 0.35, (2, 2)).tolist() + [rng.uniform(-3.0, 3.0, 2).tolist()]
        checks.append([[int(rng.integers(0, 1000)), blocks, places[3], places[4], offsets]])
    return checks


class _ChildSequence:
    """The student's ClickSequence as tasks.click_with sees it: each click's point and view go to the child as plain
    data, its answer (grab which block seen, drop where, or refuse) comes back and is checked here."""

    def __init__(self, call):
        self.call = call
        call("start")

    def on_click(self, point, seen):
        from armlab.tasks import ClickRefused

        from ._replay import block_to_plain

        got = self.call("click", np.asarray(point, float).tolist(), [block_to_plain(b) for b in seen])
        if got[0] == "refuse":
            raise ClickRefused(str(got[1])[:200])
        if got[0] == "grab":
            index = got[1]
            if isinstance(index, bool) or not isinstance(index, (int, float)) or index != int(index) or \
                    not 0 <= index < len(seen):
                raise ValueError("the grab names no block of those seen")
            return ("grab", seen[int(index)])
        if got[0] == "drop":
            return ("drop", np.asarray(got[1], float), float(got[2]))
        raise ValueError("an action is grab, drop or refuse")

    def after(self, action, ok) -> None:
        self.call("after", bool(ok))


def _on_face(block, offset) -> np.ndarray:
    """The world point (3,) mm on a block's top face at `offset` (2,) of its edge along the face's own axes."""
    c, s = np.cos(block.yaw), np.sin(block.yaw)
    du, dv = np.asarray(offset) * block.edge
    return block.position + [c * du - s * dv, s * du + c * dv, block.edge / 2]


def _judge_sequence(call, seed, blocks, bare, spot, offsets):
    """Five clicks on a fresh sim scene of the judge's: bare board, A, a free spot, B, C's top. Per click [refused
    and nothing moved, A held, A's bottom within 3 mm of the spot, B held, B's bottom within 3 mm of the clicked
    point on C's top] (1.0 / 0.0); an answer the kit cannot use, or an error, scores 0 for that click and the rest."""
    from armlab import tasks
    from armlab.station import make_station

    from ..judge import ChildGone

    station = make_station("sim", seed=int(seed), scene={"objects": [
        {"color": c, "size": s, "position_mm": xy, "yaw_rad": yaw} for c, s, xy, yaw in blocks]})
    session = tasks.start_session(station)
    sequence = _ChildSequence(call)
    a, b, c = (next(o for o in station.world.blocks if o.color == name) for name, *_ in blocks)
    on_c = c.position + [offsets[2][0], offsets[2][1], c.edge / 2]
    clicks = [np.array([*bare, 0.0]), _on_face(a, offsets[0]), np.array([*spot, 0.0]), _on_face(b, offsets[1]), on_c]

    def bottom(o):
        return o.position - [0.0, 0.0, o.edge / 2]

    out = []
    for k, point in enumerate(clicks):
        before = [o.position.copy() for o in station.world.objects]
        try:
            kind, ok = tasks.click_with(session, station.camera.truth.project(point[None])[0], sequence)
        except tasks.ClickRefused:
            kind, ok = "refuse", False
        except ChildGone:
            raise
        except Exception:           # unusable, refused by the kit's checks, or raised in the child: this and the rest
            break
        if k == 0:
            still = all(np.allclose(p, o.position) for p, o in zip(before, station.world.objects, strict=True))
            out.append(float(kind == "refuse" and still))
        elif k in (1, 3):
            out.append(float(kind == "grab" and ok and (a if k == 1 else b).id in station.world.held))
        else:
            held, truth = (a, point) if k == 2 else (b, point)
            out.append(float(kind == "drop" and ok and held.id not in station.world.held
                             and np.abs(bottom(held) - truth).max() < 3.0))
    return out + [0.0] * (len(clicks) - len(out))


SPECS = (HiddenSpec("ClickSequence", _scenes, atol=0, adapter="_call_sequence", judge=_judge_sequence,
                    prelude="definitions", outcome=True,
                    criteria=("the click on the bare board refused with nothing moved", "block A held",
                              "block A landed within 3 mm of the spot clicked", "block B held",
                              "block B landed within 3 mm of the point clicked on C's top")),)
FORBIDDEN = ("click_grab", "click_drop", "ClickToGrab", "click_with", "current_view", "tasks.pick", "tasks.place",
             "armlab.tasks.click_rule", "centre_click_block", "standin_drop_point")   # the module: all it holds
