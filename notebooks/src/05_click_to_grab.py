# %% [markdown]
# # 05 · Click to grab: from a pixel to the world to the joints
#
# You click a block in the camera image; the arm picks it up. Behind that click:
# 1. **pixel → world**: the calibrated camera and the depth image turn $(u, v)$ into a world point (you wrote this in
#    notebook 01; here the kit's `tasks.surface_point` does it);
# 2. **the motion sequence**: where the gripper goes, in what order, at what pitch and wrist roll, so that it grasps
#    the block without touching anything else — the lab report's `move_path`, which **you write** here;
# 3. **where the arm really goes**: the arm *sags* under gravity, and the kit compensates for it.
#
# Units: millimetres and radians; world (board) frame: origin on the board below the waist axis, +y away from the
# robot, +z up. Everything runs on the simulator (`make_station("sim")`); `make_station("real")` runs the same code on
# the lab's arm. The kit's tasks work in a **session**: `session = tasks.start_session(station)` calibrates the camera
# and fits the sag model once, there (the arm moves out of the camera's view), and every task (`tasks.look`,
# `tasks.pick`, the clicks) takes that session.
#
# | exercise | points | kind | how it is graded |
# |---|---|---|---|
# | `grab.click_target` | 5 | code | hidden boards of turned and stacked blocks, and clicks on them |
# | `grab.move_path` (in `armlab/tasks/move_path.py`) | 10 | open task | outcome on the simulator (below) |
# | `grab.sag_question` | 2 | written | by hand, from your answer under the sag figure |
#
# `grab.move_path` is graded by outcome: at hidden clicks (other blocks, positions, yaws and sizes) each block must end
# in the gripper and, dropped at a hidden spot, rest within 3 mm of it, every plan passing the kit's safety check.
#
# The cells called **Check** test your work (the grader runs the same kind of check at hidden inputs); cells marked
# **Demonstration** show the kit and test nothing of yours.

# %%
import numpy as np
import matplotlib.pyplot as plt
from IPython import get_ipython

from armlab import kinematics, make_station, planning, tasks
from armlab_course.exercises import require_written, with_reference
from armlab.tasks.experiments import LAB_TABLE_III_ERROR_MM, format_table, reach_experiment
from armlab.tasks.move_path import default_path, drop_with, grab_with, move_path
from armlab.tasks.sag import LAB_BASELINE, calibration_poses, hover_pose

get_ipython().run_line_magic("matplotlib", "inline")
from armlab.sim.gripper import SQUARE_TOLERANCE_RAD, off_square_rad
from armlab.viz.figures import readable

readable()                                             # figure size and fonts readable at 100 % zoom
np.set_printoptions(precision=1, suppress=True)
SCENE = {"objects": [
    {"color": "red", "size": "large", "position_mm": [-150.0, 200.0], "yaw_rad": 0.0},
    {"color": "blue", "size": "small", "position_mm": [200.0, 150.0], "yaw_rad": 0.3},
    {"color": "green", "size": "large", "position_mm": [60.0, 300.0], "yaw_rad": -0.5},
]}
station = make_station("sim", seed=0, scene=SCENE)
session = tasks.start_session(station)  # calibrates the camera (checkerboard, tags, depth plane), fits the sag model
obs = tasks.look(session)               # arm out of view, capture, detect
print(session.calibration.notes)
for b in obs.blocks:
    print(f"{b.color:6s} {b.size:5s} top-face centre {b.position} mm, yaw {np.degrees(b.yaw):5.1f} deg, "
          f"pixel ({b.pixel[0]:.0f}, {b.pixel[1]:.0f})")

# %% [markdown]
# ## 1 · Pixel → world (notebook 01's work, reused)
#
# A click at pixel $(u, v)$ becomes a world point through the depth under it and the calibrated camera: exactly the
# back-projection you wrote and were graded on in notebook 01. Here the kit's `tasks.surface_point` does it (the
# median depth of a small window, corrected for the depth camera's planar bias). **Demonstration.**

# %%
red = next(b for b in obs.blocks if b.color == "red")
p = tasks.surface_point(session.calibration, obs.depth, red.pixel)
truth = next(o for o in station.world.blocks if o.color == "red")
print("clicked the red block at pixel", np.round(red.pixel, 1), "-> world", p, "mm; true top-face centre",
      truth.position + [0, 0, truth.edge / 2])

