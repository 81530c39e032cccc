# %% [markdown]
# # 08 · The control station: a lab procedure
#
# In the lab you drive the arm from a **control station**: the live camera view, the world point under the mouse,
# buttons for calibrate, click-to-grab / click-to-drop, teach, record, repeat and the **emergency stop**, and joint
# sliders, over everything the earlier notebooks built. Every button drives **one state machine**,
# `armlab.tasks.TaskMachine` (states idle, estop, calibrate, detect, execute, teach, repeat, click-grab, click-drop).
# This notebook is the procedure for a session: the checklist before the real arm moves, your transition of the
# state machine (on the simulator), then the panel itself.
#
# | exercise | points | kind | how it is graded |
# |---|---|---|---|
# | `station.transition` | 6 | code | hidden sequences of commands, errors, stops and nested commands |
# | `station.machine` | 12 | open task | hidden scripted sessions: buttons, a stop in every state, teach, repeat |
#
# The cells called **Check** test your transition on the simulator and your machine on scripted sessions; cells
# marked **Demonstration** show the kit's panel and test nothing of yours. Units: millimetres and radians; world
# (board) frame.
#
# ## 0 · Before the real arm moves: the checklist
#
# On the simulator nothing can break; on the lab's RX200 every item below is yours to do, in this order:
# 1. **Space.** The board clear of everything but the blocks; nobody within the arm's reach (about 0.5 m from the
#    waist axis); the power supply's switch and the emergency stop within your reach.
# 2. **Start pose.** The arm resting in its sleep pose before power-on; the gripper empty.
# 3. **Camera.** The RealSense on its mount, not knocked since the last calibration; *calibrate* (notebook 01) when
#    it was moved or at the start of the day, and check the reprojection error it prints (under 1 px).
# 4. **Stop first.** Press the panel's **EMERGENCY STOP** once with the arm idle and see the state turn to
#    `estop`; *reset*. Do it again during a slow move (real-time on) before any task.
# 5. **Teach.** Hold the arm with one hand *before* pressing *teach* (the torque goes off and the arm falls);
#    *finish teaching* only with the arm supported.
# 6. **First motion.** *home* at the driver's slow speed; watch the whole path; then one click-to-grab on a single
#    block in the middle of the board.
# 7. **End.** *sleep*, then `station.close()`; power off with the arm resting.
#
# The panel works in a task session: `tasks.start_session(station)` calibrates the camera (the arm moves out of its
# view) and fits the sag model once, before the panel opens; its *calibrate* button calibrates again.
#
# The kit enforces what software can (joint limits, speeds, board and block clearance are checked before anything is
# sent; a stop always wins); the checklist covers what it cannot see.

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
session = tasks.start_session(station)          # calibrates the camera and fits the sag model, here
panel = station_panel(session, viewer=viewer)
print("state:", panel.machine.state, "| the panel's states:", ", ".join(tasks.STATES))

# %% [markdown]
# ## 1 · One transition of the state machine
#
# Every command of the machine (calibrate, detect, execute, click-grab, click-drop, repeat) is the same transition:
# from **idle** into the command's state, run the command's work, and back. What makes it a safety device is what
# happens when things go wrong:
# - a command may only start from `idle`: in `estop` it is refused with `EmergencyStopped` (nothing may move until a
#   reset), and in any other state with `MachineBusy` (one command at a time — a button pressed twice, a command
#   started from inside another); a refused command enters no state;
# - the emergency stop can come from the arm itself (the work raises `EmergencyStopped`) or from the button
#   (`machine.estop()`, which sets `machine.stop_requested` and may happen while the work runs, or just as it ends):
#   either way the machine must end in `estop` — once, not twice in its history — and the caller must hear
#   `EmergencyStopped`;
# - any other error in the work returns the machine to where commands may start again, unless a stop was requested
#   meanwhile, and the error goes on to the caller.
#
# `machine.enter(state)` enters a state (and adds it to `machine.history`); `machine.state` is the current one.
#
# **Exercise `station.transition`:** write `run_command(machine, state, action)`, returning what `action()` returns.
# `TaskMachine(session, transition=run_command)` then runs every command through it.

