"""Property tests (hypothesis) over the public API: any input gives a result, or the kit's ValueError / TypeError
whose message names the argument (or a refusal of the kit's own: Unreachable, MotionRefused, ClickRefused, a
checkerboard not found). Never OverflowError, AttributeError, ZeroDivisionError, LinAlgError, MemoryError,
IndexError or numpy's own unnamed messages.

Each test puts a hypothesis-drawn value in place of one argument of a valid call. The values: None, booleans,
integers up to 10**400, floats with NaN and infinities, text, complex numbers, bytes, dicts, nested lists of those,
and numpy arrays of every dtype and of the right and wrong shapes; and, always, the issue's own examples (@example:
10**400 in fk, ik, move_to and place, text for numbers, camera=None, block None, step=0, damping=0,
radius=10**6, clicks at numpy floats). Example counts are modest and derandomized (settings below), so the suite
stays fast and CI reproducible; test_zz_report_the_example_counts prints how many examples each entry point ran.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from armlab import calibration, kinematics, make_station, tasks
from armlab.camera import Camera
from armlab.detection import detect_blocks
from armlab.kinematics import Unreachable
from armlab.station import MotionRefused
from armlab.tasks import ClickRefused

SETTINGS = settings(max_examples=60, derandomize=True, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
SLOW = settings(SETTINGS, max_examples=25)
DOMAIN = (Unreachable, MotionRefused, ClickRefused)
COUNTS: dict[str, int] = {}

scalars = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-(10**400), max_value=10**400),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=5), st.complex_numbers(max_magnitude=1e3),
    st.binary(max_size=3), st.just({}), st.just(object()))
nested = st.recursive(scalars, lambda inner: st.lists(inner, max_size=6) | st.tuples(inner, inner, inner),
                      max_leaves=12)
arrays = hnp.arrays(dtype=st.sampled_from([np.float64, np.float32, np.int64, np.uint8, np.bool_, np.complex128,
                                           np.dtype("U3"), np.dtype("O")]),
                    shape=hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=6))
anything = st.one_of(scalars, nested, arrays)


def _vectors(n: int):
    """Length-n vectors whose entries are anything numeric-ish: huge, NaN, inf, text, None..."""
    return st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                              st.integers(min_value=-(10**400), max_value=10**400), st.none(), st.text(max_size=2),
                              st.booleans()), min_size=n, max_size=n)


def _holds(what: str, call, names: tuple[str, ...], domain_words: tuple[str, ...] = ()) -> None:
    """Run call(); pass on a result; pass on ValueError/TypeError naming one of `names` (or a domain refusal);
    fail on anything else."""
    COUNTS[what] = COUNTS.get(what, 0) + 1
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            call()
    except DOMAIN as e:
        _no_numpy_wording(what, e)
    except (ValueError, TypeError) as e:
        msg = str(e)
        if not any(n in msg for n in names + domain_words):
            raise AssertionError(f"{what}: {type(e).__name__} names none of {names}: {msg}") from e
        _no_numpy_wording(what, e)


def _no_numpy_wording(what: str, error: Exception) -> None:
    """Numbers in a refusal read as a reader writes them (-10.0, not np.float64(-10.0)), and no numpy message
    stands in for the kit's."""
    msg = str(error)
    if "np.float64(" in msg or "np.int64(" in msg or "could not convert string to float" in msg:
        raise AssertionError(f"{what}: numpy's wording leaked: {msg}") from error


@pytest.fixture(scope="module")
def station():
    return make_station("sim", seed=0)


@pytest.fixture(scope="module")
def session(station):
    return tasks.start_session(station)


@pytest.fixture(scope="module")
def frame(station):
    f = station.camera.capture()
    cam = station.camera.truth
    return f.rgb, calibration.fit_depth_correction(f.depth, cam).apply(f.depth), cam, station.arm.joint_positions()


Q = [0.0, -0.5, 0.3, 1.2, 0.0]
JOINTS = ("joint angles", "q")


