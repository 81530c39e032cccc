"""armlab.planning: time scaling, velocity limits, Cartesian lines, grasp choice, clearance, place heights, execute."""

import dataclasses
import re

import numpy as np
import pytest

from armlab import kinematics, motion_safety, planning
from armlab.blocks import ObjectState
from armlab.kinematics import Unreachable
from armlab.lab import lab_config
from armlab.planning import timing
from armlab.profile import default_moving_time, trapezoid_fraction
from armlab.robot import rx200
from armlab.station import EmergencyStopped, MotionRefused
from armlab.transforms import wrap_quarter

ROBOT = rx200()


def random_poses(rng, n):
    return rng.uniform(ROBOT.lower, ROBOT.upper, size=(n, 5))


# ---------------------------------------------------------------------------------------------------- time scaling

@pytest.mark.parametrize("scaling", planning.SCALINGS)
def test_time_scaling_is_rest_to_rest_and_rate_is_the_derivative(scaling):
    T = 2.0
    t = np.linspace(0, T, 4001)
    s, ds = planning.time_scaling(t, T, scaling)
    assert s[0] == 0 and s[-1] == pytest.approx(1.0, abs=1e-12)
    assert ds[0] == pytest.approx(0.0, abs=1e-12) and ds[-1] == pytest.approx(0.0, abs=1e-12)
    assert np.all(np.diff(s) >= -1e-15)
    numeric = np.gradient(s, t)
    assert np.abs(numeric - ds)[5:-5].max() < 2e-3
    assert ds.max() == pytest.approx(timing.peak_rate(T, scaling), rel=1e-4)


def test_trapezoid_scaling_is_the_manufacturers_profile():
    t = np.linspace(-0.5, 3.5, 301)
    s, _ = planning.time_scaling(t, 3.0, "trapezoid", accel_time=0.7)
    assert np.array_equal(s, trapezoid_fraction(t, 3.0, 0.7))


@pytest.mark.parametrize("scaling", planning.SCALINGS)
def test_random_moves_never_exceed_velocity_limits(scaling):
    rng = np.random.default_rng(1)
    a, b = random_poses(rng, 200), random_poses(rng, 200)
    worst = 0.0
    for q0, q1 in zip(a, b, strict=True):
        move = planning.joint_move(q0, q1, scaling)
        t = np.linspace(0, move.duration, 1001)
        q, qd = move.sample(t)
        assert np.allclose(q[0], q0) and np.allclose(q[-1], q1)
        worst = max(worst, float((np.abs(qd) / ROBOT.velocity).max()))
        if scaling == "trapezoid":
            assert move.duration == pytest.approx(default_moving_time(q0, q1))
    assert worst <= 1 + 1e-9
    assert worst > 0.95          # the moving time is not padded far beyond what the limits need


def test_shoulder_move_reaches_but_does_not_exceed_its_1_rad_s_limit():
    q1 = np.array([0.0, 1.5, 0.0, 0.0, 0.0])
    move = planning.joint_move(np.zeros(5), q1)
    assert move.duration == pytest.approx(2.25)          # 1.5 rad / (1 rad/s * (1 - 1/3))
    assert move.peak_speed()[1] == pytest.approx(1.0, rel=1e-3)
    with pytest.raises(ValueError, match="shoulder"):
        planning.joint_move(np.zeros(5), q1, duration=1.0)


def test_quintic_waypoints_stream_through_the_curve_within_limits():
    move = planning.joint_move(np.zeros(5), [1.0, 0.8, -0.5, 0.3, 2.0], "quintic")
    wps = move.waypoints()
    assert np.allclose(wps[-1].q, move.end)
    assert sum(w.moving_time for w in wps) == pytest.approx(move.duration)
    prev = move.start
    for w in wps:
        assert w.accel_time == 0 and np.all(np.abs(w.q - prev) / w.moving_time <= ROBOT.velocity + 1e-9)
        prev = w.q


def test_joint_move_rejects_bad_input():
    with pytest.raises(ValueError, match="NaN"):
        planning.joint_move(np.zeros(5), [0, np.nan, 0, 0, 0])
    with pytest.raises(ValueError, match="shape"):
        planning.joint_move(np.zeros(4), np.zeros(5))
    with pytest.raises(ValueError, match="shoulder"):
        planning.joint_move(np.zeros(5), [0, 3.0, 0, 0, 0])
    with pytest.raises(ValueError, match="scaling"):
        planning.joint_move(np.zeros(5), np.ones(5) * 0.1, "cubic")


# ---------------------------------------------------------------------------------------------- Cartesian lines

def distance_to_line(p, a, b):
    u = (b - a) / np.linalg.norm(b - a)
    rel = p - a
    along = np.clip(rel @ u, 0, np.linalg.norm(b - a))
    return np.linalg.norm(rel - along[:, None] * u, axis=1)


