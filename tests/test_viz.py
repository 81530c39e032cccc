"""armlab.viz: scene contents against the kinematics/camera/lab models, the server lifecycle, and a real browser."""

from __future__ import annotations

import base64
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
import umsgpack

from armlab import kinematics
from armlab.blocks import LAB_RGB, ObjectState
from armlab.camera import Camera, look_at
from armlab.lab import lab_config
from armlab.robot import rx200
from armlab.viz import Viewer, rgbd_to_point_cloud
from armlab.viz import geometry as geo
from armlab.viz.server import ZMQ_ENV, probe, server_pids

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).parent))
import browser  # noqa: E402

ROOT = "/meshcat/armlab"
_DTYPES = {"Float32Array": np.float32, "Uint32Array": np.uint32, "Uint16Array": np.uint16, "Uint8Array": np.uint8}


# -- helpers: read back what the meshcat server holds (what every browser will be sent) --------------------------
def scene_commands(html: str) -> list[dict]:
    """The drawing commands embedded in a meshcat static HTML page, decoded from base64 msgpack."""
    blobs = re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", html)
    return [umsgpack.unpackb(base64.b64decode(b)) for b in blobs]


def by_path(commands: list[dict], kind: str) -> dict[str, dict]:
    return {c["path"]: c for c in commands if c["type"] == kind}


def matrix(cmd: dict) -> np.ndarray:
    return np.array(cmd["matrix"], dtype=float).reshape(4, 4).T


def array(packed: dict) -> np.ndarray:
    data = np.frombuffer(packed["array"].data, dtype=_DTYPES[packed["type"]])
    return data.reshape(-1, packed["itemSize"])


def geometry_of(cmd: dict) -> dict:
    return cmd["object"]["geometries"][0]


def material_of(cmd: dict) -> dict:
    return cmd["object"]["materials"][0]


def random_q(n: int, seed: int = 0) -> np.ndarray:
    robot = rx200()
    return np.random.default_rng(seed).uniform(robot.lower, robot.upper, (n, 5))


@pytest.fixture
def viewer():
    with Viewer() as v:
        yield v


# -- geometry of the arm --------------------------------------------------------------------------------------------
def test_links_run_between_joint_positions():
    q = random_q(200)
    parts = geo.arm_part_poses(q, 30.0)
    points = kinematics.joint_positions(q)
    lengths = np.linalg.norm(np.diff(kinematics.joint_positions(np.zeros(5)), axis=0), axis=1)
    np.testing.assert_allclose(lengths, [65.66, 38.91, np.hypot(50, 200), 200, 65, 93.575], atol=1e-9)
    for i, name in enumerate(geo.LINK_NAMES):
        T = parts.poses[f"links/{name}"]
        ends = [T[:, :3, :3] @ [0, s * lengths[i] / 2, 0] + T[:, :3, 3] for s in (-1, 1)]
        np.testing.assert_allclose(ends[0], points[:, i], atol=1e-9)
        np.testing.assert_allclose(ends[1], points[:, i + 1], atol=1e-9)
        R = T[:, :3, :3]
        np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
        np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)


def test_gripper_fingers_at_opening_and_drums_on_axes():
    q = random_q(50, seed=1)
    openings = np.linspace(0, 74, 50)
    parts = geo.arm_part_poses(q, openings)
    tool = kinematics.fk(q)
    for side, sign in (("left_finger", 1), ("right_finger", -1)):
        local = np.linalg.inv(tool) @ parts.poses[f"gripper/{side}"]  # finger pose in the tool frame
        inner_face_y = local[:, 1, 3] - sign * geo.FINGER_SIZE_MM[1] / 2
        np.testing.assert_allclose(inner_face_y, sign * openings / 2, atol=1e-9)
        np.testing.assert_allclose(local[:, :3, :3], np.broadcast_to(np.eye(3), (50, 3, 3)), atol=1e-12)
    frames = kinematics.link_frames(q)
    np.testing.assert_allclose(parts.poses["gripper/tool_point"], tool, atol=1e-12)
    # the wrist_rotate drum turns about the approach direction (tool x), the shoulder drum about DH z1
    np.testing.assert_allclose(parts.poses["joints/wrist_rotate"][:, :3, 1], tool[:, :3, 0], atol=1e-12)
    np.testing.assert_allclose(parts.poses["joints/shoulder"][:, :3, 1], frames[:, 1, :3, 2], atol=1e-12)
    with pytest.raises(ValueError, match=r"gripper_opening_mm must lie in \[0, 74\]"):
        geo.arm_part_poses(q[0], 80.0)
    with pytest.raises(ValueError, match="one value or one per pose"):
        geo.arm_part_poses(q, openings[:3])