# %% [markdown]
# ### Which block did the click hit?
#
# The click's world point $p$ lies on whatever surface the camera saw under the pointer. Each detected block is known
# by its top face: a square of edge $e$ (38 or 25 mm) centred at $c$ (world mm), turned by its yaw $\psi$ about the
# vertical, at the height $c_z$. Two facts decide which block the click hit:
#
# * **the face's own axes.** A square turned by $\psi$ is easy to test in the frame that turns with it: express the
#   click's offset from the centre, $p - c$ in $x$ and $y$, in that frame (a rotation about $z$), and the square is
#   just two bounds on its two coordinates. The outline of a face in the depth image is blurred by a pixel or two, so
#   allow a margin $m$ (3 mm) around it;
# * **the depth.** Seen from above, faces can overlap: a small block stacked off-centre on a large one sits inside the
#   large one's square. The click's height $p_z$ tells which surface was under the pointer.
#
# The nearest-centre rule (the nearest face centre within one block edge) ignores both: near the corner of a turned
# block, or on the bare board just beside one, it can pick the wrong block or one that was not clicked.
#
# **Exercise `grab.click_target` (5 points, code):** write `click_target(click, tops, yaws, edges, margin_mm=3.0)`:
# `click` the world point (3,) mm, `tops` (n, 3) the top-face centres (world mm), `yaws` (n,) rad, `edges` (n,) mm;
# return the index of the block whose face the click hit (the one whose height matches the click's best when several
# faces contain it), or -1 when it hit none. Refuse (ValueError) a click that is not a finite point and blocks whose
# arrays do not match.

# %%
def click_target(click, tops, yaws, edges, margin_mm=3.0):
    """The index of the block whose top face the click hit, or -1 (see above)."""
    # BEGIN SOLUTION grab.click_target
    click = np.asarray(click, dtype=float)
    tops = np.asarray(tops, dtype=float).reshape(-1, 3)
    yaws = np.asarray(yaws, dtype=float).reshape(-1)
    edges = np.asarray(edges, dtype=float).reshape(-1)
    if click.shape != (3,) or not np.isfinite(click).all():
        raise ValueError(f"click must be a finite world point (3,) mm, got {click}")
    if not len(tops) == len(yaws) == len(edges):
        raise ValueError(f"tops, yaws and edges must describe the same blocks: {len(tops)}, {len(yaws)} and "
                         f"{len(edges)} given")
    if not len(tops):
        return -1
    offset = click[:2] - tops[:, :2]                      # (n, 2) from each face's centre, world axes
    cos, sin = np.cos(yaws), np.sin(yaws)
    along = cos * offset[:, 0] + sin * offset[:, 1]       # the offset in each face's own axes
    across = -sin * offset[:, 0] + cos * offset[:, 1]
    half = edges / 2 + margin_mm
    hit = np.flatnonzero((np.abs(along) <= half) & (np.abs(across) <= half))
    if not hit.size:
        return -1
    height_gap = np.abs(tops[hit, 2] - click[2])          # the depth says which surface the camera saw
    return int(hit[np.argmin(height_gap)])
    # END SOLUTION


# %% [markdown]
# *Demonstration* on this scene (your rule where you have written it, the kit's otherwise): clicks near the corners of
# the turned green block, at 0.47 of its edge along its diagonals, and on bare board 6 mm beside each block.

# %%
from armlab_course.exercises import references

my_click_target = with_reference(click_target, "grab.click_target", references.click_target_by_kit,
                                 "the kit's nearest-centre rule stands in for your click_target")
tops = np.array([b.position for b in obs.blocks])
yaws = np.array([b.yaw for b in obs.blocks])
edges = np.array([b.edge_mm for b in obs.blocks])
green = [b.color for b in obs.blocks].index("green")
turn = np.array([[np.cos(yaws[green]), -np.sin(yaws[green])], [np.sin(yaws[green]), np.cos(yaws[green])]])
corners = [tops[green] + [*(turn @ (0.47 * edges[green] * np.array(d))), 0.0]
           for d in ((1, 1), (1, -1), (-1, 1), (-1, -1))]
beside = [t + [*(turn_k @ [e / 2 + 6.0, 0.0]), -t[2]] for t, e, turn_k in
          zip(tops, edges, [np.array([[np.cos(y), -np.sin(y)], [np.sin(y), np.cos(y)]]) for y in yaws])]


def name(k):
    return "none" if k < 0 else obs.blocks[k].color


print(f"{'click (world mm)':>24}  {'yours':>6}  {'kit':>6}")
for point in [*corners, *beside]:
    mine, kit = my_click_target(point, tops, yaws, edges), references.click_target_by_kit(point, tops, yaws, edges)
    print(f"{np.array2string(np.round(point, 0), precision=0):>24}  {name(mine):>6}  {name(kit):>6}")