# %%
from armlab.station.contract import EmergencyStopped
from armlab.tasks import MachineBusy, TaskMachine


def run_command(machine, state, action):
    """Run `action()` as the command `state` of `machine` (a TaskMachine): the transition from "idle" into `state`
    and back (see above); returns the action's result."""
    # BEGIN SOLUTION station.transition
    if machine.state == "estop":
        raise EmergencyStopped(f"{state} refused: the station is emergency-stopped; reset first")
    if machine.state != "idle":
        raise MachineBusy(f"{state} refused: the machine is in {machine.state!r}")
    machine.enter(state)
    try:
        result = action()
    except EmergencyStopped:
        if machine.state != "estop":
            machine.enter("estop")
        raise
    except Exception:
        if not machine.stop_requested:
            machine.enter("idle")
        elif machine.state != "estop":
            machine.enter("estop")
        raise
    if machine.stop_requested:
        if machine.state != "estop":
            machine.enter("estop")
        raise EmergencyStopped(f"{state} was emergency-stopped as it ended")
    machine.enter("idle")
    return result
    # END SOLUTION


# %% [markdown]
# ## Check: your transition drives the station
#
# A second simulated station with the same blocks, its machine running every command through your `run_command`:
# detect, grab the red block by a click, a stop pressed before the drop (refused), reset, the drop, a command whose
# work fails, a command started from inside another, and a stop pressed while a command's work runs. The
# simulator's ground truth and the machine's history must show each step.

# %%
# CHECK station.transition
mine = make_station("sim", seed=0, scene={"objects": [
    {"color": "red", "size": "large", "position_mm": [-150.0, 200.0], "yaw_rad": 0.0},
    {"color": "blue", "size": "small", "position_mm": [200.0, 150.0], "yaw_rad": 0.3},
]})
machine = TaskMachine(tasks.start_session(mine), transition=run_command)
seen = machine.detect()
red = next(b for b in seen if b.color == "red")
red_truth = next(o for o in mine.world.blocks if o.color == "red")
assert machine.click_grab(red.pixel) and red_truth.id in mine.world.held, "the click did not grab the red block"
assert machine.history == ["idle", "detect", "idle", "click-grab", "idle"], f"history {machine.history}"
machine.estop()
try:
    machine.click_drop(mine.camera.truth.project(np.array([[-200.0, 80.0, 0.0]]))[0])
    refused = False
except EmergencyStopped:
    refused = True
assert refused and machine.state == "estop", f"a command ran while emergency-stopped (state {machine.state!r})"
assert machine.history[-1] == "estop" and machine.history.count("estop") == 1, f"history {machine.history}"
machine.reset()
machine.click_drop(mine.camera.truth.project(np.array([[-200.0, 80.0, 0.0]]))[0])
landed = np.abs(red_truth.position - [0, 0, red_truth.edge / 2] - [-200.0, 80.0, 0.0]).max()
assert not mine.world.held and landed < 3.0, f"the red block landed {landed:.1f} mm from the clicked spot"
assert machine.history[-2:] == ["click-drop", "idle"], f"history {machine.history}"


def failing():
    raise ValueError("the work failed")


try:
    run_command(machine, "execute", failing)
    failed = False
except ValueError:
    failed = True
assert failed and machine.state == "idle", f"a failing command left the machine in {machine.state!r}"
try:
    run_command(machine, "execute", lambda: run_command(machine, "detect", lambda: None))
    nested = "ran"
except MachineBusy:
    nested = "busy"
assert nested == "busy" and machine.state == "idle", f"a nested command {nested}, state {machine.state!r}"


def stopped_meanwhile():
    machine.estop()            # the button, pressed while the work runs (the simulated arm halts at once)
    return "done"


try:
    run_command(machine, "execute", stopped_meanwhile)
    heard = False
except EmergencyStopped:
    heard = True