# -- the scene the server holds ------------------------------------------------------------------------------------
def test_scene_holds_the_arm_at_the_shown_pose(viewer):
    q = np.array([0.4, -0.3, 0.5, 0.9, -0.7])
    viewer.show(q, gripper_opening_mm=28.0)
    commands = scene_commands(viewer.static_html())
    transforms, objects = by_path(commands, "set_transform"), by_path(commands, "set_object")
    np.testing.assert_allclose(matrix(transforms[ROOT]), np.diag([1e-3, 1e-3, 1e-3, 1]))  # mm inside, metres outside
    expected = geo.arm_part_poses(q, 28.0).poses
    for path, pose in expected.items():
        np.testing.assert_allclose(matrix(transforms[f"{ROOT}/arm/{path}"]), pose, atol=1e-9, err_msg=path)
    points = kinematics.joint_positions(q)
    for i, name in enumerate(geo.LINK_NAMES):
        cylinder = geometry_of(objects[f"{ROOT}/arm/links/{name}"])
        assert cylinder["type"] == "CylinderGeometry"
        assert cylinder["height"] == pytest.approx(np.linalg.norm(points[i + 1] - points[i]), abs=1e-9)
    tool_in_world = matrix(transforms[f"{ROOT}/arm/gripper/tool_point"])[:3, 3]
    np.testing.assert_allclose(tool_in_world, kinematics.fk(q)[:3, 3], atol=1e-9)


def test_bad_pose_raises_and_changes_nothing(viewer):
    q0 = np.array([0.1, 0.2, 0.3, 0.4, 0.5])
    viewer.show(q0, 35.0)
    before = viewer.static_html()
    bad = q0.copy()
    bad[1] = 2.5  # shoulder limit is 113 deg
    with pytest.raises(ValueError, match=r"shoulder = .*143.2 deg.* is outside its limits"):
        viewer.show(bad)
    with pytest.raises(ValueError, match=r"one joint vector \(5,\) rad, got shape \(4,\)"):
        viewer.show(np.zeros(4))
    with pytest.raises(ValueError, match="gripper_opening_mm"):
        viewer.show(q0, gripper_opening_mm=float("nan"))
    with pytest.raises(ValueError, match="strictly increase"):
        viewer.animate([0.0, 1.0, 1.0], np.zeros((3, 5)))
    np.testing.assert_array_equal(viewer.q, q0)
    assert viewer.gripper_opening_mm == 35.0
    strip = re.compile(r'"uuid"|[0-9a-f]{8}-[0-9a-f]{4}-')
    assert strip.sub("", viewer.static_html()) == strip.sub("", before)


def test_board_grid_and_tags_follow_the_lab_config(viewer):
    lab = lab_config()
    commands = scene_commands(viewer.static_html())
    objects, transforms = by_path(commands, "set_object"), by_path(commands, "set_transform")
    plate = geometry_of(objects[f"{ROOT}/board/plate"])
    assert (plate["width"], plate["height"]) == (1000.0, 650.0)
    np.testing.assert_allclose(matrix(transforms[f"{ROOT}/board/plate"])[:2, 3], [0.0, 150.0])
    segments = array(objects[f"{ROOT}/board/grid"]["object"]["geometries"][0]["data"]["attributes"]["position"])
    segments = segments.reshape(-1, 2, 3)
    along_y = segments[segments[:, 0, 0] == segments[:, 1, 0]]
    along_x = segments[segments[:, 0, 1] == segments[:, 1, 1]]
    np.testing.assert_array_equal(np.sort(along_y[:, 0, 0]), np.arange(-450, 451, 50))
    np.testing.assert_array_equal(np.sort(along_x[:, 0, 1]), np.arange(-175, 476, 50))
    centres = {i: matrix(transforms[f"{ROOT}/board/tags/tag_{i}"])[:2, 3] for i in (1, 2, 3, 4)}
    expected = {1: (-250, -25), 2: (250, -25), 3: (250, 275), 4: (-250, 275)}
    for i, xy in expected.items():
        np.testing.assert_allclose(centres[i], xy)
        assert geometry_of(objects[f"{ROOT}/board/tags/tag_{i}"])["width"] == lab.tags.size_mm


# -- station drawings ----------------------------------------------------------------------------------------------
def test_objects_are_their_footprints_extruded(viewer):
    cube = ObjectState("red", "large", 38.0, [100.0, 200.0, 19.0], yaw=0.3, id=1)
    arch = ObjectState("blue", "large", 38.0, [-150.0, 250.0, 57.0], yaw=-0.6, shape="arch", id=2)
    viewer.draw_objects([cube, arch])
    commands = scene_commands(viewer.static_html())
    objects, transforms = by_path(commands, "set_object"), by_path(commands, "set_transform")
    for obj in (cube, arch):
        cmd = objects[f"{ROOT}/objects/{obj.id}"]
        assert material_of(cmd)["color"] == int("{:02x}{:02x}{:02x}".format(*LAB_RGB[obj.color]), 16)
        local = array(geometry_of(cmd)["data"]["attributes"]["position"]).astype(float)
        T = matrix(transforms[f"{ROOT}/objects/{obj.id}"])
        world = local @ T[:3, :3].T + T[:3, 3]
        np.testing.assert_allclose([world[:, 2].min(), world[:, 2].max()], [obj.bottom_z, obj.top_z], atol=1e-4)
        footprint = np.vstack(obj.footprint_world())
        top = world[np.isclose(world[:, 2], obj.top_z, atol=1e-4)][:, :2]
        np.testing.assert_allclose(top, footprint, atol=1e-4)  # same vertices, same order
    np.testing.assert_allclose(np.sort(world[:, :2].reshape(-1, 2), axis=0)[[0, -1]],
                               np.sort(arch.corners()[:, :2], axis=0)[[0, -1]], atol=1e-4)
    viewer.draw_objects([cube])  # the arch left the board
    objects = by_path(scene_commands(viewer.static_html()), "set_object")
    assert f"{ROOT}/objects/1" in objects and f"{ROOT}/objects/2" not in objects
    with pytest.raises(ValueError, match="unique"):
        viewer.draw_objects([cube, cube])