# %% [markdown]
# ### Check: which block a click hit

# %%
# CHECK grab.click_target
require_written("grab.click_target")
for k, b in enumerate(obs.blocks):
    assert click_target(b.position, tops, yaws, edges) == k, f"a click at the {b.color} face's centre is not on it"
for point in corners:
    got = click_target(point, tops, yaws, edges)
    assert got == green, f"a click inside the turned green face near its corner {point.round(0)} gave {got}: " \
                         "test the point in the face's own axes"
for point in beside:
    got = click_target(point, tops, yaws, edges)
    assert got == -1, f"a click on the board 6 mm beside a face {point.round(0)} gave {got}, not -1"
stack_tops = np.array([[0.0, 250.0, 38.0], [4.0, 247.0, 63.0]])        # a small block off-centre on a large one
stack_yaws, stack_edges = np.array([0.2, -0.4]), np.array([38.0, 25.0])
assert click_target([4.0, 247.0, 63.4], stack_tops, stack_yaws, stack_edges) == 1, \
    "a click on the small block on top went to the large one below: let the click's height decide"
assert click_target([-15.0, 250.0, 37.6], stack_tops, stack_yaws, stack_edges) == 0, \
    "a click on the large block's uncovered edge did not hit it"
assert click_target([0.0, 250.0, 0.0], np.empty((0, 3)), [], []) == -1, "no blocks: the answer is -1"
try:
    click_target([0.0, np.nan, 0.0], tops, yaws, edges)
    raise AssertionError("a NaN click was not refused")
except ValueError:
    pass
print(f"OK: every face centre, the four corners of the turned green face and the stack's two surfaces hit the "
      f"right block; the {len(beside)} clicks beside the faces hit none")

# %% [markdown]
# ## 2 · The motion sequence: `move_path`
#
# The lab report's `move_path` lifted the gripper to 275 mm, came down to 150 mm, then to "half the height of the
# block", and closed or opened the gripper. Fixed heights like these are safe only on an empty board and waste
# time; you will plan the same sequence from the block itself. Write `move_path(q_start, target, yaw, edge, action,
# clearance)` in `armlab/tasks/move_path.py`: it returns a `planning.Plan` (a tuple of `planning.MoveStep` and
# `planning.GripperStep`) that the kit checks whole and runs (`grab_with` / `drop_with`).
#
# What the plan must respect (derive each number from these; none is given):
# - **The grasp height.** The fingers' pads are 16 mm tall and centred on the tool point, so the finger tips reach
#   `GRIPPER.fingertip_mm` beyond it (`armlab.gripper_geometry`). Grip a cube as the report did, through its middle,
#   unless the tips would then come within `TIP_MARGIN_MM` of what the cube stands on (the real arm sags 5–15 mm
#   at long reach): then grip it higher. For "release", `target` is where the held cube's *bottom* face goes.
# - **Clearance.** Arrive above the target, come **straight down** (a `planning.cartesian_line`), act, and go
#   **straight back up**, so that the lowest part of the gripper — or of the cube it holds — passes `clearance` mm
#   above what it leaves. The joint move to that hover point (`planning.joint_move`) starts from `q_start`. Open the
#   gripper before coming down to grasp.
# - **Pitch.** Top-down (pitch $\pi/2$) keeps the pads square and the descent vertical, but the RX200 cannot point
#   straight down far from its base (notebook 03's reach map). Take the steepest pitch at which the whole straight
#   descent can be made (`cartesian_line` raises `kinematics.Unreachable` where it cannot), trying pitches in small
#   steps.
# - **Roll.** The pads must close across two opposite faces of the cube. Notebook 03 gave the tool's orientation
#   $R_z(h)\,R_y(\text{pitch})\,R_x(\text{roll})$ at heading $h = \operatorname{atan2}(y, x)$; the cube's face
#   normals point at its yaw plus multiples of $\pi/2$. `planning.tilted_roll(heading, pitch, yaw)` gives the roll
#   that lines the pads up at any pitch — check on paper why a quarter turn of the wrist changes nothing.
#
# Section 5 below shows what goes wrong when the roll ignores the yaw.

