# %% [markdown]
# # 08 · The control station
#
# In the lab you drive the arm from a **control station**: the live camera view, the world coordinates under the
# mouse, buttons for calibrate, click-to-grab / click-to-drop, teach, record, repeat and the **emergency stop**, and
# joint sliders. This notebook puts that station in JupyterLab, over everything the earlier notebooks built:
# the calibrated camera (01), kinematics (02, 03), the detector (04), click-to-grab (05) and teach-and-repeat (06).
#
# **Run the cells** (Run ▸ Run All Cells). A committed notebook shows its widgets only as a line of text, such as
# `StationPanel(...): run the cell`; the live panel and the 3D view appear when the kernel runs.
#
# How it works:
# - every button drives **one state machine**, `armlab.tasks.TaskMachine` (states idle, estop, calibrate, detect,
#   execute, teach, repeat, click-grab, click-drop): a command runs from `idle` and returns there, and while one runs
#   the others are refused;
# - commands that move the arm run on a **worker thread**, so the notebook's kernel stays free to hear the
#   **EMERGENCY STOP** button, which halts the arm at once, even halfway through a motion; nothing moves again until
#   you press *reset*;
# - after every command the picture is **fresh**: the camera looks again (arm out of view) after a grab, a drop or a
#   detection, and takes a new frame after any other move. A click on a frame taken with the arm in view first looks
#   again, so a click never acts on a picture of the past;
# - the status line says what the gripper holds and what the **next click** does (grab the block under it, or drop
#   the held block where you click).
#
# The same panel drives the real arm: only `make_station("sim")` becomes `make_station("real")`.
# Units: millimetres and radians; world (board) frame.

# %%
import time

import numpy as np
from IPython import get_ipython

from armlab import make_station, tasks
from armlab.ui import station_panel
from armlab.viz import Viewer

get_ipython().run_line_magic("matplotlib", "inline")
np.set_printoptions(precision=1, suppress=True)
station = make_station("sim", seed=0, scene={"objects": [
    {"color": "red", "size": "large", "position_mm": [-150.0, 200.0], "yaw_rad": 0.0},
    {"color": "blue", "size": "small", "position_mm": [200.0, 150.0], "yaw_rad": 0.3},
    {"color": "green", "size": "large", "position_mm": [60.0, 300.0], "yaw_rad": -0.5},
]})
viewer = Viewer()
panel = station_panel(station, viewer=viewer)   # calibrates the camera and fits the sag model on first use
print("state:", panel.machine.state, "| the panel's states:", ", ".join(tasks.STATES))

# %% [markdown]
# ## 1 · The panel
#
# - **view**: the camera image (*camera*), its depth in colour (*depth*, near = bright), or the image with the last
#   look's detections drawn (*detections*). *refresh view* takes a frame now; *live camera* refreshes it on a timer.
# - **mouse over the image**: the world point under the pointer, through the calibrated camera and the depth image
#   (the median depth of the surface in a 17 × 17 window, corrected for the camera's planar bias as in notebook 01:
#   the very point a click acts on).
# - **click on the image**: grabs the block under the click (gripper empty) or drops the held block there.
# - **calibrate**, **detect**, **home**, **sleep**; **teach** turns the torque off (hold the real arm first!) and on
#   the simulator makes the sliders your hand; **record waypoint** stores the pose with the gripper state you pick;
#   **finish teaching** turns the torque on; **repeat** replays the program.
# - **joint sliders** start from the arm's pose and move the arm within the joint limits when you release them.
# - **real-time (simulator)**: the simulated arm then moves at its real speed, so you can watch it in the 3D view
#   (beside the camera: drag to turn, scroll to zoom) and stop it with the red button.

# %%
panel.widget()

# %% [markdown]
# ## 2 · Click to grab, click to drop
#
# The panel's handlers are plain calls too: `panel.click((u, v))` is what a click on the image does (with the pixel
# of the full 1280 × 720 frame), and `panel.wait()` waits for the command on the worker thread. Here we click the
# detected blue block's centre, as you would with the mouse.

# %%
blue = next(b for b in panel.ctx.last.blocks if b.color == "blue")
panel.click(blue.pixel)
panel.wait()
print(panel.status_text())

# %% [markdown]
# **Check:** the simulator's ground truth must have the blue block in the gripper, and the panel must say so.

# %%
blue_truth = next(o for o in station.world.blocks if o.color == "blue")
assert blue_truth.id in station.world.held, f"the blue block is not in the gripper: {panel.messages[-1]}"
assert blue_truth.position[2] > 30.0, f"the blue block's centre is only {blue_truth.position[2]:.1f} mm high"
assert panel.next_click == "drop" and "holding the blue small block" in panel.status_text(), panel.status_text()
print("OK: a click on the blue block's pixel grabbed it; the panel says the next click drops it")

# %% [markdown]
# Now a click on a free spot of the board drops it there.

# %%
spot = np.array([-200.0, 80.0, 0.0])
panel.click(station.camera.truth.project(spot[None])[0])
panel.wait()
print(panel.status_text())

# %%
bottom = blue_truth.position - [0, 0, blue_truth.edge / 2]
err = np.abs(bottom - spot).max()
assert not station.world.held, "the gripper still holds a block after the drop"
assert err < 3.0, f"the blue block landed {err:.1f} mm from the clicked spot"
assert panel.machine.history[-4:] == ["click-grab", "idle", "click-drop", "idle"], panel.machine.history[-4:]
print("OK: the drop put the blue block within 3 mm of the clicked spot, through the machine's click-grab and "
      "click-drop states")