@SETTINGS
@given(value=st.one_of(anything, _vectors(5)))
@example(value=[10**400, 0, 0, 0, 0])
@example(value=["a", 0, 0, 0, 0])
def test_fk(value):
    _holds("fk(q)", lambda: kinematics.fk(value), JOINTS)


@SETTINGS
@given(value=st.one_of(anything, _vectors(3)), which=st.sampled_from(["position", "pitch", "roll"]))
@example(value=[10**400, 0, 0], which="position")
@example(value=["300", 0, 30], which="position")
def test_ik(value, which):
    args = {"position": [0.0, 300.0, 30.0], "pitch": 1.0, "roll": 0.0, which: value}
    _holds(f"ik({which})", lambda: kinematics.ik(args["position"], args["pitch"], args["roll"]), (which,))


@SETTINGS
@given(value=anything)
@example(value=0)
def test_jacobian_step(value):
    _holds("jacobian(step)", lambda: kinematics.jacobian([0.0, 0.0, 0.0, 0.0, 0.0], step=value), ("step",))


def _camera_args(station):
    t = station.camera.truth
    return {"K": t.K, "dist": t.dist, "T_cam_world": t.T_cam_world, "width": 1280, "height": 720}


@SETTINGS
@given(value=st.one_of(anything, st.integers(min_value=-(10**400), max_value=10**400)),
       which=st.sampled_from(["K", "dist", "T_cam_world", "width", "height"]))
def test_camera(station, value, which):
    args = {**_camera_args(station), which: value}
    names = {"K": ("K",), "dist": ("dist",), "T_cam_world": ("T_cam_world",), "width": ("width",),
             "height": ("height",)}[which]
    _holds(f"Camera({which})", lambda: Camera(**args), names)


@SETTINGS
@given(value=st.one_of(anything, _vectors(2), _vectors(3)), which=st.sampled_from(["project", "uv", "depth_mm"]))
def test_camera_projection(station, value, which):
    cam = station.camera.truth
    if which == "project":
        _holds("Camera.project", lambda: cam.project(value), ("points_world",))
    elif which == "uv":
        _holds("Camera.pixel_to_world(uv)", lambda: cam.pixel_to_world(value, [900.0]), ("uv", "depth_mm"))
    else:
        _holds("Camera.pixel_to_world(depth_mm)", lambda: cam.pixel_to_world([[640.0, 360.0]], value),
               ("depth_mm",))


@SLOW
@given(value=st.one_of(anything, st.integers(min_value=-(10**400), max_value=10**400)),
       which=st.sampled_from(["depth_mm", "camera", "step", "inlier_mm", "iterations", "exclude"]))
@example(value=0, which="step")
@example(value=None, which="camera")
def test_fit_depth_correction(frame, value, which):
    _, depth, cam, _ = frame
    args = {"depth_mm": depth, "camera": cam, which: value}
    _holds(f"fit_depth_correction({which})",
           lambda: calibration.fit_depth_correction(args.pop("depth_mm"), args.pop("camera"), **args),
           (which, "board pixels"))


@SETTINGS
@given(value=st.one_of(anything, st.integers(min_value=-(10**400), max_value=10**400)),
       which=st.sampled_from(["uv", "depth_mm", "radius"]))
@example(value=10**6, which="radius")
def test_calibration_pixel_to_world(frame, value, which):
    _, depth, cam, _ = frame
    args = {"uv": [[640.0, 360.0]], "depth_mm": depth, "radius": 2, which: value}
    _holds(f"Calibration.pixel_to_world({which})",
           lambda: calibration.Calibration(cam).pixel_to_world(args["uv"], args["depth_mm"], args["radius"]),
           (which,))


@SETTINGS
@given(value=anything, which=st.sampled_from(["images", "pattern_size", "square_mm"]))
def test_calibrate_intrinsics(value, which):
    args = {"images": [np.zeros((24, 32), np.uint8)] * 3, "pattern_size": (9, 6), "square_mm": 25.0, which: value}
    _holds(f"calibrate_intrinsics({which})", lambda: calibration.calibrate_intrinsics(**args),
           (which, "image"), ("checkerboard was found",))


