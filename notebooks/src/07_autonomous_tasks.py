# %% [markdown]
# # 07 · Autonomous tasks: the competition events
#
# Everything so far comes together: the station calibrates its camera, **looks** at the board (detection), **plans**
# a pick and a place (IK, trajectories, clearance), **acts**, and looks again to check what happened. In this
# notebook you write the strategy of every event, at every level, and run it on the simulator.
#
# The events and their scoring are **the kit's rules** (the course's recent competitions); the
# lab report does not state them (it says only that its arm met "basic expectations" in the competition):
#
# - **sort 'n stack** (180 s): small blocks left, large right, into $y<0$; levels 2–3: one stack per size, rainbow
#   order, red at the bottom. +30 per block.
# - **line 'em up** (600 s): large and small blocks in two lines, rainbow order, centres within 30 mm of the line,
#   each line shorter than 300 mm. +30 per block, +20 neatness per line.
# - **to the sky** (600 s): large blocks handed over one at a time; one tower as high as possible. 30 points for each
#   of the first 8 blocks, then 50.
#
# Level 3 boards start with blocks **stacked** two or three high and **distractors** (arches, cylinders, triangles)
# that must be left alone. The score is computed from the simulator's **ground truth** at the end (never from what
# the robot believes), and the time is **simulated** seconds. Units: mm, rad, s; world (board) frame.
#
# | exercise | points | kind | how it is graded |
# |---|---|---|---|
# | `events.sort_stack` | 12 | open task | the event's own score on hidden seeds (below) |
# | `events.line_up` | 12 | open task | the event's own score on hidden seeds (below) |
# | `events.sky` | 8 | open task | the tower your strategy builds on hidden seeds (below) |
# | `events.tower_question` | 2 | written | by hand, from your answer under the tower figure |
#
# The three strategies are graded by outcome: each runs its event on hidden seeds, at every level, and a sort 'n
# stack or line 'em up run counts when it earns the event's full marks within the time limit; a to-the-sky run is
# scored on the tower it builds (how high, every block standing in it, stopped only when the next level is out of
# reach, in time).
#
# The cells called **Check** run your strategies on public seeds. While a strategy is blank, its event makes no
# move (it says so once) and scores the board as it starts: the kit's own strategies are not in your copy.

# %%
import numpy as np
import matplotlib.pyplot as plt
from IPython import get_ipython

from armlab.blocks import COLORS, LAB_RGB, block_edge
from armlab.robot import JOINT_NAMES
from armlab.tasks import start_session
from armlab.tasks.events import columns, event_station, run_event, score_event
from armlab.tasks.events.layout import Move, covered, free_spot, is_stacked
from armlab.tasks.events.replay import objects_from_snapshot
from armlab.tasks.events.sort_stack import STACK_XY
from armlab.tasks.events import scoring
from armlab.tasks.events.sky import TOWER_XY, highest_tool_z

get_ipython().run_line_magic("matplotlib", "inline")
from armlab_course.exercises import with_reference
from armlab.viz.figures import readable

readable()                                             # figure size and fonts readable at 100 % zoom
np.set_printoptions(precision=2, suppress=True)


def full_marks_runs(event, name, strategy, runs, world_scored=False):
    """Run `strategy` (a class taking the level) on each (level, seed) of `runs`: each must earn the event's full
    marks within its time limit (and, with world_scored, the score must be the world's as it stands); prints each
    run's score and time under the event's `name`."""
    for level, seed in runs:
        st = event_station(event, level, seed=seed)
        res = run_event(start_session(st), event, level, strategy=strategy(level), record=False)
        lost = [f"{line.what}: {line.why}" for line in res.score.lines if line.points == 0]
        assert res.score.full_marks, (f"level {level}, seed {seed}: your strategy scored {res.score.points:g}/"
                                      f"{res.score.max_points} ({res.stopped}); lost: {lost}")
        assert res.within_limit, \
            f"level {level}, seed {seed}: it took {res.time_s:.0f} s (limit {res.time_limit_s:.0f} s)"
        assert not world_scored or res.score == score_event(event, level, st.world.objects), \
            "the score is not the world's"
        print(f"OK: {name} level {level} (seed {seed}): {res.score.points:g}/{res.score.max_points} in "
              f"{res.time_s:.0f} s of {res.time_limit_s:.0f} s")