# %%
# your move_path; while it is blank a stand-in plans and says so once (in the student release the lab report's own
# plan: fixed heights, joint moves, the pads square to the board's axes rather than to the block)
path = with_reference(move_path, "grab.move_path", *default_path())
plan = path(session.arm.joint_positions(), red.position, float(red.yaw), 38.0, "grasp")
print(plan.describe())
sampled = planning.sample_plan(plan, 0.05)
tool_z = kinematics.fk(sampled.q)[:, 2, 3]
fig, ax = plt.subplots(figsize=(7.5, 3.0))
ax.plot(sampled.t, tool_z, color="C0")
ax.set_ylim(0, 200)                                    # the joint move comes down from the camera-clear pose above
ax.axhline(red.position[2], color="C3", ls=":", lw=1)
ax.text(sampled.t[0], red.position[2] + 4, "top of the red block", color="C3", fontsize=9)
ax.set(xlabel="time in the plan (s)", ylabel="tool point z (mm)", title="your grasp plan for the red block")
fig.tight_layout()

# %% [markdown]
# ## Check: your `move_path` grabs and drops on the simulator
#
# A fresh station with the same three blocks: each is clicked (its detected top-face centre), grabbed with your plan
# and dropped with your plan at a free spot. The simulator's ground truth decides: the block is in the gripper after
# the grasp, held square (its faces flat on the pads, within `SQUARE_TOLERANCE_RAD`: `off_square_rad` measures it),
# and after the release it rests within 3 mm of the spot. Every plan must come straight down: its last move
# before the gripper acts stays within `planning.STRAIGHT_TOLERANCE_MM` of the vertical
# (`planning.approach_deviation`). And every plan passes the kit's safety check first (a plan that would touch the
# board, another block or a joint limit raises `MotionRefused` and nothing moves).

# %%
# CHECK grab.move_path
require_written("grab.move_path")
check_station = make_station("sim", seed=1, scene=SCENE)
check_session = tasks.start_session(check_station)
spots = {"red": [-250.0, 80.0, 0.0], "blue": [250.0, 60.0, 0.0], "green": [0.0, 220.0, 0.0]}
landed = {}


def straight_move_path(q_start, target, yaw, edge, action):
    """Your move_path, its final approach measured before the plan runs."""
    checked = move_path(q_start, target, yaw, edge, action)
    bow = planning.approach_deviation(checked, "close" if action == "grasp" else "open")
    assert bow <= planning.STRAIGHT_TOLERANCE_MM, \
        f"your {action} plan's last move strays {bow:.1f} mm from the vertical: it does not come straight down"
    return checked


for block in tasks.look(check_session).blocks:
    block_truth = next(o for o in check_station.world.blocks if o.color == block.color)
    assert grab_with(check_session, block, path=straight_move_path) and block_truth.id in check_station.world.held, \
        f"your plan did not grasp the {block.color} block (the gripper closed on nothing)"
    turned = off_square_rad(check_station.arm.tool_pose_true(), block_truth)
    assert turned <= SQUARE_TOLERANCE_RAD, \
        f"your plan grasped the {block.color} block {np.degrees(turned):.0f} deg off square: the pads pinched it on " \
        f"two edges instead of closing flat on two faces"
    drop_with(check_session, np.array(spots[block.color]), 0.0, path=straight_move_path)
    assert not check_station.world.held, f"the {block.color} block is still held after your release plan"
    bottom = block_truth.position - [0, 0, block_truth.edge / 2]
    landed[block.color] = np.abs(bottom - spots[block.color]).max()
    assert landed[block.color] < 3.0, f"the {block.color} block landed {landed[block.color]:.1f} mm from its spot"
print("OK: move_path: your plans came straight down, grabbed all 3 blocks and dropped each within 3 mm of its spot, "
      "every plan passing the safety check")

# %% [markdown]
# ## 3 · Where the arm really goes: sag
#
# The servos hold the commanded angles, but links and gears bend under gravity: shoulder and elbow give by a
# compliance times the gravity moment of what lies beyond them. With lumped masses at the elbow, wrist and tool, each
# moment is *linear* in the horizontal distances from the joint to those points, so the joint errors are linear in a
# few unknown compliances, and so is the tool's error $J(q)\,\delta q$. Measuring the tool point at a few dozen
# poses (on the real arm: touch-off on the grid with a height gauge; here the simulator's ground truth plus 1 mm
# reading noise) gives one least-squares problem (`tasks.fit_sag`). **Demonstration** of the kit's model.
#
# What is compared: the **simulated** arm's sag, with three corrections —
# - the **lab report**'s: every target raised by a flat 16 mm (Table II/III: "the Z_w coordinates were all offset by
#   16mm"), measured on the **real** arm;
# - a **straight line in the reach** $r$ fitted to these simulated measurements (least squares). The kit's default
#   line $z \mathrel{+}= 0.068\,r + 3$ mm is **the kit's own rule**, not the report's;
# - the kit's **joint compliance model**.

