# %% [markdown]
# # 00 · Getting started: the kit, its frames and the arm viewer
#
# **armlab** is the course kit of the robot-arm lab: an Interbotix **RX200** arm (5 joints + a gripper) above a board
# of coloured wooden blocks, watched by an RGB-D camera. The notebooks 00 → 07 take you from camera calibration and
# kinematics to block detection and autonomous pick-and-place. Everything runs on a simulated station out of the box,
# and the same code drives the real arm and camera in the lab.
#
# This notebook is for every student on day one. You will learn
# 1. the **coordinate frames** every function of the kit uses,
# 2. how to **move the arm in the 3D viewer** and read where its tool is,
# 3. how the lab is graded: **exercises** you write, the **check cells** that test them, and the **rubric** at the
#    end of each notebook.
#
# This notebook has no exercise: its cells that verify something are **demonstrations** of the kit (they test the
# kit's own code, not yours) and carry no grade.
#
# Units everywhere: **millimetres and radians**.

# %%
import numpy as np
import matplotlib.pyplot as plt
from IPython import get_ipython

from armlab import kinematics
from armlab.camera import Camera, look_at
from armlab.lab import lab_config
from armlab.robot import rx200
from armlab.viz import Viewer

get_ipython().run_line_magic("matplotlib", "inline")  # figures appear below their cell
from armlab.viz.figures import readable

readable()                                             # figure size and fonts readable at 100 % zoom
np.set_printoptions(precision=3, suppress=True)
robot = rx200()
lab = lab_config()
print("joints:", ", ".join(robot.joint_names))

# %% [markdown]
# ## 1 · Coordinate frames
#
# | frame | where | axes |
# |---|---|---|
# | **world** (= board) | on the board, right below the waist axis | +x right, +y away from the robot, +z up |
# | `base_link` (manufacturer) | same origin | world turned −90° about z: $x_b = y_w$, $y_b = -x_w$ |
# | **tool** `ee_gripper_link` | between the finger pads | x = approach direction, y = finger opening direction |
# | **camera** | optical centre | x right, y down in the image, z along the optical axis |
#
# A pose is a 4×4 homogeneous transform. Forward kinematics gives the tool pose in the world,
# $T_{world,tool}(q) = \begin{bmatrix} R & p \\ 0 & 1 \end{bmatrix}$, with $p$ the tool point in mm. The camera's
# extrinsic $T_{cam,world}$ maps world points into the camera frame: $p_{cam} = T_{cam,world}\, p_{world}$.
#
# At home (all joints 0) the arm points along +y:

# %%
T_home = kinematics.fk(robot.home)
print("tool point at home (mm):", T_home[:3, 3].round(1))
print("approach direction (tool x):", T_home[:3, 0].round(12) + 0.0)  # + 0.0 turns -0 into 0
print("finger opening direction (tool y):", T_home[:3, 1].round(12) + 0.0)

# %% [markdown]
# The board is 1000 × 650 mm with a 50 mm grid and four AprilTags; the camera hangs about 1 m above it, tilted towards
# the robot. `Camera.project` turns world points into pixels (OpenCV convention: u right, v down):

# %%
camera = Camera(lab.factory_K, lab.factory_dist, look_at(lab.camera_position_mm, lab.camera_look_at_mm),
                *lab.image_size)
print(camera)
tag_centres = np.array([[x, y, 0.0] for x, y in lab.tags.centres_mm.values()])
for tag_id, (u, v) in zip(lab.tags.centres_mm, camera.project(tag_centres)):
    print(f"tag {tag_id} at {lab.tags.centres_mm[tag_id]} mm -> pixel ({u:.1f}, {v:.1f})")

# %% [markdown]
# **Check:** going world → pixel → world (the ray through the pixel meets the board plane z = 0) must return the tag
# centres.

# %%
back = camera.pixel_to_plane(camera.project(tag_centres), 0.0)
err = np.abs(back - tag_centres).max()
assert err < 1e-6, f"the round trip misses a tag centre by {err:.1e} mm: project and pixel_to_plane disagree"
print("OK: world -> pixel -> board plane round trip of the 4 tag centres within 1e-6 mm")