def stack_label(col) -> str:
    """A stack's colours bottom to top by initial (R red, O orange, Y yellow, G green, B blue, V violet)."""
    return "".join(o.color[0].upper() for o in col)


def draw_board(ax, objects, title):
    """Top view of the board: every object's footprint in its lab colour (distractors hatched), each stack labelled
    with its colours' initials, bottom first."""
    ax.add_patch(plt.Rectangle((-500, -175), 1000, 650, color="0.93", zorder=0))
    for col in columns(objects):
        for o in col:
            for poly in o.footprint_world():
                ax.add_patch(plt.Polygon(poly, closed=True, fc=np.array(LAB_RGB[o.color]) / 255,
                                         ec="k", lw=0.5, hatch=None if o.is_block else "///"))
        if len(col) > 1:
            ax.annotate(stack_label(col), col[-1].position[:2], xytext=(0, 14), textcoords="offset points",
                        ha="center", va="bottom", fontsize=9.5, bbox=dict(boxstyle="round,pad=0.15", fc="w", ec="0.5"))
    ax.add_patch(plt.Rectangle((-55, -60), 110, 120, fc="0.4", zorder=1))   # the arm's base plate
    ax.set(xlim=(-500, 500), ylim=(-175, 475), aspect="equal", title=title, xlabel="x (mm)", ylabel="y (mm)",
           xticks=range(-400, 401, 200))


def draw_side(ax, objects, title):
    """Side view (x, z) of every column of blocks seen from the front of the board (looking along +y), each block in
    its lab colour with its colour's initial, so the order up a stack can be read."""
    for col in columns(objects):
        for o in col:
            if not o.is_block:
                continue
            e = o.edge
            ax.add_patch(plt.Rectangle((o.position[0] - e / 2, o.bottom_z), e, e,
                                       fc=np.array(LAB_RGB[o.color]) / 255, ec="k", lw=0.5))
            ax.text(o.position[0], o.bottom_z + e / 2, o.color[0].upper(), ha="center", va="center", fontsize=9.5,
                    color="k" if o.color == "yellow" else "w")
    ax.axhline(0, color="0.3", lw=1)
    ax.set(xlim=(-280, 280), ylim=(-5, 130), aspect="equal", xlabel="x (mm)", ylabel="z (mm)", title=title)


def before_after(result, side=False):
    """Top views of the board at the start and the end of a run (stacks labelled bottom first); with side=True, the
    end also seen from the side."""
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True)
    snaps = result.replay.snapshots
    draw_board(axes[0], objects_from_snapshot(snaps[0][2]), "start")
    draw_board(axes[1], objects_from_snapshot(snaps[-1][2]),
               f"end: {result.score.points:g}/{result.score.max_points} points, {result.time_s:.0f} s simulated")
    axes[1].set_ylabel("")
    fig.tight_layout()
    if side:
        fig, ax = plt.subplots(figsize=(8, 3.0))
        draw_side(ax, objects_from_snapshot(snaps[-1][2]), "the end seen from the front (red at the bottom)")
        fig.tight_layout()


# %% [markdown]
# ## 1 · Scoring from the world state
#
# A scorer reads the objects on the board (true centres and yaws) and applies the rules. Only objects **at rest**
# count: an object rests when its bottom face lies on the board or on the top face of what is under it, and it is
# neither tilted nor held. `columns` follows those supports: each column is a stack, bottom first. Here is a
# hand-made finished sort 'n stack board — and the same board with two large blocks swapped:

# %%
def stack(colors, size, x, y):
    e = block_edge(size)
    from armlab.blocks import ObjectState
    return [ObjectState(c, size, e, np.array([x, y, e / 2 + k * e])) for k, c in enumerate(colors)]


board = stack(["red", "green", "violet"], "large", 200, -100) + stack(["orange", "yellow", "blue"], "small", -200, -100)
for i, o in enumerate(board):
    o.id = i
print(score_event("sort_stack", 3, board).table())
board[0].color, board[1].color = "green", "red"
print("swapped:", score_event("sort_stack", 3, board).points, "points")

# %% [markdown]
# ## 2 · Your strategy: sort 'n stack
#
# A strategy is an object with `next_move(seen)`: given the detections of a fresh look (`detection.Block`s: `color`,
# `size`, `position` = top-face centre in world mm, `is_block` — False for a distractor), it returns the next
# `Move(block, to, yaw, why)` — `to` is where the block's *bottom-face* centre goes (world mm), `why` a word for the
# log — or `None` when it is done. `run_event` runs in a task session (`start_session(station)` calibrates the camera
# and fits the sag model, before the event's clock starts): it picks, places, looks again and calls it again; it calls
# `placed(move)` after each place that ran through. A pick that fails is simply seen again on the next look.
#
# The goal at levels 2 and 3: one stack per size at `STACK_XY[size]`, in rainbow order from the bottom (`COLORS` is
# that order); at level 1 every block must only end in its area (the stacks are in it, so one strategy can serve every
# level). Level 1 and 2 start with every block on the board; level 3 starts with some blocks standing on others and
# with distractors. Think about:
# - what a look **cannot** tell you (a block under another shows no top face, or only a rim), and what that means
#   for the first block you may put at the bottom of a stack;
# - what must be true of a block before it can be picked (nothing on it: `covered(b, seen)`), and where a block
#   goes that is in the way (`free_spot(seen, size, near, reserved)` finds a free board spot clear of the
#   detections and of the points you reserve); `is_stacked(b)` says a detected block stands on something;
# - how high the next block must be put down on a stack, and what you do when the camera shows the stack lower than
#   you believe (a block knocked off);
# - when you are done.
#
# **Exercise `events.sort_stack`:** write `SortStackStrategy(level)`.

# %%
class SortStackStrategy:
    """Sort 'n stack at level 1, 2 or 3 from what the robot sees (see above)."""

    def __init__(self, level):
        self.level = level
        self.notes = {}          # whatever your strategy remembers between moves

    def next_move(self, seen):
        # BEGIN SOLUTION events.sort_stack
        built = self.notes.setdefault("built", {"large": [], "small": []})   # colours on each stack, bottom first
        cubes = [b for b in seen if b.is_block]

        def on_its_stack(b):
            return np.hypot(*(np.asarray(b.position[:2]) - STACK_XY[b.size])) < 20.0

        for size in built:                   # the camera wins: a stack is no higher than its detected top
            top = max((b.position[2] for b in cubes if b.size == size and on_its_stack(b)), default=0.0)
            del built[size][int(round(top / block_edge(size))):]
        loose = [b for b in cubes if not on_its_stack(b)]
        free = [b for b in loose if not covered(b, seen)]
        if not free:
            return None
        standing_on_something = [b for b in free if is_stacked(b)]
        if standing_on_something:            # unstack first: what is below may be an earlier colour
            b = max(standing_on_something, key=lambda b: b.position[2])
            spot = free_spot(seen, b.size, b.position, reserved=list(STACK_XY.values()))
            return Move(b, spot, 0.0, "unstack")
        b = min(free, key=lambda b: (COLORS.index(b.color), b.size != "large"))
        x, y = STACK_XY[b.size]
        return Move(b, np.array([x, y, len(built[b.size]) * block_edge(b.size)]), 0.0, "stack")
        # END SOLUTION

    def placed(self, move):
        # BEGIN SOLUTION events.sort_stack
        if move.why == "stack":
            self.notes.setdefault("built", {"large": [], "small": []})[move.block.size].append(move.block.color)
        # END SOLUTION


