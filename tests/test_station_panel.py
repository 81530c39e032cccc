"""The control-station panel (armlab.ui.station_panel) headless, on the simulator with its ground truth as the known
answer: the handlers the widgets call, the worker thread that keeps the kernel free, the emergency stop during a
motion, fresh views after moves, the mouse-over readout, teach/record/repeat, and the 3D view that follows the arm.
The same panel in a real browser: tests/test_station_panel_browser.py."""

from __future__ import annotations

import re
import threading
import time

import numpy as np
import pytest

from armlab import make_station, tasks
from armlab.robot import rx200
from armlab.tasks.perception import pointed_point
from armlab.ui.station_panel import StationPanel, depth_rgb, station_panel
from armlab.viz import Viewer

SCENE = {"objects": [
    {"color": "red", "size": "large", "position_mm": [-150.0, 200.0], "yaw_rad": 0.0},
    {"color": "blue", "size": "small", "position_mm": [200.0, 150.0], "yaw_rad": 0.3},
    {"color": "green", "size": "large", "position_mm": [60.0, 300.0], "yaw_rad": -0.5},
]}
READOUT = re.compile(r"pixel \((-?[\d.]+), (-?[\d.]+)\): world x (-?[\d.]+), y (-?[\d.]+), z (-?[\d.]+) mm")


@pytest.fixture(scope="module")
def viewer():
    with Viewer() as v:
        yield v


@pytest.fixture
def panel(viewer):
    station = make_station("sim", seed=0, scene=SCENE)
    session = tasks.start_session(station)
    p = station_panel(session, viewer=viewer)
    p.widget()
    yield p
    p.close()
    assert not p.busy


def walk(widget):
    """The widget and every widget inside it."""
    yield widget
    for child in getattr(widget, "children", ()):
        yield from walk(child)


def truth_block(station, color):
    return next(o for o in station.world.blocks if o.color == color)


def top_pixel(station, color):
    o = truth_block(station, color)
    return station.camera.truth.project((o.position + [0, 0, o.edge / 2])[None])[0]


def board_pixel(station, xy):
    return station.camera.truth.project(np.array([[xy[0], xy[1], 0.0]]))[0]


def readout(text):
    m = READOUT.search(text)
    assert m, text
    values = [float(g) for g in m.groups()]
    return np.array(values[:2]), np.array(values[2:])


def test_click_grabs_the_block_under_it_then_drops_it_where_clicked(panel):
    station = panel.station
    assert panel.next_click == "grab" and "holding nothing" in panel.status_text()
    assert panel.click(top_pixel(station, "blue"))
    message = panel.wait()
    assert "holding the blue small block" in message
    blue = truth_block(station, "blue")
    assert blue.id in station.world.held and blue.position[2] > 30.0        # in the gripper, off the board
    assert panel.next_click == "drop" and "holding the blue small block: the next click drops it" in \
        panel.status_text()
    assert panel.frame_is_look and sorted(b.color for b in panel.session.last.blocks) == ["green", "red"]
    spot = np.array([-200.0, 80.0, 0.0])
    assert panel.click(board_pixel(station, spot[:2]))
    assert "put the blue block down" in panel.wait()
    bottom = blue.position - [0, 0, blue.edge / 2]
    assert np.abs(bottom - spot).max() < 3.0 and not station.world.held
    assert panel.machine.history[-4:] == ["click-grab", "idle", "click-drop", "idle"]    # through the machine


def test_mouse_over_reads_world_coordinates_within_2_mm(panel):
    station, truth = panel.station, panel.station.camera.truth
    rng = np.random.default_rng(3)
    for xy in rng.uniform([-400, 0], [400, 420], (40, 2)):
        near = min(np.hypot(*(xy - o.position[:2])) for o in station.world.blocks)
        if near < 45 or np.hypot(*xy) < 130:                   # bare board only: away from blocks and the robot
            continue
        uv, p = readout(panel.mouse(np.round(board_pixel(station, xy) * 2) / 2))
        assert np.linalg.norm(p - truth.pixel_to_plane(uv[None], 0.0)[0]) < 2.0, (xy, p)
    for color in ("red", "green"):
        o = truth_block(station, color)
        uv, p = readout(panel.mouse(top_pixel(station, color)))
        assert np.linalg.norm(p - truth.pixel_to_plane(uv[None], o.position[2] + o.edge / 2)[0]) < 2.0, (color, p)
    assert "outside the 1280x720 image" in panel.mouse((2000.0, 10.0))
    assert panel._w["mouse"].value.startswith("pixel (2000.0, 10.0)")      # shown under the image