# %%
rng = np.random.default_rng(0)
poses = calibration_poses()
measured = []
for qc in poses:                       # the raw arm, no compensation
    above = hover_pose(qc)             # 60 mm above the pose (None far out: approached directly)
    station.arm.move_to(qc if above is None else above)
    station.arm.move_to(qc)
    measured.append(station.arm.tool_pose_true()[:3, 3] + rng.normal(0, 1.0, 3))
measured = np.array(measured)
commanded = kinematics.fk(poses)[:, :3, 3]
reach = np.hypot(commanded[:, 0], commanded[:, 1])
sag = commanded[:, 2] - measured[:, 2]                      # mm the tool ends below its target
model = tasks.fit_sag(poses, measured)
slope, offset = np.polyfit(reach, sag, 1)
predicted = -model.tool_error(poses)[:, 2]
rms = {"flat 16 mm (report)": np.sqrt(np.mean((sag - 16.0) ** 2)),
       "kit's line 0.068 r + 3": np.sqrt(np.mean((sag - (LAB_BASELINE[0] * reach + LAB_BASELINE[1])) ** 2)),
       "fitted line": np.sqrt(np.mean((sag - (slope * reach + offset)) ** 2)),
       "joint model": np.sqrt(np.mean((sag - predicted) ** 2))}
for name, value in rms.items():
    print(f"{name:>24}: residual RMS {value:4.1f} mm")
fig, ax = plt.subplots(figsize=(7.5, 3.8))
ax.plot(reach, sag, "o", color="C0", ms=5, label="measured (simulated arm)")
ax.plot(reach, predicted, "x", color="C2", label="joint model")
r_line = np.linspace(100, 460, 2)
ax.plot(r_line, slope * r_line + offset, "--", color="C1", label="fitted line")
ax.axhline(16.0, color="C3", ls=":", label="report: flat 16 mm (real arm)")
ax.set(xlabel="reach r (mm)", ylabel="sag: tool below target (mm)", ylim=(-2, 20),
       title=f"fitted line leaves {rms['fitted line']:.1f} mm RMS, the joint model {rms['joint model']:.1f} mm")
ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=9)
fig.tight_layout()

# %% [markdown]
# **Question `grab.sag_question` (2 points, written).** Read the figure. On this simulated arm, how far from its
# target would the report's flat 16 mm offset leave the tool at 150 mm and at 450 mm of reach, and why could the same
# flat offset still look good in the report's Table III (its six locations lie 150–270 mm from the base, on the real
# arm)? The fitted line and the joint model leave almost the same residual here: what in the figure would have to look
# different for the joint model to be clearly worth its nine parameters, and what would you measure on the real arm
# to find out?

# %% [markdown]
# <!-- BEGIN ANSWER grab.sag_question -->
# At 150 mm the simulated arm sags about 1 mm, so +16 mm leaves the tool about 15 mm too high; at 450 mm it sags about
# 11 mm, so about 5 mm too high. The report's Table III "corrected Zw" shows it also corrected the z by hand per
# location, and its targets all sat at one height and a narrow band of reach, where one offset is close to right for a
# heavier real arm. The joint model pays off when the sag at one reach depends on the pose (high and low targets, a
# held block): the measured points would then spread widely at each reach, beyond the 1 mm reading noise, and the
# line could not follow them. On the real arm: touch off a dozen or more poses spread over reach and over the heights
# the tasks use (board, block tops, stacks), and compare the residuals.
# <!-- END ANSWER -->

# %% [markdown]
# ## 4 · The lab report's six locations (Tables II and III), on the simulated arm
#
# **Demonstration.** For each of the report's six locations the simulated student clicks the grid point in the image;
# the click becomes a world point; the tool goes top-down to 37 mm above it; we measure where the tool really is.
# Once with the raw arm, once through the session's guarded arm (`session.arm`, which applies the fitted sag model).
#
# What is compared: the **simulated** arm (its sag and its camera are the simulator's, with the kit's calibration) with
# the **real** arm of the lab report (Table III: 7.5 / 9.2 / 2.5 mm mean error in x / y / z, after the report's flat
# 16 mm z offset and the "corrected Zw" of Table III). The report's numbers are printed for orientation only: they are
# not like for like (a different arm, camera, calibration and measurement), so no verdict is drawn from them.

