# %% [markdown]
# # 07 · Autonomous tasks: the competition events
#
# Everything so far comes together: the station calibrates its camera, **looks** at the board (detection), **plans**
# a pick and a place (IK, trajectories, clearance), **acts**, and looks again to check what happened. In this
# notebook you write the strategy for one event at its harder levels and run it on the simulator.
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
# | `events.tower_question` | 2 | written | by hand, from your answer under the tower figure |
#
# `events.sort_stack` is graded by outcome: your strategy runs sort 'n stack at levels 2 and 3 on hidden seeds, and
# each run counts when it earns the event's full marks within 180 s.
#
# The cell called **Check** runs your strategy on two public seeds; cells marked **Demonstration** run the kit's own
# strategies and test nothing of yours.

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


def draw_board(ax, objects, title):
    """Top view of the board: every object's footprint in its lab colour (distractors hatched), stacks labelled."""
    ax.add_patch(plt.Rectangle((-500, -175), 1000, 650, color="0.93", zorder=0))
    for col in columns(objects):
        for o in col:
            for poly in o.footprint_world():
                ax.add_patch(plt.Polygon(poly, closed=True, fc=np.array(LAB_RGB[o.color]) / 255,
                                         ec="k", lw=0.5, hatch=None if o.is_block else "///"))
        if len(col) > 1:
            ax.annotate(str(len(col)), col[-1].position[:2], color="w", ha="center", va="center", fontsize=9)
    ax.add_patch(plt.Rectangle((-55, -60), 110, 120, fc="0.4", zorder=1))   # the arm's base plate
    ax.set(xlim=(-500, 500), ylim=(-175, 475), aspect="equal", title=title)


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
            ax.text(o.position[0], o.bottom_z + e / 2, o.color[0].upper(), ha="center", va="center", fontsize=8,
                    color="k" if o.color == "yellow" else "w")
    ax.axhline(0, color="0.3", lw=1)
    ax.set(xlim=(-280, 280), ylim=(-5, 130), aspect="equal", xlabel="x (mm)", ylabel="z (mm)", title=title)


def before_after(result, side=False):
    """Top views of the board at the start and the end of a run; with side=True, the end also seen from the side."""
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
    snaps = result.replay.snapshots
    draw_board(axes[0], objects_from_snapshot(snaps[0][2]), "start")
    draw_board(axes[1], objects_from_snapshot(snaps[-1][2]), f"end ({result.time_s:.0f} s simulated)")
    fig.tight_layout()
    if side:
        fig, ax = plt.subplots(figsize=(7, 2.4))
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
# ## 2 · Your strategy: sort 'n stack, levels 2 and 3
#
# A strategy is an object with `next_move(seen)`: given the detections of a fresh look (`detection.Block`s: `color`,
# `size`, `position` = top-face centre in world mm, `is_block` — False for a distractor), it returns the next
# `Move(block, to, yaw, why)` — `to` is where the block's *bottom-face* centre goes (world mm), `why` a word for the
# log — or `None` when it is done. `run_event` runs in a task session (`start_session(station)` calibrates the camera
# and fits the sag model, before the event's clock starts): it picks, places, looks again and calls it again; it calls
# `placed(move)` after each place that ran through. A pick that fails is simply seen again on the next look.
#
# The goal at levels 2 and 3: one stack per size at `STACK_XY[size]`, in rainbow order from the bottom (`COLORS` is
# that order). Level 2 starts with every block on the board; level 3 starts with some blocks standing on others and
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
    """Sort 'n stack at level 2 or 3 from what the robot sees (see above)."""

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
    """The stand-in while your strategy is blank: no move at all, so the event ends at once and scores the board as
    it starts (the kit's own strategy stays out of your notebook)."""
    return None


def strategy_for(level):
    """Your strategy; while it is blank no move is made (it says so once)."""
    mine = SortStackStrategy(level)
    mine.next_move = with_reference(mine.next_move, "events.sort_stack", no_move,
                                    "no move is made: the event scores the board as it starts")
    return mine