@pytest.mark.parametrize("p0, p1, pitch, roll", [
    ((100, 250, 150), (100, 250, 19), np.pi / 2, 0.4),        # final approach, top-down
    ((-200, 150, 60), (200, 300, 60), np.pi / 2, 0.0),        # long horizontal sweep
    ((0, 380, 120), (60, 430, 19), np.radians(60), 0.0),      # tilted, diagonal
])
def test_cartesian_line_keeps_the_tool_on_the_line(p0, p1, pitch, roll):
    p0, p1 = np.array(p0, float), np.array(p1, float)
    seg = planning.cartesian_line(p0, p1, pitch, roll)
    t = np.linspace(0, seg.duration, 3001)
    q, qd = seg.sample(t)
    T = kinematics.fk(q)
    assert distance_to_line(T[:, :3, 3], p0, p1).max() <= 0.5
    assert np.allclose(T[0, :3, 3], p0, atol=1e-6) and np.allclose(T[-1, :3, 3], p1, atol=1e-6)
    # orientation held at every knot: approach pitched `pitch` in the arm plane, wrist roll `roll`
    Tk = kinematics.fk(seg.knots)
    heading = np.arctan2(Tk[:, 1, 3], Tk[:, 0, 3])
    assert np.abs(Tk[:, :3, :3] - kinematics.tool_orientation(heading, pitch, roll)).max() < 1e-9
    assert np.all(np.abs(qd) <= ROBOT.velocity + 1e-9)
    assert np.abs(np.diff(q, axis=0)).max() < 0.05                 # one branch: no jumps between samples
    back = planning.reverse(seg)
    assert np.allclose(back.sample(t)[0], q[::-1])


FAST_LINES = [   # (p0, p1 world mm, pitch rad) at 2000 mm/s: each is bound by a joint's velocity limit, not the speed
    ((-150, 150, 40), (150, 150, 40), np.pi / 2),     # across, close in: the waist binds
    ((-200, 250, 60), (200, 250, 60), np.pi / 2),     # across, further out: the shoulder binds
    ((0, 200, 150), (0, 420, 150), 0.0),              # outwards, horizontal approach
    ((0, 350, 50), (0, 350, 300), 0.0),               # up, horizontal approach
    ((250, 0, 60), (0, 250, 60), np.pi / 2),          # a diagonal across the front
]


def _piece_rates(seg) -> np.ndarray:
    """Largest |dq/dt| per joint (5,) rad/s of a piecewise-linear segment: exact, it is what the arm executes."""
    return np.abs(np.diff(seg.knots, axis=0) / np.diff(seg.times)[:, None]).max(axis=0)


@pytest.mark.parametrize("scaling", ["quintic", "trapezoid"])
@pytest.mark.parametrize("p0, p1, pitch", FAST_LINES)
def test_a_fast_cartesian_line_keeps_every_joint_within_its_velocity_limit(p0, p1, pitch, scaling):
    # no GuardedArm here: the line itself must be slow enough, as planned, for the driver's rule on every piece
    seg = planning.cartesian_line(p0, p1, pitch, speed=2000.0, scaling=scaling)
    assert seg.duration > np.linalg.norm(np.subtract(p1, p0)) / 2000.0 * 1.2      # the joints, not the speed, bind
    rate = _piece_rates(seg)
    assert np.all(rate <= ROBOT.velocity * (1 + 1e-9)), rate / ROBOT.velocity
    assert (rate / ROBOT.velocity).max() > 0.95          # the bound is tight: the line is not stretched for nothing
    segments = [motion_safety.Segment(w.q, w.moving_time, w.accel_time) for w in seg.waypoints()]
    motion_safety.check_plan(seg.start, segments)        # the arms' own velocity rule, command by command


@pytest.mark.parametrize("joint", range(4))
def test_a_fast_cartesian_line_respects_whichever_joint_is_slowest(joint):
    # a robot whose only slow joint is `joint` (the others 100x faster): that joint must bind at exactly its limit.
    # wrist_rotate is left out: a line holds the roll, so it never moves.
    slow = np.full(5, 100.0)
    slow[joint] = 0.5
    robot = dataclasses.replace(ROBOT, velocity=slow)
    moving = [line for line in FAST_LINES
              if np.ptp(planning.cartesian_line(*line, speed=80.0).knots[:, joint]) > 0.05]
    assert moving, f"no test line moves joint {joint}"
    for p0, p1, pitch in moving:
        seg = planning.cartesian_line(p0, p1, pitch, speed=2000.0, robot=robot)
        rate = _piece_rates(seg)
        assert np.all(rate <= slow * (1 + 1e-9)), (p0, p1, rate)
        assert rate[joint] > 0.95 * slow[joint], (p0, p1, rate)


def test_cartesian_line_names_where_it_leaves_the_workspace():
    p0, p1 = np.array([0.0, 300, 40]), np.array([0.0, 700, 40])
    with pytest.raises(Unreachable, match="of the way along") as err:
        planning.cartesian_line(p0, p1, np.pi / 2)
    m = re.search(r"fails (\d+)% of the way along, at \(([-\d.]+), ([-\d.]+), ([-\d.]+)\) mm", str(err.value))
    assert m, str(err.value)
    where = np.array([float(m.group(i)) for i in (2, 3, 4)])
    with pytest.raises(Unreachable):
        kinematics.ik(where + [0, 0.3, 0], np.pi / 2)
    kinematics.ik(where - [0, 0.3, 0], np.pi / 2)    # just before the named point the line is still reachable
    assert 20 <= int(m.group(1)) <= 40


