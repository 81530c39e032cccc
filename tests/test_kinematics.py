"""armlab.kinematics: FK against the manufacturer's model and hand-derived poses, Jacobian, every IK branch."""

import modern_robotics as mr
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from armlab import kinematics as k
from armlab.robot import rx200
from armlab.transforms import homogeneous, log_so3, rot_x, rot_z

ROBOT = rx200()
SETTINGS = settings(deadline=None, derandomize=True, max_examples=300)

# The manufacturer's product-of-exponentials model exactly as interbotix_xs_modules/xs_robot/mr_descriptions.py
# gives it (reference/rx200.md): space frame base_link, metres, screw axes as rows (w, v).
MR_SLIST = np.array([
    [0, 0, 1, 0, 0, 0],
    [0, 1, 0, -0.10457, 0, 0],
    [0, 1, 0, -0.30457, 0, 0.05],
    [0, 1, 0, -0.30457, 0, 0.25],
    [1, 0, 0, 0, 0.30457, 0],
], float).T
MR_M = homogeneous(None, [0.408575, 0, 0.30457])
# base_link is the world frame turned -90 deg about z (x_base = y_world, y_base = -x_world); same origin.
T_WORLD_BASE = homogeneous(rot_z(np.pi / 2))
SHOULDER = np.array([0.0, 0.0, 104.57])


def random_q(n, seed):
    return np.random.default_rng(seed).uniform(ROBOT.lower, ROBOT.upper, (n, 5))


def wrapped(a):
    return np.angle(np.exp(1j * np.asarray(a)))


def target_of(q):
    """Position (mm), pitch and roll (rad) that the IK interface describes the tool pose of q (..., 5) by."""
    T = k.fk(q)
    p, approach = T[..., :3, 3], T[..., :3, 0]
    radial = p[..., :2] / np.linalg.norm(p[..., :2], axis=-1, keepdims=True)
    pitch = np.arctan2(-approach[..., 2], np.sum(approach[..., :2] * radial, axis=-1))
    return p, pitch, q[..., 4]


def elbow_up(q, target):
    """The documented meaning of elbow up: seen from the side with the target to the right of the base axis, the
    elbow lies left of the direction from the shoulder to the wrist centre."""
    jp = k.joint_positions(q)
    u = np.append(target[:2] / np.linalg.norm(target[:2]), 0.0)

    def plane(p):
        return np.stack([(p - SHOULDER) @ u, p[..., 2] - SHOULDER[2]], -1)

    wrist, elbow = plane(jp[..., 4, :]), plane(jp[..., 3, :])
    return wrist[..., 0] * elbow[..., 1] - wrist[..., 1] * elbow[..., 0] > 0


# ---------------------------------------------------------------------------------------------------------------
# Forward kinematics
# ---------------------------------------------------------------------------------------------------------------

@pytest.mark.exercise("fk.dh_link_transform", "fk.dh_table")   # the kit's DH table: instructor only
def test_dh_matches_pox_at_random_poses():
    q = random_q(10_000, seed=1)
    T_dh, T_pox = k.fk_dh(q), k.fk_pox(q)
    assert np.abs(T_dh[:, :3, 3] - T_pox[:, :3, 3]).max() < 1e-9          # mm
    assert np.abs(T_dh[:, :3, :3] - T_pox[:, :3, :3]).max() < 1e-12


def test_fk_matches_the_manufacturers_numbers_via_modern_robotics():
    """Independent of data/: the manufacturer's metres and base_link frame, evaluated by modern_robotics."""
    for q in random_q(300, seed=2):
        T_base = mr.FKinSpace(MR_M, MR_SLIST, q)
        T_base[:3, 3] *= 1000.0
        T = T_WORLD_BASE @ T_base
        ours = k.fk(q)
        assert np.abs(ours[:3, 3] - T[:3, 3]).max() < 1e-9
        assert np.abs(ours[:3, :3] - T[:3, :3]).max() < 1e-12


