# %% [markdown]
# # 07 · Autonomous tasks: the competition events
#
# Everything so far comes together: the station calibrates its camera, **looks** at the board (detection), **plans**
# a pick and a place (IK, trajectories, clearance), **acts**, and looks again to check what happened. In this
# notebook you run the lab's three competition events on the simulator and score them by the rules:
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

# %%
import numpy as np
import matplotlib.pyplot as plt
from IPython import get_ipython

from armlab.blocks import LAB_RGB, block_edge
from armlab.robot import JOINT_NAMES
from armlab.tasks.events import columns, event_station, run_event, score_event
from armlab.tasks.events.layout import Move, covered
from armlab.tasks.events.replay import objects_from_snapshot
from armlab.tasks.events.sort_stack import ROW_XY, SortStack
from armlab.tasks.events import scoring
from armlab.tasks.events.sky import TOWER_XY, highest_tool_z

get_ipython().run_line_magic("matplotlib", "inline")
from armlab.exercises import with_reference
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


def before_after(result):
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4))
    snaps = result.replay.snapshots
    draw_board(axes[0], objects_from_snapshot(snaps[0][2]), "start")
    draw_board(axes[1], objects_from_snapshot(snaps[-1][2]), f"end ({result.time_s:.0f} s simulated)")
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
# **Exercise.** "To the sky" pays 30 points for each of the first 8 blocks of the tower and 50 for every block
# above: $\text{points}(n) = 30\,\min(n, 8) + 50\,\max(n - 8, 0)$. Write it.

# %%
def sky_points(n):
    """Points for a tower of n large blocks."""
    # BEGIN SOLUTION events.sky_points
    return 30 * min(n, 8) + 50 * max(n - 8, 0)
    # END SOLUTION


# %%
# CHECK events.sky_points
expected = {0: 0, 1: 30, 5: 150, 7: 210, 8: 240, 9: 290, 12: 440, 13: 490, 20: 840, 24: 1040}
wrong = {n: sky_points(n) for n, points in expected.items() if sky_points(n) != points}
assert not wrong, f"sky_points gives {wrong} (n: points): 30 each for the first 8 blocks, then 50 each"
print(f"OK: sky_points is right for towers of {len(expected)} heights; the class record (20) is worth "
      f"{sky_points(20)} points")

# %% [markdown]
# ## 2 · Sort 'n stack, level 3
#
# The strategy (`armlab.tasks.events.sort_stack`) works only from detections:
# 1. **unstack first**: a block seen standing on another is staged on a free spot (the one below is hidden, so the
#    rainbow order can only be planned once every block is seen);
# 2. then, the block with the **earliest rainbow colour** goes on top of its size's stack at (±200, −100) mm;
# 3. after every move the robot **looks again**: the stack's detected top height corrects its belief, a block that
#    fell is found and moved again, a failed grasp is retried.
#
# Distractors are detected as such (`detect_objects(...).shape == "distractor"`) and only avoided.

# %%
station = event_station("sort_stack", 3, seed=0)
sort3 = run_event(station, "sort_stack", 3)
for m in sort3.moves:
    print(f"{m.t_start:6.1f} s  {m.move}")
print(sort3.score.table())
before_after(sort3)

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
_ = ax.legend(fontsize=9, ncol=5, loc="lower right")

# %%
assert sort3.score.full_marks, f"sort 'n stack scored {sort3.score.points:g}/{sort3.score.max_points}"
assert sort3.within_limit, f"sort 'n stack took {sort3.time_s:.0f} s (limit 180 s)"
assert sort3.score == score_event("sort_stack", 3, station.world.objects), "the score is not the world's"
err = np.linalg.norm(sort3.placement_errors[:, :2], axis=1)
assert err.max() < 3.0, f"a block was placed {err.max():.1f} mm from its spot"
print(f"OK: sort 'n stack level 3: {sort3.score.points:g}/{sort3.score.max_points} in {sort3.time_s:.0f} s of 180 s, "
      f"placement error at most {err.max():.1f} mm")

# %% [markdown]
# ## 3 · Line 'em up, level 3
#
# Both lines run along $x$, red nearest the base, 50 mm apart for large blocks (5·50 + 38 = 288 mm < 300) and 40 mm
# for small ones. Along $x$ and at headings within 45° of the line, a top-down gripper placing a block square to
# the line closes **across** the line, so its pads never touch the neighbours (only 12 mm away). The layout (side,
# $y$) is chosen on the first look to avoid distractors; blocks standing where the gripper must come down are moved
# out of the way first, and the highest blocks go first (never lift a block with another on it).

# %%
station = event_station("line_up", 3, seed=0)
line3 = run_event(station, "line_up", 3)
print(line3.summary())
print(line3.score.table())
before_after(line3)

# %%
assert line3.score.full_marks and line3.within_limit, f"line 'em up: {line3.summary()}"
print(f"OK: line 'em up level 3: {line3.score.points:g}/{line3.score.max_points} in {line3.time_s:.0f} s of 600 s")