def test_cartesian_line_rejects_bad_input():
    with pytest.raises(ValueError, match="NaN"):
        planning.cartesian_line([0, 200, np.nan], [0, 250, 50], np.pi / 2)
    with pytest.raises(ValueError, match="shape"):
        planning.cartesian_line([0, 200], [0, 250, 50], np.pi / 2)


# ----------------------------------------------------------------------------------------------------- grasps

def test_roll_puts_fingers_across_faces_by_fk():
    rng = np.random.default_rng(2)
    for _ in range(300):
        r, h = rng.uniform(120, 320), rng.uniform(0.1, np.pi - 0.1)
        p = np.array([r * np.cos(h), r * np.sin(h), rng.uniform(10, 80)])
        yaw = rng.uniform(-np.pi, np.pi)
        g = planning.choose_grasp(p, yaw)
        assert g.top_down and abs(g.roll) <= np.pi / 4 + 1e-12 and g.misalignment < 1e-7
        R = kinematics.fk(kinematics.ik(p, g.pitch, g.roll)[0])[:3, :3]
        y_tool = R[:, 1]
        normal_a = np.array([np.cos(yaw), np.sin(yaw), 0.0])
        normal_b = np.array([-np.sin(yaw), np.cos(yaw), 0.0])
        # perpendicular to one face normal = closing straight across the other pair of faces
        assert min(abs(y_tool @ normal_a), abs(y_tool @ normal_b)) < 1e-9
        assert R[2, 0] == pytest.approx(-1.0, abs=1e-12)            # approach straight down


def test_roll_takes_the_smaller_turn():
    # target straight ahead (+y, heading pi/2): roll = heading - yaw mod 90 deg, in (-45, 45] deg (the tie at +45)
    for yaw_deg, roll_deg in [(0, 0), (20, -20), (-30, 30), (80, 10), (100, -10), (135, 45), (-170, -10)]:
        assert np.degrees(planning.face_roll(np.pi / 2, np.radians(yaw_deg))) == pytest.approx(roll_deg, abs=1e-9)


def test_pitch_falls_back_at_long_reach_with_fingers_turned_square_as_far_as_a_small_tilt_allows():
    p = np.array([0.0, 450.0, 19.0])
    g = planning.choose_grasp(p, 0.0, approach_z=120.0)          # faces along the arm plane: roll 0, level fingers
    assert not g.top_down and g.roll == 0.0 and g.misalignment < 1e-9
    assert abs(kinematics.fk(kinematics.ik(p, g.pitch, g.roll)[0])[2, 1]) < 1e-9
    g = planning.choose_grasp(p, 0.2, approach_z=120.0)
    assert not g.top_down and g.roll == pytest.approx(planning.tilted_roll(np.pi / 2, g.pitch, 0.2))
    assert g.pitch <= kinematics.steepest_pitch(p) + 1e-12 and g.pitch > np.radians(30)
    q = kinematics.ik(p, g.pitch, g.roll)[0]
    y = kinematics.fk(q)[:3, 1]
    # the closing direction is tilted at most MAX_CLOSING_TILT_RAD (here exactly: 0.2 rad needs more at this pitch)
    assert np.arcsin(abs(y[2])) == pytest.approx(planning.MAX_CLOSING_TILT_RAD, abs=1e-9)
    horizontal = abs(wrap_quarter(np.arctan2(y[1], y[0]) - 0.2))
    assert 0.0 < horizontal < 0.2 - np.radians(5)             # turned part of the way (roll 0: 0.2 rad off square)
    # just short of top-down (400 mm out) a block 40 deg off the arm plane is met square, the tilt within the bound
    p = np.array([0.0, 400.0, 19.0])
    g = planning.choose_grasp(p, np.radians(40), approach_z=60.0)
    y = kinematics.fk(kinematics.ik(p, g.pitch, g.roll)[0])[:3, 1]
    assert not g.top_down and abs(wrap_quarter(np.arctan2(y[1], y[0]) - np.radians(40))) < 1e-9
    assert np.arcsin(abs(y[2])) <= planning.MAX_CLOSING_TILT_RAD + 1e-12
    # the whole vertical approach is reachable at that pitch and roll
    seg = planning.cartesian_line([0, 400, 60], p, g.pitch, g.roll)
    assert np.allclose(kinematics.fk(seg.end)[:3, 3], p, atol=1e-6)
    p = np.array([0.0, 450.0, 19.0])
    g = planning.choose_grasp(p, 0.2, approach_z=120.0)
    seg = planning.cartesian_line([0, 450, 120], p, g.pitch, g.roll)
    assert np.allclose(kinematics.fk(seg.end)[:3, 3], p, atol=1e-6)
    assert planning.choose_grasp(np.array([0.0, 200, 19]), 0.2).top_down


def _limit_distance(plan) -> np.ndarray:
    """Smallest distance (5,) rad of any commanded waypoint of a plan from each joint's position limits."""
    qs = np.vstack([wp.q for s in plan.steps if isinstance(s, planning.MoveStep) for wp in s.trajectory.waypoints()])
    return np.minimum(qs - ROBOT.lower, ROBOT.upper - qs).min(axis=0)