def test_the_emergency_stop_halts_a_running_motion(panel):
    station = panel.station
    panel.set_real_time(True)                   # motions take wall-clock time, as on the real arm
    try:
        target = rx200().sleep
        start = station.arm.joint_positions()
        assert panel.sleep()
        deadline = time.monotonic() + 10
        while not station.arm.is_moving() and time.monotonic() < deadline:
            time.sleep(0.01)
        time.sleep(0.4)
        assert panel.busy and station.arm.is_moving()
        assert not panel.detect() and "detect refused: sleep runs" in panel.messages[-1]   # one at a time
        panel.estop()                            # from this (the "kernel's main") thread while the worker moves
        message = panel.wait(timeout_s=60)
        assert "sleep stopped: EmergencyStopped" in message and panel.machine.state == "estop"
        q_stop = station.arm.joint_positions()
        time.sleep(0.5)
        np.testing.assert_allclose(station.arm.joint_positions(), q_stop, atol=0.005)   # and it stays there
        assert np.abs(q_stop - target).max() > 0.2 and np.abs(q_stop - start).max() > 0.02   # halfway
        assert panel.status_text().startswith("state estop") and any("EMERGENCY STOP" in m for m in panel.messages)
        assert not panel.home() or "refused" in panel.wait()          # everything is refused until reset
        assert panel.machine.state == "estop"
        assert panel._w["reset"].disabled is False and panel._w["home"].disabled is True
        assert "reset" in panel.reset() and panel.machine.state == "idle"
    finally:
        panel.set_real_time(False)


def test_every_move_leaves_a_fresh_view_and_the_next_click_looks_first(panel):
    station = panel.station
    before = panel._frame.timestamp
    sliders = panel._w["sliders"]
    sliders[0].value = 0.5                                  # what a released slider does
    assert "sliders: moved" in panel.wait()
    np.testing.assert_allclose(panel.session.arm.joint_positions()[0], 0.5, atol=0.01)
    assert not panel.frame_is_look and panel._frame.timestamp > before   # a frame captured after the move
    assert "the next click looks again first" in panel._w["caption"].value
    q = np.clip(panel.session.arm.joint_positions(), rx200().lower, rx200().upper)
    np.testing.assert_allclose([s.value for s in sliders], q, atol=0.005)   # encoder ticks
    looks = panel.machine.history.count("detect")
    assert panel.click(top_pixel(station, "red"))
    assert "holding the red large block" in panel.wait()
    assert panel.machine.history.count("detect") == looks + 1   # it looked (arm out of view) before grabbing


def test_sliders_are_the_joint_limits_and_a_move_outside_is_refused(panel):
    robot = rx200()
    assert [(s.min, s.max) for s in panel._w["sliders"]] == list(zip(robot.lower, robot.upper, strict=True))
    q = panel.station.arm.joint_positions()
    bad = robot.home.copy()
    bad[1] = 2.5
    assert not panel.move(bad) and "shoulder" in panel.messages[-1] and "nothing moved" in panel.messages[-1]
    np.testing.assert_allclose(panel.station.arm.joint_positions(), q, atol=0.005)


def test_teach_record_and_repeat(panel):
    station = panel.station
    w = panel._w
    w["teach"].click()                                       # the button, as a click in the browser calls it
    assert panel.machine.state == "teach" and not station.arm.torque_enabled
    assert w["teach"].description == "finish teaching" and not w["record"].disabled
    waypoints = [[0.3, -0.3, 0.3, 0.6, 0.0], [-0.3, -0.2, 0.2, 0.7, 0.0]]
    for q in waypoints:
        for s, v in zip(w["sliders"], q, strict=True):   # in teach mode the sliders are the simulator's hand
            s.value = v
        w["record"].click()
    assert "waypoint 2 recorded" in panel.messages[-1]
    w["teach"].click()
    assert panel.machine.state == "idle" and station.arm.torque_enabled and len(panel.machine.program) == 2
    station.arm.home()
    w["repeat"].click()
    assert "repeated the program" in panel.wait()
    np.testing.assert_allclose(panel.session.arm.joint_positions(), panel.machine.program.q[-1], atol=0.02)


def test_widget_events_reach_the_handlers(panel):
    station = panel.station
    (W, H), (w, h) = panel.frame_size(), panel.image_size()
    uv = board_pixel(station, (250.0, 80.0))
    x, y = (uv + 0.5) * [w / W, h / H]
    move = {"type": "mousemove", "dataX": int(round(x)), "dataY": int(round(y))}
    panel._events._handle_mouse_msg(None, move, None)       # what ipyevents does with the browser's message
    pix, p = readout(panel._w["mouse"].value)
    assert np.abs(p[:2] - [250.0, 80.0]).max() < 3.0        # the shown image's pixel: 2 camera pixels per step
    panel._events._handle_mouse_msg(None, {**move, "type": "click"}, None)
    assert "refused" in panel.wait() and "no block" in panel.messages[-1]     # bare board: nothing to grab
    panel._w["mode"].value = "depth"
    assert panel.view_mode == "depth" and bytes(panel._w["image"].value[:2]) == b"\xff\xd8"
    panel._w["estop"].click()
    assert panel.machine.state == "estop"
    panel._w["reset"].click()
    assert panel.machine.state == "idle"


