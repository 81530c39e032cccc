"""armlab.robot: the RX200 description matches the manufacturer's numbers; broken data files are named precisely."""

import shutil

import numpy as np
import pytest

from armlab._paths import data_path
from armlab.robot import JOINT_NAMES, RobotDataError, load_robot, rx200

FILES = {"joints": "rx200_joints.csv", "dh": "rx200_dh.csv", "pox": "rx200_pox.csv"}
# the kit's DH table (data/rx200_dh.csv) is the answer of exercise fk.dh_table: the student release leaves it out
needs_dh_table = pytest.mark.exercise("fk.dh_table")


def test_joint_limits_and_poses_are_the_manufacturers():
    r = rx200()
    assert r.joint_names == JOINT_NAMES == ("waist", "shoulder", "elbow", "wrist_angle", "wrist_rotate")
    np.testing.assert_allclose(np.degrees(r.lower[1:4]), [-108, -108, -100], atol=1e-4)
    np.testing.assert_allclose(np.degrees(r.upper[1:4]), [113, 93, 123], atol=1e-4)
    np.testing.assert_allclose(r.upper[[0, 4]], np.pi - 1e-5)
    np.testing.assert_allclose(r.lower[[0, 4]], -(np.pi - 1e-5))
    np.testing.assert_allclose(r.velocity, [np.pi, 1.0, np.pi, np.pi, np.pi])
    np.testing.assert_array_equal(r.home, np.zeros(5))
    np.testing.assert_allclose(r.sleep, [0, -1.80, 1.55, 0.8, 0])


@needs_dh_table
def test_dh_table_encodes_the_geometry():
    dh = rx200().dh
    assert dh.shape == (5, 4)
    np.testing.assert_allclose(dh[0, 1], 65.66 + 38.91)                     # shoulder height
    np.testing.assert_allclose(dh[1, 2], np.hypot(50, 200))                 # L-shaped upper arm
    np.testing.assert_allclose(dh[1, 0], -np.arctan2(200, 50))              # its angle from horizontal
    np.testing.assert_allclose(dh[1, 0] + dh[2, 0], 0, atol=1e-15)          # forearm horizontal at q = 0
    np.testing.assert_allclose(dh[2, 2], 200)
    np.testing.assert_allclose(dh[4, 1], 65 + 43 + 23 + 27.575)            # wrist_angle axis to tool point


def test_pox_model_in_world_frame():
    r = rx200()
    np.testing.assert_allclose(np.linalg.norm(r.screws[:, :3], axis=1), 1)
    np.testing.assert_allclose(r.M[:3, 3], [0, 408.575, 304.57])
    # tool x (approach) along world +y at home, tool z up
    np.testing.assert_allclose(r.M[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]], atol=1e-15)
    for a in (r.lower, r.upper, r.dh, r.screws, r.M):
        if a is None:                   # no DH table (the student release)
            continue
        with pytest.raises(ValueError):
            a[0] = 1.0  # read-only: the shared model cannot be changed by accident


def test_limit_checks_name_the_joint():
    r = rx200()
    q = np.array([0.0, 0.0, 2.0, 0.0, 0.0])
    assert not r.within_limits(q)
    msg = r.limit_violations(q)
    assert len(msg) == 1 and msg[0].startswith("elbow = 2.000000 rad (114.6 deg) is outside its limits")
    assert r.limit_violations(r.sleep) == []
    np.testing.assert_array_equal(r.within_limits(np.stack([r.home, q, r.sleep])), [True, False, True])


def copy_data(tmp_path):
    for name in FILES.values():
        if data_path(name).is_file():              # (the student release has no DH table)
            shutil.copy(data_path(name), tmp_path / name)
    return {k: tmp_path / v for k, v in FILES.items()}


def edit(path, old, new):
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new, 1))


def line_of(path, start):
    return 1 + [i for i, line in enumerate(path.read_text().splitlines()) if line.startswith(start)][0]


def load(paths):
    return load_robot(paths["joints"], paths["dh"], paths["pox"])


@needs_dh_table
def test_copied_files_load_identically(tmp_path):
    r, copy = rx200(), load(copy_data(tmp_path))
    for field in ("lower", "upper", "velocity", "home", "sleep", "dh", "screws", "M"):
        np.testing.assert_array_equal(getattr(copy, field), getattr(r, field))