def test_plans_keep_a_margin_from_the_joint_limits_where_they_can():
    # carrying a block from the hand-over spot onto a 6-block tower: the rise from the pick falls back to the steepest
    # pitch, which used to sit exactly on wrist_angle's limit (sag compensation then pushed it past)
    tower = planning.Obstacle(150.0, 150.0, 6 * 38.0, 27.0)
    plan = planning.plan_pick_place(planning.CAMERA_CLEAR_POSE, [-200.0, 150.0, 38.0], 0.1, 38.0,
                                    [150.0, 150.0, 6 * 38.0], obstacles=[tower])
    assert "rise" in [s.label for s in plan.steps]
    assert _limit_distance(plan).min() >= planning.LIMIT_MARGIN_RAD - 1e-6
    # the tilted grasp at long reach keeps the margin too: its pitch is the steepest within the inner limits
    p = np.array([0.0, 450.0, 19.0])
    g = planning.choose_grasp(p, 0.0, approach_z=120.0)
    q = kinematics.ik(p, g.pitch, g.roll)[0]
    assert np.minimum(q - ROBOT.lower, ROBOT.upper - q).min() >= planning.LIMIT_MARGIN_RAD - 1e-6
    # where only the limits themselves leave a pitch, it is still found (no margin then)
    inner = planning.inner_limits()
    assert np.allclose(inner.upper, ROBOT.upper - planning.LIMIT_MARGIN_RAD)


def test_unreachable_block_says_why():
    with pytest.raises(Unreachable, match="out of reach"):
        planning.choose_grasp(np.array([0.0, 700.0, 19.0]), 0.0)
    with pytest.raises(ValueError, match="grasp position"):
        planning.choose_grasp(np.array([0.0, np.nan, 19.0]), 0.0)
    with pytest.raises(Unreachable, match="picking the block"):
        planning.plan_pick(ROBOT.home, [0, 700, 38], 0.0, 38)


# ----------------------------------------------------------------------------------------- heights and clearance

def tool_z(q):
    return kinematics.fk(q)[2, 3]


def test_grasp_and_place_heights():
    pick = planning.plan_pick(ROBOT.sleep, [120, 250, 38], 0.1, 38)
    descend = [s for s in pick.steps if s.label == "descend"][0].trajectory
    assert tool_z(descend.end) == pytest.approx(38 - 19, abs=1e-6)
    assert np.allclose(kinematics.fk(descend.end)[:2, 3], [120, 250], atol=1e-6)
    place = planning.plan_place(pick.end, [-100, 200, 38], 25)
    descend = [s for s in place.steps if s.label == "descend"][0].trajectory
    assert tool_z(descend.end) == pytest.approx(38 + 18, abs=1e-6)        # bottom face on the 38 mm top
    assert planning.default_grasp_depth(25) == 7 and planning.default_grasp_depth(38) == 19
    place = planning.plan_place(pick.end, [-100, 200, 38], 25, grasp_depth=5)
    descend = [s for s in place.steps if s.label == "descend"][0].trajectory
    assert tool_z(descend.end) == pytest.approx(38 + 20, abs=1e-6)
    assert planning.place_tool_height(0.0, 38) == 19.0 and planning.grasp_height(76.0, 38) == 57.0
    with pytest.raises(ValueError, match="grasp_depth"):
        planning.plan_place(pick.end, [-100, 200, 38], 25, grasp_depth=30)
    assert [s.action for s in pick.steps if isinstance(s, planning.GripperStep)] == ["open", "close"]
    assert [s.action for s in place.steps if isinstance(s, planning.GripperStep)] == ["open"]


def stack(x, y, n, edge=38.0):
    return [ObjectState("red", "large", edge, [x, y, edge / 2 + i * edge], yaw=0.3, id=i) for i in range(n)]


def heights_near(plan, obstacle, held_below, dt=0.005):
    q = np.vstack([s.trajectory.sample(np.arange(0, s.duration, dt))[0] for s in plan.steps
                   if s.label in ("rise", "transit")])
    pts = kinematics.joint_positions(q)
    near = np.linalg.norm(pts[:, [4, 6], :2] - [obstacle.x, obstacle.y], axis=-1) < obstacle.radius + 45
    return pts[:, 4, 2][near[:, 0]], pts[:, 6, 2][near[:, 1]] - held_below


def test_transit_clears_a_stack_between_pick_and_place():
    tower = stack(0, 320, 4)                 # top at 152 mm, under the arc the arm sweeps between the two spots
    blocks = stack(-200, 250, 1) + tower
    obstacle = planning.as_obstacles(tower)[-1]
    assert obstacle.top == 152 and obstacle.radius == pytest.approx(19 * np.sqrt(2))
    pick = planning.plan_pick(ROBOT.sleep, [-200, 250, 38], 0.0, 38, blocks)
    place = planning.plan_place(pick.end, [200, 250, 0], 38, 0.0, tower)
    wrist, tool = heights_near(place, obstacle, held_below=19)
    assert tool.size > 10 and wrist.size > 10                  # the transit does pass over the stack
    assert tool.min() >= 152 + 50 - 1e-6 and wrist.min() >= 152 + 50 - 1e-6
    # without the obstacles the same move would sweep the held block through the stack
    bare = planning.plan_place(pick.end, [200, 250, 0], 38)
    assert heights_near(bare, obstacle, held_below=19)[1].min() < 152