def test_the_3d_view_follows_the_arm_during_a_real_time_motion(panel, viewer, monkeypatch):
    shown = []
    real_show = viewer.show
    monkeypatch.setattr(viewer, "show", lambda q, g=None: (shown.append(np.array(q)), real_show(q, g))[1])
    panel.set_real_time(True)
    try:
        panel.home()
        panel.wait()
        shown.clear()
        assert panel.sleep()
        panel.wait(timeout_s=30)
    finally:
        panel.set_real_time(False)
    path = np.array(shown)
    assert len(path) >= 8, f"the view was redrawn {len(path)} times during a 2+ s motion"
    sleep = rx200().sleep
    far = np.abs(path - sleep).max(axis=1)
    assert np.sum((far > 0.1) & (np.abs(path).max(axis=1) > 0.1)) >= 3       # poses between home and sleep
    np.testing.assert_allclose(viewer.q, panel.station.arm.joint_positions(), atol=0.005)


def test_panel_text_form_and_no_thread_left(panel):
    box = panel.widget()
    assert repr(box) == ("StationPanel(camera, world readout, click-to-grab/drop, teach/repeat, E-STOP, joints): run "
                         "the cell")
    assert len(repr(box)) <= 110
    panes = [w for w in walk(box) if type(w).__name__ == "SceneView"]
    assert len(panes) == 1                                          # the 3D view, beside the camera
    panel.detect()
    panel.wait()
    time.sleep(0.1)
    assert not [t for t in threading.enumerate() if t.name.startswith("armlab-panel")]


def test_live_camera_refreshes_and_stops(panel):
    n = panel.refreshes
    panel._w["live"].value = True
    time.sleep(1.6)
    panel.stop_live()
    assert panel.refreshes - n >= 2
    assert not panel._live_thread.is_alive()


def test_depth_view_and_bad_options():
    d = np.full((4, 6), 900.0, np.float32)
    d[0, 0] = np.nan
    rgb = depth_rgb(d)
    assert rgb.shape == (4, 6, 3) and rgb.dtype == np.uint8 and rgb[0, 0].max() == 0 and rgb[1, 1].max() > 0
    station, other = make_station("sim", seed=0, scene="empty"), make_station("sim", seed=1, scene="empty")
    session = tasks.Session(station, tasks.GuardedArm(station.arm))        # uncalibrated: refused before it matters
    with pytest.raises(ValueError, match="another session"):
        StationPanel(session, machine=tasks.TaskMachine(tasks.Session(other, tasks.GuardedArm(other.arm))))
    with pytest.raises(TypeError, match=r"start_session\(station\)"):
        StationPanel(station)
    with pytest.raises(ValueError, match="live_period_s"):
        StationPanel(session, live_period_s=0.0)


def test_teaching_a_real_arm_the_sliders_follow_the_hand(panel, monkeypatch):
    station = panel.station
    monkeypatch.setattr(panel, "_hand", lambda: None)          # as on the real arm: no simulated hand to drive
    assert "pose the arm by hand" in panel.teach()
    try:
        assert all(s.disabled for s in panel._w["sliders"])     # the sliders show the arm, they do not move it
        station.arm.move_by_hand([0.4, -0.3, 0.3, 0.5, 0.0])    # the student's hand
        deadline = time.monotonic() + 5
        while abs(panel._w["sliders"][0].value - station.arm.joint_positions()[0]) > 0.01 and \
                time.monotonic() < deadline:
            time.sleep(0.05)
        np.testing.assert_allclose([s.value for s in panel._w["sliders"]], station.arm.joint_positions(), atol=0.01)
    finally:
        panel.teach()
    assert panel.machine.state == "idle" and station.arm.torque_enabled


def test_readout_and_click_use_one_pixel_to_world_rule(panel):
    station = panel.station
    for uv in (top_pixel(station, "red"), board_pixel(station, (250.0, 80.0)), board_pixel(station, (-300.0, 350.0))):
        shown = panel.world_at(uv)
        np.testing.assert_array_equal(shown, pointed_point(panel.session.calibration, panel._depth, uv))
        frame = station.camera.capture()                                 # what a click on that frame acts on
        np.testing.assert_array_equal(tasks.click_world(panel.session, uv, frame), pointed_point(
            panel.session.calibration, panel.session.calibration.depth_correction.apply(frame.depth), uv))
        _, p = readout(panel.mouse(uv))
        np.testing.assert_allclose(p, shown, atol=0.051)                 # the readout prints 0.1 mm