# %% [markdown]
# ## 2 · The arm in the viewer
#
# `Viewer()` starts a meshcat server and draws the board, the tags, the arm (links between the joint positions, the
# joint drums along their axes, the gripper) and the frames of every link. The 3D view appears below (drag to turn,
# scroll to zoom); `viewer.url` opens it in its own tab.

# %%
viewer = Viewer()
print(viewer)

# %%
viewer.widget()

# %% [markdown]
# `viewer.show(q, gripper_opening_mm=...)` moves the drawn arm to joint angles `q` (waist, shoulder, elbow,
# wrist_angle, wrist_rotate in rad). Positive shoulder, elbow and wrist_angle tip the arm forward and down; positive
# waist turns it towards −x. Here are a few poses and where forward kinematics puts the tool:

# %%
poses = {
    "home": robot.home,
    "sleep": robot.sleep,
    "reach left, down": np.array([0.6, 0.3, 0.2, 0.9, 0.0]),
    "tall": np.array([-0.4, -0.6, -0.5, 0.2, 0.0]),
}
for name, q in poses.items():
    viewer.show(q, gripper_opening_mm=30.0)
    x, y, z = kinematics.fk(q)[:3, 3].round(1) + 0.0
    print(f"{name:>17}: q = {q} rad -> tool at ({x:7.1f}, {y:7.1f}, {z:7.1f}) mm")

# %% [markdown]
# A picture of the same poses (drawn with matplotlib from `kinematics.joint_positions`, the very points the viewer
# draws its links between): a top view of the board and a side view along the arm.

# %%
fig, (top, side) = plt.subplots(1, 2, figsize=(9, 3.8))
top.add_patch(plt.Rectangle((lab.board_x[0], lab.board_y[0]), 1000, 650, color="wheat"))
top.plot(tag_centres[:, 0], tag_centres[:, 1], "ks", ms=4)
for name, q in poses.items():
    p = kinematics.joint_positions(q)
    line, = top.plot(p[:, 0], p[:, 1], "o-")
    top.annotate(name, p[-1, :2], xytext=(4, 4), textcoords="offset points", color=line.get_color(), fontsize=9)
    heading = np.array([-np.sin(q[0]), np.cos(q[0])])  # the arm's forward direction on the board
    side.plot(p[:, :2] @ heading, p[:, 2], "o-", color=line.get_color())
    side.annotate(name, (p[-1, :2] @ heading, p[-1, 2]), xytext=(4, 4), textcoords="offset points",
                  color=line.get_color(), fontsize=9)
top.set(xlabel="x (mm)", ylabel="y (mm)", title="top view (world)", aspect="equal")
side.set(xlabel="along the arm's heading (mm)", ylabel="z (mm)", title="side view", aspect="equal")
side.axhline(0, color="peru")
fig.tight_layout()

# %% [markdown]
# **Live:** in JupyterLab the sliders below move the arm in the viewer (joint angles in rad, gripper in mm). Try to
# touch the tag at (250, 275) with the tool point.

# %%
sliders = viewer.joint_sliders()
sliders

# %% [markdown]
# A trajectory plays as an animation in the viewer (and in a saved snapshot, `viewer.save_html("scene.html")`, a
# self-contained page you can open anywhere). The driver moves every joint with a trapezoidal velocity profile;
# `armlab.profile` has it:

# %%
from armlab.profile import default_moving_time, trapezoid_fraction

T = default_moving_time(robot.sleep, robot.home)
times = np.linspace(0.0, T, 31)
s = trapezoid_fraction(times, T, T / 3)
qs = robot.sleep + s[:, None] * (robot.home - robot.sleep)
viewer.animate(times, qs, gripper_opening_mm=np.linspace(30, 60, len(times)))
end = kinematics.fk(qs[-1])[:3, 3].round(1)
print(f"sleep -> home in {T:.2f} s, {len(times)} keyframes; the tool ends at {end} mm")