@needs_dh_table
@pytest.mark.parametrize("which, old, new, line_start, problem", [
    ("dh", "shoulder,-1.3258176636680326", "shoulder,abc", "shoulder", "theta_offset_rad = 'abc' is not a number"),
    ("dh", "elbow,1.3258176636680326,0.0,200.0,0.0", "elbow,1.3,0.0,200.0", "elbow", "4 fields, expected 5"),
    ("dh", "wrist_rotate,0.0,158.575", "wrist_rotate,0.0,inf", "wrist_rotate", "d_mm = 'inf' is not finite"),
    ("dh", "joint,theta_offset_rad", "joint,theta_rad", "joint", "header is"),
    ("dh", "elbow,", "forearm,", "forearm", "row 'forearm' where 'elbow' was expected"),
    ("joints", "shoulder,-1.884956,1.972222", "shoulder,1.972222,-1.884956", "shoulder",
     "joint shoulder: lower limit 1.972222 is not below upper -1.884956"),
    ("joints", "elbow,-1.884956,1.623156,3.141592653589793", "elbow,-1.884956,1.623156,0", "elbow",
     "velocity limit 0.0 must be positive"),
    ("joints", ",0.0,-1.80", ",0.0,-1.95", "shoulder", "joint shoulder: sleep pose -1.95 is outside its limits"),
    ("pox", "elbow,-1.0,0.0,0.0", "elbow,-1.0,0.5,0.0", "elbow", "rotation axis has length 1.118"),
])
def test_malformed_files_name_file_line_and_problem(tmp_path, which, old, new, line_start, problem):
    paths = copy_data(tmp_path)
    edit(paths[which], old, new)
    with pytest.raises(RobotDataError) as err:
        load(paths)
    msg = str(err.value)
    assert msg.startswith(f"{paths[which]}, line {line_of(paths[which], line_start)}: "), msg
    assert problem in msg, msg


@needs_dh_table
def test_missing_extra_and_empty_files(tmp_path):
    paths = copy_data(tmp_path)
    text = paths["pox"].read_text()
    paths["pox"].write_text("\n".join(line for line in text.splitlines() if not line.startswith("wrist_rotate_home")))
    with pytest.raises(RobotDataError, match="row 'wrist_rotate_home' is missing"):
        load(paths)
    paths["pox"].write_text(text + "gripper,0,0,1,0,0,0\n")
    with pytest.raises(RobotDataError, match=rf"line {len(text.splitlines()) + 1}: unexpected extra row 'gripper'"):
        load(paths)
    paths["pox"].write_text("# only a comment\n\n")
    with pytest.raises(RobotDataError, match="no header row"):
        load(paths)
    with pytest.raises(RobotDataError, match="nowhere.csv: file not found"):
        load_robot(tmp_path / "nowhere.csv")
    assert issubclass(RobotDataError, ValueError)


@needs_dh_table
def test_printing_the_robot_shows_its_tables_not_a_dataclass_dump():
    text = repr(rx200())
    assert text == str(rx200()) and len(text) < 1600 and "array(" not in text
    lines = text.splitlines()
    assert lines[0].startswith("RobotModel: 5 joints") and any(line.startswith("DH (standard)") for line in lines)
    assert any(line.startswith("PoX screws") for line in lines)
    shoulder_dh = next(line for line in lines if line.startswith("  shoulder") and "206.16" in line)
    assert shoulder_dh.split()[1:] == ["-75.96", "0.00", "206.16", "0.00"]        # theta0 deg, d, a mm, alpha deg


def test_the_drawing_points_come_from_the_data_file():
    """The waist top and the wrist_rotate joint are rows of rx200_pox.csv (rx200.urdf.xacro: the waist joint's
    origin 65.66 mm up the base axis, the wrist_rotate joint 65 mm out along the approach from the wrist), carried
    with link frames 1 and 4; kinematics.joint_positions types no lengths of its own."""
    from armlab.kinematics import joint_positions, link_frames
    robot = rx200()
    np.testing.assert_allclose(robot.points_home, [[0.0, 0.0, 65.66], [0.0, 315.0, 304.57]])
    q = np.random.default_rng(3).uniform(robot.lower, robot.upper, (200, 5))
    points, frames = joint_positions(q), link_frames(q, check_limits=False)
    np.testing.assert_allclose(points[:, 1], np.tile([0.0, 0.0, 65.66], (200, 1)), atol=1e-9)
    wrist, approach = frames[:, 3, :3, 3], frames[:, 6, :3, 0]
    np.testing.assert_allclose(points[:, 5], wrist + 65.0 * approach, atol=1e-9)


def test_without_its_dh_table_the_model_loads_and_the_kit_works(tmp_path, monkeypatch):
    """The student release has no data/rx200_dh.csv: the model's dh is None, and everything but the DH chain (which
    says how to chain the student's table) works from the PoX model."""
    import armlab.robot as robot_module
    from armlab import kinematics

    paths = copy_data(tmp_path)
    paths["dh"].unlink(missing_ok=True)
    monkeypatch.setattr(robot_module, "data_path", lambda name: tmp_path / name)
    r = load_robot()
    assert r.dh is None and "DH (standard)" not in repr(r)
    np.testing.assert_array_equal(kinematics.fk(r.sleep, r), kinematics.fk(r.sleep, rx200()))
    np.testing.assert_allclose(kinematics.ik([0.0, 250.0, 19.0], np.pi / 2, robot=r),
                               kinematics.ik([0.0, 250.0, 19.0], np.pi / 2), atol=0)
    with pytest.raises(ValueError, match="no DH table"):
        kinematics.fk_dh(r.home, r)
    with pytest.raises(RobotDataError, match="file not found"):                # asked for by name: must exist
        load_robot(dh_csv=tmp_path / "rx200_dh.csv")