def test_transit_height_out_of_reach_is_refused():
    tower = [planning.Obstacle(150, 200, 600, 20)]            # a tall post beside the block
    with pytest.raises(Unreachable, match="transit height"):
        planning.plan_pick(ROBOT.sleep, [150, 250, 38], 0.0, 38, tower)


def test_obstacles_reject_bad_items():
    with pytest.raises(ValueError, match="obstacle 1"):
        planning.as_obstacles([(0, 0, 10, 5), "tower"])
    with pytest.raises(ValueError, match="finite"):
        planning.Obstacle(0, np.nan, 10, 5)


def test_camera_clear_pose_hides_nothing_in_front_of_the_base():
    cam = lab_config().camera_position_mm

    def shadow(q):  # where the arm's points are seen on the board from the camera
        pts = kinematics.joint_positions(q)
        s = cam[2] / (cam[2] - pts[:, 2])
        return cam[:2] + (pts[:, :2] - cam[:2]) * s[:, None]

    clear = shadow(planning.CAMERA_CLEAR_POSE)
    assert clear[:, 1].max() < 60 and np.abs(clear[:, 0]).max() < 1e-6
    assert shadow(ROBOT.sleep)[:, 1].max() > 100                # the sleep pose's gripper would hide blocks
    plan = planning.plan_camera_clear(ROBOT.sleep)
    assert np.allclose(plan.end, planning.CAMERA_CLEAR_POSE)
    # after picking the top block of a stack the move rises away from the rest of it: clear
    hover = planning.plan_pick(ROBOT.sleep, [150, 250, 114], 0.0, 38, stack(150, 250, 3)).end
    planning.plan_camera_clear(hover, stack(150, 250, 2), held_below=19)
    with pytest.raises(Unreachable, match="too low"):           # the held block would scrape the stack it came from
        planning.plan_camera_clear(hover, stack(150, 250, 3), held_below=19)


# --------------------------------------------------------------------------------------------- plans and execute

class RecordingArm:
    """A fake arm: records every call, tracks its joint positions, optionally fails on the n-th call."""

    def __init__(self, q, fail_at=None, error=None):
        self.q = np.array(q, float)
        self.calls = []
        self.fail_at, self.error = fail_at, error

    def _record(self, call):
        if self.fail_at is not None and len(self.calls) == self.fail_at:
            raise self.error
        self.calls.append(call)

    def joint_positions(self):
        return self.q.copy()

    def move_to(self, q, moving_time=None, accel_time=None, blocking=True):
        self._record(("move_to", np.array(q, float), moving_time, accel_time))
        self.q = np.array(q, float)

    def open_gripper(self):
        self._record(("open",))

    def close_gripper(self):
        self._record(("close",))
        return True


def executed_motion(start, calls, t):
    """Joint angles at times t if each move_to follows the manufacturer's profile from the previous pose."""
    out = np.full((len(t), 5), np.nan)
    q_prev, t0 = np.array(start, float), 0.0
    for call in calls:
        if call[0] == "move_to":
            _, q, T, Ta = call
            sel = (t >= t0) & (t <= t0 + T + 1e-9)
            out[sel] = q_prev + np.outer(trapezoid_fraction(t[sel] - t0, T, Ta), q - q_prev)
            q_prev, t0 = q, t0 + T
        else:
            sel = (t >= t0) & (t <= t0 + planning.GRIPPER_TIME_S + 1e-9)
            out[sel] = q_prev
            t0 += planning.GRIPPER_TIME_S
    return out


def test_execute_sends_the_plan_to_any_arm():
    plan = planning.plan_pick_place(ROBOT.sleep, [150, 250, 38], 0.4, 38, [-150, 200, 0], 0.2,
                                    stack(150, 250, 1) + stack(0, 230, 3))
    arm = RecordingArm(ROBOT.sleep)
    result = planning.execute(plan, arm)
    kinds = [c[0] for c in arm.calls]
    gripper = [k for k in kinds if k != "move_to"]
    assert gripper == ["open", "close", "open"] and result.holding is True
    assert result.commands == len(arm.calls) == sum(
        len(s.trajectory.waypoints()) if isinstance(s, planning.MoveStep) else 1 for s in plan.steps)
    first, wp = arm.calls[0], plan.steps[0].trajectory.waypoints()[0]
    assert np.array_equal(first[1], wp.q) and (first[2], first[3]) == (wp.moving_time, wp.accel_time)
    assert np.allclose(arm.q, plan.end)
    # what the arm does for these commands is exactly what the plan samples
    t = np.linspace(0, plan.duration, 5000)
    assert np.abs(executed_motion(ROBOT.sleep, arm.calls, t) - plan.sample(t).q).max() < 1e-9


@pytest.mark.parametrize("error", [EmergencyStopped("e-stop pressed"), MotionRefused("elbow limit")])
def test_execute_propagates_arm_errors_and_stops(error):
    plan = planning.plan_pick(ROBOT.sleep, [150, 250, 38], 0.0, 38)
    arm = RecordingArm(ROBOT.sleep, fail_at=3, error=error)
    with pytest.raises(type(error), match=str(error)):
        planning.execute(plan, arm)
    assert len(arm.calls) == 3 and ("close",) not in arm.calls