assert heard and machine.state == "estop" and machine.history[-2:] == ["execute", "estop"], \
    f"a stop during the work: heard {heard}, history ends {machine.history[-3:]}"
machine.reset()
print(f"OK: your transition ran {machine.history.count('idle') - 1} commands on the simulator: the grab and the "
      "drop landed, a stop refused the next command until reset, a failing and a nested command left the machine "
      "idle, a stop during the work ended in estop")

# %% [markdown]
# ## 1b · The whole machine: buttons, the stop, teach and repeat
#
# Now the machine itself. The station's buttons are `calibrate`, `detect`, `execute`, `click-grab`, `click-drop`
# (the commands: `COMMANDS`), `teach`, `record`, `finish`, `repeat`, `estop` and `reset`. Your machine gets the kit's
# **port** — all it may do to the station — and the kit presses its buttons with `machine.press(button, *args)`:
# - `port.work(command, *args)` runs a command's work (its arguments are the button's); `port.halt()` stops the arm
#   at once, after which every arm command raises `EmergencyStopped` until `port.restart()`; `port.set_torque(on)`;
#   `port.joints()` reads the arm's joints (5,) rad; `port.replay(joints, grippers)` plays waypoints back;
# - a command and `repeat` run through your `run_command` above (the same rules; `repeat` with nothing taught is a
#   `ValueError`, and nothing is entered);
# - `teach` (from `idle`): the torque goes off (the arm is posed by hand) and the machine is in `teach`; `record`
#   (`"open"` or `"closed"`, the gripper there) stores `port.joints()` and returns it; `finish` puts the torque back
#   on, keeps the waypoints as the program `repeat` plays (none recorded: the last program stays) and returns their
#   number; a `record` or `finish` outside `teach`, and every other button during `teach`, is refused
#   (`MachineBusy`);
# - `estop`, in **every** state: halt the arm and be in `estop` (entered once); everything but `estop` and `reset` is
#   then refused with `EmergencyStopped`; `reset` only in `estop` (elsewhere `MachineBusy`): restart the arm, forget a
#   teaching cut short, back to `idle`. A stop during teaching leaves the arm limp until the reset restarts it.
#
# The machine keeps `state`, `history` (every state entered), `stop_requested` (from `estop` until `reset`) and
# `enter(state)`, so that `run_command(self, ...)` works on it.
#
# **Exercise `station.machine`:** write `StationMachine.press`. `machine_on(session)` then drives the simulated
# station.

# %%
from armlab.tasks.port import COMMANDS, SessionPort


class StationMachine:
    """The station's state machine over the kit's port (see above)."""

    def __init__(self, port):
        self.port = port
        self.state, self.history = "idle", ["idle"]
        self.stop_requested = False
        self.program = None          # the last taught waypoints: [(joints, gripper), ...]
        self.notes = {}              # whatever else your machine remembers

    def enter(self, state):
        self.state = state
        self.history.append(state)

    def press(self, button, *args):
        # BEGIN SOLUTION station.machine
        if button == "estop":
            self.stop_requested = True
            self.port.halt()
            if self.state != "estop":
                self.enter("estop")
            return None
        if button == "reset":
            if self.state != "estop":
                raise MachineBusy(f"reset refused: the machine is in {self.state!r}, not 'estop'")
            self.port.restart()
            self.stop_requested = False
            self.notes.pop("teaching", None)
            self.enter("idle")
            return None
        if self.state == "estop":
            raise EmergencyStopped(f"{button} refused: the station is emergency-stopped; reset first")
        if button in ("record", "finish"):
            if self.state != "teach":
                raise MachineBusy(f"{button} refused: the machine is in {self.state!r}, not 'teach'")
            if button == "record":
                gripper = args[0] if args else "open"
                if gripper not in ("open", "closed"):
                    raise ValueError(f"the gripper is 'open' or 'closed', got {gripper!r}")
                q = self.port.joints()
                self.notes["teaching"].append((q, gripper))
                return q
            self.port.set_torque(True)
            self.program = self.notes.pop("teaching") or self.program
            self.enter("idle")
            return len(self.program or ())
        if self.state != "idle":
            raise MachineBusy(f"{button} refused: the machine is in {self.state!r}")
        if button == "teach":
            self.port.set_torque(False)
            self.notes["teaching"] = []
            self.enter("teach")
            return None
        if button == "repeat":
            if not self.program:
                raise ValueError("nothing to repeat: teach a program first")
            joints, grippers = zip(*self.program)
            return run_command(self, "repeat", lambda: self.port.replay(np.array(joints), grippers))
        if button in COMMANDS:
            return run_command(self, button, lambda: self.port.work(button, *args))
        raise ValueError(f"unknown button {button!r}")
        # END SOLUTION


