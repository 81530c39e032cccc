"""The click-to-grab panel (armlab.ui.click_widget): click events as ipyevents sends them -> camera pixels ->
grab on the first click, drop on the second, refusals that move nothing. Runs on the simulator with its ground
truth as the known answer."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from armlab import make_station, tasks
from armlab.ui import click_widget
from armlab.ui.click_widget import ClickToGrab, encode_view, event_pixel, scaled_size

FRAME, IMAGE = (1280, 720), (640, 360)


def browser_event(uv, frame=FRAME, image=IMAGE, drawn_width=800.0, border=0.0):
    """The dict ipyevents sends for a click on camera pixel uv of an image of size `image` showing `frame`, drawn
    `drawn_width` px wide (aspect kept) with a border: its JavaScript computes dataX = round((relativeX - border) /
    drawn width * natural width)."""
    drawn = np.array([drawn_width, drawn_width * image[1] / image[0]])
    edge = (np.asarray(uv, float) + 0.5) / np.asarray(frame)           # fraction of the frame from its top-left
    rel = edge * drawn + border
    data = np.round((rel - border) / drawn * np.asarray(image))
    return {"type": "click", "relativeX": float(rel[0]), "relativeY": float(rel[1]), "dataX": int(data[0]),
            "dataY": int(data[1]), "boundingRectWidth": float(drawn[0] + 2 * border),
            "boundingRectHeight": float(drawn[1] + 2 * border), "button": 0, "altKey": False}


# ---------------------------------------------------------------------------------------------------------------
# Event -> pixel
# ---------------------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("drawn_width, border", [(640.0, 0.0), (800.0, 0.0), (333.0, 3.0), (1600.0, 1.0)])
def test_event_pixel_recovers_the_camera_pixel_whatever_the_drawn_size(drawn_width, border):
    rng = np.random.default_rng(1)
    for uv in [(0.0, 0.0), (1279.0, 719.0), (640.0, 360.0), *rng.uniform([0, 0], [1279, 719], (50, 2))]:
        got = event_pixel(browser_event(uv, drawn_width=drawn_width, border=border), FRAME, IMAGE)
        # dataX is rounded to a whole pixel of the 640-px image: 2 camera px per image px
        assert np.abs(np.subtract(got, uv)).max() <= 1.0 + 1e-9


def test_event_pixel_falls_back_to_the_drawn_position():
    ev = browser_event((900.0, 100.0), drawn_width=500.0)
    del ev["dataX"], ev["dataY"]
    np.testing.assert_allclose(event_pixel(ev, FRAME, IMAGE), (900.0, 100.0), atol=1e-9)   # unrounded: exact


def test_event_pixel_exact_values():
    # dataX = 320 of a 640-px image is the middle of a 1280-px frame: the edge between pixels 639 and 640
    assert event_pixel({"dataX": 320, "dataY": 180}, FRAME, IMAGE) == (639.5, 359.5)
    assert event_pixel({"dataX": 0, "dataY": 0}, FRAME, IMAGE) == (0.0, 0.0)            # clipped to the first pixel
    assert event_pixel({"dataX": 640, "dataY": 360}, FRAME, IMAGE) == (1279.0, 719.0)


@pytest.mark.parametrize("event, match", [
    ({"type": "click"}, "no position"),
    ({"type": "click", "relativeX": 5, "relativeY": 5, "boundingRectWidth": 0, "boundingRectHeight": 0}, "drawn 0"),
    ({"type": "click", "dataX": 700, "dataY": 10}, "outside the image"),
    ({"type": "click", "dataX": -3, "dataY": 10}, "outside the image"),
])
def test_event_pixel_refuses_events_without_a_usable_position(event, match):
    with pytest.raises(tasks.ClickRefused, match=match):
        event_pixel(event, FRAME, IMAGE)


def test_event_pixel_rejects_bad_sizes():
    with pytest.raises(ValueError, match="must be positive"):
        event_pixel({"dataX": 1, "dataY": 1}, (0, 720), IMAGE)


def test_encode_view_downscales_and_marks_the_click():
    rgb = np.zeros((720, 1280, 3), np.uint8)
    rgb[:, 640:] = (0, 200, 0)
    data, size = encode_view(rgb, 0.5, marker=(300.0, 500.0))
    assert size == IMAGE == scaled_size(FRAME, 0.5) and data[:2] == b"\xff\xd8"
    img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)[..., ::-1]
    assert img.shape == (360, 640, 3)
    assert img[100, 400, 1] > 180 and img[100, 200, 1] < 20               # the right half stayed green
    ring = np.argwhere((img[..., 0] > 150) & (img[..., 2] > 150) & (img[..., 1] < 100))
    centre = ring.mean(axis=0)[::-1]                                      # (x, y) in the shown image
    np.testing.assert_allclose(centre, (150.0, 250.0), atol=1.0)           # camera (300, 500) at half size
    assert np.hypot(*(ring[:, ::-1] - centre).T).max() < 10
    with pytest.raises(ValueError, match="uint8"):
        encode_view(rgb.astype(np.float32))
    with pytest.raises(ValueError, match="scale"):
        encode_view(rgb, 0.0)


# ---------------------------------------------------------------------------------------------------------------
# The handler on the simulator
# ---------------------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def panel():
    station = make_station("sim", seed=0, scene={"objects": [
        {"color": "red", "size": "large", "position_mm": [-150.0, 200.0], "yaw_rad": 0.0},
        {"color": "blue", "size": "small", "position_mm": [200.0, 150.0], "yaw_rad": 0.3},
    ]})
    session = tasks.start_session(station)
    tasks.look(session)
    return ClickToGrab(session)


def truth(panel, color):
    return next(o for o in panel.station.world.blocks if o.color == color)


@pytest.mark.exercise("calib.tag_extrinsics", "calib.depth_plane", "detect.classify")
def test_first_click_grabs_second_click_drops(panel):
    blue = next(b for b in panel.session.last.blocks if b.color == "blue")
    assert panel.next_action == "grab" and panel.image_size() == IMAGE and panel.frame_size() == FRAME
    grab = panel.handle_event(browser_event(blue.pixel, drawn_width=900.0))
    assert grab.action == "grab" and grab.ok and panel.holding is not None and panel.holding.color == "blue"
    top = truth(panel, "blue").position                    # the true block, carried by the gripper now
    assert np.abs(grab.world[:2] - blue.position[:2]).max() < 4.0 and abs(grab.world[2] - 25.0) < 3.0
    assert "holding the blue small block" in grab.message and "world (" in grab.message
    kinds = [c[0] for c in grab.commands]
    assert kinds.count("close") == 1 and ("close", True) in grab.commands and kinds.count("move") >= 4
    assert top[2] > 30.0                                   # the true block left the board with the gripper

    spot = np.array([-200.0, 80.0, 0.0])
    uv = panel.station.camera.truth.project(spot[None])[0]
    assert panel.next_action == "drop"
    drop = panel.handle_event(browser_event(uv, drawn_width=640.0))
    assert drop.action == "drop" and drop.ok and panel.holding is None and panel.next_action == "grab"
    assert np.abs(drop.world - spot).max() < 3.0 and "put the blue block down" in drop.message
    placed = truth(panel, "blue")
    bottom = placed.position - [0, 0, placed.edge / 2]
    assert np.abs(bottom - spot).max() < 3.0
    assert panel.history[-2:] == [grab, drop]


@pytest.mark.parametrize("where, match", [
    ((5.0, 5.0), "off the board"),
    ((640.0, 700.0), "on the robot's base"),
    ("bare board", "no block at the click"),
])
def test_refused_clicks_move_nothing(panel, where, match):
    station = panel.station
    if where == "bare board":
        where = station.camera.truth.project(np.array([[100.0, 350.0, 0.0]]))[0]
    q = station.arm.joint_positions().copy()
    before = [o.position.copy() for o in station.world.blocks]
    result = panel.handle_event(browser_event(where))
    assert not result.ok and not result.moved and match in result.message and "nothing moved" in result.message
    np.testing.assert_allclose(station.arm.joint_positions(), q, atol=0.005)   # encoder readings jitter
    for o, p in zip(station.world.blocks, before, strict=True):
        np.testing.assert_array_equal(o.position, p)
    assert panel.next_action == "grab"


def test_malformed_and_other_events(panel):
    assert panel.handle_event({"type": "mousemove", "dataX": 10, "dataY": 10}) is None
    result = panel.handle_event({"type": "click", "button": 0})
    assert not result.ok and "no position" in result.message and result.world is None
    assert "2 finite numbers" in panel.click((np.nan, 3.0)).message
    assert "2 finite numbers" in panel.click((1.0, 2.0, 3.0)).message


def test_a_stopped_arm_is_reported_not_raised(panel):
    station, session = panel.station, panel.session
    arm = session.arm
    red = next(b for b in session.last.blocks if b.color == "red")
    station.arm.emergency_stop()
    try:
        result = panel.click(red.pixel)
    finally:
        station.arm.reset()
    assert not result.ok and "EmergencyStopped" in result.message and panel.holding is None
    assert session.arm is arm           # the click recorded through the session's own arm, swapped nothing


def test_widget_wires_the_image_clicks_to_the_handler(panel, capsys):
    box = panel.widget()
    assert repr(box) == "click-to-grab panel (1280x720 frame shown at 640x360 px): run the cell, then click a block"
    assert len(repr(box)) <= 110                            # ipywidgets cuts a longer text form
    assert "holding nothing: the next click grabs" in box.children[0].value
    image = box.children[1]
    assert image.format == "jpeg" and bytes(image.value[:2]) == b"\xff\xd8"
    assert panel._events.source is image and panel._events.watched_events == ["click"]
    shown = bytes(image.value)
    red = next(b for b in panel.session.last.blocks if b.color == "red")
    panel._events._handle_mouse_msg(None, browser_event(red.pixel, drawn_width=700.0), None)   # what the browser does
    assert panel.holding is not None and panel.holding.color == "red"
    shown_text = panel._out.outputs[-1]
    assert shown_text["name"] == "stdout" and "holding the red large block" in shown_text["text"]
    assert capsys.readouterr().out == ""                    # the message goes to the panel, not the cell
    assert bytes(image.value) != shown                      # the view was refreshed after the grab
    assert "holding the red large block: the next click drops it" in box.children[0].value   # and the state


# ---------------------------------------------------------------------------------------------------------------
# Stale views (notebook 05's trap) and the state machine
# ---------------------------------------------------------------------------------------------------------------

SCENE3 = {"objects": [
    {"color": "red", "size": "large", "position_mm": [-150.0, 200.0], "yaw_rad": 0.0},
    {"color": "green", "size": "large", "position_mm": [60.0, 300.0], "yaw_rad": -0.5},
]}


def test_a_panel_opened_after_a_pick_starts_from_a_fresh_look_and_says_what_is_held():
    station = make_station("sim", seed=0, scene=SCENE3)
    session = tasks.start_session(station)
    green = next(b for b in tasks.look(session).blocks if b.color == "green")
    assert tasks.pick(session, green)                       # picked outside the panel: the last look is stale
    assert not click_widget.view_is_current(session)
    panel = ClickToGrab(session)
    box = panel.widget()
    assert click_widget.view_is_current(session)      # widget() looked again
    assert [b.color for b in session.last.blocks] == ["red"]   # the green block is in the gripper
    assert "holding the green large block: the next click drops it where you click" in box.children[0].value
    assert panel.next_action == "drop"


def test_a_click_on_a_stale_picture_is_refused_after_a_new_look():
    station = make_station("sim", seed=0, scene=SCENE3)
    session = tasks.start_session(station)
    obs = tasks.look(session)
    panel = ClickToGrab(session)
    red = next(b for b in obs.blocks if b.color == "red")
    station.arm.home()                                      # moved by other code: the picture is out of date
    before = [o.position.copy() for o in station.world.blocks]
    result = panel.click(red.pixel)
    assert not result.ok and "out of date" in result.message and "nothing moved" in result.message
    assert session.last is not obs and click_widget.view_is_current(session)
    for o, p in zip(station.world.blocks, before, strict=True):
        np.testing.assert_array_equal(o.position, p)        # only the arm moved (out of view)
    again = panel.click(red.pixel)                          # a click on the new picture acts
    assert again.ok and panel.holding.color == "red"


def test_clicks_through_the_state_machine():
    station = make_station("sim", seed=0, scene=SCENE3)
    session = tasks.start_session(station)
    machine = tasks.TaskMachine(session)
    obs = tasks.look(session)
    panel = ClickToGrab(session, machine=machine)
    red = next(b for b in obs.blocks if b.color == "red")
    grab = panel.click(red.pixel)
    assert grab.ok and machine.history[-2:] == ["click-grab", "idle"]
    machine.estop()
    stopped = panel.click(station.camera.truth.project(np.array([[-200.0, 80.0, 0.0]]))[0])
    assert not stopped.ok and not stopped.moved and "EmergencyStopped" in stopped.message
    assert panel.holding.color == "red" and machine.state == "estop"
    machine.reset()
    drop = panel.click(station.camera.truth.project(np.array([[-200.0, 80.0, 0.0]]))[0])
    assert drop.ok and machine.history[-2:] == ["click-drop", "idle"]
    other = make_station("sim", seed=1, scene="empty")
    with pytest.raises(ValueError, match="another session"):
        ClickToGrab(tasks.Session(other, tasks.GuardedArm(other.arm)), machine=machine)
    with pytest.raises(ValueError, match="another session"):
        ClickToGrab(tasks.Session(station, tasks.GuardedArm(station.arm)), machine=machine)   # same station, not it


class _FirstBlockThenPoint:
    """A click sequence of one's own, plainer than the kit's rule: the first click grabs the first block seen
    wherever it lands; the next one drops on the clicked point (yaw 0)."""

    def __init__(self):
        self.held, self.told = None, []

    def on_click(self, point, seen):
        if self.held is None:
            return ("grab", seen[0])
        return ("drop", np.asarray(point, float), 0.0)

    def after(self, action, ok):
        self.told.append((action[0], ok))
        self.held = (action[1] if ok else None) if action[0] == "grab" else (None if ok else self.held)


def test_a_sequence_of_ones_own_decides_what_the_panels_clicks_mean():
    """ClickToGrab(session, sequence=...) runs each click through tasks.click_with: a click on bare board grabs the
    first block seen (the kit's rule would refuse it), the next drops it where clicked; a drop the kit cannot act on
    is a refused click with nothing moved; a sequence with a machine, or without on_click / after, is refused."""
    station = make_station("sim", seed=0, scene=SCENE3)
    session = tasks.start_session(station)
    sequence = _FirstBlockThenPoint()
    panel = ClickToGrab(session, sequence=sequence)
    first = tasks.look(session).blocks[0]
    truth = next(o for o in station.world.blocks if o.color == first.color)
    bare = station.camera.truth.project(np.array([[0.0, 150.0, 0.0]]))[0]
    grab = panel.click(bare)
    assert grab.ok and grab.action == "grab" and truth.id in station.world.held, grab.message
    spot = np.array([-220.0, 70.0, 0.0])
    drop = panel.click(station.camera.truth.project(spot[None])[0])
    assert drop.ok and drop.action == "drop" and not station.world.held, drop.message
    assert np.abs(truth.position - [0, 0, truth.edge / 2] - spot).max() < 3.0
    assert sequence.told == [("grab", True), ("drop", True)]
    sequence.held = first                                   # believes it holds a block: the kit has nothing to drop
    before = [o.position.copy() for o in station.world.blocks]
    refused = panel.click(station.camera.truth.project(np.array([[150.0, 250.0, 0.0]]))[0])
    assert not refused.ok and not refused.moved and "cannot be acted on" in refused.message, refused.message
    for o, p in zip(station.world.blocks, before, strict=True):
        np.testing.assert_array_equal(o.position, p)
    with pytest.raises(ValueError, match="without a machine"):
        ClickToGrab(session, sequence=sequence, machine=tasks.TaskMachine(session))
    with pytest.raises(ValueError, match="on_click"):
        ClickToGrab(session, sequence=object())