def test_execute_refuses_a_plan_from_elsewhere():
    plan = planning.plan_pick(ROBOT.sleep, [150, 250, 38], 0.0, 38)
    arm = RecordingArm(ROBOT.home)
    with pytest.raises(ValueError, match="not where the plan starts"):
        planning.execute(plan, arm)
    assert arm.calls == []


def test_plan_sampling_and_plot():
    import matplotlib

    matplotlib.use("Agg")
    plan = planning.plan_pick(ROBOT.sleep, [150, 250, 38], 0.0, 38)
    s = planning.sample_plan(plan, dt=0.01)
    assert s.t[-1] == pytest.approx(plan.duration) and np.allclose(s.q[-1], plan.end)
    assert np.all(np.abs(np.diff(s.q, axis=0)) <= ROBOT.velocity * 0.01 + 1e-9)      # continuous, within limits
    close_t = plan.step_times[[i for i, st in enumerate(plan.steps) if getattr(st, "action", "") == "close"][0]]
    assert not s.closed[s.t < close_t].any() and s.closed[s.t >= close_t].all()
    ax = planning.plot_plan(plan)
    assert [ln.get_label() for ln in ax.get_lines()][:5] == list(ROBOT.joint_names)
    with pytest.raises(ValueError, match="join up"):
        planning.Plan((plan.steps[0], planning.MoveStep(planning.joint_move(ROBOT.home, ROBOT.sleep))))


@pytest.mark.parametrize("seed", [0, 3])
def test_pick_and_place_round_trips_on_the_simulator(seed):
    from armlab import make_station

    station = make_station("sim", seed=seed, realism="realistic")
    arm, world = station.arm, station.world
    for i, block in enumerate([b for b in world.blocks if b.is_block][:3]):
        top = block.position + [0, 0, block.edge / 2]
        dest = np.array([-150.0 + 150 * i, 150.0, 0.0])
        plan = planning.plan_pick_place(arm.joint_positions(), top, block.yaw, block.edge, dest, 0.3, world.blocks)
        assert planning.execute(plan, arm).holding
        assert np.abs(block.position - dest - [0, 0, block.edge / 2]).max() < 3.0     # mm, with realistic errors
        turn = np.degrees(block.yaw - 0.3) % 90
        assert min(turn, 90 - turn) < 2.0                                           # square to the requested yaw


# ----------------------------------------------------------------------------------------- one shared geometry

def test_planner_and_simulator_share_one_gripper_and_base_description(monkeypatch):
    from dataclasses import replace

    from armlab.gripper_geometry import GRIPPER
    from armlab.sim import SimArm, World, faces

    assert SimArm(World()).gripper_geometry is GRIPPER
    assert planning.pickplace.FINGERTIP_MM == GRIPPER.fingertip_mm == GRIPPER.pad_height_mm / 2
    # 25 mm cube: the finger tips (8 mm beyond the tool point) stay 10 mm above the board
    assert planning.default_grasp_depth(25.0) == pytest.approx(25.0 - GRIPPER.fingertip_mm - 10.0)
    # the renderer draws the base plate the lab config describes (data/lab.json "robot_base")
    wide = replace(lab_config(), robot_base_half_mm=(70.0, 80.0))
    monkeypatch.setattr(faces, "lab_config", lambda: wide)
    base = faces.arm_faces(ROBOT.home, 40.0, GRIPPER).vertices[:6].reshape(-1, 3)
    assert np.allclose(np.abs(base[:, :2]).max(axis=0), (70.0, 80.0))


def _held_cube_lowest_z(q, edge: float, depth: float) -> float:
    """World z (mm) of the lowest corner of a cube held as plan_pick grasps it (square to the fingers, its top
    `depth` above the tool point along the tool's approach axis) with the arm at joint angles q (5,) rad."""
    T_down = kinematics.fk(kinematics.ik([0.0, 250.0, 50.0], np.pi / 2)[0])
    approach = T_down[:3, :3].T @ [0.0, 0.0, -1.0]                       # world down, in the tool frame
    centre = (edge / 2 - depth) * approach
    corners = centre + np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) * edge / 2
    T = kinematics.fk(q)
    return float((T[:3, 3] + corners @ T[:3, :3].T)[:, 2].min())