def test_extruded_mesh_is_closed_and_outward():
    vertices, faces = geo.extruded_mesh([np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)], 0.0, 5.0)
    tri = vertices[faces]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    volume = np.einsum("ij,ij->i", tri[:, 0], normals).sum() / 6  # divergence theorem: positive iff outward
    assert volume == pytest.approx(500.0)
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    assert np.all(np.unique(edges, axis=0, return_counts=True)[1] == 2)  # every edge shared by two faces: closed


def station_camera() -> Camera:
    lab = lab_config()
    return Camera(lab.factory_K, [0.05, -0.02, 0.001, 0.0, 0.0],
                  look_at(lab.camera_position_mm, lab.camera_look_at_mm), *lab.image_size)


def test_frustum_corners_back_project_the_image_corners(viewer):
    camera = station_camera()
    corners = geo.frustum_corners(camera, 900.0)
    edges = np.array([[-0.5, -0.5], [1279.5, -0.5], [1279.5, 719.5], [-0.5, 719.5]])
    np.testing.assert_allclose(camera.project(corners), edges, atol=1e-6)
    np.testing.assert_allclose(camera.depth_of(corners), 900.0, atol=1e-9)
    # known answer without distortion: a camera 1000 mm above the origin looking straight down
    down = Camera(np.array([[1000.0, 0, 639.5], [0, 1000.0, 359.5], [0, 0, 1]]), np.zeros(5),
                  look_at([0, 0, 1000], [0, 0, 0]), 1280, 720)
    np.testing.assert_allclose(np.abs(geo.frustum_corners(down, 1000.0)), [[640, 360, 0]] * 4, atol=1e-9)
    viewer.draw_camera(camera, depth_mm=900.0)
    commands = scene_commands(viewer.static_html())
    lines = by_path(commands, "set_object")[f"{ROOT}/cameras/camera/frustum"]
    drawn = array(geometry_of(lines)["data"]["attributes"]["position"])
    np.testing.assert_allclose(drawn, geo.frustum_segments(camera, 900.0), atol=1e-3)
    frame = matrix(by_path(commands, "set_transform")[f"{ROOT}/cameras/camera/frame"])
    np.testing.assert_allclose(frame, np.linalg.inv(camera.T_cam_world), atol=1e-9)
    with pytest.raises(TypeError, match="Camera"):
        viewer.draw_camera("not a camera")


def test_rgbd_frame_becomes_a_world_point_cloud(viewer):
    camera = station_camera()
    h, w = camera.image_shape
    v, u = np.mgrid[0:h, 0:w]
    uv = np.column_stack([u.ravel(), v.ravel()]).astype(float)
    board = camera.pixel_to_plane(uv, 0.0)                              # what every pixel sees on the board
    depth = camera.depth_of(board).reshape(h, w).astype(np.float32)
    depth[:100] = np.nan                                                # no return in the top rows
    rgb = np.zeros((h, w, 3), np.uint8)
    rgb[..., 0] = (u % 256).astype(np.uint8)
    rgb[..., 1] = (v % 256).astype(np.uint8)
    points, colors = rgbd_to_point_cloud(rgb, depth, camera, stride=8)
    assert len(points) == (h - 100) // 8 * (w // 8)
    np.testing.assert_allclose(points[:, 2], 0.0, atol=0.05)            # float32 depth: ~0.01 mm at 1 m
    px = camera.project(points)
    np.testing.assert_allclose(px, np.round(px), atol=1e-3)             # each point lies on its pixel's ray
    np.testing.assert_array_equal(colors[:, 0], (np.round(px[:, 0]) % 256).astype(np.uint8))
    np.testing.assert_array_equal(colors[:, 1], (np.round(px[:, 1]) % 256).astype(np.uint8))
    assert viewer.draw_rgbd(rgb, depth, camera, stride=8) == len(points)
    cloud = by_path(scene_commands(viewer.static_html()), "set_object")[f"{ROOT}/clouds/cloud"]
    np.testing.assert_allclose(array(geometry_of(cloud)["data"]["attributes"]["color"]), colors / 255.0, atol=1e-6)
    with pytest.raises(ValueError, match="uint8"):
        rgbd_to_point_cloud(rgb.astype(float), depth, camera)
    with pytest.raises(ValueError, match="camera is 1280x720"):
        rgbd_to_point_cloud(rgb[:, :640], depth[:, :640], camera)
    with pytest.raises(ValueError, match="colors must be uint8"):
        viewer.draw_point_cloud(points, colors.astype(float))