def no_move(seen):
    """The stand-in while a strategy is blank: no move at all, so the event ends at once and scores the board as it
    starts (the kit's own strategies stay out of your notebook)."""
    return None


def strategy_for(cls, exercise_id, level=1):
    """Your strategy `cls(level)`; while it is blank no move is made (it says so once), nothing is built to avoid
    and a failed place ends the run."""
    mine = cls(level)
    mine.next_move = with_reference(mine.next_move, exercise_id, no_move,
                                    "no move is made: the event scores the board as it starts")
    if hasattr(mine, "obstacles"):
        mine.obstacles = with_reference(mine.obstacles, exercise_id, lambda: [], "nothing built to avoid")
    if hasattr(mine, "cannot_place"):
        mine.cannot_place = with_reference(mine.cannot_place, exercise_id, lambda why: False, "a failed place stops")
    return mine


station = event_station("sort_stack", 3, seed=0)
sort3 = run_event(start_session(station), "sort_stack", 3, strategy=strategy_for(SortStackStrategy,
                                                                                  "events.sort_stack", 3))
for m in sort3.moves:
    print(f"{m.t_start:6.1f} s  {m.move}")
print(sort3.score.table())
before_after(sort3, side=True)

# %% [markdown]
# ## Check: your strategy on two public seeds
#
# Levels 1, 2 and 3, each on a seed of its own (the grader runs every level on other seeds). Each run must earn the
# event's full marks within its 180 s, scored from the simulator's ground truth.

# %%
# CHECK events.sort_stack
full_marks_runs("sort_stack", "sort 'n stack", SortStackStrategy, ((1, 2), (2, 3), (3, 4)), world_scored=True)

# %% [markdown]
# The replay holds the arm's joint angles every 0.1 s of simulated time (`result.replay.q`) and a snapshot of the
# world after every move. `result.replay.to_viewer(Viewer())` plays it in meshcat (the demo saves it as
# `out/replay.html`). Below, the joints over the run: the shaded bands are where the gripper is closed (holding a
# block), and each numbered dotted line is the end of a move (its description is printed under the figure).

# %%
r = sort3.replay
fig, ax = plt.subplots(figsize=(9, 4.0))
for j, name in enumerate(JOINT_NAMES):
    ax.plot(r.times, r.q[:, j], lw=1, label=name)
ax.fill_between(r.times, 0, 1, where=r.gripper < 50, transform=ax.get_xaxis_transform(), color="0.85", zorder=0)
moves = [(t, label) for t, label, _ in r.snapshots if label not in ("start", "end")]
for k, (t, _) in enumerate(moves, 1):
    ax.axvline(t, color="0.3", ls=":", lw=0.8)
    ax.text(t, 1.0, str(k), transform=ax.get_xaxis_transform(), ha="center", va="bottom", fontsize=9.5)
ax.set(xlabel="simulated time (s)", ylabel="joint angle (rad)",
       title="each move (numbered) is a pick and a place: shaded while a block is held", xlim=(0, r.times[-1]))
ax.set_title(ax.get_title(), pad=18)
ax.legend(ncol=5, loc="upper center", bbox_to_anchor=(0.5, -0.2), frameon=False)
fig.tight_layout()
for k, (t, label) in enumerate(moves, 1):
    print(f"{k:2d}  {t:6.1f} s  {label}")