# %%
measure = lambda: station.arm.tool_pose_true()[:3, 3]  # noqa: E731
raw = reach_experiment(session, station.arm, measure)
comp = reach_experiment(session, session.arm, measure)
rows = [[f"{i + 1}", *r.desired, *c.actual, *LAB_TABLE_III_ERROR_MM[i], *r.error, *c.error]
        for i, (r, c) in enumerate(zip(raw, comp))]
avg = lambda rr: np.mean([r.error for r in rr], axis=0)  # noqa: E731
rows.append(["avg", "", "", "", "", "", "", *LAB_TABLE_III_ERROR_MM.mean(axis=0), *avg(raw), *avg(comp)])
print(format_table(["loc", "want x", "y", "z", "got x", "y", "z", "report |dx|", "|dy|", "|dz|", "sim raw |dx|", "|dy|",
                    "|dz|", "sim comp |dx|", "|dy|", "|dz|"], rows))
print(f"simulated arm, sag compensated: mean error {avg(comp).round(1)} mm; raw: {avg(raw).round(1)} mm "
      f"(the report's real arm, Table III: 7.5 / 9.2 / 2.5 mm, not like for like)")

# %% [markdown]
# ## 5 · The misaligned wrist
#
# **Demonstration** (the kit's own `tasks.pick`). The green block is turned by about $-29°$. Grasp it with the wrist
# unturned (as if its yaw were 0) and the fingers
# land on its corners: the parallel gripper fails to hold it, shoves it around, or pinches it on two edges and
# carries it still turned between the pads (the simulator's grasp is contact physics: the squeeze's couple turns the
# block, the rubber pads' friction resists). Turning the wrist by the block's detected yaw (section 2) closes the
# fingers flat on two faces.

# %%
green = next(b for b in tasks.look(session).blocks if b.color == "green")
green_truth = next(o for o in station.world.blocks if o.color == "green")
yaw_before = green_truth.yaw
held_unturned = tasks.pick(session, type(green)(**{**green.__dict__, "yaw": 0.0}))   # pretend it is not turned
off_pads = off_square_rad(station.arm.tool_pose_true(), green_truth)      # its faces against the pads'
print(f"roll 0: held = {held_unturned} ({station.arm.last_grasp}); block yaw {np.degrees(yaw_before):.1f} -> "
      f"{np.degrees(green_truth.yaw):.1f} deg, {np.degrees(off_pads):.0f} deg off square to the pads")
if held_unturned:
    tasks.place(session, green_truth.position - [0, 0, green_truth.edge / 2])
green = next(b for b in tasks.look(session).blocks if b.color == "green")
held_turned = tasks.pick(session, green)
print(f"roll from the yaw ({np.degrees(green.yaw):.1f} deg): held = {held_turned}")

# %%
# demonstration: the kit's pick, not your work
assert held_turned, f"the turned wrist did not grasp the green block: {station.arm.last_grasp}"
assert not held_unturned or max(abs(green_truth.yaw - yaw_before), abs(off_pads)) > np.radians(5), \
    "roll 0 grasped a turned block cleanly"
print("OK: misaligned wrist: roll 0 fails, shoves the block or holds it turned; the roll from its yaw grasps it")

# %% [markdown]
# ## Your click-to-grab sequence
#
# `move_path` plans one grasp or one release. What turns clicks into those is the **sequence**: the first click on
# a block grabs it, the next click puts it down on the surface under the click (the board, or the top of another
# block: a click on a block while holding one stacks on it), and a click that cannot be acted on is refused with
# nothing moved. The kit runs one click with `tasks.click_with(session, uv, sequence)`: it finds the world point
# under the pixel (`click_world`, on the corrected depth) and the current view's detections, asks your
# `sequence.on_click(point, seen)` what to do, does it (the kit's pick or place, checked whole), looks again and
# tells you `sequence.after(action, ok)`: whether the block is now held, or the place ran through. Think about:
# - which detected block a click means (a click lands anywhere on a top face, up to its corners; the face is turned by
#   its yaw) and what to say when it means none (`ClickRefused(why)`);
# - what your sequence must remember between clicks, and what it must *not* believe until `after` says so (a pick
#   that closes on nothing);
# - where the held block's *bottom* face goes for a click on the board and on another block's top, and a click where
#   the held block itself stood (the frame still shows it).
#
# **Exercise `grab.sequence`:** write `ClickSequence.on_click` and `ClickSequence.after`.

# %%
from armlab.blocks import block_edge
from armlab.tasks import ClickRefused


