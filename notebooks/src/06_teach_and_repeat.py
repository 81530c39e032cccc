# %% [markdown]
# # 06 · Teach and repeat: swap two blocks
#
# The lab's first manipulation task needs no camera at all: turn the motors' torque off, move the arm by hand, record
# waypoints (joint angles and whether the gripper should be open or closed), then let the arm replay them. The lab
# report's exercise swaps two blocks, A at (−100, 225) and B at (100, 225) mm, through an intermediate spot at
# (250, 75) mm: A → intermediate, B → A, intermediate → B. In this notebook you
# 1. teach the swap (on the simulator your "hand" is `arm.move_by_hand`),
# 2. save it as a JSON file and load it back (with validation),
# 3. replay it and plot the joint angles against time (the lab report's figure 10),
# 4. check with the simulator's ground truth that the blocks really swapped,
# 5. do the same swap with your `move_path` of notebook 05 (the report's `move_path`), and compare,
# 6. replay the program faster, within every joint's limits.
#
# | exercise | points | kind | how it is graded |
# |---|---|---|---|
# | `teach.replay` | 10 | code | hidden teaching sessions (other poses, gripper states, seeds), programs and speeds |
# | `teach.replay_question` | 2 | written | by hand, from your answer under the swap figure |
#
# Section 5 also runs your `grab.move_path` (notebook 05; graded there). The cells called **Check** test your work;
# the rest show the kit. Units: radians, seconds, millimetres; world (board) frame.

# %%
import numpy as np
import matplotlib.pyplot as plt
import tempfile
from pathlib import Path
from IPython import get_ipython

from armlab import kinematics, make_station, planning, tasks
from armlab._paths import data_path
from armlab_course.exercises import references, require_written, with_reference
from armlab.tasks import teach
from armlab.detection import Block
from armlab.tasks.move_path import default_path, drop_with, grab_with, move_path
from armlab.transforms import wrap_quarter

get_ipython().run_line_magic("matplotlib", "inline")
from armlab.viz.figures import readable

readable()                                             # figure size and fonts readable at 100 % zoom
np.set_printoptions(precision=1, suppress=True)
station = make_station("sim", seed=0, scene="swap")
for o in station.world.blocks:
    print(f"{o.color:4s} block at {o.position} mm")

# %% [markdown]
# ## 1 · Teach
#
# Each move of the swap is six waypoints: above the block (open), down at the block's centre (close), back up
# (closed), above the destination (closed), down until the block is a few mm above the board (open), back up (open).
# A waypoint's gripper state is the state *after* arriving there. `teach.swap_waypoints()` gives the poses a careful
# student would hold the arm in (top-down, fingers square to the block); teaching records what the encoders read.
# **Exercise `teach.replay`, first part:** record one waypoint per pose with the `Recorder` (torque goes off when it is
# created).

# %%
def teach_program(arm, poses, gripper, name="swap"):
    """Teach by hand: hold the arm (torque off) in each pose of `poses` (N, 5) rad, record a waypoint with the
    gripper state `gripper[i]`, and return the TeachProgram (the torque comes back on)."""
    recorder = teach.Recorder(arm, name=name)
    try:
        # BEGIN SOLUTION teach.replay
        for q, g in zip(poses, gripper):
            arm.move_by_hand(q)
            recorder.record(g)
        # END SOLUTION
    except BaseException:
        arm.set_torque(True)      # never leave the arm limp
        raise
    return recorder.finish()


def kit_recording(arm, poses, gripper, name="swap"):
    """The reference while teach.replay is blank: the kit's own recording of the swap (data/teach/swap.json)."""
    return teach.load_teach(data_path("teach/swap.json"))


poses, gripper = teach.swap_waypoints()
# your teach_program; while it is blank the kit's recording of the swap stands in (it says so once)
program = with_reference(teach_program, "teach.replay", kit_recording,
                         "the program is the kit's recording of the swap")(station.arm, poses, gripper)
print(f"{len(program)} waypoints; gripper states: {' '.join(g[0] for g in program.gripper)} (o = open, c = closed)")
print("first waypoint (rad):", program.q[0].round(3))

# %%
# CHECK teach.replay
require_written("teach.replay")          # the program above must be yours, not the kit's recording
tool = kinematics.fk(program.q)[:, :3, 3]
assert len(program) == 18, f"{len(program)} waypoints recorded, expected one per pose (18)"
assert station.arm.torque_enabled, "the torque is still off after finish()"
assert np.abs(tool[1] - [-100, 225, 19]).max() < 2.0, f"waypoint 1 puts the tool at {tool[1].round(1)} mm, not at A"
print(f"OK: teach: 18 waypoints; waypoint 1 is the grasp at A, tool at {tool[1].round(1)} mm")