# %% [markdown]
# ## 4 · To the sky
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
sky = run_event(station, "sky")
tower = len(sky.score.lines)
print(sky.summary())
heights = [o.top_z for o in max(columns(station.world.objects), key=len)]
print(f"tower: {tower} blocks, top at {heights[-1]:.0f} mm; {sky.score.points:g} points")

# %%
fig, ax = plt.subplots(figsize=(3.8, 4.6))
col = max(columns(station.world.objects), key=len)
for o in col:
    ax.add_patch(plt.Rectangle((o.position[0] - 19, o.bottom_z), 38, 38, fc=np.array(LAB_RGB[o.color]) / 255,
                               ec="k", lw=0.5))
ax.axhline(heights[-1], color="0.5", ls=":")
ax.set(xlim=(TOWER_XY[0] - 80, TOWER_XY[0] + 80), ylim=(0, 520), aspect="equal", xlabel="x (mm)",
       ylabel="z (mm)", title="the tower, side view")

# %%
assert tower >= 12, f"the tower has {tower} blocks (expected at least 12)"
assert sky.score.points == scoring.sky_points(tower), "the score does not follow the sky rules"
assert "out of reach" in sky.stopped, f"the tower stopped for another reason: {sky.stopped}"
print(f"OK: to the sky: a stable tower of {tower} blocks ({sky.score.points:g} points); it stopped because the next "
      f"level is out of the arm's reach")

# %% [markdown]
# ## 5 · Your own strategy: sort 'n stack, level 1
#
# A strategy is an object with `next_move(seen)`: given the detections of a fresh look (`detection.Block`s: `color`,
# `size`, `position` = top-face centre in world mm, `is_block`), it returns the next `Move(block, to, yaw, why)` —
# `to` is where the block's *bottom* centre goes, (x, y, 0) on the board — or `None` when it is done. `run_event`
# picks, places, looks again and calls it again; it calls `placed(move)` after each successful place.
#
# Level 1: every cube into $y < 0$, small ones on the left ($x < 0$), large ones on the right. Use the slots
# `ROW_XY[size]` (reachable top-down, clear of each other):
# - a cube is **sorted** when it stands (not on another block) within 20 mm of a slot of its size;
# - take an unsorted cube that nothing covers, the **highest** first (unstacks stacks);
# - send it to the first slot of its size that **no detection occupies** (within 30 mm), so that a block that fell
#   or a failed place is simply seen again;
# - `None` when every cube is sorted.
#
# **Exercise:** write `next_move`.

# %%
class SortLevel1:
    """Sort 'n stack level 1 from what the robot sees (see above)."""

    def __init__(self):
        self.moves = 0

    def next_move(self, seen):
        # BEGIN SOLUTION events.strategy
        def near(b, xy, mm):
            return np.hypot(b.position[0] - xy[0], b.position[1] - xy[1]) < mm

        def is_sorted(b):
            return b.position[2] < block_edge(b.size) + 5.0 and any(near(b, xy, 20.0) for xy in ROW_XY[b.size])

        todo = [b for b in seen if b.is_block and not is_sorted(b)]
        free = [b for b in todo if not covered(b, seen)]
        if not free:
            return None
        b = max(free, key=lambda b: b.position[2])
        slot = next((xy for xy in ROW_XY[b.size] if not any(near(o, xy, 30.0) for o in seen)), None)
        if slot is None:
            return None
        return Move(b, np.array([slot[0], slot[1], 0.0]), 0.0, "sort")
        # END SOLUTION

    def placed(self, move):
        self.moves += 1


# your strategy; while next_move is blank the kit's SortStack(1) plays (it says so once)
mine = SortLevel1()
mine.next_move = with_reference(mine.next_move, "events.strategy", SortStack(1).next_move,
                                "the kit's sort 'n stack strategy plays")
station = event_station("sort_stack", 1, seed=3)
sort1 = run_event(station, "sort_stack", 1, strategy=mine)
print(sort1.summary())

# %%
# CHECK events.strategy
def run_own(seed):
    st = event_station("sort_stack", 1, seed=seed)
    return st, run_event(st, "sort_stack", 1, strategy=SortLevel1(), record=False)


results = [run_own(seed) for seed in (3, 11)]
for seed, (st, res) in zip((3, 11), results):
    assert res.score.full_marks, (f"seed {seed}: your strategy scored {res.score.points:g}/{res.score.max_points} "
                                  f"({res.stopped}): {[line.why for line in res.score.lines if line.points == 0]}")
    assert res.within_limit, f"seed {seed}: it took {res.time_s:.0f} s (limit {res.time_limit_s:.0f} s)"
    assert res.score == score_event("sort_stack", 1, st.world.objects), "the score is not the world's"
    assert not any(not m.placed for m in res.moves), f"seed {seed}: a pick or place failed: {res.moves}"
print(f"OK: your sort 'n stack level 1 strategy: full marks on 2 seeds in "
      f"{' and '.join(f'{res.time_s:.0f} s' for _, res in results)} of {results[0][1].time_limit_s:.0f} s")