class ClickSequence:
    """Click to grab, click to drop (see above): on_click(point, seen) -> ("grab", block) or ("drop", position, yaw)."""

    def __init__(self):
        self.held = None             # the detection of the block the gripper holds (None: it holds nothing)
        self.notes = {}              # whatever else your sequence remembers

    def on_click(self, point, seen):
        # BEGIN SOLUTION grab.sequence
        point = np.asarray(point, dtype=float)

        def under_click(b):
            """The click's offset in the top face's own axes is within half its edge (and 3 mm) both ways."""
            c, s = np.cos(b.yaw), np.sin(b.yaw)
            dx, dy = point[:2] - np.asarray(b.position[:2])
            return max(abs(c * dx + s * dy), abs(-s * dx + c * dy)) <= b.edge_mm / 2 + 3.0

        if self.held is None:
            hit = [b for b in seen if b.is_block and under_click(b)]
            if not hit:
                raise ClickRefused(f"no block under the click at ({point[0]:.0f}, {point[1]:.0f}) mm")
            return ("grab", max(hit, key=lambda b: b.position[2]))       # the top one of a stack
        held = self.held
        if under_click(held) and point[2] > held.position[2] - held.edge_mm / 2:
            point[2] = held.position[2] - block_edge(held.size)           # where it stood: on what it stood on
        return ("drop", point, 0.0)
        # END SOLUTION

    def after(self, action, ok):
        # BEGIN SOLUTION grab.sequence
        if action[0] == "grab":
            self.held = action[1] if ok else None
        elif ok:
            self.held = None
        # END SOLUTION


def refuse_every_click(point, seen):
    """The stand-in while your sequence is blank: every click is refused and nothing moves."""
    raise ClickRefused("your click sequence is not written yet: nothing moves")


clicks = ClickSequence()
clicks.on_click = with_reference(clicks.on_click, "grab.sequence", refuse_every_click,
                                 "every click is refused: nothing moves")
demo_station = make_station("sim", seed=2, scene=SCENE)
demo_session = tasks.start_session(demo_station)
for where in ([-150.0, 200.0, 38.0], [-220.0, 60.0, 0.0]):              # the red block, then a free spot
    uv = demo_station.camera.truth.project(np.array([where]))[0]
    try:
        print(f"click at ({uv[0]:.0f}, {uv[1]:.0f}) px:", tasks.click_with(demo_session, uv, clicks))
    except ClickRefused as refused:
        print(f"click at ({uv[0]:.0f}, {uv[1]:.0f}) px refused: {refused}")

# %% [markdown]
# ## Check: your sequence, click by click, on the simulator
#
# A fresh station with the same three blocks: a click on bare board (refused, nothing moves), the red block (held),
# a free spot (it lands within 3 mm), the blue block near a corner of its face (held) and the green block's top (the
# blue one lands on it, centred). The simulator's ground truth decides.

# %%
# CHECK grab.sequence
seq_station = make_station("sim", seed=3, scene=SCENE)
seq_session = tasks.start_session(seq_station)
mine = ClickSequence()
truth = {o.color: o for o in seq_station.world.blocks}


def click_at(point):
    return tasks.click_with(seq_session, seq_station.camera.truth.project(np.array([point], float))[0], mine)


try:
    click_at([0.0, 120.0, 0.0])
    refused = False
except ClickRefused:
    refused = True
assert refused and not seq_station.world.held, "a click on bare board was not refused"
assert click_at([-150.0, 200.0, 38.0]) == ("grab", True) and truth["red"].id in seq_station.world.held, \
    "the click on the red block did not grab it"
assert click_at([-220.0, 60.0, 0.0]) == ("drop", True), "the drop on the board did not run"
red_off = np.abs(truth["red"].position - [-220.0, 60.0, 19.0]).max()
assert red_off < 3.0 and not seq_station.world.held, f"the red block landed {red_off:.1f} mm from the click"
corner = np.array([200.0, 150.0]) + 9.0 * np.array([np.cos(0.3) + np.sin(0.3), np.sin(0.3) - np.cos(0.3)])
assert click_at([*corner, 25.0]) == ("grab", True) and truth["blue"].id in seq_station.world.held, \
    "a click near a corner of the blue block's face did not grab it"
assert click_at([60.0, 300.0, 38.0]) == ("drop", True), "the drop on the green block did not run"
blue_off = np.abs(truth["blue"].position - [60.0, 300.0, 38.0 + 12.5]).max()
assert blue_off < 3.0, f"the blue block landed {blue_off:.1f} mm from the green block's top centre"
print(f"OK: your click sequence refused bare board, grabbed and dropped the red block ({red_off:.1f} mm off) and "
      f"stacked the blue one on the green ({blue_off:.1f} mm off)")