# %% [markdown]
# ## 3 · Where is the mouse? World coordinates under the pointer
#
# `panel.mouse((u, v))` is the readout the image shows under the pointer, and `panel.world_at((u, v))` the point it
# shows. **Check:** on bare board and on the large blocks' top faces it must agree with the truth (the true camera's
# ray through the same pixel, met at the true surface height) within 2 mm.

# %%
truth = station.camera.truth
print(panel.mouse(truth.project(np.array([[250.0, 275.0, 0.0]]))[0].round()), "(the tag at (250, 275) mm)")
rng = np.random.default_rng(0)
board = [xy for xy in rng.uniform([-400, 0], [400, 420], (40, 2))
         if np.hypot(*xy) > 130 and min(np.hypot(*(xy - o.position[:2])) for o in station.world.blocks) > 45][:12]
points = [(np.array([*xy, 0.0]), 0.0) for xy in board]
points += [(o.position + [0, 0, o.edge / 2], o.position[2] + o.edge / 2)
           for o in station.world.blocks if o.size == "large"]
errors = []
for p_true, height in points:
    uv = np.round(truth.project(p_true[None])[0])
    errors.append(np.linalg.norm(panel.world_at(uv) - truth.pixel_to_plane(uv[None], height)[0]))
worst = max(errors)
assert len(errors) == 14, f"only {len(errors) - 2} bare-board points were drawn"
assert worst < 2.0, f"the mouse-over readout is {worst:.1f} mm from the truth"
print("OK: mouse-over readout within 2 mm of the truth at 12 bare-board points and 2 block tops")

# %% [markdown]
# ## 4 · Teach and repeat
#
# *teach* turns the torque off. On the real arm you now pose it with your hand; on the simulator the sliders are your
# hand (here: `station.arm.move_by_hand`). *record waypoint* stores each pose, *finish teaching* turns the torque
# back on, *repeat* replays the program through the guarded arm (sag compensated, stoppable).

# %%
print(panel.teach())
for q, grip in (([0.35, -0.3, 0.3, 0.6, 0.0], "open"), ([-0.35, -0.2, 0.2, 0.7, 0.0], "open"),
                ([0.0, -0.5, 0.0, 0.5, 0.0], "open")):
    station.arm.move_by_hand(q)
    panel.record(grip)
print(panel.teach())
panel.home()
panel.wait()
panel.repeat()
print(panel.wait())

# %%
end = panel.ctx.arm.joint_positions()
gap = np.abs(end - panel.machine.program.q[-1]).max()
assert len(panel.machine.program) == 3, f"the program has {len(panel.machine.program)} waypoints, expected 3"
assert gap < 0.02, f"the repeat ended {gap:.3f} rad from the last taught waypoint"
assert station.arm.torque_enabled and panel.machine.state == "idle", panel.status_text()
print("OK: taught 3 waypoints by hand, the repeat ended at the last one within 0.02 rad")

# %% [markdown]
# ## 5 · The emergency stop, in the middle of a motion
#
# With *real-time* ticked, the simulated arm takes as long as the real one. The motion runs on the panel's worker
# thread, so this cell (like the button) is free to call `panel.estop()` while the arm moves: the arm halts where it
# is, the running command ends with `EmergencyStopped`, and every command is refused until `panel.reset()`.

# %%
panel.set_real_time(True)
start = station.arm.joint_positions()
panel.sleep()                                 # about 2.5 s to the sleep pose
deadline = time.monotonic() + 10
while not station.arm.is_moving() and time.monotonic() < deadline:
    time.sleep(0.01)
time.sleep(0.5)
moving = station.arm.is_moving()
panel.estop()
stopped = panel.wait(timeout_s=10)
q_stop = station.arm.joint_positions()
time.sleep(0.3)
drift = np.abs(station.arm.joint_positions() - q_stop).max()
refused = panel.home()
state = panel.machine.state
print(panel.reset())
panel.set_real_time(False)

# %%
sleep_pose = station.arm.robot.sleep
assert moving, "the arm was not moving when the stop came"
assert "EmergencyStopped" in stopped, f"the motion was not stopped: {stopped}"
assert drift < 0.005, f"the arm drifted {drift:.3f} rad after the stop"
assert np.abs(q_stop - sleep_pose).max() > 0.2, "the arm reached the sleep pose: the stop came too late"
assert np.abs(q_stop - start).max() > 0.02, "the arm had not moved at all"
assert not refused and state == "estop", f"a command was accepted while stopped (state {state})"
assert panel.machine.state == "idle", f"reset left the machine in {panel.machine.state!r}"
print("OK: the emergency stop halted the arm halfway to the sleep pose; it stayed there and refused commands "
      "until reset")

# %% [markdown]
# ## 6 · When you are done
#
# The 3D view stays live as long as the kernel runs. `viewer.close()` stops it; an open view then says it is closed
# (and a browser tab on the viewer turns grey with a "viewer closed" sign) instead of freezing. Shutting the kernel
# down stops the viewer too. On the real arm, leave the station with `station.close()` (or a `with` block): the arm
# goes to its sleep pose first.
#
# Next steps: use the panel to repeat notebook 05's six-location experiment by clicking, or to teach a pick and place
# and replay it (notebook 06).