# %% [markdown]
# ## 3 · Your strategy: line 'em up
#
# The goal: the large blocks in one straight line and the small ones in another, each in rainbow order, every centre
# within 30 mm of its line, each line shorter than 300 mm; +20 more per line when it is neat (centres within 10 mm of
# the line, blocks square to it within 10°). Level 1 has large blocks only; level 3 starts with stacks and with
# distractors, which must not be moved. Where the lines go is yours to choose. Think about:
# - the gripper's pads: a block placed square to its line is gripped either along the line or across it; which way
#   lets you put a block 12 mm from its neighbour without touching it, and at what headings does the gripper come
#   down that way (the plans grip a block across the line when the line runs along the arm's heading ±45°);
# - how far apart the slots must be for the line to stay under 300 mm, and where on the board the lines can go so
#   that no distractor stands where the gripper must come down (`footprint_radius(b)` is a detection's radius in mm,
#   `GRIPPER_RADIUS_MM` the open gripper's);
# - a block standing on the slot another block needs, and a block with another one on it (`covered`).
#
# **Exercise `events.line_up`:** write `LineUpStrategy(level)`: `next_move(seen)` and `placed(move)` as above.

# %%
from armlab.planning.transit import GRIPPER_RADIUS_MM
from armlab.tasks.events.layout import footprint_radius


class LineUpStrategy:
    """Line 'em up at level 1, 2 or 3 from what the robot sees (see above)."""

    def __init__(self, level):
        self.level = level
        self.notes = {}          # whatever your strategy remembers between moves

    def next_move(self, seen):
        # BEGIN SOLUTION events.line_up
        def slots_for(large_side, y, x0):
            """(size, colour) -> where its bottom face goes: both lines along x from |x| = x0, red nearest the base."""
            pitch = {"large": 50.0, "small": 40.0}       # 5 * 50 + 38 = 288 mm, 5 * 40 + 25 = 225 mm: under 300
            return {(size, c): np.array([side * (x0 + k * pitch[size]), y, 0.0])
                    for size, side in (("large", large_side), ("small", -large_side)) for k, c in enumerate(COLORS)}

        def blocks_slot(b, slot):
            """b stands where the open gripper comes down on the slot."""
            return np.hypot(*(np.asarray(b.position[:2]) - slot[:2])) < footprint_radius(b) + GRIPPER_RADIUS_MM

        if "slots" not in self.notes:        # the layout whose slots the fewest distractors (then blocks) stand on
            layouts = [slots_for(side, y, x0) for x0 in (110.0, 125.0)
                       for y in (-95.0, -80.0, 80.0, 95.0, -110.0, -65.0, 65.0, 110.0) for side in (1, -1)
                       if abs(y) < x0]     # |y| < |x| at every slot: the pads close across the line
            self.notes["slots"] = min(layouts, key=lambda slots: sum(
                (1 if b.is_block else 100) for b in seen for slot in slots.values() if blocks_slot(b, slot)))
        slots = self.notes["slots"]

        def in_place(b):
            return b.is_block and not is_stacked(b) and np.hypot(
                *(np.asarray(b.position[:2]) - slots[(b.size, b.color)][:2])) < 8.0

        waiting = [b for b in seen if b.is_block and not in_place(b) and not covered(b, seen)]
        waiting.sort(key=lambda b: (-b.position[2], np.hypot(*b.position[:2])))    # stack tops first, then nearest
        in_the_way = []
        for b in waiting:
            slot = slots[(b.size, b.color)]
            taken = [o for o in seen if o is not b and not in_place(o) and blocks_slot(o, slot)]
            if not taken:
                return Move(b, slot.copy(), 0.0, "line")
            in_the_way += [o for o in taken if o.is_block]
        if in_the_way:                       # every waiting block's slot is taken: clear one first
            o = in_the_way[0]
            return Move(o, free_spot(seen, o.size, o.position, reserved=list(slots.values())), 0.0, "clear")
        return None
        # END SOLUTION

    def placed(self, move):
        # BEGIN SOLUTION events.line_up
        pass                                 # the next look shows where every block is
        # END SOLUTION


station = event_station("line_up", 3, seed=0)
line3 = run_event(start_session(station), "line_up", 3, strategy=strategy_for(LineUpStrategy, "events.line_up", 3))
print(line3.summary())
print(line3.score.table())
before_after(line3)