def test_a_tilted_place_releases_the_lowest_edge_at_the_target_height():
    # the to-the-sky tower's 8th level from the hand-over side: the hover is high, so the descent comes in tilted
    # (flatter than a straight descent from the spot itself would be); the held cube's lowest edge, not its bottom
    # face's centre, must end at the target height (without the lift it ends 5.6 mm lower, inside the tower's top;
    # it ends 1.3 mm high since the tilted cube also hangs less far below the tool point: (e - depth)(1 - sin pitch))
    from armlab.tasks.events.sky import SKY_CLEARANCE_MM

    e, spot = 38.0, np.array([120.0, 120.0, 268.0])
    q0 = kinematics.ik(np.array([-200.0, 150.0, 330.0]), 0.0, 0.0)[0]
    tower = [planning.Obstacle(120.0, 120.0, 266.0, e / np.sqrt(2))]
    plan = planning.plan_place(q0, spot, e, 0.0, tower, clearance=SKY_CLEARANCE_MM)
    down = next(s.trajectory for s in plan.steps if s.label == "descend")
    assert down.pitch < np.radians(75)                                   # tilted
    lift = planning.tilted_release_lift(e, down.pitch)
    assert lift > 4.0
    assert down.p1[2] >= planning.place_tool_height(spot[2], e) + lift - 1e-9
    assert spot[2] <= _held_cube_lowest_z(down.end, e, planning.default_grasp_depth(e)) <= spot[2] + 3.0
    # top-down places are not lifted
    flat = planning.plan_place(q0, [0.0, 250.0, 0.0], e, 0.0)
    down = next(s.trajectory for s in flat.steps if s.label == "descend")
    assert down.pitch == pytest.approx(np.pi / 2)
    assert down.p1[2] == pytest.approx(planning.place_tool_height(0.0, e))
    assert planning.tilted_release_lift(e, np.pi / 2) == pytest.approx(0.0, abs=1e-12)


def test_place_prefers_a_shorter_top_down_descent_that_keeps_the_yaw():
    # 390 mm out the tool cannot come straight down from the 88 mm transit height, but can from a lower hover
    plan = planning.plan_place(planning.CAMERA_CLEAR_POSE, [0.0, 390.0, 0.0], 38.0, yaw=0.3)
    down = next(s.trajectory for s in plan.steps if s.label == "descend")
    assert down.pitch == pytest.approx(np.pi / 2) and down.p0[2] < 88.0
    assert down.p0[2] >= 38.0 + planning.pickplace.LOW_HOVER_MM - 1e-9
    y_tool = kinematics.fk(down.end)[:3, 1]                    # the fingers close across faces at yaw 0.3
    yaw_placed = np.arctan2(y_tool[1], y_tool[0])
    assert abs((yaw_placed - 0.3 + np.pi / 4) % (np.pi / 2) - np.pi / 4) < 1e-6
    # beyond that the place tilts (and can only keep the block square to the fingers)
    far = planning.plan_place(planning.CAMERA_CLEAR_POSE, [0.0, 420.0, 0.0], 38.0, yaw=0.3)
    assert next(s.trajectory for s in far.steps if s.label == "descend").pitch < np.radians(85)


def _held_turned(degrees: float) -> np.ndarray:
    """T_tool_block (4, 4) mm of a cube centred on the tool point, held as a top-down grasp leaves it, then turned by
    `degrees` about the tool's closing axis y (as a pitched grasp holds it, seen from a top-down tool)."""
    from armlab.transforms import homogeneous

    a = np.radians(degrees)
    c, s = np.cos(a), np.sin(a)
    return homogeneous(np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]) @ kinematics.fk(
        kinematics.ik(np.array([0.0, 250.0, 57.0]), np.pi / 2, 0.0)[0])[:3, :3].T, np.zeros(3))


def _released(plan, T_tool_block: np.ndarray, edge: float) -> tuple[float, float, np.ndarray]:
    """(tilt deg: its nearest face normal from vertical, lowest corner's z mm, centre x, y (2,) mm) of the held cube
    at the end of the plan's descent, where it is let go."""
    cube = kinematics.fk(next(st.trajectory for st in plan.steps if st.label == "descend").end) @ T_tool_block
    corners = np.array([[x, y, z] for x in (-.5, .5) for y in (-.5, .5) for z in (-.5, .5)]) * edge
    tilt = np.degrees(np.arccos(min(1.0, np.abs(cube[2, :3]).max())))
    return float(tilt), float((corners @ cube[:3, :3].T + cube[:3, 3])[:, 2].min()), cube[:2, 3]


def test_a_place_is_aimed_with_the_held_blocks_pose_in_the_tool_frame():
    # a block picked tilted at full reach sits 8 deg turned (about the closing axis) in the tool frame: placed
    # top-down without its pose its lowest corner would end 2.5 mm below the target (into what it is put on)
    e, spot = 38.0, np.array([0.0, 250.0, 38.0])
    T_tool_block = _held_turned(8.0)
    _, low, centre = _released(planning.plan_place(planning.CAMERA_CLEAR_POSE, spot, e, 0.0), T_tool_block, e)
    assert low < spot[2] - 2.0
    _, low, centre = _released(planning.plan_place(planning.CAMERA_CLEAR_POSE, spot, e, 0.0,
                                                   held_in_tool=T_tool_block), T_tool_block, e)
    assert low == pytest.approx(spot[2], abs=0.1) and np.abs(centre - spot[:2]).max() <= 0.1
    with pytest.raises(ValueError, match="held_in_tool"):
        planning.plan_place(planning.CAMERA_CLEAR_POSE, spot, e, held_in_tool=np.eye(3))