def test_status_and_slider_readouts_follow_a_real_time_move(panel):
    panel.set_real_time(True)
    try:
        readouts, statuses = [], []
        assert panel.sleep()
        deadline = time.monotonic() + 60
        while panel.busy and time.monotonic() < deadline:
            readouts.append([s.value for s in panel._w["sliders"]])
            statuses.append(panel._w["status"].value)
            time.sleep(0.05)
        panel.wait(60)
    finally:
        panel.set_real_time(False)
    moving = [t for t in statuses if "running: sleep" in t]
    assert moving and all("machine: execute" in t or "machine: starting" in t for t in moving)
    assert any("machine: execute" in t for t in moving), "the status never named the machine's state while moving"
    assert not any("state idle" in t for t in moving)
    distinct = {tuple(np.round(r, 3)) for r in readouts}
    assert len(distinct) >= 3, f"the slider readouts did not follow the motion ({len(distinct)} distinct values)"
    np.testing.assert_allclose([s.value for s in panel._w["sliders"]], panel.session.arm.joint_positions(), atol=0.005)


def test_sliders_go_through_the_machine(panel):
    station = panel.station
    sliders = panel._w["sliders"]
    assert all(s.step == 0.01 and not s.continuous_update and s.layout.width == "100%" for s in sliders)
    panel.set_real_time(True)
    try:
        assert panel.sleep()
        while not station.arm.is_moving():
            time.sleep(0.01)
        assert all(s.disabled for s in sliders)                          # no dragging while a command runs ...
        n = len(panel.messages)
        sliders[0].value = 0.5                                            # ... and a change that comes anyway
        assert "sliders refused: sleep runs" in panel.messages[n]
        panel.estop()                                                     # the e-stop stops a slider move too
        panel.wait(60)
        assert all(s.disabled for s in sliders)
        before = station.arm.joint_positions()
        sliders[1].value = 0.3
        assert "refused" in panel.messages[-1] and "emergency-stopped" in panel.messages[-1]
        np.testing.assert_allclose(station.arm.joint_positions(), before, atol=0.005)     # encoder ticks
        panel.reset()
        assert not any(s.disabled for s in sliders)
        sliders[0].value = 0.4                                            # a slider move, stopped halfway
        while not station.arm.is_moving():
            time.sleep(0.01)
        panel.estop()
        assert "sliders stopped: EmergencyStopped" in panel.wait(60)
        assert abs(station.arm.joint_positions()[0] - 0.4) > 0.02
    finally:
        panel.estop()                        # whatever failed above, leave no motion running
        panel.wait(60)
        panel.reset()
        panel.set_real_time(False)


def test_a_change_made_while_another_thread_writes_readouts_still_acts(panel, monkeypatch):
    """The follow thread writes slider readouts (which must not act) while the user may move a slider: a readout
    being written on one thread must not swallow the user's change on another (a CI run lost 'sliders refused'
    this way). Here a readout is held half-written while the user's change comes."""
    writing, release = threading.Event(), threading.Event()
    set_controls = panel._set_controls

    def slow_set_controls(*args):
        writing.set()
        release.wait(10)
        set_controls(*args)

    monkeypatch.setattr(panel, "_set_controls", slow_set_controls)
    readout = threading.Thread(target=panel._update_widgets)
    readout.start()
    assert writing.wait(10)
    threading.Timer(0.3, release.set).start()      # the readout finishes a moment after the user's change came
    n = len(panel.messages)
    panel._w["sliders"][0].value = 0.25
    readout.join(10)
    monkeypatch.undo()
    assert panel.wait(60).startswith("sliders: moved to"), panel.messages[n:]
    np.testing.assert_allclose(panel.station.arm.joint_positions()[0], 0.25, atol=0.005)


def test_the_depth_view_has_a_colour_scale(panel):
    from armlab.ui.station_panel import DEPTH_RANGE_MM, depth_scale_html

    scale = panel._w["depth_scale"]
    assert scale.layout.display == "none"
    panel._w["mode"].value = "depth"
    assert scale.layout.display == ""
    lo, hi = DEPTH_RANGE_MM
    html = depth_scale_html()
    assert f"{lo:.0f} mm (near)" in html and f"{hi:.0f} mm (far)" in html and "no return" in html
    near, far = depth_rgb(np.array([[lo, hi]]))[0]
    assert html.index("rgb({},{},{}) 0%".format(*near)) < html.index("rgb({},{},{}) 100%".format(*far))
    panel._w["mode"].value = "camera"
    assert scale.layout.display == "none"