# %% [markdown]
# ## Check: your line 'em up on public seeds
#
# Levels 1 and 2, each on a seed of its own (with level 3 above, every level once; the grader runs every level on
# other seeds). Each run must earn the event's full marks within its 600 s.

# %%
# CHECK events.line_up
full_marks_runs("line_up", "line 'em up", LineUpStrategy, ((1, 3), (2, 4)))
assert line3.score.full_marks and line3.within_limit, f"line 'em up level 3 (seed 0): {line3.summary()}"

# %% [markdown]
# ## 4 · To the sky
#
# The scene hands over a large block at `HANDOVER_XY` = (−200, 150) mm after each one that ends on the tower; your
# strategy stacks them into one tower as high as it can. How high can it go? The arm must carry the block **over**
# the tower and come straight down onto it. With the top at $z$, the tool must hover at $z + 38 + c$ mm, $c$ the
# clearance over the top (`Move(..., clearance=c)`; the kit's default is 50 mm). `highest_tool_z(xy)` is the highest
# tool point the arm reaches over a board point (at any pitch, or `top_down=True`); the arm runs out of reach long
# before 20 blocks ($20 \cdot 38 = 760$ mm). Think about:
# - where the tower should stand (`TOWER_XY` is one choice: measure others with `highest_tool_z`), and why you aim
#   at the same $x, y$ every time rather than at the detected top;
# - how many blocks the tower has when the camera no longer sees its top well, and what the plans must avoid that
#   the camera may not see (`obstacles()`: `Obstacle(x, y, top, radius)` of `armlab.planning`);
# - what happens when a level cannot be placed: the runner puts the block back and asks `cannot_place(why)` — return
#   True to carry on, and let `next_move` return None from then on, with `stopped` saying why;
# - what a block does when it is let go tilted: above about 6 levels the arm can no longer come straight down, so the
#   block (picked straight down at the hand-over) hangs in the pads turned by the approach's tilt; it lands on its
#   lowest edge and tips flat, off to one side. `landing_offset(levels)` says where such a block lands from where it
#   was let go (section 5 shows what a tower does with blocks that are off).
#
# **Exercise `events.sky`:** write `SkyStrategy(level)`: `next_move(seen)`, `placed(move)`, `cannot_place(why)` and
# `obstacles()`.

# %%
print("highest tool point at the tower spot: "
      f"{highest_tool_z(TOWER_XY):.0f} mm at any pitch, {highest_tool_z(TOWER_XY, top_down=True):.0f} mm top-down")

# %%
from armlab.planning import Obstacle
from armlab.tasks.events.sky import HANDOVER_XY, SKY_TOWER_BLOCKS, landing_offset


class SkyStrategy:
    """To the sky from what the robot sees (see above); `stopped` says why the tower stopped growing."""

    def __init__(self, level=1):
        self.level = level
        self.notes = {}          # whatever your strategy remembers between moves
        self.stopped = ""

    def next_move(self, seen):
        # BEGIN SOLUTION events.sky
        if self.stopped:
            return None
        edge = block_edge("large")

        def near(b, xy):
            return b.is_block and np.hypot(*(np.asarray(b.position[:2]) - xy)) < 40.0

        tops = [b.position[2] for b in seen if near(b, TOWER_XY)]
        if tops:                             # the camera sees the top: it counts the levels
            self.notes["levels"] = int(round(max(tops) / edge))
        waiting = [b for b in seen if near(b, HANDOVER_XY)]
        if not waiting:
            return None
        # always the same (x, y): the detected top of a tall tower drifts more than the arm errs, less where a block
        # let go tilted will tip on landing; carried 15 mm over the top (the empty finger tips end 7 mm above the new
        # top), not 50: the last levels fit under the reach
        levels = self.notes.get("levels", 0)
        aim = np.asarray(TOWER_XY) - landing_offset(levels)
        return Move(waiting[0], np.array([*aim, levels * edge]), 0.0, "tower", 15.0)
        # END SOLUTION

    def placed(self, move):
        # BEGIN SOLUTION events.sky
        self.notes["levels"] = self.notes.get("levels", 0) + 1
        # END SOLUTION

    def cannot_place(self, why):
        # BEGIN SOLUTION events.sky
        self.stopped = f"the next level is out of reach: {why}"
        return True
        # END SOLUTION

    def obstacles(self):
        # BEGIN SOLUTION events.sky
        return [Obstacle(*TOWER_XY, self.notes.get("levels", 0) * block_edge("large"), 27.0)]   # the tower, believed
        # END SOLUTION