@pytest.mark.parametrize("descent", ["straight", "joint chord"])
def test_a_block_held_tilted_is_let_go_level_on_its_bottom_face(descent, monkeypatch):
    # a block gripped at pitch 60 deg sits 30 deg turned about the closing axis in the tool frame: a top-down place
    # would let it go 30 deg tilted, to land on an edge and tip; the place comes down at the pitch that levels it,
    # whichever descent the kit has (the student release's joint chord: test_descent.py)
    import sys

    if descent == "joint chord":
        monkeypatch.setitem(sys.modules, "armlab.planning.straight_descent", None)
    assert planning.descent.straight() == (descent == "straight")
    e, T_tool_block = 38.0, _held_turned(30.0)
    assert planning.level_pitch_roll(T_tool_block[:3, :3]) == pytest.approx((np.radians(60.0), 0.0), abs=1e-9)
    for spot in ([0.0, 250.0, 38.0], [150.0, 100.0, 0.0], [-300.0, 0.0, 0.0], [0.0, 400.0, 0.0]):
        spot = np.array(spot)
        plan = planning.plan_place(planning.CAMERA_CLEAR_POSE, spot, e, 0.3, held_in_tool=T_tool_block)
        tilt, low, centre = _released(plan, T_tool_block, e)
        assert tilt < 0.5, f"let go {tilt:.2f} deg tilted at {spot}"
        assert low == pytest.approx(spot[2], abs=0.1) and np.abs(centre - spot[:2]).max() <= 0.1
        assert _released(planning.plan_place(planning.CAMERA_CLEAR_POSE, spot, e, 0.3), T_tool_block, e)[0] > 10.0


def test_where_no_level_release_is_reachable_the_lowest_corner_is_aimed():
    # held 5 deg turned, the block is level only with the tool at 85 deg: 420 mm out the arm reaches no steeper than
    # 83.7 deg even at the board, so the place is tilted and its lowest corner, not its bottom face, is aimed
    e, spot, T_tool_block = 38.0, np.array([0.0, 420.0, 0.0]), _held_turned(5.0)
    level_pitch, _ = planning.level_pitch_roll(T_tool_block[:3, :3])
    assert kinematics.steepest_pitch(spot) < level_pitch - np.radians(1.0)
    tilt, low, centre = _released(planning.plan_place(planning.CAMERA_CLEAR_POSE, spot, e, 0.0,
                                                      held_in_tool=T_tool_block), T_tool_block, e)
    assert tilt > 1.0
    assert low == pytest.approx(spot[2], abs=0.1) and np.abs(centre - spot[:2]).max() <= 0.1
    # a cube held level under a top-down tool is placed as before (with the requested yaw): no levelling needed
    assert planning.level_pitch_roll(_held_turned(0.0)[:3, :3])[0] == pytest.approx(np.pi / 2)


def test_level_pitch_roll_is_the_grasps_own_pitch_and_roll():
    # a cube gripped level at pitch p and roll r is let go level at the same pitch and roll, whatever the heading;
    # no pitch below horizontal levels a cube whose top face points ahead of the tool
    rng = np.random.default_rng(7)
    for h, p, r in zip(rng.uniform(-np.pi, np.pi, 20), rng.uniform(0.2, np.pi / 2 - 0.05, 20),
                       rng.uniform(-0.6, 0.6, 20), strict=True):
        R_tool = kinematics.tool_orientation(h, p, r)
        yaw = rng.uniform(-np.pi, np.pi)
        R_block = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
        assert planning.level_pitch_roll(R_tool.T @ R_block) == pytest.approx((p, r), abs=1e-9)
    assert planning.level_pitch_roll(kinematics.tool_orientation(0.0, -0.1, 0.0).T) is None
    with pytest.raises(ValueError, match="R_tool_block"):
        planning.level_pitch_roll(np.eye(4))


def test_face_misalignment_is_exact_at_zero_and_the_angle_elsewhere():
    # a top-down grasp closing along a face normal is aligned to rounding, whatever the heading and yaw (arccos of
    # the dot product gave 1.5e-8 rad from a last-bit error, and which CPU decided it); a turn of d off the face is d
    rng = np.random.default_rng(5)
    for heading, yaw, d in zip(rng.uniform(-np.pi, np.pi, 50), rng.uniform(-np.pi / 4, np.pi / 4, 50),
                               rng.uniform(0.01, np.pi / 4 - 0.01, 50), strict=True):
        aligned = planning.face_roll(heading, float(yaw))
        assert planning.face_misalignment(heading, np.pi / 2, aligned, float(yaw)) < 1e-12
        for turned in (aligned + d, aligned - d):
            assert planning.face_misalignment(heading, np.pi / 2, turned, float(yaw)) == pytest.approx(d, abs=1e-12)


def test_a_block_at_45_degrees_to_the_arm_plane_gets_the_same_roll_whatever_the_last_bit_of_the_heading():
    from armlab.planning import face_roll, tilted_roll

    quarter = np.pi / 4
    below = np.nextafter(quarter, 0.0)                 # what another CPU's arctan2(y, y) can give
    assert face_roll(quarter, 0.0) == pytest.approx(quarter, abs=1e-12)
    assert face_roll(below, 0.0) == pytest.approx(quarter, abs=1e-12)
    assert tilted_roll(below, 1.2, 0.0) == pytest.approx(tilted_roll(quarter, 1.2, 0.0), abs=1e-12)
    assert face_roll(quarter - 0.01, 0.0) == pytest.approx(quarter - 0.01)      # off the tie: the smaller turn