# %% [markdown]
# **Demonstration (the kit testing itself, not a check of your work):** the links the viewer draws join exactly the
# joint positions of the kinematic model, at every pose (the viewer's cylinders run along their local y axis, so a
# link's ends are its pose applied to (0, ±L/2, 0)).

# %%
from armlab.viz.geometry import LINK_NAMES, arm_part_poses

qs_check = np.random.default_rng(0).uniform(robot.lower, robot.upper, (100, 5))
points = kinematics.joint_positions(qs_check)
parts = arm_part_poses(qs_check)
gap = 0.0
for i, name in enumerate(LINK_NAMES):
    T_link = parts.poses[f"links/{name}"]
    half = np.linalg.norm(points[0, i + 1] - points[0, i]) / 2
    ends = T_link[:, :3, 3, None] + T_link[:, :3, 1, None] * np.array([-half, half])
    gap = max(gap, np.abs(np.swapaxes(ends, 1, 2) - points[:, i:i + 2]).max())
assert gap < 1e-9, f"a drawn link misses its joints by {gap:.1e} mm: the viewer's link poses are off"
tool = kinematics.fk(robot.home)[:3, 3]
assert np.allclose(tool, [0.0, 408.575, 304.57], atol=1e-9), f"home tool point {tool} mm, expected (0, 408.575, 304.57)"
print(f"OK: drawn links join the joint positions at 100 random poses (gaps below 1e-9 mm); "
      f"home tool point {tool.round(1)} mm matches the manufacturer")

# %% [markdown]
# ## 3 · The station: simulated or real
#
# Everything above the hardware talks to a **station**: an arm, an RGB-D camera and, in simulation, the world with
# its ground truth. One call makes it; the same code then runs in the lab with `make_station("real")`.

# %%
from armlab import make_station

station = make_station("sim", seed=0, scene="random", n=6)
frame = station.camera.capture()
print("rgb:", frame.rgb.shape, frame.rgb.dtype, "| depth:", frame.depth.shape, frame.depth.dtype,
      f"| depth range {np.nanmin(frame.depth):.0f}-{np.nanmax(frame.depth):.0f} mm")
print("the camera reports its factory intrinsics: fx =", station.camera.K[0, 0], "px")

# %% [markdown]
# A frame is a colour image (RGB, `uint8`) and a depth image aligned to it: each depth pixel holds the camera-frame
# **Z** of the surface it sees, in mm (`NaN` where the sensor got no return). The blocks stand out as nearer
# (darker-blue) patches; the arm at its sleep pose is in the picture too.

# %%
fig, (ax_rgb, ax_depth) = plt.subplots(1, 2, figsize=(9, 3.2))
ax_rgb.imshow(frame.rgb)
ax_rgb.set_title("RGB: the board, blocks and arm")
im = ax_depth.imshow(frame.depth, cmap="viridis", vmin=850, vmax=1100)
ax_depth.set_title("depth: nearer is darker")
fig.colorbar(im, ax=ax_depth, fraction=0.03, label="camera Z (mm)")
for ax in (ax_rgb, ax_depth):
    ax.set(xlabel="u (px)", ylabel="v (px)", xticks=(0, 600, 1200))
fig.tight_layout()

# %% [markdown]
# The arm moves with the manufacturer's time-based profile. In simulation time is simulated: a 2 s move takes
# milliseconds. Moves the real driver would refuse (joint limits, joint speeds such as the shoulder's 1 rad/s) or that
# would hit the board are refused **before** anything moves, with a message saying why.

# %%
from armlab.station import MotionRefused

station.arm.home()
print("encoders after home:", station.arm.joint_positions().round(3) + 0.0)  # + 0.0 turns -0 into 0
try:
    station.arm.move_to([0.0, 1.2, 1.0, 0.5, 0.0])   # tips the arm into the board
except MotionRefused as refusal:
    print("refused:", str(refusal).split(":")[0])
print("still at home:", bool(np.allclose(station.arm.joint_positions(), robot.home, atol=0.01)))