# -- animation and sliders -----------------------------------------------------------------------------------------
def test_animation_keyframes_follow_the_trajectory(viewer):
    times = np.array([0.0, 0.5, 1.25, 2.0])
    qs = np.linspace(rx200().home, rx200().sleep, 4)
    viewer.animate(times, qs, gripper_opening_mm=[74, 60, 40, 30], fps=20)
    anim = [c for c in scene_commands(viewer.static_html()) if c["type"] == "set_animation"]
    assert len(anim) == 1
    clips = {a["path"]: a["clip"] for a in anim[0]["animations"]}
    expected = geo.arm_part_poses(qs, np.array([74, 60, 40, 30.0])).poses
    for path in ("links/forearm", "gripper/left_finger", "frames/tool"):
        clip = clips[f"{ROOT}/arm/{path}"]
        assert clip["fps"] == 20
        track = {t["name"]: t["keys"] for t in clip["tracks"]}[".position"]
        np.testing.assert_allclose([k["time"] for k in track], times * 20)
        np.testing.assert_allclose([k["value"] for k in track], expected[path][:, :3, 3], atol=1e-9)
    np.testing.assert_allclose(viewer.q, qs[-1])
    assert viewer.gripper_opening_mm == 30
    viewer.show(rx200().home)  # a later pose replaces the animation, or the browser would replay it over the pose
    anim = [c for c in scene_commands(viewer.static_html()) if c["type"] == "set_animation"]
    assert all(a["animations"] == [] for a in anim)


def test_animation_moves_objects_too(viewer):
    times = np.array([0.0, 1.0, 2.0])
    qs = np.linspace(rx200().home, rx200().sleep, 3)
    red = [ObjectState("red", "large", 38.0, np.array([x, 200.0, z]), yaw, "cube", 7)
           for x, z, yaw in [(-100.0, 19.0, 0.0), (0.0, 120.0, 0.2), (100.0, 19.0, 0.4)]]   # carried across
    blue = ObjectState("blue", "small", 25.0, np.array([50.0, 300.0, 12.5]), 0.0, "cube", 8)  # handed over at 1 s
    viewer.animate(times, qs, objects=[[red[0]], [red[1], blue], [red[2], blue]], fps=10)
    anim = [c for c in scene_commands(viewer.static_html()) if c["type"] == "set_animation"]
    clips = {a["path"]: a["clip"] for a in anim[-1]["animations"]}
    tracks = {t["name"]: t for t in clips[f"{ROOT}/objects/7"]["tracks"]}
    np.testing.assert_allclose([k["time"] for k in tracks[".position"]["keys"]], times * 10)
    np.testing.assert_allclose([k["value"] for k in tracks[".position"]["keys"]], [o.position for o in red])
    quats = [k["value"] for k in tracks[".quaternion"]["keys"]]      # three.js (x, y, z, w): a turn about z
    np.testing.assert_allclose([2 * np.arctan2(qz, qw) for _, _, qz, qw in quats], [0.0, 0.2, 0.4], atol=1e-9)
    assert ".visible" not in tracks                                    # always there: no visibility track
    blue_tracks = {t["name"]: t for t in clips[f"{ROOT}/objects/8"]["tracks"]}
    visible = blue_tracks[".visible"]
    assert visible["type"] == "boolean" and [k["value"] for k in visible["keys"]] == [False, True, True]
    # drawn where the animation ends
    transforms = by_path(scene_commands(viewer.static_html()), "set_transform")
    np.testing.assert_allclose(matrix(transforms[f"{ROOT}/objects/7"])[:3, 3], red[2].position)
    with pytest.raises(ValueError, match="one list of objects per key frame"):
        viewer.animate(times, qs, objects=[[red[0]]])
    with pytest.raises(ValueError, match="appears twice"):
        viewer.animate(times, qs, objects=[[red[0], red[1]], [], []])


def test_joint_sliders_move_the_arm(viewer):
    box = viewer.joint_sliders()
    sliders = [*box.sliders, box.gripper]
    assert [s.description for s in sliders] == [*rx200().joint_names, "gripper mm"]
    np.testing.assert_allclose([s.min for s in sliders[:5]], rx200().lower)
    sliders[1].value = -0.5
    sliders[5].value = 20.0
    np.testing.assert_allclose(viewer.q, [0, -0.5, 0, 0, 0])
    assert viewer.gripper_opening_mm == 20.0
    transforms = by_path(scene_commands(viewer.static_html()), "set_transform")
    np.testing.assert_allclose(matrix(transforms[f"{ROOT}/arm/gripper/tool_point"]),
                               kinematics.fk([0, -0.5, 0, 0, 0]), atol=1e-9)
    # nbval compares a displayed widget's text/plain: it must not change from run to run, and it tells the student
    # who opens a committed notebook what to do (the widget itself appears only in a running kernel)
    assert repr(box) == ("JointSliders(waist, shoulder, elbow, wrist_angle, wrist_rotate, gripper mm): run the cell "
                         "to use them")
    assert len(repr(box)) <= 110                                   # ipywidgets cuts a longer text form