# %% [markdown]
# ## 2 · Save and load
#
# A teach file is small JSON (`{"format": "armlab-teach/1", "waypoints": [{"q": [...], "gripper": "open"}, ...]}`),
# written atomically (a temporary file, then a rename) so a crash never leaves half a file. Loading checks everything
# — the shape of each waypoint, the joint limits, the gripper values — and says which waypoint is wrong.

# %%
folder = Path(tempfile.mkdtemp())
path = teach.save_teach(program, folder / "swap.json")
loaded = teach.load_teach(path)
broken = path.read_text().replace('"closed"', '"half-open"', 1)
(folder / "broken.json").write_text(broken)
try:
    teach.load_teach(folder / "broken.json")
except tasks.TeachFileError as e:
    print("refused:", str(e).replace(str(folder), "<folder>"))

# %%
assert np.abs(loaded.q - program.q).max() < 1e-6 and loaded.gripper == program.gripper, "the program did not round-trip"
print("OK: save/load: the program round-trips (to 1e-6 rad) and a bad gripper value is refused")

# %% [markdown]
# ## 3 · Repeat, and figure 10
#
# Replaying moves to each waypoint in turn with the lab's timing rule (the largest joint change at $\pi/4$ rad/s, at
# least 0.4 s, ramps a third of the move, never above a joint's velocity limit) and opens or closes the gripper when
# the recorded state changes. The taught poses were held by hand, with no load on the motors; under torque the arm
# sags a few millimetres, so we replay through the guarded arm of a task session (`tasks.start_session(station)`: it
# calibrates the camera and fits the sag model once, moving the arm out of the camera's view), which commands the arm
# so that it ends where the hand held it (notebook 05). The whole replay is a `planning.Plan`, so we can plot it
# before running it.

# %%
fig, ax = plt.subplots(figsize=(8.5, 3.6))
teach.plot_teach(loaded, ax=ax)
ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=9, frameon=False)   # beside the data, not on it
fig.tight_layout()
plan = loaded.to_plan()
print(f"replay: {len(plan.steps)} steps, {plan.duration:.1f} s")

# %%
session = tasks.start_session(station)   # calibrates the camera and fits the sag model, once, here
arm = session.arm                        # sag-compensated
red, blue = (next(o for o in station.world.blocks if o.color == c) for c in ("red", "blue"))
a, b = red.position.copy(), blue.position.copy()
result = tasks.repeat(arm, loaded)
print("grasps:", result.grasps)
print(f"red block now at {red.position} mm, blue block now at {blue.position} mm")

# %% [markdown]
# ## 4 · Did they swap?

# %%
# CHECK teach.replay
require_written("teach.replay")
peak = max(float(np.max(s.trajectory.peak_speed() / station.arm.robot.velocity)) for s in plan.steps
           if hasattr(s, "trajectory"))
assert result.grasps == (True, True, True), f"grasps {result.grasps}: a block was not held"
assert np.abs(red.position - b).max() < 3.0, f"red is {np.abs(red.position - b).max():.1f} mm from B's spot"
assert np.abs(blue.position - a).max() < 3.0, f"blue is {np.abs(blue.position - a).max():.1f} mm from A's spot"
assert peak <= 1.0, f"a joint ran at {100 * peak:.0f}% of its velocity limit"
print(f"OK: swap: red is {np.abs(red.position - b).max():.1f} mm from B's spot, blue "
      f"{np.abs(blue.position - a).max():.1f} mm from A's; peak joint speed {100 * peak:.0f}% of its limit")

# %% [markdown]
# ## 5 · The same swap with `move_path`
#
# The report did the swap by teaching; its click-to-grab used `move_path`, which plans each pick and place from a
# point. Here the three moves of the swap run through **your** `move_path` of notebook 05 (while it is blank, a
# stand-in plans and says so: in the student release the lab report's own fixed-height plan), on a fresh station:
# A → intermediate, B → A, intermediate → B, each block picked at its top-face centre as the simulator knows it (no
# camera here, as in the taught swap).