station = event_station("sort_stack", 3, seed=0)
sort3 = run_event(start_session(station), "sort_stack", 3, strategy=strategy_for(3))
for m in sort3.moves:
    print(f"{m.t_start:6.1f} s  {m.move}")
print(sort3.score.table())
before_after(sort3, side=True)

# %% [markdown]
# ## Check: your strategy on two public seeds
#
# Level 2 and level 3, each on a seed of its own (the grader runs both levels on other seeds). Each run must earn the
# event's full marks within its 180 s, scored from the simulator's ground truth.

# %%
# CHECK events.sort_stack
for level, seed in ((2, 3), (3, 4)):
    st = event_station("sort_stack", level, seed=seed)
    res = run_event(start_session(st), "sort_stack", level, strategy=SortStackStrategy(level), record=False)
    lost = [f"{line.what}: {line.why}" for line in res.score.lines if line.points == 0]
    assert res.score.full_marks, (f"level {level}, seed {seed}: your strategy scored {res.score.points:g}/"
                                  f"{res.score.max_points} ({res.stopped}); lost: {lost}")
    assert res.within_limit, f"level {level}, seed {seed}: it took {res.time_s:.0f} s (limit {res.time_limit_s:.0f} s)"
    assert res.score == score_event("sort_stack", level, st.world.objects), "the score is not the world's"
    print(f"OK: sort 'n stack level {level} (seed {seed}): {res.score.points:g}/{res.score.max_points} in "
          f"{res.time_s:.0f} s of {res.time_limit_s:.0f} s")

# %% [markdown]
# The replay holds the arm's joint angles every 0.1 s of simulated time (`result.replay.q`) and a snapshot of the
# world after every move. `result.replay.to_viewer(Viewer())` plays it in meshcat (the demo saves it as
# `out/replay.html`). The shaded bands are where the gripper is closed (holding a block):

# %%
r = sort3.replay
fig, ax = plt.subplots(figsize=(9, 3.2))
for j, name in enumerate(JOINT_NAMES):
    ax.plot(r.times, r.q[:, j], lw=1, label=name)
ax.fill_between(r.times, 0, 1, where=r.gripper < 50, transform=ax.get_xaxis_transform(), color="0.85", zorder=0)
ax.set(xlabel="simulated time (s)", ylabel="joint angle (rad)")
ax.legend(fontsize=9, ncol=5, loc="lower center", bbox_to_anchor=(0.5, 1.0), frameon=False)
fig.tight_layout()

# %% [markdown]
# ## 3 · Line 'em up, level 3
#
# **Demonstration** of the kit's own strategy (`armlab.tasks.events.line_up`); it tests nothing of yours.
#
# Both lines run along $x$, red nearest the base, 50 mm apart for large blocks (5·50 + 38 = 288 mm < 300) and 40 mm
# for small ones. Along $x$ and at headings within 45° of the line, a top-down gripper placing a block square to
# the line closes **across** the line, so its pads never touch the neighbours (only 12 mm away). The layout (side,
# $y$) is chosen on the first look to avoid distractors; blocks standing where the gripper must come down are moved
# out of the way first, and the highest blocks go first (never lift a block with another on it).

# %%
station = event_station("line_up", 3, seed=0)
line3 = run_event(start_session(station), "line_up", 3)
print(line3.summary())
print(line3.score.table())
before_after(line3)

# %%
# demonstration: the kit's strategy, not your work
assert line3.score.full_marks and line3.within_limit, f"line 'em up: {line3.summary()}"
print(f"OK: line 'em up level 3: {line3.score.points:g}/{line3.score.max_points} in {line3.time_s:.0f} s of 600 s")

# %% [markdown]
# ## 4 · To the sky
#
# **Demonstration** of the kit's own strategy (`armlab.tasks.events.sky`); it tests nothing of yours.
#
# The scene hands over a large block at (−200, 150) mm after each one that ends on the tower; the robot stacks them at
# a fixed spot (aiming at the same $x, y$ every time keeps errors from adding up). How high can it go? The arm must
# carry the block **over** the tower and come straight down onto it. With the top at $z$, the tool must hover at
# $z + 38 + c$ mm, $c$ the clearance: the kit's default 50 mm would stop the tower at 11 blocks, so the sky strategy
# carries the block only $c = 15$ mm over the top (the empty finger tips still end 7 mm above it). The highest tool
# point the RX200 reaches is about 510 mm, at 150–180 mm from the waist axis with the gripper horizontal (straight
# down only about 260 mm: the upper levels come in tilted), so the tower stands 170 mm out on the diagonal. The arm
# runs out of reach long before 20 blocks ($20 \cdot 38 = 760$ mm).