def test_joint_sliders_start_from_and_follow_the_viewers_pose(viewer):
    viewer.show([0.3, -0.2, 0.1, 0.4, 0.2], 25.0)
    box = viewer.joint_sliders()
    np.testing.assert_allclose([s.value for s in box.sliders], [0.3, -0.2, 0.1, 0.4, 0.2])
    assert box.gripper.value == 25.0
    robot = rx200()
    viewer.animate([0.0, 1.0], np.array([robot.sleep, robot.home]))     # the viewer ends at home ...
    np.testing.assert_allclose([s.value for s in box.sliders], robot.home)   # ... and so do the sliders
    np.testing.assert_allclose(viewer.q, robot.home)                   # following moved nothing back
    box.sliders[0].value = 0.25                                        # the first touch moves from there
    np.testing.assert_allclose(viewer.q, [0.25, 0, 0, 0, 0])


def test_joint_sliders_drive_the_arm_within_its_limits(viewer):
    from armlab import make_station, tasks

    station = make_station("sim", seed=0, scene="empty")
    station.arm.home()
    with pytest.raises(TypeError, match="TaskMachine"):              # no slider moves the arm around the executor
        viewer.joint_sliders(arm=station.arm)
    box = viewer.joint_sliders(machine=tasks.TaskMachine(tasks.Session(station, tasks.GuardedArm(station.arm))))
    np.testing.assert_allclose(viewer.q, station.arm.joint_positions(), atol=0.005)  # the viewer shows the arm first
    np.testing.assert_allclose([s.value for s in box.sliders], viewer.q)
    assert [(s.min, s.max) for s in box.sliders] == list(zip(rx200().lower, rx200().upper, strict=True))
    assert not box.sliders[0].continuous_update                       # the arm moves when a slider is released
    box.sliders[0].value = 0.4
    np.testing.assert_allclose(station.arm.joint_positions(), [0.4, 0, 0, 0, 0], atol=0.005)
    np.testing.assert_allclose(viewer.q, station.arm.joint_positions(), atol=0.005)   # encoder ticks
    assert box.note.value == ""
    box.sliders[1].value = 1.2                                        # tips the arm into the board: refused
    box.sliders[2].value = 1.0
    assert "not moved: PlanRefused" in box.note.value and "board" in box.note.value   # before the first command
    assert station.arm.joint_positions()[2] < 0.05                    # the arm did not go there
    np.testing.assert_allclose([s.value for s in box.sliders], viewer.q)   # the sliders went back to the arm
    box.gripper.value = "closed"
    assert station.arm.gripper_opening_mm < 74.0


def test_close_tells_what_is_still_open(viewer):
    pane = viewer.widget(height_px=300)
    assert pane.height_px == 300 and pane.notice == ""
    assert repr(pane) == "ViewerPane(live 3D view of the station; run the cell to see it)"
    box = viewer.joint_sliders()
    viewer.close()
    assert "closed" in pane.notice
    sent = []
    pane.send = lambda content, buffers=None: sent.append(content)
    pane._on_view_message(pane, {"type": "ready", "view": "v"}, [])     # a view opened later still gets the picture
    assert [c["type"] for c in sent] == ["scene"]
    assert all(s.disabled for s in box.sliders) and "viewer closed" in box.note.value
    box.sliders[0].value = 0.3                                        # no RuntimeError in the log console
    assert viewer.closed
    with pytest.raises(RuntimeError, match="closed"):
        viewer.widget()


def test_close_puts_a_sign_on_an_open_page(monkeypatch):
    sent = []
    with Viewer() as viewer:
        real = viewer._vis.window.send
        monkeypatch.setattr(viewer._vis.window, "send", lambda cmd: (sent.append(cmd.lower()), real(cmd))[1])
    sky = [c for c in sent if c["type"] == "set_property" and c["path"] == "/Background"]
    assert {c["property"] for c in sky} == {"top_color", "bottom_color"}
    assert all(max(c["value"]) - min(c["value"]) < 0.01 for c in sky)      # grey
    sign = [c for c in sent if c["type"] == "set_object" and c["path"].endswith("_closed")]
    assert len(sign) == 1
    obj = sign[0]["object"]
    assert obj["object"]["type"] == "Sprite" and obj["textures"][0]["text"] == "viewer closed"
    with Viewer() as again:                                            # the next viewer on the same server ...
        commands = scene_commands(again.static_html())
    assert not [c for c in commands if c["type"] == "set_object" and c["path"].endswith("_closed")]   # ... no sign
    sky = {c["property"]: c["value"] for c in commands if c.get("path") == "/Background"}
    assert max(sky["top_color"]) - min(sky["top_color"]) > 0.3                                       # ... blue sky


def test_point_size_is_given_to_meshcat_in_metres(viewer):
    points = np.array([[0.0, 0.0, 0.0], [100.0, 50.0, 20.0]])
    viewer.draw_point_cloud(points, np.full((2, 3), 200, np.uint8), point_size_mm=4.0)
    cloud = by_path(scene_commands(viewer.static_html()), "set_object")[f"{ROOT}/clouds/cloud"]
    assert material_of(cloud)["size"] == pytest.approx(0.004)          # 4 mm, not 4 m
    np.testing.assert_allclose(array(geometry_of(cloud)["data"]["attributes"]["position"]), points)  # in mm