station = event_station("sky", seed=0)
sky = run_event(start_session(station), "sky", strategy=strategy_for(SkyStrategy, "events.sky"))
tower = len(sky.score.lines)
heights = [o.top_z for o in max(columns(station.world.objects), key=len)]
print(f"tower: {tower} blocks, top at {heights[-1]:.0f} mm")

# %%
fig, ax = plt.subplots(figsize=(5.8, 5.4))
col = max(columns(station.world.objects), key=len)
for o in col:
    ax.add_patch(plt.Rectangle((o.position[0] - 19, o.bottom_z), 38, 38, fc=np.array(LAB_RGB[o.color]) / 255,
                               ec="k", lw=0.5))
reach_z = highest_tool_z(TOWER_XY)
ax.axhline(heights[-1], color="0.5", ls=":")
ax.axhline(reach_z, color="C3", ls="--")
ax.text(TOWER_XY[0] + 30, heights[-1] - 6, "top of the tower", ha="left", va="top", fontsize=9.5, color="0.3")
ax.text(TOWER_XY[0] + 30, reach_z + 6, "highest tool point here", ha="left", va="bottom", fontsize=9.5, color="C3")
ax.set(xlim=(TOWER_XY[0] - 60, TOWER_XY[0] + 240), ylim=(0, 560), aspect="equal", xlabel="x (mm)",
       ylabel="z (mm)", title="the tower, side view:\nthe room left above its top")
fig.tight_layout()

# %%
# CHECK events.sky
SkyStrategy().next_move([])          # your strategy is written (a blank one raises, naming the exercise)
assert tower >= SKY_TOWER_BLOCKS, f"the tower has {tower} blocks (expected at least {SKY_TOWER_BLOCKS})"
assert sky.score.points == scoring.sky_points(tower), "the score does not follow the sky rules"
assert sky.moves and "cannot place" in sky.moves[-1].move, f"the tower stopped before the arm ran out of reach: " \
    f"{sky.stopped}"
assert sky.within_limit, f"it took {sky.time_s:.0f} s (limit {sky.time_limit_s:.0f} s; the kit's tower of " \
    f"{SKY_TOWER_BLOCKS} takes about 190 s): did the strategy stop once the next level was out of reach?"
print(f"OK: to the sky: a stable tower of {tower} blocks, scored by the sky rules")

# %% [markdown]
# **Question `events.tower_question` (2 points, written).** Read the tower figure. How many points does this tower
# earn under the to-the-sky rule (30 for each of the first 8 blocks, 50 for each one above; show the sum), and how
# many fewer would the kit's default 50 mm clearance have earned? Between the tower's top and the highest tool point
# there is still room: add up, in mm, what has to fit into it for the next block to be put on (read the heights off
# the figure), and say what you would change in the strategy to gain one more block — at what risk, and what you
# would measure on the real arm before trying it.