# %%
print("highest tool point at the tower spot: "
      f"{highest_tool_z(TOWER_XY):.0f} mm at any pitch, {highest_tool_z(TOWER_XY, top_down=True):.0f} mm top-down")

# %%
station = event_station("sky", seed=0)
sky = run_event(start_session(station), "sky")
tower = len(sky.score.lines)
print(sky.summary())
heights = [o.top_z for o in max(columns(station.world.objects), key=len)]
print(f"tower: {tower} blocks, top at {heights[-1]:.0f} mm; {sky.score.points:g} points")

# %%
fig, ax = plt.subplots(figsize=(4.6, 4.6))
col = max(columns(station.world.objects), key=len)
for o in col:
    ax.add_patch(plt.Rectangle((o.position[0] - 19, o.bottom_z), 38, 38, fc=np.array(LAB_RGB[o.color]) / 255,
                               ec="k", lw=0.5))
reach_z = highest_tool_z(TOWER_XY)
ax.axhline(heights[-1], color="0.5", ls=":")
ax.axhline(reach_z, color="C3", ls="--")
ax.text(TOWER_XY[0] + 30, heights[-1] - 6, "top of the tower", ha="left", va="top", fontsize=8, color="0.3")
ax.text(TOWER_XY[0] + 30, reach_z + 6, "highest tool point here", ha="left", va="bottom", fontsize=8, color="C3")
ax.set(xlim=(TOWER_XY[0] - 60, TOWER_XY[0] + 200), ylim=(0, 560), aspect="equal", xlabel="x (mm)",
       ylabel="z (mm)", title="the tower, side view")
fig.tight_layout()

# %%
# demonstration: the kit's strategy, not your work
assert tower >= 12, f"the tower has {tower} blocks (expected at least 12)"
assert sky.score.points == scoring.sky_points(tower), "the score does not follow the sky rules"
assert "out of reach" in sky.stopped, f"the tower stopped for another reason: {sky.stopped}"
print(f"OK: to the sky: a stable tower of {tower} blocks ({sky.score.points:g} points); it stopped because the next "
      f"level is out of the arm's reach")

# %% [markdown]
# **Question `events.tower_question` (2 points, written).** Read the tower figure. How many points does this tower
# earn under the to-the-sky rule (30 for each of the first 8 blocks, 50 for each one above; show the sum)? Between
# the tower's top and the highest tool point there is still room: what else has to fit into it for the next block
# to be put on (think of the held block, the clearance and the finger tips), and what would you change in the
# strategy to gain one more block — at what risk?

# %% [markdown]
# <!-- BEGIN ANSWER events.tower_question -->
# 12 blocks: 8 x 30 + 4 x 50 = 440 points. The 13th block's bottom would go on the top at 456 mm; gripped at its
# centre it hangs 19 mm below the tool point, so the tool must come down to about 477 mm, and it comes straight down
# from a hover the held block's height plus the 15 mm clearance higher, about 511 mm: the very highest point the tool
# reaches there, where the arm can no longer move it straight down at any pitch. For one more block: grip it higher
# up (less of it below the tool: the same tower top needs a lower tool), carry it in with less clearance, or build at
# the spot where the arm reaches highest while still coming down near-vertically. The risk: a grip off the centre
# tilts the block in the pads, and less clearance lets a few mm of sag or detection error knock the tower over.
# <!-- END ANSWER -->

# %% [markdown]
# ## Your table for this notebook
#
# What `python -m armlab check` lists for this notebook: each exercise, its points, its kind, how it is graded and
# whether you have written it (from the saved files: save the notebook first). The grader decides the score.

# %%
from armlab_course.exercises.rubric import rubric

rubric("07_autonomous_tasks")