# -- server lifecycle ----------------------------------------------------------------------------------------------
def test_viewers_share_the_session_server(meshcat_server):
    assert os.environ[ZMQ_ENV] == meshcat_server
    with Viewer() as a, Viewer() as b:
        assert not a.owns_server and a.zmq_url == b.zmq_url == meshcat_server
        assert repr(a) == f"Viewer({a.url})" and a.url.startswith("http://127.0.0.1:")
    assert a.closed and repr(a) == "Viewer(closed)"
    assert probe(meshcat_server).startswith("http://")            # closing a viewer leaves the shared server up
    assert len(server_pids(os.getpid())) <= 1                     # no server of our own besides the shared one
    with pytest.raises(RuntimeError, match="closed"):
        a.show(np.zeros(5))


def test_owned_server_is_stopped_on_close(monkeypatch):
    monkeypatch.delenv(ZMQ_ENV)
    before = set(server_pids(os.getpid()))
    with Viewer() as viewer:
        assert viewer.owns_server and viewer.server.alive()
        pid = viewer.server.pid
        assert set(server_pids(os.getpid())) - before == {pid}
        assert probe(viewer.zmq_url) == viewer.url
    assert viewer.server.proc.returncode is not None              # killed and reaped: no zombie either
    assert set(server_pids(os.getpid())) == before
    assert not Path(f"/proc/{pid}").exists() or pid not in server_pids()


def test_server_dies_with_a_killed_parent():
    code = ("import os, sys; os.environ.pop('ARMLAB_MESHCAT_ZMQ', None)\n"
            "from armlab.viz import Viewer\nv = Viewer()\nprint(v.server.pid, flush=True)\nsys.stdin.read()\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    pid = int(proc.stdout.readline())
    assert pid in server_pids(proc.pid)
    proc.send_signal(signal.SIGKILL)                               # what nbval does to a kernel
    proc.wait()
    deadline = time.monotonic() + 60                               # a liveness bound, not a speed check
    while pid in server_pids() and time.monotonic() < deadline:
        time.sleep(0.1)
    assert pid not in server_pids()


def test_stale_server_url_is_a_clear_error(monkeypatch):
    monkeypatch.setenv(ZMQ_ENV, "tcp://127.0.0.1:9")               # nobody listens on the discard port
    with pytest.raises(ConnectionError, match="no meshcat server answers at tcp://127.0.0.1:9"):
        Viewer()


def test_session_server_does_not_outlive_the_session():
    env = {k: v for k, v in os.environ.items() if k != ZMQ_ENV}
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                          "tests/test_viz.py::test_viewers_share_the_session_server"],
                         cwd=REPO, env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-3000:]
    match = re.search(r"meshcat: the session's shared server \(pid (\d+)\) stopped", run.stdout)
    assert match, run.stdout[-3000:]
    assert int(match.group(1)) not in server_pids()


# -- a real browser ------------------------------------------------------------------------------------------------
SIZE = (1024, 768)
EYE = np.array([700.0, -550.0, 500.0])


def browser_camera() -> Camera:
    """meshcat's default camera as a pinhole model: 75 deg vertical field of view, at EYE, looking at the origin."""
    w, h = SIZE
    f = (h / 2) / np.tan(np.radians(75 / 2))
    K = np.array([[f, 0, (w - 1) / 2], [0, f, (h - 1) / 2], [0, 0, 1]])
    return Camera(K, np.zeros(5), look_at(EYE, [0, 0, 0], up=(0, 0, 1)), w, h)


@pytest.mark.skipif(browser.find_chromium() is None, reason="no chromium on PATH (tools/ensure-chromium installs it)")
def test_browser_draws_the_arm_where_the_model_says(tmp_path):
    q = np.array([0.5, -0.4, 0.3, 0.8, 0.0])
    with Viewer(q=q, frames=False) as viewer:
        viewer.look_from(EYE)
        with_arm = browser.screenshot(viewer.save_html(tmp_path / "arm.html"), tmp_path / "arm.png", SIZE)
        viewer.set_visible("arm", False)
        without = browser.screenshot(viewer.save_html(tmp_path / "no_arm.html"), tmp_path / "no_arm.png", SIZE)
    assert (tmp_path / "arm.html").stat().st_size > 500_000                  # self-contained: three.js inside
    changed = np.abs(with_arm.astype(int) - without.astype(int)).max(axis=2) > 40
    # where the arm should be: its links, sampled along each segment and projected with the browser's camera
    camera = browser_camera()
    points = kinematics.joint_positions(q)
    t = np.linspace(0.05, 0.95, 15)[:, None]
    samples = np.vstack([a + t * (b - a) for a, b in zip(points[1:-1], points[2:], strict=True)])
    px = np.round(camera.project(samples)).astype(int)
    hit = [changed[v - 2:v + 3, u - 2:u + 3].any() for u, v in px]
    assert np.mean(hit) > 0.95, f"arm drawn at only {np.mean(hit):.0%} of its projected link points"
    # and nowhere else: every changed pixel lies within the arm's projected silhouette (plus the gripper)
    silhouette = np.zeros(changed.shape, np.uint8)
    for (a, b), radius in zip(zip(points[:-1], points[1:], strict=True), geo.LINK_RADII_MM, strict=True):
        pa, pb = np.round(camera.project(np.array([a, b]))).astype(int)
        width = int(2 * radius * camera.K[0, 0] / camera.depth_of(np.array([a]))[0]) + 2
        cv2.line(silhouette, tuple(pa), tuple(pb), 1, width)
    tool = np.round(camera.project(points[-1:])).astype(int)[0]
    cv2.circle(silhouette, tuple(tool), int(60 * camera.K[0, 0] / camera.depth_of(points[-1:])[0]), 1, -1)
    silhouette = cv2.dilate(silhouette, np.ones((25, 25), np.uint8)).astype(bool)   # joint drums stick out
    assert changed.sum() > 2000
    assert changed[silhouette].sum() / changed.sum() > 0.99
    # the board (around the tag at (250, 275)) is drawn in both images, unchanged, and is not the background
    tag = np.round(camera.project(np.array([[250.0, 275.0, 0.0]]))).astype(int)[0]
    assert not changed[tag[1] - 3:tag[1] + 4, tag[0] - 3:tag[0] + 4].any()
    assert with_arm[tag[1], tag[0]].max() < 60                               # the black tag square