# %% [markdown]
# ## 6 · Click to grab, click to drop
#
# **Demonstration** of the kit's click-to-grab panel (it plans with the kit's planners, not your `move_path`).
# `tasks.click_grab(session, (u, v))` and `tasks.click_drop(session, (u, v))` do all of the above from a pixel of the
# current frame (`session.last.frame`), by the kit's click rule. Clicks off the board, on the robot, on bare board or
# out of reach raise `tasks.ClickRefused` and nothing moves. In the student release that rule is a lesser stand-in
# for your sequence: a click grabs only within a few pixels of a block's detected centre, and a drop where the held
# block was seen is refused; your `ClickSequence` runs through `tasks.click_with` (above), and
# `ClickToGrab(session, sequence=ClickSequence())` puts it behind the live panel instead of the kit's rule.
#
# In a live notebook you click the image itself: `ClickToGrab(session).widget()` shows the current frame
# (downscaled to $w \times h = 640 \times 360$ px to keep it light) and listens to its clicks with `ipyevents`. The
# browser reports a click at $(x, y)$ pixels of the *shown* image, measured from its top-left corner, whatever size
# the page draws it at; the camera pixel (OpenCV: integer = pixel centre) of a $W \times H = 1280 \times 720$ frame is
# $$u = x\,\frac{W}{w} - \tfrac12,\qquad v = y\,\frac{H}{h} - \tfrac12 .$$
# The first click grabs the block under it, the next one drops it there; each click prints the world point and what
# the arm did, or why it refused. Headless (here, and in the checks) the same handler is a plain call with $(u, v)$,
# or with the event dictionary the browser would send.

# %%
from armlab.tasks import ClickToGrab

panel = ClickToGrab(session)
panel.widget()

# %%
target_uv = station.camera.truth.project(np.array([[-200.0, 80.0, 0.0]]))[0]     # a free spot on the board
print("the gripper holds the", session.held.color, "block; the next click will", panel.next_action)
drop = panel.click(target_uv)
print(drop.message)
refused = panel.click(station.camera.truth.project(np.array([[0.0, 20.0, 0.0]]))[0])
print(refused.message)

# %% [markdown]
# A click as the browser sends it: `ipyevents` gives the click in the shown image's own pixels (`dataX`, `dataY`)
# together with where it fell on the page. Here we click the red block's centre, then a spot next to the green one.

# %%
red = next(b for b in tasks.look(session).blocks if b.color == "red")
(W, H), (w, h) = panel.frame_size(), panel.image_size()
x, y = (np.asarray(red.pixel) + 0.5) * [w / W, h / H]
event = {"type": "click", "dataX": int(round(x)), "dataY": int(round(y)), "relativeX": round(float(x), 1),
         "relativeY": round(float(y), 1), "boundingRectWidth": w, "boundingRectHeight": h}
print("event", event)
grab_event = panel.handle_event(event)
print(grab_event.message)
spot = np.array([-120.0, 60.0, 0.0])
x, y = (station.camera.truth.project(spot[None])[0] + 0.5) * [w / W, h / H]
drop_event = panel.handle_event({"type": "click", "dataX": int(round(x)), "dataY": int(round(y))})
print(drop_event.message)

# %%
green_err = np.abs(green_truth.position - [0, 0, green_truth.edge / 2] - [-200.0, 80.0, 0.0])
red_truth = next(o for o in station.world.blocks if o.color == "red")
red_err = np.abs(red_truth.position - [0, 0, red_truth.edge / 2] - spot)
assert drop.ok and green_err.max() < 3.0, f"the green block landed {green_err.max():.1f} mm from the clicked spot"
assert not refused.ok and not refused.moved, "a click on the robot's base was not refused, or moved the arm"
assert grab_event.ok and drop_event.ok, f"the browser-style clicks failed: {grab_event.message} / {drop_event.message}"
assert red_err.max() < 3.0 and panel.next_action == "grab", f"the red block landed {red_err.max():.1f} mm off"
print(f"OK: click to grab/drop: the blocks landed {green_err.max():.1f} and {red_err.max():.1f} mm from the clicked "
      f"spots; the refused click moved nothing")

# %% [markdown]
# ## Your table for this notebook
#
# What `python -m armlab check` lists for this notebook: each exercise, its points, its kind, how it is graded and
# whether you have written it (from the saved files: save the notebook first). The grader decides the score.

# %%
from armlab_course.exercises.rubric import rubric

rubric("05_click_to_grab")
