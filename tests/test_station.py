"""make_station("sim"): one call builds world, arm and camera; the same seed gives the same station."""

import numpy as np
import pytest

from armlab import make_station
from armlab.camera import Camera
from armlab.robot import rx200
from armlab.sim import SceneError, scene_objects
from armlab.sim.scenes import scene_to_dict
from armlab.station import Arm, EmergencyStopped, RGBDCamera, Station


def test_sim_station_has_arm_camera_and_world_behind_the_common_interfaces():
    station = make_station("sim", seed=0, scene="swap")
    assert isinstance(station, Station) and station.kind == "sim"
    assert isinstance(station.arm, Arm) and isinstance(station.camera, RGBDCamera)
    frame = station.camera.capture()
    assert frame.rgb.shape == (720, 1280, 3) and frame.rgb.dtype == np.uint8
    assert frame.depth.shape == (720, 1280) and frame.depth.dtype == np.float32
    assert isinstance(station.camera.truth, Camera)                      # ground truth, kept apart from K, dist
    assert station.camera.K.shape == (3, 3)
    blocks = station.world.blocks
    assert [(b.color, b.size, b.edge) for b in blocks] == [("red", "large", 38.0), ("blue", "large", 38.0)]
    assert np.abs(station.arm.joint_positions() - rx200().sleep).max() < 0.01   # the lab's arm starts asleep
    station.close()


def test_same_seed_same_station_other_seed_other_scene():
    a, b, c = (make_station("sim", seed=s, scene="random", n=5) for s in (11, 11, 12))
    assert scene_to_dict(a.world.objects) == scene_to_dict(b.world.objects)
    assert scene_to_dict(a.world.objects) != scene_to_dict(c.world.objects)
    assert len(a.world.blocks) == 5
    for s in (a, b):
        s.arm.home()
    np.testing.assert_array_equal(a.arm.joint_positions(), b.arm.joint_positions())
    np.testing.assert_array_equal(a.arm.q_true, b.arm.q_true)
    fa, fb = a.camera.capture(), b.camera.capture()
    np.testing.assert_array_equal(fa.rgb, fb.rgb)
    np.testing.assert_array_equal(fa.depth, fb.depth)


def test_scene_choices_reach_the_world(tmp_path):
    from armlab.sim import save_scene

    path = save_scene(scene_objects("stacks", seed=5), tmp_path / "stacks.json")
    station = make_station("sim", scene=str(path))
    assert scene_to_dict(station.world.objects) == scene_to_dict(scene_objects(str(path)))
    assert make_station("sim", scene="empty").world.objects == []
    with pytest.raises(SceneError, match="unknown scene"):
        make_station("sim", scene="nowhere")
    with pytest.raises(ValueError, match="seed must be an integer"):
        make_station("sim", seed="one")


def test_ideal_station_has_exact_encoders_and_realistic_one_does_not():
    ideal = make_station("sim", scene="empty", realism="ideal")
    real = make_station("sim", scene="empty", realism="realistic")
    for s in (ideal, real):
        s.arm.home()
    np.testing.assert_array_equal(ideal.arm.q_true, ideal.arm.joint_positions())
    assert np.abs(real.arm.q_true - real.arm.joint_positions()).max() > 1e-3     # sag, offsets, backlash


def test_emergency_stop_through_the_station():
    station = make_station("sim", scene="empty", realism="ideal")
    station.arm.home()
    station.arm.move_to([0.6, 0.0, 0.0, 0.0, 0.0], moving_time=2.0, blocking=False)
    station.world.advance(1.0)
    station.arm.emergency_stop()
    q = station.arm.joint_positions()
    assert 0.0 < q[0] < 0.6
    with pytest.raises(EmergencyStopped):
        station.arm.sleep()
    station.arm.reset()
    station.arm.sleep()
    np.testing.assert_allclose(station.arm.joint_positions(), rx200().sleep, atol=1e-12)