# %%
path = with_reference(move_path, "grab.move_path", *default_path())
path_station = make_station("sim", seed=0, scene="swap")
path_session = tasks.start_session(path_station)
path_red, path_blue = (next(o for o in path_station.world.blocks if o.color == c) for c in ("red", "blue"))
spot_a, spot_b, middle = path_red.position.copy(), path_blue.position.copy(), np.array([250.0, 75.0, 19.0])
t0 = path_station.world.time_s
for block, to in ((path_red, middle), (path_blue, spot_a), (path_red, spot_b)):
    top = block.position + [0, 0, block.edge / 2]
    known = Block(block.color, block.size, top, float(wrap_quarter(block.yaw)), (0.0, 0.0), block.edge)
    grab_with(path_session, known, path=path)
    drop_with(path_session, to - [0, 0, block.edge / 2], path=path)
path_time = path_station.world.time_s - t0
print(f"swap by move_path: {path_time:.0f} s simulated; the taught replay: {plan.duration:.0f} s of plan")
print(f"red now at {path_red.position.round(1)} mm, blue at {path_blue.position.round(1)} mm")

# %%
# CHECK grab.move_path
require_written("grab.move_path")
swap_err = max(np.abs(path_red.position - spot_b).max(), np.abs(path_blue.position - spot_a).max())
assert swap_err < 3.0, f"after the move_path swap a block is {swap_err:.1f} mm from its spot"
print("OK: your move_path swapped the blocks, each within 3 mm of its spot")

# %% [markdown]
# **Question `teach.replay_question` (2 points, written).** Look at the joint-angle figure of section 3 (the report's
# Fig. 10 for this swap). Which joints move during a pick's descent and lift, and which only between the spots? The
# taught program and the `move_path` swap do the same job: compare their times printed above, and say what each
# needs from the lab (the camera, the calibration, your hands) and what happens to each when block B starts 20 mm
# from where it was taught.

# %% [markdown]
# <!-- BEGIN ANSWER teach.replay_question -->
# Descents and lifts move the shoulder, elbow and wrist angle together (a straight vertical line needs all three)
# while the waist and the wrist rotation stay put; the waist (and the wrist rotation, to square the fingers) turn only
# in the moves between spots. The taught replay needs no camera and no calibration, only a careful student's hands,
# and repeats exactly what was taught: with B 20 mm away the fingers close beside it or on its edge and the swap fails.
# The move_path swap needs a point per block (a calibrated camera's detection in the lab) and plans every motion from
# it, so a block 20 mm away is still picked at its centre; its time differs from the replay's because it plans its own
# hover heights and joint moves instead of the taught waypoints.
# <!-- END ANSWER -->

# %% [markdown]
# ## 6 · A time-scaled replay
#
# A demonstration runs at the lab's pace; a competition wants the same program faster. Scaling time by a speed
# factor $s$ divides each segment's moving time, but two floors stay: the driver's shortest move (0.4 s) and every
# joint's velocity limit $v_j$ (`robot.velocity`). The lab's pace moves the largest joint change of a segment at
# $\pi/4$ rad/s; the replay's moves are trapezoids whose ramps take a third of the move each: work out how fast a
# joint of a segment of moving time $T$ peaks, and so how short $T$ may be for each joint.
#
# **Exercise (the rest of `teach.replay`):** write `scaled_durations(program, speed)`, the moving time of each
# segment, and `scaled_plan(program, durations)`, the replay as a `planning.Plan`: a `planning.MoveStep` of a
# `planning.joint_move` per segment (with its `duration`), and a `planning.GripperStep` wherever the recorded gripper
# state changes (and one at the start, for the first waypoint's state). We replay the swap at 1.5× on a fresh
# station.

# %%
robot = station.arm.robot           # joint velocity limits: robot.velocity (rad/s)


def scaled_durations(program, speed):
    """Moving time (s) of each segment between consecutive waypoints (len(program) - 1,) when replaying at `speed`
    times the lab's pace (the largest joint change at speed * pi/4 rad/s), at least 0.4 s, and never so short that a
    joint's trapezoid peak speed |dq| / (2/3 T) exceeds its velocity limit (robot.velocity, rad/s)."""
    # BEGIN SOLUTION teach.replay
    dq = np.abs(np.diff(program.q, axis=0))
    lab_pace = dq.max(axis=1) / (speed * np.pi / 4)
    velocity_floor = (dq / (2 / 3 * robot.velocity)).max(axis=1)
    return np.maximum(np.maximum(lab_pace, velocity_floor), 0.4)
    # END SOLUTION