def test_home_and_hand_derived_poses():
    T = k.fk(ROBOT.home)
    np.testing.assert_allclose(T[:3, 3], [0, 408.575, 304.57], atol=1e-9)
    np.testing.assert_allclose(T[:3, :3], ROBOT.M[:3, :3], atol=1e-12)
    cases = [
        # waist +90 deg turns the arm from +y to -x (right hand about +z)
        ([np.pi / 2, 0, 0, 0, 0], [-408.575, 0, 304.57]),
        # wrist_angle +90 deg: the last 158.575 mm point straight down from the wrist at (0, 250, 304.57)
        ([0, 0, 0, np.pi / 2, 0], [0, 250, 304.57 - 158.575]),
        # shoulder +90 deg: the upper arm's (50 forward, 200 up) becomes (200 forward, 50 down), the rest hangs
        ([0, np.pi / 2, 0, 0, 0], [0, 200, 104.57 - 50 - 200 - 158.575]),
        # elbow +90 deg: the forearm and hand point down from the elbow at (0, 50, 304.57)
        ([0, 0, np.pi / 2, 0, 0], [0, 50, 304.57 - 200 - 158.575]),
        # wrist_rotate turns about the approach axis: the tool point stays put
        ([0, 0, 0, 0, 1.0], [0, 408.575, 304.57]),
    ]
    for q, p in cases:
        np.testing.assert_allclose(k.fk(q)[:3, 3], p, atol=1e-9, err_msg=str(q))
    # wrist_rotate spins the finger axis (tool y) about the approach (tool x), right-handed about +y world
    np.testing.assert_allclose(k.fk([0, 0, 0, 0, 0.5])[:3, :3], rot_z(np.pi / 2) @ rot_x(0.5), atol=1e-12)


def test_vectorised_fk_equals_loop():
    q = random_q(500, seed=3)
    batch = k.fk(q)
    assert batch.shape == (500, 4, 4)
    np.testing.assert_array_equal(batch, np.stack([k.fk(qi) for qi in q]))
    np.testing.assert_allclose(k.fk_pox(q), np.stack([k.fk_pox(qi) for qi in q]), atol=1e-12)


def _textbook_link_frames(q: np.ndarray) -> np.ndarray:
    """Link frames (N, 7, 4, 4) written out from the formulas, rebuilding every matrix at every call (what link_frames
    computed before it kept the screws' matrices): [w], its square, Rodrigues' R and the translation's G v, then the
    chain. The same operations in the same order, so the same bits."""
    S = ROBOT.screws
    W = np.zeros((5, 3, 3))
    W[:, 0, 1], W[:, 0, 2], W[:, 1, 0], W[:, 1, 2], W[:, 2, 0], W[:, 2, 1] = \
        -S[:, 2], S[:, 1], S[:, 2], -S[:, 0], -S[:, 1], S[:, 0]
    th = q[:, :, None, None]
    R = np.eye(3) + np.sin(th) * W + (1.0 - np.cos(th)) * (W @ W)
    G = np.eye(3) * th + (1.0 - np.cos(th)) * W + (th - np.sin(th)) * (W @ W)
    E = np.zeros(q.shape + (4, 4))
    E[..., :3, :3], E[..., :3, 3], E[..., 3, 3] = R, np.einsum("...ij,...j->...i", G, S[:, 3:]), 1.0
    frames = np.empty((len(q), 7, 4, 4))
    frames[:, 0] = np.eye(4)
    chain = E[:, 0]
    for i in range(5):
        chain = chain @ E[:, i] if i else chain
        frames[:, i + 1] = chain @ ROBOT.frames_home[i]
    frames[:, 6] = chain @ ROBOT.M
    return frames


def test_pox_kinematics_are_the_textbook_formulas_bit_for_bit():
    """The screws' matrices built once and the checks skipped for plain float arrays change no bit of any pose (stored
    notebook outputs and the hidden checks' references depend on them): one pose at a time and in a batch; fk_pox is
    the same chain's last frame, from an array or from a list."""
    q = random_q(300, seed=9)
    expected = _textbook_link_frames(q)
    assert k.link_frames(q).tobytes() == expected.tobytes()
    assert all(k.link_frames(qi).tobytes() == e.tobytes() for qi, e in zip(q[:40], expected[:40], strict=True))
    assert k.fk_pox(q).tobytes() == expected[:, 6].tobytes() == k.fk_pox(q.tolist()).tobytes()
    assert all(k.fk_pox(list(qi)).tobytes() == e[6].tobytes() for qi, e in zip(q[:40], expected[:40], strict=True))