@SETTINGS
@given(value=anything, which=st.sampled_from(["rgb", "K", "dist"]))
def test_calibrate_extrinsics(station, value, which):
    t = station.camera.truth
    args = {"rgb": np.zeros((48, 64, 3), np.uint8), "K": t.K, "dist": t.dist, which: value}
    _holds(f"calibrate_extrinsics({which})", lambda: calibration.calibrate_extrinsics(**args),
           (which, "camera matrix", "distortion"), ("AprilTag",))


@SLOW
@given(value=anything, which=st.sampled_from(["rgb", "depth_mm", "camera", "arm_q", "color_model", "settings"]))
@example(value=None, which="camera")
def test_detect_blocks(frame, value, which):
    rgb, depth, cam, q = frame
    args = {"rgb": rgb, "depth_mm": depth, "camera": cam, "arm_q": q, which: value}
    _holds(f"detect_blocks({which})", lambda: detect_blocks(**args), (which,))


@SETTINGS
@given(value=st.one_of(anything, _vectors(3)), which=st.sampled_from(["position", "yaw", "clearance"]))
@example(value=[10**400, 20, 10], which="position")
@example(value=["0", "20", "10"], which="position")
def test_tasks_place(session, value, which):
    args = {"position": [0.0, 250.0, 0.0], "yaw": 0.0, "clearance": 20.0, which: value}
    _holds(f"tasks.place({which})", lambda: tasks.place(session, **args), (which,), ("holds no block",))


@SETTINGS
@given(value=anything)
@example(value=None)
def test_tasks_pick(session, value):
    _holds("tasks.pick(block)", lambda: tasks.pick(session, value), ("block",))


@SETTINGS
@given(value=anything)
def test_tasks_need_a_session(value):
    _holds("tasks.look(session)", lambda: tasks.look(value), ("session",))


@SLOW
@given(value=st.one_of(anything, _vectors(2)), which=st.sampled_from(["grab", "drop"]))
@example(value=(np.float64(-10.0), np.float64(5.0)), which="drop")
@example(value=(np.float64(-10.0), np.float64(5.0)), which="grab")
def test_clicks(session, value, which):
    call = (lambda: tasks.click_grab(session, value)) if which == "grab" else (lambda: tasks.click_drop(session, value))
    _holds(f"click_{which}(uv)", call, ("uv",), ("holds no block", "drop it first"))


@SETTINGS
@given(value=st.one_of(anything, _vectors(5)), which=st.sampled_from(["q", "moving_time", "accel_time"]))
@example(value=[10**400, 0, 0, 0, 0], which="q")
def test_arm_move_to(station, value, which):
    args = {"q": station.arm.joint_positions(), "moving_time": 2.0, "accel_time": 0.5, which: value}
    _holds(f"arm.move_to({which})", lambda: station.arm.move_to(args["q"], args["moving_time"], args["accel_time"]),
           {"q": JOINTS, "moving_time": ("moving_time",), "accel_time": ("accel_time",)}[which])


@SETTINGS
@given(value=st.one_of(anything, st.integers(min_value=-(10**400), max_value=10**400)))
def test_make_station_seed(value):
    if isinstance(value, int) and not isinstance(value, bool) and 0 <= value < 2**63:
        return                                          # a valid seed builds a whole station: not fuzzed here
    _holds("make_station(seed)", lambda: make_station("sim", seed=value), ("seed",))


def test_zz_report_the_example_counts():
    """Runs last in this module: the examples each entry point ran (the closing note's figure)."""
    total = sum(COUNTS.values())
    print("\nproperty-test examples: " + ", ".join(f"{k} {v}" for k, v in sorted(COUNTS.items()))
          + f"; total {total}")
    assert total == 0 or total >= 500