def scaled_plan(program, durations):
    """The program as a Plan whose joint moves take `durations` (s), with its gripper actions (starts at waypoint 0)."""
    # BEGIN SOLUTION teach.replay
    def grip(state, where):
        return planning.GripperStep("close" if state == "closed" else "open", where)

    steps = [grip(program.gripper[0], "at waypoint 0")]
    for i, T in enumerate(durations, start=1):
        steps.append(planning.MoveStep(planning.joint_move(program.q[i - 1], program.q[i], duration=float(T)),
                                       f"to waypoint {i}"))
        if program.gripper[i] != program.gripper[i - 1]:
            steps.append(grip(program.gripper[i], f"at waypoint {i}"))
    return planning.Plan(tuple(steps))
    # END SOLUTION


# your scaled_durations; while it is blank the kit's search stands in (it says so once)
durations = with_reference(scaled_durations, "teach.replay", references.scaled_durations_by_search,
                           "segment times come from a search over the kit's trapezoid moves")
replay_plan = with_reference(scaled_plan, "teach.replay", lambda program, durations: program.to_plan(),
                             "the replay is the program at the lab's pace (TeachProgram.to_plan)")
fast_station = make_station("sim", seed=0, scene="swap")
fast_arm = tasks.start_session(fast_station).arm
fast_arm.move_to(loaded.q[0])
fast = replay_plan(loaded, durations(loaded, 1.5))
fast_result = planning.execute(fast, fast_arm)
red_fast, blue_fast = (next(o for o in fast_station.world.blocks if o.color == c) for c in ("red", "blue"))
print(f"replay at 1.5x: {fast.duration:.1f} s instead of {plan.duration:.1f} s; grasps {fast_result.grasps}")

# %%
# CHECK teach.replay
require_written("teach.replay")
lab_pace = [s.trajectory.duration for s in loaded.to_plan().steps if hasattr(s, "trajectory")]
mine = {s: scaled_durations(loaded, s) for s in (0.5, 1.0, 1.5, 4.0)}
assert np.allclose(mine[1.0], lab_pace, atol=1e-9), \
    f"at speed 1 your times {np.round(mine[1.0], 2)} s should be the lab's {np.round(lab_pace, 2)} s"
assert np.all(mine[4.0] >= 0.4 - 1e-12), "a segment is shorter than the driver's 0.4 s"
for s, times in mine.items():
    for q0, q1, T in zip(loaded.q[:-1], loaded.q[1:], times):
        peak = np.abs(q1 - q0) / (2 / 3 * T)
        assert np.all(peak <= robot.velocity + 1e-9), \
            f"at speed {s} a segment of {T:.2f} s drives a joint at {peak.max():.2f} rad/s, over its velocity limit"
assert np.all(mine[0.5] >= mine[1.0] - 1e-12) and mine[0.5].sum() > 1.5 * mine[1.0].sum(), \
    "half speed should take (about) twice as long"
assert mine[1.5].sum() < mine[1.0].sum(), "1.5x is not faster than the lab's pace"
own = scaled_plan(loaded, mine[1.5])
moves = [s for s in own.steps if isinstance(s, planning.MoveStep)]
grips = [s.action for s in own.steps if isinstance(s, planning.GripperStep)]
changes = 1 + sum(g0 != g1 for g0, g1 in zip(loaded.gripper[:-1], loaded.gripper[1:]))
assert [m.duration for m in moves] == list(mine[1.5]), "the plan's moves do not take the durations given"
assert len(grips) == changes and grips[0] == ("close" if loaded.gripper[0] == "closed" else "open"), \
    f"{len(grips)} gripper steps for {changes} gripper states in a row (the first one included)"
assert fast_result.grasps == (True, True, True), f"the fast replay's grasps {fast_result.grasps}"
swap_err = max(np.abs(red_fast.position - b).max(), np.abs(blue_fast.position - a).max())
assert swap_err < 3.0, f"after the fast replay a block is {swap_err:.1f} mm from its spot"
print(f"OK: time-scaled replay: 1.5x takes {mine[1.5].sum():.1f} s of moves instead of {mine[1.0].sum():.1f} s, "
      f"within every velocity limit; the blocks swapped within {swap_err:.1f} mm")

# %% [markdown]
# ## Your table for this notebook
#
# What `python -m armlab check` lists for this notebook: each exercise, its points, its kind, how it is graded and
# whether you have written it (from the saved files: save the notebook first). The grader decides the score.

# %%
from armlab_course.exercises.rubric import rubric

rubric("06_teach_and_repeat")