@pytest.mark.skipif(browser.find_chromium() is None, reason="no chromium on PATH (tools/ensure-chromium installs it)")
def test_browser_shows_the_station_and_its_point_cloud(tmp_path):
    """The whole station (notebook 00's "draw the whole station" cell): blocks, camera frustum and a 14 000-point
    cloud. With the point size passed in mm where meshcat wants metres every point was 4 m across and the view one
    uniform wall (a software-rendered frame took over a minute)."""
    from armlab import make_station

    station = make_station("sim", seed=0, scene="random", n=6)
    frame = station.camera.capture()
    shots = {}
    with Viewer(frames=False) as viewer:
        viewer.look_from([600.0, -450.0, 500.0])
        viewer.draw_objects(station.world.objects)
        viewer.draw_camera(station.camera.truth)
        n = viewer.draw_rgbd(frame.rgb, frame.depth, station.camera.truth, stride=8)
        assert n > 10_000
        start = time.monotonic()
        shots["all"] = browser.screenshot(viewer.save_html(tmp_path / "all.html"), tmp_path / "all.png", SIZE)
        seconds = time.monotonic() - start
        for part in ("clouds", "objects"):
            viewer.set_visible(part, False)
            shots[part] = browser.screenshot(viewer.save_html(tmp_path / f"no_{part}.html"), tmp_path /
                                             f"no_{part}.png", SIZE)
            viewer.set_visible(part, True)
    full = shots["all"]
    _, counts = np.unique((full // 16).reshape(-1, 3), axis=0, return_counts=True)
    assert counts.max() / counts.sum() < 0.6 and len(counts) > 40, "the view is (nearly) one colour"
    assert seconds < 60, f"one snapshot took {seconds:.0f} s to render"
    cloud = (np.abs(full.astype(int) - shots["clouds"].astype(int)).max(axis=2) > 40).sum()
    blocks = (np.abs(full.astype(int) - shots["objects"].astype(int)).max(axis=2) > 40).sum()
    assert 1500 < cloud < 0.5 * full.shape[0] * full.shape[1], f"the cloud changes {cloud} pixels"
    assert blocks > 100, f"the blocks change only {blocks} pixels"


# -- readable figures ----------------------------------------------------------------------------------------------
def test_figure_readability_rule():
    import matplotlib
    import matplotlib.pyplot as plt

    from armlab.viz.figures import check_readable, readability_problems, readable

    with matplotlib.rc_context():
        fig, ax = plt.subplots(figsize=(10, 2.3), dpi=60)          # notebook 01's old calibration figure
        ax.plot([0, 1], [0, 1], label="a")
        ax.legend(fontsize=8)
        ax.set(title="per-view error", xlabel="view")
        problems = readability_problems(fig)
        assert not any("px wide" in p for p in problems)           # 600 px: not shrunk, just small
        assert any("'per-view error' is 12 pt at dpi 60: 10.0 px" in p for p in problems), problems
        assert any("'a' is 8 pt" in p for p in problems)
        plt.close(fig)
        readable()
        fig, ax = plt.subplots(figsize=(9, 3))
        ax.plot([0, 1], [0, 1], label="a")
        ax.legend()
        ax.set(title="t", xlabel="x (mm)", ylabel="y (mm)")
        check_readable(fig)                                       # dpi 100, fonts >= 9.5 pt, 900 px wide
        fig.set_figwidth(12)
        with pytest.raises(ValueError, match="1200 px wide"):
            check_readable(fig)
        plt.close("all")


def test_close_after_the_server_died_does_not_wait_for_it(monkeypatch):
    monkeypatch.delenv(ZMQ_ENV)
    viewer = Viewer()
    pane = viewer.widget()
    viewer.server.proc.kill()                                      # e.g. killed from outside
    viewer.server.proc.wait()
    sent = []
    monkeypatch.setattr(viewer._vis.window, "send", lambda cmd: sent.append(cmd))
    viewer.close()
    assert viewer.closed and "closed" in pane.notice and sent == []  # nothing sent to the dead server


# -- the inline view: the scene over the kernel's comm channel ------------------------------------------------------
def test_an_owned_server_listens_on_loopback_only(monkeypatch):
    monkeypatch.delenv(ZMQ_ENV)
    with Viewer() as viewer:
        fds = [os.readlink(p) for p in Path(f"/proc/{viewer.server.pid}/fd").iterdir()]
        inodes = {f[len("socket:["):-1] for f in fds if f.startswith("socket:[")}
        listening = []
        for table in ("/proc/net/tcp", "/proc/net/tcp6"):
            for line in Path(table).read_text().splitlines()[1:]:
                fields = line.split()
                if fields[3] == "0A" and fields[9] in inodes:      # state LISTEN, a socket of the server
                    listening.append(fields[1])
        assert len(listening) == 2, listening                      # zmq and web
        assert all(a.startswith("0100007F:") for a in listening), f"not 127.0.0.1 only: {listening}"


def test_scene_record_replays_the_latest_state_in_order():
    from armlab.viz.scene import SceneRecord

    record = SceneRecord()
    assert record.apply("set_object", "/meshcat/a", b"A1")
    assert not record.apply("set_object", "/meshcat/a", b"A1")           # the same object again: nothing to send
    record.apply("set_transform", "/meshcat/a", b"Ta1")
    record.apply("set_transform", "/meshcat/a", b"Ta2")                  # only the latest transform is kept
    record.apply("set_property", "/meshcat/a", b"Pa")
    record.apply("set_object", "/meshcat/a/b", b"B")
    record.apply("set_object", "/meshcat/c", b"C")
    assert record.replay() == [b"A1", b"Pa", b"Ta2", b"B", b"C"]
    record.apply("delete", "/meshcat/a", b"D")
    assert record.replay() == [b"C"]
    record.apply("set_object", "/meshcat/c", b"C2")                      # a new object drops the old properties
    assert record.replay() == [b"C2"]
    with pytest.raises(ValueError, match="not a meshcat drawing command: 'url'"):
        record.apply("url", "", b"")


def test_the_inline_view_gets_the_scene_then_one_message_per_drawing_call(viewer):
    pane = viewer.widget(height_px=350)
    sent = []
    pane.send = lambda content, buffers=None: sent.append((content, [bytes(b) for b in buffers or []]))
    pane._on_view_message(pane, {"type": "ready", "view": "abc"}, [])
    (content, scene), = sent
    assert content == {"type": "scene", "to": "abc"}
    commands = [umsgpack.unpackb(b) for b in scene]
    served = scene_commands(viewer.static_html())                      # what the server would send a new tab
    for kind in ("set_object", "set_transform"):                       # (a shared server holds others' history too)
        mine = {p: c for p, c in by_path(commands, kind).items() if p.startswith(ROOT)}
        assert len(mine) > 20 and mine == {p: c for p, c in by_path(served, kind).items() if p.startswith(ROOT)}
    sent.clear()
    viewer.show([0.5, 0.1, -0.2, 0.3, 0.0])
    assert len(sent) == 1 and sent[0][0] == {"type": "update"}         # one message for the whole pose ...
    moved = {c["path"]: matrix(c) for c in map(umsgpack.unpackb, sent[0][1]) if c["type"] == "set_transform"}
    shown = by_path(scene_commands(viewer.static_html()), "set_transform")
    assert len(moved) >= 15
    for path, T in moved.items():                                      # ... carrying what the server now holds
        np.testing.assert_array_equal(T, matrix(shown[path]))
    pane._on_view_message(pane, {"type": "error", "view": "abc", "text": "no WebGL"}, [])
    assert pane.errors == ["no WebGL"]
    with pytest.raises(ValueError, match=r"height_px must lie in \[100, 4000\] px"):
        viewer.widget(height_px=20)


def test_the_view_code_loads_meshcats_bundle_as_a_module():
    from armlab.viz.widget import _esm

    source = _esm()
    assert source.startswith("const module = { exports: {} };")
    assert "MeshCat" in source and "handle_command_bytearray" in source and source.rstrip().endswith(
        "export default { render };")
    assert "no 3D scene from the kernel after" in source and "WebGL is not available" in source


def test_joint_sliders_with_a_machine_go_through_it(viewer):
    from armlab import make_station, tasks

    station = make_station("sim", seed=0, scene="empty")
    machine = tasks.TaskMachine(tasks.start_session(station))     # calibrates and fits the sag now, not mid-move
    box = viewer.joint_sliders(machine=machine)
    start = len(machine.history)
    box.sliders[0].value = 0.3
    assert box.note.value == "" and machine.history[start:] == ["execute", "idle"]     # a move of the machine
    np.testing.assert_allclose(station.arm.joint_positions()[0], 0.3, atol=0.01)
    machine.estop()
    box.sliders[0].value = -0.2                                       # refused: the e-stop wins
    assert "not moved" in box.note.value and "emergency-stopped" in box.note.value
    np.testing.assert_allclose(station.arm.joint_positions()[0], 0.3, atol=0.01)
    assert box.sliders[0].value == pytest.approx(station.arm.joint_positions()[0], abs=0.01)   # back to the arm
    machine.reset()
    machine.teach_start("sliders test")                               # another command holds the machine
    box.sliders[0].value = -0.2
    assert "the machine is in 'teach'" in box.note.value
    machine.estop()
    machine.reset()
    with pytest.raises(ValueError, match="give the machine alone"):
        viewer.joint_sliders(arm=make_station("sim", seed=1, scene="empty").arm, machine=machine)