def machine_on(session):
    """Your machine over the kit's port of a task session."""
    return StationMachine(SessionPort(session))


# %% [markdown]
# ## Check: your machine in scripted sessions
#
# First on the simulator: detect, teach two waypoints (the arm posed by hand), repeat them, and a stop pressed while
# teaching. Then on a scripted port that records what your machine asks of the station: a stop in every state, and a
# button pressed in every state, must be handled as above.

# %%
# CHECK station.machine
mine = make_station("sim", seed=0, scene={"objects": [
    {"color": "red", "size": "large", "position_mm": [-150.0, 200.0], "yaw_rad": 0.0}]})
m = machine_on(tasks.start_session(mine))
assert any(b.color == "red" for b in m.press("detect")), "detect found no red block"
m.press("teach")
assert not mine.arm.torque_enabled, "teaching: the torque must be off"
for q, g in (([0.3, -0.2, 0.1, 0.9, 0.0], "open"), ([-0.3, -0.1, 0.2, 0.8, 0.0], "closed")):
    mine.arm.move_by_hand(np.array(q))
    m.press("record", g)
taught = m.press("finish")
assert mine.arm.torque_enabled, "finish: the torque is still off: teaching ends with the arm holding its pose again"
assert taught == 2 and m.state == "idle", f"finish: {taught} waypoints taught (2 recorded), state {m.state!r}"
m.press("repeat")
assert np.abs(mine.arm.joint_positions() - [-0.3, -0.1, 0.2, 0.8, 0.0]).max() < 0.02, "the repeat did not end there"
m.press("teach")
m.press("estop")
assert m.state == "estop", f"a stop while teaching: state {m.state!r}"
m.press("reset")
assert mine.arm.torque_enabled and m.history[-3:] == ["teach", "estop", "idle"], f"history {m.history[-4:]}"


def raises(error, call, *args) -> bool:
    """Whether call(*args) raises `error` (the check's own helper)."""
    try:
        call(*args)
    except error:
        return True
    return False


class ScriptedPort:
    """A port that records what the machine asks (its work returns the command's name)."""

    def __init__(self):
        self.log = []

    def __getattr__(self, name):
        def call(*args):
            self.log.append(name)
            return np.zeros(5) if name == "joints" else (args[0] if name == "work" else None)
        return call


every = ("idle", "teach", "calibrate", "repeat", "estop")
for where in every:                  # a stop in every state (a command's state: pressed during its work)
    port = ScriptedPort()
    m = StationMachine(port)
    m.program = [(np.zeros(5), "open")]
    if where == "teach":
        m.press("teach")
    elif where == "estop":
        m.press("estop")
    if where in ("calibrate", "repeat"):
        port.work = port.replay = lambda *a, m=m: m.press("estop")
        heard = raises(EmergencyStopped, m.press, where)
        assert heard, f"a stop during {where}: the caller did not hear EmergencyStopped"
    else:
        m.press("estop")
    assert m.state == "estop" and m.history.count("estop") == 1, f"a stop in {where}: history {m.history}"
    assert "halt" in port.log, f"a stop in {where}: the arm was not halted"
    for button in ("detect", "teach", "repeat", "record"):
        assert raises(EmergencyStopped, m.press, button), f"after a stop in {where}: {button} was not refused"
    m.press("reset")
    assert m.state == "idle" and port.log[-1] == "restart", f"reset after a stop in {where}: {port.log}"