# %% [markdown]
# These sliders move the station's arm, and they go through the station's state machine (notebook 08), as every
# command does: a move is refused while another command runs or after an emergency stop, and `machine.estop()`
# stops it. The machine drives a task session; this one is built without calibrating the camera (nothing moves
# until you drag a slider), which is all that moving joints needs. A move the arm refuses is reported under the
# sliders and they return to the arm's pose.

# %%
from armlab import tasks

machine = tasks.TaskMachine(tasks.Session(station, tasks.GuardedArm(station.arm)))
arm_sliders = viewer.joint_sliders(machine=machine)
arm_sliders

# %% [markdown]
# The viewer can draw the whole station: the blocks of the world, the camera's frustum and the depth image turned into
# a point cloud in the world frame (each pixel's depth through the camera model; here the simulator's true camera,
# `station.camera.truth`, which a student pipeline never uses — notebook 01 calibrates its own).

# %%
viewer.show(station.arm.joint_positions(), gripper_opening_mm=station.arm.gripper_opening_mm)
viewer.draw_objects(station.world.objects)
viewer.draw_camera(station.camera.truth)
n_points = viewer.draw_rgbd(frame.rgb, frame.depth, station.camera.truth, stride=8)
print(f"drew {len(station.world.objects)} blocks, the camera and a cloud of {n_points} points")

# %% [markdown]
# **Demonstration (the simulated camera against its own ground truth):** the depth the simulated camera measures at
# each block's top-face centre puts that point back on the block
# (pixel + depth → world through the true camera), within the sensor's noise and bias (about 2.5 mm noise, up to
# ~20 mm of planar bias before calibration — notebook 01 removes it).

# %%
from armlab.images import sample_depth

truth = station.camera.truth
tops = np.array([b.position + [0, 0, b.edge / 2] for b in station.world.blocks])
uv = truth.project(tops)
back = truth.pixel_to_world(uv, sample_depth(frame.depth, uv, radius=3))
err = np.linalg.norm(back - tops, axis=1)
assert np.all(err < 30), f"block tops seen {err.round(1)} mm from where they are: depth or camera pose is off"
print(f"OK: {len(tops)} block tops seen where they are: error {err.min():.0f}-{err.max():.0f} mm "
      "before depth calibration")

# %% [markdown]
# **On the real arm** only the first line changes: `make_station("real")` (see the README: it needs the Interbotix
# ROS 2 packages and `pyrealsense2`). Use it in a `with` block, so that the arm goes to its sleep pose before the
# driver shuts down, even when your code raises. There is no `world` there: the truth is what you measure.

# %% [markdown]
# The viewer stays live while the kernel runs; `viewer.close()` (or shutting the kernel down) stops it, and open
# views then say so.

# %% [markdown]
# ## 4 · How to check your work
#
# - Each notebook states its **exercises** at the top: what you write, how many points, and how it is graded —
#   *code* (checked on hidden inputs), *open tasks* (graded by outcome on hidden seeds or held-out frames) and
#   *written answers* (a question about a figure, in a marked answer cell, graded by hand).
# - You write code between `# BEGIN SOLUTION <id>` and `# END SOLUTION`, and written answers between
#   `<!-- BEGIN ANSWER <id> -->` and `<!-- END ANSWER -->`. Until you do, the kit's own method stands in where it
#   can and says so in one line.
# - A cell titled **Check** tests *your* work: it starts with `# CHECK <id>`, asserts against a known answer and
#   prints one line starting with `OK`. If it raises, your code is not right yet. (The demonstrations above test the
#   kit and carry no `# CHECK`.)
# - The last cell of each notebook prints your own rubric table (the same as `python -m armlab check` lists for it):
#   exercises, points, kind, and whether each is still blank.
# - Your instructor runs every notebook top to bottom with `pytest --nbval`, which re-executes each cell and compares
#   its printed output with the stored one: keep outputs deterministic (seeded random numbers, no timings).
# - `make check` runs the check cells of the exercises you have written (`python -m armlab check`), `make test` the
#   kit's own tests; `make lab` opens JupyterLab on `notebooks/`.
#
# Next: **01 · camera calibration**.

# %%
from armlab_course.exercises import rubric

rubric("00")