@pytest.mark.exercise("fk.dh_link_transform")
def test_dh_link_transform_is_rz_tz_tx_rx():
    theta, d, a, alpha = 0.7, 12.0, 34.0, -1.1
    expected = (homogeneous(rot_z(theta)) @ homogeneous(None, [0, 0, d]) @ homogeneous(None, [a, 0, 0])
                @ homogeneous(rot_x(alpha)))
    np.testing.assert_allclose(k.dh_link_transform(theta, d, a, alpha), expected, atol=1e-14)
    A = k.dh_link_transform(np.zeros((2, 3)), 1.0, 2.0, 0.0)
    assert A.shape == (2, 3, 4, 4)


@pytest.mark.exercise("fk.dh_link_transform", "fk.dh_table")
def test_link_frames_and_joint_positions():
    q = random_q(200, seed=4)
    F = k.link_frames(q)
    assert F.shape == (200, 7, 4, 4)
    R = F[..., :3, :3]
    np.testing.assert_allclose(R @ np.swapaxes(R, -1, -2), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(R), 1, atol=1e-12)
    np.testing.assert_array_equal(F[:, 0], np.broadcast_to(np.eye(4), (200, 4, 4)))
    np.testing.assert_allclose(F[:, 1, :3, 3], np.broadcast_to(SHOULDER, (200, 3)), atol=1e-12)
    np.testing.assert_array_equal(F[:, 6], k.fk_pox(q))
    # the physical model (product of exponentials) and the DH exercise pose every link frame alike
    np.testing.assert_allclose(F, k.dh_frames(q), atol=1e-9)
    np.testing.assert_allclose(k.link_frames(q[0]), k.dh_frames(q[0]), atol=1e-9)
    np.testing.assert_allclose(F[:, 4, :3, 2], F[:, 6, :3, 0], atol=1e-12)    # wrist_rotate axis = approach
    heading = q[:, 0] + np.pi / 2                                              # the arm's plane
    across = np.stack([-np.sin(heading), np.cos(heading), 0 * heading], -1)
    for i in (1, 2, 3):  # shoulder, elbow and wrist_angle axes are horizontal, across the arm's plane
        np.testing.assert_allclose(np.abs(np.sum(F[:, i, :3, 2] * across, -1)), 1, atol=1e-12)

    P = k.joint_positions(q)
    assert P.shape == (200, 7, 3)
    np.testing.assert_allclose(np.linalg.norm(np.diff(P, axis=1), axis=-1),
                               np.broadcast_to([65.66, 38.91, np.hypot(50, 200), 200, 65, 93.575], (200, 6)),
                               atol=1e-9)
    np.testing.assert_allclose(np.sum(P * across[:, None], -1), 0, atol=1e-9)  # all in the arm's plane
    np.testing.assert_allclose(k.joint_positions(q[7]), P[7])
    np.testing.assert_allclose(k.joint_positions(ROBOT.home),
                               [[0, 0, 0], [0, 0, 65.66], [0, 0, 104.57], [0, 50, 304.57], [0, 250, 304.57],
                                [0, 315, 304.57], [0, 408.575, 304.57]], atol=1e-9)


def test_jacobian_predicts_the_tool_motion_of_a_small_joint_step():
    """J dq is the first-order change of the tool pose: for joint steps of t rad, the tool point moves J[:3] dq and
    turns by J[3:] dq up to O(t^2) (the Jacobian of central differences, about 1e-7 mm per rad off the exact one)."""
    rng = np.random.default_rng(5)
    for q in random_q(50, seed=5):
        direction = rng.normal(size=5)
        direction /= np.linalg.norm(direction)
        J, T = k.jacobian(q), k.fk(q, check_limits=False)
        misses = []
        for t in (1e-3, 5e-4):
            T_t = k.fk(q + t * direction, check_limits=False)
            moved = T_t[:3, 3] - T[:3, 3]
            turned = log_so3(T_t[:3, :3] @ T[:3, :3].T)
            misses.append([np.linalg.norm(moved - t * J[:3] @ direction),          # mm
                           np.linalg.norm(turned - t * J[3:] @ direction)])        # rad
            assert misses[-1][0] < 1e3 * t**2 and misses[-1][1] < 5 * t**2, (q, t, misses)
        # second order: halving the step quarters the miss (a wrong column would leave a first-order miss: halved)
        assert misses[1][0] < misses[0][0] / 3 + 1e-9 and misses[1][1] < misses[0][1] / 3 + 1e-12, (q, misses)
    Q = random_q(20, seed=6)
    np.testing.assert_allclose(k.jacobian(Q), np.stack([k.jacobian(qi) for qi in Q]))
    with pytest.raises(ValueError, match="step must be a positive number"):
        k.jacobian(Q[0], step=0.0)