m = StationMachine(ScriptedPort())
m.press("teach")
for button in ("detect", "teach", "repeat", "reset"):
    assert raises(MachineBusy, m.press, button) and m.state == "teach", \
        f"{button} during teaching was not refused (state {m.state!r})"
print("OK: your machine detected, taught and repeated on the simulator, and a stop in every state halted the arm, "
      "refused every button but reset, and reset restarted it")

# %% [markdown]
# ## 2 · The panel (demonstration)
#
# The panel drives the kit's `TaskMachine`. In the student release its teaching buttons are a lesser stand-in for
# your `StationMachine`: a *teach*, *record* or *finish* pressed out of turn stops the station (press *reset* to go
# on) instead of being refused. `station_panel(session, machine=OwnMachine(session, StationMachine))` (from
# `armlab.tasks.port`) puts your machine behind the panel instead. The emergency stop is the kit's own either way:
# it halts the arm through the guarded arm first, whatever a machine does.
#
# The view shows the camera image, its depth or the last detections; hovering shows the world point under the
# pointer; a click grabs the block under it or drops the held one there. The buttons run the machine's commands
# (calibrate, detect, home, sleep, teach / record waypoint / finish teaching, repeat) on a worker thread, so the
# **EMERGENCY STOP** button is heard at once, even halfway through a motion; nothing moves again until *reset*. The
# joint sliders move the arm within its limits; *real-time* runs the simulated arm at the real one's speed. A committed
# notebook shows the panel as a line of text; it appears when the kernel runs the cell.

# %%
panel.widget()

# %% [markdown]
# ## 3 · Click to grab, click to drop (demonstration)
#
# The panel's handlers are plain calls too: `panel.click((u, v))` is what a click on the image does (with the pixel
# of the full 1280 × 720 frame), and `panel.wait()` waits for the command on the worker thread. Here we click the
# detected blue block's centre, as you would with the mouse.

# %%
blue = next(b for b in session.last.blocks if b.color == "blue")
panel.click(blue.pixel)
panel.wait()
print(panel.status_text())

# %% [markdown]
# The simulator's ground truth must have the blue block in the gripper, and the panel must say so.

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
# ## 4 · Where is the mouse? (demonstration)
#
# `panel.mouse((u, v))` is the readout the image shows under the pointer, and `panel.world_at((u, v))` the point it
# shows. On bare board and on the large blocks' top faces it must agree with the truth (the true camera's
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
# ## 5 · Teach and repeat (demonstration)
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
end = session.arm.joint_positions()
gap = np.abs(end - panel.machine.program.q[-1]).max()
assert len(panel.machine.program) == 3, f"the program has {len(panel.machine.program)} waypoints, expected 3"
assert gap < 0.02, f"the repeat ended {gap:.3f} rad from the last taught waypoint"
assert station.arm.torque_enabled and panel.machine.state == "idle", panel.status_text()
print("OK: taught 3 waypoints by hand, the repeat ended at the last one within 0.02 rad")

# %% [markdown]
# ## 6 · The emergency stop, in the middle of a motion (demonstration)
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
# ## 7 · When you are done
#
# The 3D view stays live as long as the kernel runs. `viewer.close()` stops it; an open view then says it is closed
# (and a browser tab on the viewer turns grey with a "viewer closed" sign) instead of freezing. Shutting the kernel
# down stops the viewer too. On the real arm, leave the station with `station.close()` (or a `with` block): the arm
# goes to its sleep pose first.
#
# Next steps: use the panel to repeat notebook 05's six-location experiment by clicking, or to teach a pick and place
# and replay it (notebook 06).

# %% [markdown]
# ## Your table for this notebook
#
# What `python -m armlab check` lists for this notebook: each exercise, its points, its kind, how it is graded and
# whether you have written it (from the saved files: save the notebook first). The grader decides the score.

# %%
from armlab_course.exercises.rubric import rubric

rubric("08_control_station")