# %% [markdown]
# <!-- BEGIN ANSWER events.tower_question -->
# 12 blocks: 8 x 30 + 4 x 50 = 440 points; with the default 50 mm clearance the arm comes down from higher, more
# tilted, and the tower stops at 8 blocks (a run with clearance 50 shows it; the 9th falls off): 8 x 30 = 240, 200
# points fewer. The 13th block's bottom would go on the top at 456 mm (3 mm over it: the release gap); gripped at
# its centre it hangs 19 mm below the tool point, so the tool comes down to about 478 mm, up to 19 mm higher for a
# block let go tilted (its lowest edge, not its face, meets the top), from a hover the held block's 38 mm plus the
# 15 mm clearance higher: about 531 mm, above the 511 mm the tool reaches there, so reach is what stops it. Above
# about 6 levels the arm can no longer come straight down; the block, picked straight down, hangs in the pads turned
# by the approach's tilt, lands on an edge and tips flat (the kit aims it where it lands; the open finger on its low
# side catches it). For one more block: a smaller clearance (the finger tips end 7 mm above the new top now), grip
# the block higher up so it hangs less far below the tool point, or put the tower where the arm reaches higher. The
# risk: the held block or the fingers brush the tower's top, and a block gripped high is held by less of its faces
# and turns in the pads. On the real arm, measure first how far the tool sags below its command at that height and
# reach (it eats the clearance), how tilted the arm comes down at each level, and where a block let go that tilted
# lands.
# <!-- END ANSWER -->

# %% [markdown]
# ## 5 · A tower that falls and one that stands
#
# The simulated world runs contact physics (MuJoCo): a block let go over a tower falls onto it and rests where the
# forces leave it, and a tower stands or falls as a real one does. Below, two towers of eight large blocks are put
# down one block at a time, each block 4 mm (left) or 6 mm (right) further out than the one under it: every block
# lies well over the block it is put on (its centre at most 6 mm from that block's centre, of a 19 mm half edge).
# Dashed: where each block was put; filled: where the physics left it.

# %%
from armlab.blocks import ObjectState
from armlab.sim.scenes import with_objects_at


def leaning_tower(step_mm, y_mm, levels=8):
    """`levels` large blocks put one on another at y_mm, each step_mm further out (+x) than the one below."""
    return [ObjectState("red", "large", 38.0, np.array([-300.0 + k * step_mm, y_mm, 0.0]), 0.0, "cube", k)
            for k in range(levels)]


fig, axes = plt.subplots(1, 2, figsize=(8.0, 4.6))
for ax, step in zip(axes, (4.0, 6.0)):
    put = leaning_tower(step, 250.0)
    rested = with_objects_at([], put)
    for k, o in enumerate(put):
        ax.add_patch(plt.Rectangle((o.position[0] - 19, 38 * k), 38, 38, fill=False, ls="--", ec="0.5", lw=0.8))
    for o in rested:
        corners = np.array([[-19, -19], [19, -19], [19, 19], [-19, 19]], float)
        c, s_ = np.cos(o.tilt[1]), np.sin(o.tilt[1])       # the side view of a block tipped over about y
        xz = corners @ np.array([[c, -s_], [s_, c]]) + o.position[[0, 2]]
        ax.add_patch(plt.Polygon(xz, fc=np.array(LAB_RGB[COLORS[o.id % 6]]) / 255, ec="k", lw=0.5, alpha=0.85))
    top = max(o.top_z for o in rested)
    ax.set(xlim=(-360, 20), ylim=(0, 340), xticks=range(-300, 1, 100), xlabel="x (mm)", ylabel="z (mm)",
           title=f"each block {step:.0f} mm further out:\ntop now at {top:.0f} mm")
    ax.set_aspect("equal", adjustable="box")
fig.tight_layout()

# %% [markdown]
# **Think about it (not graded).** Both towers were built by the same rule, and in both every block was put squarely
# over the one below it. Why does one stand and the other fall? What would you have to check, block by block, to
# know before building it whether a tower will stand, and how does that change what your to-the-sky strategy must
# care about when it places the blocks high up?

# %% [markdown]
# ## Your table for this notebook
#
# What `python -m armlab check` lists for this notebook: each exercise, its points, its kind, how it is graded and
# whether you have written it (from the saved files: save the notebook first). The grader decides the score.

# %%
from armlab_course.exercises.rubric import rubric

rubric("07_autonomous_tasks")