# ---------------------------------------------------------------------------------------------------------------
# Closed-form inverse kinematics
# ---------------------------------------------------------------------------------------------------------------

@pytest.mark.exercise("ik.candidates")
def test_ik_round_trip_over_thousands_of_reachable_targets():
    q = random_q(3000, seed=7)
    P, pitch, roll = target_of(q)
    found = 0
    for i in range(len(q)):
        sols = k.ik(P[i], pitch[i], roll[i])                       # raises (fails the test) if unreachable
        T = k.fk(sols)                                             # also checks every solution is within limits
        assert np.abs(T[:, :3, 3] - P[i]).max() < 1e-6
        np.testing.assert_allclose(T[:, :3, 0], np.broadcast_to(k.fk(q[i])[:3, 0], (len(sols), 3)), atol=1e-9)
        np.testing.assert_allclose(sols[:, 4], roll[i], atol=1e-12)
        found += np.abs(wrapped(sols - q[i])).max(axis=1).min() < 1e-6
    assert found == len(q)  # the pose's own joint angles are always among the branches


@pytest.mark.exercise("ik.candidates")
@SETTINGS
@given(st.tuples(*[st.floats(lo, hi) for lo, hi in zip(ROBOT.lower, ROBOT.upper, strict=True)]).map(np.array))
def test_ik_round_trip_property(q):
    P, pitch, roll = target_of(q)
    if np.hypot(*P[:2]) < 1e-3:   # on the waist axis the heading (and the pitch) is undefined
        return
    sols = k.ik(P, pitch, roll)
    assert np.abs(k.fk(sols)[:, :3, 3] - P).max() < 1e-6
    assert np.abs(wrapped(sols - q)).max(axis=1).min() < 1e-6


@pytest.mark.exercise("ik.candidates")
def test_solutions_within_limits_and_elbow_up_first():
    q = random_q(3000, seed=8)
    P, pitch, roll = target_of(q)
    several = 0
    for i in range(len(q)):
        sols = k.ik(P[i], pitch[i], roll[i], current=q[i])
        assert ROBOT.within_limits(sols).all()
        up = elbow_up(sols, P[i])
        assert np.all(up[:-1] >= up[1:]), (sols, up)             # every elbow-up solution before elbow-down ones
        motion = np.abs(wrapped(sols - q[i])).sum(axis=1)
        for flag in (True, False):                                # then least motion from `current`
            assert np.all(np.diff(motion[up == flag]) >= -1e-12)
        several += len(sols) > 1
    assert several > 500


def test_top_down_grasps_over_the_board_are_elbow_up():
    xs, ys = np.meshgrid(np.arange(-300, 301, 50.0), np.arange(50, 351, 50.0))
    grid = np.stack([xs.ravel(), ys.ravel(), np.full(xs.size, 19.0)], 1)
    for p in grid[np.hypot(grid[:, 0], grid[:, 1]) < 380]:          # within top-down reach
        sol = k.ik(p, np.pi / 2)[0]
        jp = k.joint_positions(sol)
        shoulder, elbow, wrist = jp[2], jp[3], jp[4]
        t = (elbow - shoulder)[:2] @ (wrist - shoulder)[:2] / np.sum((wrist - shoulder)[:2] ** 2)
        assert elbow[2] > shoulder[2] + t * (wrist - shoulder)[2]   # the elbow above the shoulder-wrist line
        np.testing.assert_allclose(k.fk(sol)[:3, 0], [0, 0, -1], atol=1e-12)   # approach straight down


def test_ik_batch_equals_first_ik_solution():
    rng = np.random.default_rng(9)
    P = np.column_stack([rng.uniform(-500, 500, 2000), rng.uniform(-200, 500, 2000), rng.uniform(-50, 450, 2000)])
    pitch = rng.uniform(-0.5, 2.5, 2000)
    current = random_q(2000, seed=10)
    res = k.ik_batch(P, pitch, 0.3, current=current)
    assert 300 < res.success.sum() < 1900        # a mix of reachable and unreachable targets
    for i in range(len(P)):
        try:
            first = k.ik(P[i], pitch[i], 0.3, current=current[i])[0]
        except k.Unreachable:
            assert not res.success[i] and np.isnan(res.q[i]).all() and res.branch[i] == -1
            continue
        assert res.success[i] and 0 <= res.branch[i] < 4
        # one target goes ik's fast path (Python floats and libm, numpy's SIMD loops in the batch): last bits differ
        np.testing.assert_allclose(res.q[i], first, rtol=0, atol=1e-12)


@pytest.mark.exercise("ik.candidates")
def test_ik_gives_the_same_answers_whatever_form_the_numbers_take():
    """ik() answers one target the same, solutions in the same order to 1e-12 rad and the same reasons, whether the
    numbers come as Python floats or as numpy arrays of one value (ik solves plain floats its quick way and arrays
    through the batch machinery): over reachable, joint-limited and unreachable targets, either elbow, any current
    pose."""
    rng = np.random.default_rng(21)
    q = random_q(2500, seed=22)
    P, pitch, roll = target_of(q)                                  # reachable: every branch of the arm's poses
    P = np.vstack([P, np.column_stack([rng.uniform(-500, 500, 2500), rng.uniform(-300, 500, 2500),
                                       rng.uniform(-80, 480, 2500)])])
    pitch = np.concatenate([pitch, rng.uniform(-0.6, 2.6, 2500)])
    roll = np.concatenate([roll, rng.uniform(-3.5, 3.5, 2500)])   # beyond +-pi: wrapped, sometimes out of limits
    current = random_q(5000, seed=23)
    counts = {"one": 0, "several": 0, "elbow down first": 0, "limits": 0, "reach": 0}
    for i in range(len(P)):
        cur = current[i] if i % 2 else None
        plain = dict(position=P[i].tolist(), pitch=float(pitch[i]), roll=float(roll[i]),
                     current=None if cur is None else cur.tolist())
        arrays = dict(position=P[i], pitch=pitch[i:i + 1], roll=roll[i:i + 1], current=cur)
        try:
            general = k.ik(**arrays)
        except k.Unreachable as e:
            with pytest.raises(k.Unreachable) as again:
                k.ik(**plain)
            assert str(again.value) == str(e)
            counts["limits" if "joint limit" in str(e) else "reach"] += 1
            continue
        fast = k.ik(**plain)
        assert fast.shape == general.shape, (i, fast, general)
        np.testing.assert_allclose(fast, general, rtol=0, atol=1e-12)
        counts["one" if len(fast) == 1 else "several"] += 1
        counts["elbow down first"] += not elbow_up(fast, P[i])[0]
    assert all(n >= 100 for n in counts.values()), counts
    # what ik does not take as is (shapes, NaN) is refused saying why
    with pytest.raises(ValueError, match="shape"):
        k.ik(np.zeros((3, 1)), 1.0)
    with pytest.raises(ValueError, match="NaN"):
        k.ik([0.0, np.nan, 19.0], 1.0)


def test_unreachable_says_why():
    assert issubclass(k.Unreachable, ValueError)
    with pytest.raises(k.Unreachable, match=r"\(0\.0, 600\.0, 30\.0\) mm with pitch 90\.0 deg: out of reach: the wrist "
                                            r"centre would be 605\.9 mm from the shoulder axis, beyond the 406\.2 mm"):
        k.ik([0, 600, 30], np.pi / 2)
    # wrist centre exactly on the shoulder axis
    with pytest.raises(k.Unreachable, match="too close: the wrist centre would be 0.0 mm from the shoulder axis"):
        k.ik([0, 158.575, 104.57], 0.0)
    # straight behind the base needs the waist at 180 deg, 1e-5 rad beyond its limit; the other branches break more
    with pytest.raises(k.Unreachable, match="every branch breaks a joint limit") as err:
        k.ik([0, -150, 20], np.pi / 2)
    msg = str(err.value)
    assert "facing, elbow up: waist = 3.141593 rad (180.0 deg) is outside its limits [-3.141583, 3.141583] rad" in msg
    assert "flipped, elbow up: elbow = " in msg and "flipped, elbow down: shoulder = " in msg
    assert len(k.ik([1, -150, 20], np.pi / 2)) >= 1   # a millimetre to the side is fine


def test_steepest_pitch():
    for y in np.arange(150.0, 521.0, 30.0):
        for x in (0.0, -120.0, 200.0):
            p = np.array([x, y, 19.0])
            pitch = k.steepest_pitch(p)
            assert 0 <= pitch <= np.pi / 2
            sols = k.ik(p, pitch)                                  # reachable
            assert np.abs(k.fk(sols[0])[:3, 3] - p).max() < 1e-6
            if pitch < np.pi / 2:                                  # and a slightly steeper one is not
                with pytest.raises(k.Unreachable):
                    k.ik(p, pitch + 1e-6)
    assert k.steepest_pitch(np.array([0.0, 250.0, 19.0])) == np.pi / 2
    assert k.steepest_pitch(np.array([0.0, 450.0, 19.0])) < np.radians(80)    # long reach cannot grasp top-down
    with pytest.raises(k.Unreachable, match=r"no pitch between 0\.0 and 90\.0 deg reaches \(0\.0, 700\.0, 19\.0\) "
                                            r"mm: out of reach"):
        k.steepest_pitch(np.array([0.0, 700.0, 19.0]))


@pytest.mark.parametrize("call, message", [
    (lambda: k.fk([0, 0, 0, 0]), r"shape \(5,\) or \(N, 5\).*got shape \(4,\)"),
    (lambda: k.fk(np.zeros((2, 3, 5))), r"got shape \(2, 3, 5\)"),
    (lambda: k.fk([0, np.nan, 0, 0, 0]), "NaN or infinity"),
    (lambda: k.fk([0, 0, 2.0, 0, 0]), r"out of range: elbow = 2\.000000 rad \(114\.6 deg\) is outside its limits"),
    (lambda: k.fk([[0, 0, 0, 0, 0], [0, -2.0, 0, 0, 0]]), "out of range: row 1: shoulder = "),
    (lambda: k.jacobian([0, 0, 0]), "got shape"),
    (lambda: k.ik([0, 300], 1.0), r"position must have shape \(3,\) or \(N, 3\)"),
    (lambda: k.ik([0, np.nan, 30], 1.0), "position contains NaN"),
    (lambda: k.ik([0, 300, 30], np.nan), "pitch contains NaN"),
    (lambda: k.ik([0, 300, 30], 1.0, roll=np.inf), "roll contains NaN or infinity"),
    (lambda: k.ik([[0, 300, 30]] * 2, 1.0), "use ik_batch"),
    (lambda: k.ik([0, 300, 30], 1.0, current=[0, 0]), "joint angles must have shape"),
    (lambda: k.ik_batch([[0, 300, 30]] * 3, [1.0, 1.1]), r"pitch must be a scalar or hold one value per target \(3\)"),
    (lambda: k.steepest_pitch(np.array([0, 300, 30.0]), max_pitch=0.1, min_pitch=0.5), "must not exceed max_pitch"),
    (lambda: k.steepest_pitch(np.array([0, 300, 30.0]), step=0.0), "step must be a positive number"),
])
def test_bad_input_raises_clear_value_error(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_every_ik_solver_answers_with_q_success_and_reason():
    targets = [[0.0, 250.0, 19.0], [0.0, 600.0, 30.0], [0.0, -150.0, 20.0]]   # fine, out of reach, joint limits
    res = k.ik_batch(targets, np.pi / 2)
    assert res.success.tolist() == [True, False, False] and res.q.shape == (3, 5)
    assert res.reason[0] == ""
    # the batch's reason: ik()'s Unreachable, word for word
    for target, reason in zip(targets[1:], res.reason[1:], strict=True):
        with pytest.raises(k.Unreachable) as err:
            k.ik(target, np.pi / 2)
        assert reason == str(err.value), target
    with pytest.warns(DeprecationWarning, match="use .success"):
        assert res.ok.tolist() == res.success.tolist()
