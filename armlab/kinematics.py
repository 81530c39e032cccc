"""Forward kinematics (DH and PoX), the Jacobian, closed-form inverse kinematics with every branch.

Units: millimetres and radians. Frames: poses are in the world (board) frame; the tool frame is the manufacturer's
`ee_gripper_link` (x = approach direction out of the gripper, y = finger opening direction, z completes the frame).
Joint vectors are (5,) or (N, 5) in the order waist, shoulder, elbow, wrist_angle, wrist_rotate.

Two models of one arm: the DH chain (dh_link_transform, dh_frames, fk_dh: the course's method, built on the students'
slot fk.dh_link_transform and used only where notebook 02 shows it) and the product of exponentials (link_frames,
fk_pox, fk, joint_positions, jacobian: the manufacturer's model, the kit's truth, which safety checks, planning, the
simulator and every reference use as the physical arm). They agree to 1e-9 mm.
"""

from __future__ import annotations

import functools
import math
import operator
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from armlab import slots
from armlab.arguments import finite_array, finite_float
from armlab.robot import DH_TOOL_ROTATION, RobotModel, rx200
from armlab.slots import SlotNotWritten, standin
from armlab.transforms import exp_se3, exp_se3_from, homogeneous, rot_x, rot_y, rot_z, screw_matrices

__all__ = [
    "Unreachable",
    "fk",
    "fk_dh",
    "fk_pox",
    "dh_link_transform",
    "dh_frames",
    "link_frames",
    "joint_positions",
    "frame_points",
    "jacobian",
    "tool_orientation",
    "ik",
    "ik_branches",
    "BRANCHES",
    "ik_batch",
    "ik_pox",
    "IKResult",
    "IKBatchResult",
    "steepest_pitch",
    "check_joints",
    "arm_geometry",
]


class Unreachable(ValueError):
    """No joint solution reaches the requested tool pose; the message says why (reach, or which joint limit)."""


# ---------------------------------------------------------------------------------------------------------------
# Input checks
# ---------------------------------------------------------------------------------------------------------------

def check_joints(q, robot: RobotModel | None = None, check_limits: bool = True) -> np.ndarray:
    """Validate joint angles: (5,) or (N, 5) finite floats in rad, within the position limits when asked.

    Raises ValueError naming the problem (shape, NaN, or which joint of which row is out of its limits).
    """
    robot = robot or rx200()
    if not _plain_joints(q):            # what finite_array would pass unchanged needs no second look
        q = finite_array(q, "joint angles", [(5,), (None, 5)], _JOINTS_WHAT, plural=True)
    if check_limits:
        ok = robot.within_limits(q)
        if not ok.all():
            rows = np.atleast_2d(q)
            bad = int(np.flatnonzero(~np.atleast_1d(ok))[0])
            where = "" if q.ndim == 1 else f"row {bad}: "
            raise ValueError(f"joint angles out of range: {where}" + "; ".join(robot.limit_violations(rows[bad])))
    return q


_JOINTS_WHAT = "waist, shoulder, elbow, wrist_angle, wrist_rotate in rad"


def _plain_joints(q) -> bool:
    """True for a float64 ndarray (5,) or (N, 5) of finite numbers: what finite_array returns as it is (the same
    object), so check_joints can skip its general checks (the simulator's steps pass such arrays every 20 ms)."""
    return (type(q) is np.ndarray and q.dtype == np.float64 and q.shape[-1:] == (5,) and 1 <= q.ndim <= 2
            and bool(np.isfinite(q).all()))


def _check_position(position, name: str = "position") -> np.ndarray:
    return finite_array(position, name, [(3,), (None, 3)], "x, y, z in world mm")


def _check_angle(value, name: str) -> np.ndarray:
    return finite_array(value, name, what="rad")


# ---------------------------------------------------------------------------------------------------------------
# Forward kinematics
# ---------------------------------------------------------------------------------------------------------------

# The four elementary motions of a DH link as screws (w, v): rotation about z, translation along z, along x, rotation
# about x; exp_se3 of a screw with w = 0 is the translation by v times the amount.
_ELEMENTARY_SCREWS = np.array([[0.0, 0, 1, 0, 0, 0], [0, 0, 0, 0, 0, 1], [0, 0, 0, 1, 0, 0], [1, 0, 0, 0, 0, 0]])


def _dh_by_elementary_motions(theta, d, a, alpha) -> np.ndarray:
    """The stand-in while fk.dh_link_transform is blank: the product of the matrix exponentials of the link's four
    elementary screw motions (theta about z, d along z, a along x, alpha about x), the PoX way (the same transform to
    1e-12, by another method; four exponentials and three matrix products slower)."""
    params = np.stack(np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (theta, d, a, alpha))), -1)
    E = exp_se3(_ELEMENTARY_SCREWS, params)                                          # (..., 4, 4, 4)
    return E[..., 0, :, :] @ E[..., 1, :, :] @ E[..., 2, :, :] @ E[..., 3, :, :]


@standin("fk.dh_link_transform", _dh_by_elementary_motions, "DH link transforms are products of the "
                                                               "four elementary motions' exponentials")
def dh_link_transform(theta, d, a, alpha) -> np.ndarray:
    """Standard DH link transform(s) (..., 4, 4) = Rz(theta) Tz(d) Tx(a) Rx(alpha); lengths in mm, angles in rad.

    Exercise fk.dh_link_transform (notebook 02: the kit's batched DH link transform).
    """
    theta, d, a, alpha = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (theta, d, a, alpha)))
    A = np.zeros(theta.shape + (4, 4))
    # BEGIN SOLUTION fk.dh_link_transform
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    A[..., 0, 0], A[..., 0, 1], A[..., 0, 2], A[..., 0, 3] = ct, -st * ca, st * sa, a * ct
    A[..., 1, 0], A[..., 1, 1], A[..., 1, 2], A[..., 1, 3] = st, ct * ca, -ct * sa, a * st
    A[..., 2, 1], A[..., 2, 2], A[..., 2, 3] = sa, ca, d
    A[..., 3, 3] = 1.0
    # END SOLUTION
    return A


def dh_frames(q, robot: RobotModel | None = None, check_limits: bool = True) -> np.ndarray:
    """World poses of DH frames 0..5 and the tool by chaining the DH table's link transforms (the course's method):
    (7, 4, 4) for q (5,), (N, 7, 4, 4) for q (N, 5); mm."""
    robot = robot or rx200()
    q = check_joints(q, robot, check_limits)
    qs = np.atleast_2d(q)
    dh = robot.dh
    if dh is None:
        raise ValueError("this robot model has no DH table (the DH table is exercise fk.dh_table): chain yours with "
                         "dataclasses.replace(robot, dh=table)")
    A = dh_link_transform(qs + dh[:, 0], dh[:, 1], dh[:, 2], dh[:, 3])  # (N, 5, 4, 4)
    frames = np.empty((qs.shape[0], 7, 4, 4))
    frames[:, 0] = np.eye(4)
    for i in range(5):
        frames[:, i + 1] = frames[:, i] @ A[:, i]
    frames[:, 6] = frames[:, 5] @ homogeneous(DH_TOOL_ROTATION)
    return frames if q.ndim == 2 else frames[0]


def link_frames(q, robot: RobotModel | None = None, check_limits: bool = True) -> np.ndarray:
    """World poses of the world frame, link frames 1..5 and the tool: (7, 4, 4) for q (5,), (N, 7, 4, 4) for q (N, 5).

    Link frame i is where DH frame i is (its origin at the shoulder for i = 1, the elbow for 2, the wrist for 3 and
    4, the tool point for 5); the last entry is ee_gripper_link. Computed by the product of exponentials from the
    frames' poses at q = 0 (data/rx200_pox.csv): the manufacturer's model, which the simulator and the viewer use as
    the physical arm, so they never depend on the DH exercise (dh_frames / fk_dh agree with it to 1e-9 mm).
    """
    robot = robot or rx200()
    return _link_frames(check_joints(q, robot, check_limits), robot)


_SCREW_MATRICES: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}      # screws bytes -> (W, W @ W)
_EYE4 = np.eye(4)
_EYE4.setflags(write=False)


def _exponentials(q: np.ndarray, robot: RobotModel) -> np.ndarray:
    """exp_se3 of the robot's screws at checked joint angles q (5,) or (N, 5): (N, 5, 4, 4). The screws' matrices
    (transforms.screw_matrices) are built once per screw table (keyed on its values), not at every call."""
    key = robot.screws.tobytes()
    matrices = _SCREW_MATRICES.get(key)
    if matrices is None:
        W, WW, _ = screw_matrices(robot.screws)
        W.setflags(write=False)
        WW.setflags(write=False)
        if len(_SCREW_MATRICES) >= _GEOMETRY_ENTRIES:
            _SCREW_MATRICES.clear()
        matrices = _SCREW_MATRICES[key] = (W, WW)
    return exp_se3_from((*matrices, robot.screws[..., 3:]), np.atleast_2d(q))


def _link_frames(q: np.ndarray, robot: RobotModel) -> np.ndarray:
    """link_frames of checked joint angles q (5,) or (N, 5)."""
    E = _exponentials(q, robot)  # (N, 5, 4, 4)
    frames = np.empty(E.shape[:1] + (7, 4, 4))
    frames[:, 0] = _EYE4
    chain = E[:, 0]
    for i in range(5):
        if i:
            chain = chain @ E[:, i]
        frames[:, i + 1] = chain @ robot.frames_home[i]
    frames[:, 6] = chain @ robot.M
    return frames if q.ndim == 2 else frames[0]


def fk_dh(q, robot: RobotModel | None = None, check_limits: bool = True) -> np.ndarray:
    """Tool pose ee_gripper_link in the world, (4, 4) or (N, 4, 4), from the DH table (mm)."""
    return dh_frames(q, robot, check_limits)[..., 6, :, :]


def fk_pox(q, robot: RobotModel | None = None, check_limits: bool = True) -> np.ndarray:
    """Tool pose ee_gripper_link in the world, (4, 4) or (N, 4, 4), by the product of exponentials (mm)."""
    robot = robot or rx200()
    q = check_joints(q, robot, check_limits)
    E = _exponentials(q, robot)  # (N, 5, 4, 4)
    T = E[:, 0] @ E[:, 1] @ E[:, 2] @ E[:, 3] @ E[:, 4] @ robot.M
    return T if q.ndim == 2 else T[0]


def fk(q, robot: RobotModel | None = None, check_limits: bool = True) -> np.ndarray:
    """Tool pose in the world: (4, 4) for q (5,) rad, (N, 4, 4) for q (N, 5); translation in mm. By the
    manufacturer's model (fk_pox): the kit's truth, which safety checks, planning, the simulator and every reference
    use, so it never runs the DH exercise (fk_dh is the DH chain notebook 02 builds on it).

    Raises ValueError for a wrong shape, NaN, or (with check_limits) a joint outside its limits.
    """
    return fk_pox(q, robot, check_limits)


def joint_positions(q, robot: RobotModel | None = None) -> np.ndarray:
    """World positions (mm) of base, waist top, shoulder, elbow, wrist, wrist_rotate, tool: (7, 3) or (N, 7, 3).

    The points the viewer and the simulator draw the arm's links between: the link frames' origins, and the waist
    top and the wrist_rotate joint carried with link frames 1 and 4 (RobotModel.points_home, data/rx200_pox.csv).
    """
    robot = robot or rx200()
    return frame_points(_link_frames(check_joints(q, robot, check_limits=False), robot), robot)


def frame_points(frames: np.ndarray, robot: RobotModel | None = None) -> np.ndarray:
    """joint_positions' points (..., 7, 3) world mm from the link frames (..., 7, 4, 4) link_frames gave for the same
    joints: for callers that need both the frames and the points (one product of exponentials, not two)."""
    robot = robot or rx200()
    on_link1, on_link4 = robot.points_on_links
    out = np.empty(frames.shape[:-3] + (7, 3))
    out[..., 0, :] = 0.0                                                          # the base
    out[..., 1, :] = frames[..., 1, :3, :3] @ on_link1 + frames[..., 1, :3, 3]   # the waist top
    out[..., 2:5, :] = frames[..., 1:4, :3, 3]                                   # shoulder, elbow, wrist
    out[..., 5, :] = frames[..., 4, :3, :3] @ on_link4 + frames[..., 4, :3, 3]   # the wrist_rotate joint
    out[..., 6, :] = frames[..., 6, :3, 3]                                       # the tool point
    return out


def jacobian(q, robot: RobotModel | None = None, step: float = 1e-6) -> np.ndarray:
    """Jacobian of the tool pose in the world frame, (6, 5) for q (5,) rad or (N, 6, 5) for q (N, 5).

    Rows 0-2: linear velocity of the tool point (mm/s per rad/s); rows 3-5: angular velocity (rad/s per rad/s),
    world axes; one column per joint. Computed by central differences of the manufacturer's model (link_frames'
    tool pose) with a joint step of `step` rad: accurate to about 1e-7 mm per rad, plenty for linearising the sag
    fit or a Gauss-Newton step. (The exact Jacobian from the link frames is what notebook 03 derives.)
    """
    robot = robot or rx200()
    q = check_joints(q, robot, check_limits=False)
    step = finite_float(step, "step", positive=True, what="rad")
    Q = np.atleast_2d(q)
    n = len(Q)
    nudges = step * np.eye(5)
    both = np.concatenate([Q[:, None, :] + nudges, Q[:, None, :] - nudges], axis=1)    # (N, 10, 5)
    T = link_frames(both.reshape(-1, 5), robot, check_limits=False)[:, 6].reshape(n, 2, 5, 4, 4)
    R = link_frames(Q, robot, check_limits=False)[:, 6, :3, :3]
    linear = (T[:, 0, :, :3, 3] - T[:, 1, :, :3, 3]) / (2 * step)                       # (N, 5, 3)
    W = (T[:, 0, :, :3, :3] - T[:, 1, :, :3, :3]) / (2 * step) @ np.swapaxes(R, -1, -2)[:, None]   # dR/dq R^T
    angular = np.stack([W[..., 2, 1] - W[..., 1, 2], W[..., 0, 2] - W[..., 2, 0], W[..., 1, 0] - W[..., 0, 1]],
                       axis=-1) / 2                                                      # its skew part's vector
    J = np.swapaxes(np.concatenate([linear, angular], axis=-1), -1, -2)                   # (N, 6, 5)
    return J[0] if q.ndim == 1 else J


def tool_orientation(heading, pitch, roll=0.0) -> np.ndarray:
    """Tool rotation(s) (..., 3, 3) in the world for an arm plane at `heading` (rad, from world +x towards +y),
    the approach pitched `pitch` below horizontal in that plane, and wrist rotation `roll` (rad)."""
    return rot_z(heading) @ rot_y(pitch) @ rot_x(roll)


# ---------------------------------------------------------------------------------------------------------------
# Closed-form inverse kinematics
# ---------------------------------------------------------------------------------------------------------------

# Branch order within the 4 candidates: (waist facing the target | flipped) x (elbow up | elbow down).
_BRANCHES = (("facing", "elbow up"), ("facing", "elbow down"), ("flipped", "elbow up"), ("flipped", "elbow down"))


def _wrap(angle, xp=np):
    """Wrap angles to (-pi, pi] (arrays with xp = numpy, a Python float with xp = _SCALAR_MATH)."""
    return xp.pi - xp.mod(xp.pi - angle, 2 * xp.pi)


@dataclass(frozen=True)
class _Candidates:
    q: np.ndarray          # (N, 4, 5) joint solutions per branch (NaN where out of reach)
    in_reach: np.ndarray   # (N, 4) the wrist centre is within the arm's span
    valid: np.ndarray      # (N, 4) in reach and within every joint limit
    wrist_distance: np.ndarray  # (N, 4) distance from shoulder to wrist centre, mm


def arm_geometry(robot: RobotModel | None = None) -> tuple[float, float, float, float]:
    """The arm's lengths in mm, read off the manufacturer's model at q = 0: the shoulder axis's height, the upper arm
    (shoulder to elbow), the forearm (elbow to wrist) and the tool point's reach beyond the wrist_angle axis."""
    chain = _planar_chain(robot or rx200())
    return chain.shoulder[1], chain.upper_arm, chain.forearm, chain.reach


def _planar_geometry(robot: RobotModel):
    return arm_geometry(robot)


# Per branch: is the waist turned away from the target, and the sign of delta (the forearm's angle from the upper
# arm's line, counter-clockwise in the arm's plane seen with the arm's forward direction on the right). Elbow up = the
# elbow above the shoulder-wrist line as seen with the target on the right: delta < 0 facing the target; the flipped
# waist mirrors the arm's plane, which swaps the sign.
_FLIPPED = np.array([w == "flipped" for w, _ in _BRANCHES], float)               # 1.0 where flipped
_DELTA_SIGN = np.where(np.array([e == "elbow up" for _, e in _BRANCHES]) != _FLIPPED.astype(bool), -1.0, 1.0)
_ELBOW_DOWN = np.array([e == "elbow down" for _, e in _BRANCHES], float)


_NEWTON_ITERATIONS = 30       # Newton steps of the kit's IK on the planar chain (quadratic: ~5 from a seed)
_NEWTON_SEEDS = (1.0, 2.4, 0.3)   # rad: the elbow bends of the kit's IK's seeds, towards each branch's side


@dataclass(frozen=True)
class _PlanarChain:
    """The arm's shoulder-elbow-wrist chain in its own vertical plane (forward, up; mm, rad), read off the
    manufacturer's model at q = 0 (link frames 1..3 and the tool, data/rx200_pox.csv): the shoulder point, the upper
    arm's and forearm's lengths, the upper arm's angle and the forearm's turn from it at q = 0, the signs with which
    joints 2..4 turn the plane counter-clockwise (forward towards up), the tool point's reach beyond the wrist, the
    approach's angle at q = 0 and the waist's heading at q = 0."""

    shoulder: tuple[float, float]
    upper_arm: float
    forearm: float
    rest_upper: float
    rest_turn: float
    turn: tuple[float, float, float]
    reach: float
    approach0: float
    heading0: float


_CHAINS: dict[bytes, _PlanarChain] = {}


def _planar_chain(robot: RobotModel) -> _PlanarChain:
    """The robot's _PlanarChain (computed once per PoX description)."""
    key = robot.M.tobytes() + robot.frames_home.tobytes() + robot.screws.tobytes()
    chain = _CHAINS.get(key)
    if chain is None:
        tool = robot.M[:3, 3]
        heading0 = math.atan2(tool[1], tool[0])
        forward = np.array([math.cos(heading0), math.sin(heading0), 0.0])
        (sx, sz), (ex, ez), (wx, wz) = [(float(o @ forward), float(o[2])) for o in robot.frames_home[:3, :3, 3]]
        approach = robot.M[:3, 0]
        across = np.cross(forward, [0.0, 0.0, 1.0])              # an axis along it turns forward towards up
        axes = robot.screws[:, :3]
        if not (np.allclose(axes[0], [0.0, 0.0, 1.0]) and np.allclose(np.abs(axes[1:4] @ across), 1.0)
                and np.allclose(np.cross(axes[4], approach), 0.0) and np.allclose(robot.screws[0, 3:], 0.0)):
            raise ValueError("the kit's IK needs a vertical waist axis through the origin, the shoulder, elbow and "
                             "wrist_angle axes across the arm's plane and wrist_rotate along the approach")
        rest_upper = math.atan2(ez - sz, ex - sx)
        chain = _PlanarChain((sx, sz), math.hypot(ex - sx, ez - sz), math.hypot(wx - ex, wz - ez), rest_upper,
                             math.atan2(wz - ez, wx - ex) - rest_upper,
                             tuple(float(np.sign(robot.screws[j, :3] @ across)) for j in (1, 2, 3)),
                             float(np.linalg.norm(tool - robot.frames_home[2, :3, 3])),
                             math.atan2(float(approach[2]), float(approach @ forward)), heading0)
        if len(_CHAINS) >= _GEOMETRY_ENTRIES:
            _CHAINS.clear()
        _CHAINS[key] = chain
    return chain


def _wrist_goal(r, z, pitch, flipped, chain: _PlanarChain, xp=np):
    """Where the wrist must be, from the shoulder in the arm's plane (mm), for a target `r` mm from the base axis at
    height `z` mm, approach pitched `pitch` rad below horizontal, the waist facing it (flipped 0) or turned away (1);
    and the approach's angle below the arm's forward horizontal (rad)."""
    side = 1.0 - 2.0 * flipped
    below = xp.pi * flipped + side * pitch
    return (side * r - chain.reach * xp.cos(below) - chain.shoulder[0],
            z - chain.shoulder[1] + chain.reach * xp.sin(below), below)


def _newton_step(t, b, gx, gz, chain: _PlanarChain, xp=np):
    """One damped Newton step (at most 0.5 rad) moving the upper arm's angle `t` and the forearm's turn `b` (rad) so
    that the planar chain's wrist reaches (gx, gz) mm; also the wrist's distance from it before the step (mm)."""
    l1, l2 = chain.upper_arm, chain.forearm
    c1, s1, c12, s12 = xp.cos(t), xp.sin(t), xp.cos(t + b), xp.sin(t + b)
    ex, ez = l1 * c1 + l2 * c12 - gx, l1 * s1 + l2 * s12 - gz
    det = l1 * l2 * xp.sin(b)
    det = xp.where(xp.abs(det) < 1e-12, 1e-12, det)
    dt = -(l2 * c12 * ex + l2 * s12 * ez) / det                  # minus the 2 x 2 Jacobian's inverse times the error
    db = ((l1 * c1 + l2 * c12) * ex + (l1 * s1 + l2 * s12) * ez) / det
    scale = xp.maximum(1.0, xp.maximum(xp.abs(dt), xp.abs(db)) / 0.5)
    return t + dt / scale, b + db / scale, xp.hypot(ex, ez)


def _chain_joints(heading, t, b, below, chain: _PlanarChain, flipped):
    """Joint angles q1..q4 (rad, not wrapped) putting the arm's plane at `heading` (turned away when flipped), the
    upper arm at angle `t`, the forearm turned `b` from it and the approach `below` rad under forward horizontal."""
    s2, s3, s4 = chain.turn
    q2 = (t - chain.rest_upper) * s2
    q3 = (b - chain.rest_turn) * s3
    return heading - chain.heading0 + _PI * flipped, q2, q3, (-below - chain.approach0 - s2 * q2 - s3 * q3) * s4


def _newton_branch(heading, r, z, pitch, flipped, delta_sign, chain: _PlanarChain):
    """One branch of the kit's IK (_numerical_candidates) for one target, on Python floats: q1..q4 (rad, not
    wrapped), or None where Newton's method finds no solution on the branch's side (out of reach)."""
    gx, gz, below = _wrist_goal(r, z, pitch, flipped, chain, _SCALAR_MATH)
    for seed in _NEWTON_SEEDS:
        b = delta_sign * seed
        t = math.atan2(gz, gx) - 0.5 * b
        for _ in range(_NEWTON_ITERATIONS):
            t, b, error = _newton_step(t, b, gx, gz, chain, _SCALAR_MATH)
            if error < 1e-10:
                break
        b = _PI - (_PI - b) % _TWO_PI
        if _newton_step(t, b, gx, gz, chain, _SCALAR_MATH)[2] < 1e-7 and (b > 0) == (delta_sign > 0):
            return _chain_joints(heading, t, b, below, chain, flipped)
    return None


def _numerical_candidates(P: np.ndarray, pitch: np.ndarray, roll: np.ndarray, robot: RobotModel) -> _Candidates:
    """The kit's own IK (ik_pox, and the stand-in while exercise ik.candidates is blank), every branch at once, solved
    numerically on the manufacturer's model: the waist turns the arm's plane to the target (or away from it), the
    wrist rotates by `roll`; in that plane Newton's method moves the upper arm's and forearm's angles until the
    wrist reaches the point `reach` short of the target along the approach (the planar chain read off the PoX model
    at q = 0, seeded with the elbow bent to the branch's side), and the wrist angle makes up the approach. A branch
    counts where Newton's method lands (1e-7 mm) with the elbow on the branch's side; the joints agree with the PoX
    model to 1e-9 mm (the chain is that model's, for an arm whose model _planar_chain accepts)."""
    chain = _planar_chain(robot)
    planar = np.hypot(P[:, 0], P[:, 1])
    heading = np.where(planar > 1e-9, np.arctan2(P[:, 1], P[:, 0]), chain.heading0)
    gx, gz, below = _wrist_goal(planar[:, None], P[:, 2:3], pitch[:, None], _FLIPPED, chain)      # (N, 4)
    distance = np.hypot(gx, gz)
    in_reach = (distance <= chain.upper_arm + chain.forearm + 1e-9) & \
        (distance >= abs(chain.upper_arm - chain.forearm) - 1e-9)
    elbow_side = np.broadcast_to(_DELTA_SIGN, gx.shape)     # the sign of the forearm's turn from the upper arm
    theta, bend, ok = np.zeros(gx.shape), np.zeros(gx.shape), np.zeros(gx.shape, bool)
    for seed in _NEWTON_SEEDS:                              # later seeds only where the earlier ones did not land
        todo = np.flatnonzero(in_reach & ~ok)
        if not todo.size:
            break
        goal_x, goal_z, sign = gx.ravel()[todo], gz.ravel()[todo], elbow_side.ravel()[todo]
        b = sign * seed
        t = np.arctan2(goal_z, goal_x) - 0.5 * b
        for _ in range(_NEWTON_ITERATIONS):
            t, b, error = _newton_step(t, b, goal_x, goal_z, chain)
            if error.max() < 1e-10:
                break
        b = _wrap(b)
        good = (_newton_step(t, b, goal_x, goal_z, chain)[2] < 1e-7) & (np.sign(b) == sign)
        theta.ravel()[todo[good]], bend.ravel()[todo[good]], ok.ravel()[todo[good]] = t[good], b[good], True
    q = np.empty(gx.shape + (5,))
    q[..., 0], q[..., 1], q[..., 2], q[..., 3] = _chain_joints(heading[:, None], theta, bend, below, chain, _FLIPPED)
    q[..., 4] = roll[:, None]
    q = _wrap(q)
    q[~ok] = np.nan
    return _Candidates(q, in_reach, ok & robot.within_limits(q), distance)


# The math the closed-form IK needs, for numpy arrays (the batch: every target and branch at once) or for Python
# floats (one target, one branch at a time: no numpy per-call cost). The same formulas run on either.
class _ScalarMath:
    """numpy's names for the math module's functions, on Python floats (attribute lookups on a class are the
    quickest Python has: the single-target IK calls these about 60 times a solve)."""

    pi = math.pi
    cos, sin, arctan2, arccos = staticmethod(math.cos), staticmethod(math.sin), staticmethod(math.atan2), \
        staticmethod(math.acos)
    hypot, sqrt, abs, mod = staticmethod(math.hypot), staticmethod(math.sqrt), staticmethod(abs), \
        staticmethod(operator.mod)

    @staticmethod
    def minimum(a: float, b: float) -> float:
        return b if b < a else a                     # what min(a, b) does, called quicker

    @staticmethod
    def maximum(a: float, b: float) -> float:
        return b if b > a else a

    @staticmethod
    def where(condition: bool, a: float, b: float) -> float:
        return a if condition else b


_SCALAR_MATH = _ScalarMath


def _heading(x, y, robot_o1, xp=np):
    """The arm plane's heading (rad, from world +x towards +y) for a target at (x, y) mm; on the base axis any
    heading works: keep the waist at 0 (heading = the waist's DH offset)."""
    r = xp.hypot(x, y)
    return xp.where(r > 1e-9, xp.arctan2(y, x), robot_o1), r


def _branch_joints(heading, r, z, pitch, flipped, delta_sign, geometry, xp=np):
    """Joint angles q1..q4 (rad, not yet wrapped) of the IK branch(es) `flipped` (1 = the waist turned away from
    the target, 0 = facing it) and `delta_sign` (see _DELTA_SIGN) for a target at heading `heading` (rad), distance
    `r` (mm) from the base axis and height `z` (world mm), approach pitched `pitch` rad below horizontal. Also: ok
    (the wrist centre is within the arm's span) and d2 (squared shoulder-wrist distance, mm^2). geometry: the
    arm's (shoulder height, upper arm, forearm, wrist-to-tool, o1, o2, o3) in mm and rad.

    Written once for either number type: with xp = numpy every argument may be an array (broadcast together: the
    batch), with xp = _SCALAR_MATH they are Python floats (one branch of one target: the fast single solve).

    Exercise ik.candidates (notebook 03: the kit's closed-form IK: all four branches).
    """
    h0, L1, L2, Lt, o1, o2, o3 = geometry
    side = 1.0 - 2.0 * flipped                              # +1 facing, -1 flipped
    # BEGIN SOLUTION ik.candidates
    q1 = heading - o1 + xp.pi * flipped
    r_plane = side * r                                      # target's distance along the arm's forward direction
    psi = xp.pi * flipped + side * pitch                    # approach angle below the arm's forward horizontal
    wr = r_plane - Lt * xp.cos(psi)                         # wrist centre in the arm's plane, from the shoulder
    wh = z - h0 + Lt * xp.sin(psi)
    d2 = wr * wr + wh * wh
    cos_delta = (d2 - L1 * L1 - L2 * L2) / (2 * L1 * L2)
    ok = xp.abs(cos_delta) <= 1 + 1e-12
    delta = xp.arccos(xp.minimum(xp.maximum(cos_delta, -1.0), 1.0)) * delta_sign   # sign: see _DELTA_SIGN
    upper_arm_elevation = xp.arctan2(wh, wr) - xp.arctan2(L2 * xp.sin(delta), L1 + L2 * xp.cos(delta))
    q2 = -upper_arm_elevation - o2
    q3 = -delta - o3
    q4 = psi - q2 - q3 - (o2 + o3)
    # END SOLUTION
    return q1, q2, q3, q4, ok, d2


_GEOMETRY_ENTRIES = 16     # planar chains kept (no model kept: the planner makes a model with inner limits per grasp)


def _ik_geometry(robot: RobotModel) -> tuple[float, ...]:
    """(shoulder height, upper arm, forearm, wrist-to-tool) mm and the joint offsets o1, o2, o3 rad (the waist's
    heading, minus the upper arm's elevation and minus the forearm's turn from it, at q = 0), as Python floats, read
    off the manufacturer's model (_planar_chain) once per robot description."""
    chain = _planar_chain(robot)
    return (chain.shoulder[1], chain.upper_arm, chain.forearm, chain.reach, chain.heading0, -chain.rest_upper,
            -chain.rest_turn)


@standin("ik.candidates", _numerical_candidates, "inverse kinematics is solved numerically on the PoX "
                                                            "model (slower)")
def _ik_candidates(P: np.ndarray, pitch: np.ndarray, roll: np.ndarray, robot: RobotModel) -> _Candidates:
    """Every IK branch for targets P (N, 3) with pitch (N,) and roll (N,), vectorised over targets and branches
    (_branch_joints on arrays: (N, 1) targets broadcast against the 4 branches)."""
    geometry = _ik_geometry(robot)
    x, y, z = (c[:, None] for c in P.T)                     # (N, 1): broadcast against the 4 branches
    heading, r = _heading(x, y, geometry[4])
    q1, q2, q3, q4, ok, d2 = _branch_joints(heading, r, z, pitch[:, None], _FLIPPED, _DELTA_SIGN, geometry)
    q = np.empty(q2.shape + (5,))
    q[..., 0], q[..., 1], q[..., 2], q[..., 3], q[..., 4] = q1, q2, q3, q4, roll[:, None]
    q = _wrap(q)                                            # every joint angle in (-pi, pi]
    q[~ok] = np.nan
    valid = ok & robot.within_limits(q)                     # NaN (out of reach) compares False: not within
    return _Candidates(q, ok, valid, np.sqrt(d2))


_BRANCH_SIGNS = tuple(zip(_FLIPPED.tolist(), _DELTA_SIGN.tolist(), _ELBOW_DOWN.tolist()))


_PLAIN_NUMBERS = frozenset((float, int, np.float64, np.float32, np.int64, np.int32))


def _real(value) -> float:
    """A plain number as a Python float; TypeError for anything else (arrays go the general way)."""
    if type(value) in _PLAIN_NUMBERS or (isinstance(value, (float, int, np.floating, np.integer))
                                         and not isinstance(value, bool)):
        return float(value)
    raise TypeError(value)


def _floats(values, n: int) -> list[float]:
    """n plain numbers from a list, tuple or (n,) array; TypeError otherwise."""
    if isinstance(values, np.ndarray):
        if values.shape != (n,) or values.dtype.kind not in "fi":
            raise TypeError(values)
        return values.tolist()
    if isinstance(values, (list, tuple)) and len(values) == n:
        return [_real(v) for v in values]
    raise TypeError(values)


_PI, _TWO_PI = math.pi, 2 * math.pi     # _ik_one writes _wrap inline on floats: pi - (pi - angle) mod 2 pi


def _ik_one(position, pitch, roll, current, robot: RobotModel) -> np.ndarray | None:
    """ik() for one target in plain Python floats: the same _branch_joints, wrap, limits and ranking as the batch,
    without numpy's per-call cost. None where the general path must answer: input it does not take as is (it
    validates and raises), no valid branch (it explains why), or the exercise ik.candidates still blank."""
    try:
        x, y, z = _floats(position, 3)
        pitch, roll = _real(pitch), _real(roll)
        cur = None if current is None else _floats(current, 5)
    except (TypeError, OverflowError):       # not plain floats: the general path validates and names the argument
        return None
    if not (math.isfinite(x + y + z + pitch + roll) and (cur is None or math.isfinite(sum(cur)))):
        return None
    geometry = _ik_geometry(robot)
    heading, r = _heading(x, y, geometry[4], _SCALAR_MATH)
    (lo1, hi1), (lo2, hi2), (lo3, hi3), (lo4, hi4), (lo5, hi5) = robot.bounds
    roll = _PI - (_PI - roll) % _TWO_PI
    if not lo5 <= roll <= hi5:
        return None
    found, chain = [], None
    for flipped, delta_sign, elbow_down in _BRANCH_SIGNS:
        if chain is None:
            try:
                q1, q2, q3, q4, ok, _ = _branch_joints(heading, r, z, pitch, flipped, delta_sign, geometry,
                                                       _SCALAR_MATH)
            except SlotNotWritten as e:
                if e.slot_id != "ik.candidates":
                    raise
                if not slots.standing_in("ik.candidates"):
                    return None                       # the general path's stand-in answers first, and says so
                chain = _planar_chain(robot)          # blank: the kit's own IK, on floats
        if chain is not None:
            joints = _newton_branch(heading, r, z, pitch, flipped, delta_sign, chain)
            ok = joints is not None
            if ok:
                q1, q2, q3, q4 = joints
        if not ok:
            continue
        q1, q2, q3, q4 = (_PI - (_PI - q1) % _TWO_PI, _PI - (_PI - q2) % _TWO_PI,     # _wrap, inline
                          _PI - (_PI - q3) % _TWO_PI, _PI - (_PI - q4) % _TWO_PI)
        if lo1 <= q1 <= hi1 and lo2 <= q2 <= hi2 and lo3 <= q3 <= hi3 and lo4 <= q4 <= hi4:
            found.append((elbow_down, [q1, q2, q3, q4, roll]))
    if not found:
        return None
    if len(found) > 1:             # _rank's order: elbow up first, then least joint motion from `current`
        if len(found) == 2 and found[0][0] != found[1][0]:
            found.sort(key=lambda item: item[0])            # one elbow up, one down: the motion cannot reorder them
        else:
            cur = robot.home.tolist() if cur is None else cur
            found = [(elbow_down * 1e3 + sum([abs(_PI - (_PI - (a - c)) % _TWO_PI) for a, c in zip(q, cur)]), q)
                     for elbow_down, q in found]
            found.sort(key=lambda item: item[0])            # stable: ties keep the branch order, as _rank does
    return np.array([q for _, q in found])


def _explain(c: _Candidates, i: int, robot: RobotModel, position, pitch) -> str:
    """Why target i has no valid branch, in words."""
    h0, L1, L2, _ = _planar_geometry(robot)
    head = (f"no joint solution puts the tool at ({position[0]:.1f}, {position[1]:.1f}, {position[2]:.1f}) mm "
            f"with pitch {np.degrees(pitch):.1f} deg")
    if not c.in_reach[i].any():
        d = c.wrist_distance[i].min()
        if d > L1 + L2:
            return (f"{head}: out of reach: the wrist centre would be {d:.1f} mm from the shoulder axis, beyond the "
                    f"{L1 + L2:.1f} mm the upper arm and forearm span (try a smaller pitch or a closer target)")
        return (f"{head}: too close: the wrist centre would be {d:.1f} mm from the shoulder axis, nearer than the "
                f"{abs(L1 - L2):.1f} mm the folded arm allows")
    reasons = []
    for b in np.flatnonzero(c.in_reach[i]):
        names = ", ".join(_BRANCHES[b])
        reasons.append(f"{names}: " + "; ".join(robot.limit_violations(c.q[i, b])))
    return f"{head}: every branch breaks a joint limit ({' | '.join(reasons)})"


def _rank(c: _Candidates, current: np.ndarray) -> np.ndarray:
    """Branch order per target (N, 4): valid first, then elbow up, then least joint motion from `current`."""
    motion = np.abs(_wrap(c.q - current[:, None, :])).sum(-1)                   # NaN where out of reach
    key = np.where(c.valid, _ELBOW_DOWN * 1e3 + motion, np.inf)               # motion < 5 pi < 1e3
    return np.argsort(key, axis=1, kind="stable")


def _per_target(a: np.ndarray, n: int, name: str) -> np.ndarray:
    if a.ndim > 1 or (a.ndim == 1 and a.shape[0] not in (1, n)):
        raise ValueError(f"{name} must be a scalar or hold one value per target ({n}), got shape {a.shape}")
    out = np.empty(n)
    out[:] = a
    return out


def _prepare(position, pitch, roll, current, robot):
    P = _check_position(position)
    single = P.ndim == 1
    P = np.atleast_2d(P)
    n = P.shape[0]
    pitch, roll = (_per_target(_check_angle(v, name), n, name) for v, name in ((pitch, "pitch"), (roll, "roll")))
    cur = np.empty((n, 5))
    cur[:] = robot.home if current is None else check_joints(current, robot, check_limits=False)
    return P, pitch, roll, cur, single


def ik(position, pitch, roll: float = 0.0, current=None, robot: RobotModel | None = None) -> np.ndarray:
    """All joint solutions (K, 5) that put the tool point at `position` (world mm) within the joint limits.

    The approach direction (tool x axis) is pitched `pitch` rad below horizontal in the vertical plane through the
    base axis and the target (0 = horizontal pointing away from the base, pi/2 = straight down, > pi/2 = down and
    back towards the base); wrist_rotate = `roll`. Solutions are ordered best first: elbow up, then least motion
    from `current` (default: home). Elbow up, whichever way the waist faces: seen from the side with the target to
    the right of the base axis, the elbow lies to the left of the direction from the shoulder to the wrist centre,
    i.e. above the shoulder-wrist line whenever the wrist centre is on the target's side of the waist axis.
    Raises Unreachable (a ValueError) saying why when there is none.

    One plain target goes the fast way (_ik_one: the same math on Python floats, about 10x quicker); anything
    else, and every failure, through the batch machinery (_ik_general), which validates and explains.
    """
    robot = robot or rx200()
    fast = _ik_one(position, pitch, roll, current, robot)
    return fast if fast is not None else _ik_general(position, pitch, roll, current, robot)


BRANCHES = tuple(", ".join(b) for b in _BRANCHES)    # "facing, elbow up", ..., "flipped, elbow down"


def ik_branches(position, pitch, roll: float = 0.0, robot: RobotModel | None = None) -> np.ndarray:
    """Every closed-form branch for one target (4, 5) rad, in the order of BRANCHES (waist facing the target or
    flipped, x elbow up or down), joint limits NOT applied: NaN rows where the wrist centre is out of reach. The
    same solutions ik() ranks and filters; position (3,) world mm, pitch and roll rad as in ik()."""
    robot = robot or rx200()
    P, pitch_a, roll_a, _, single = _prepare(position, pitch, roll, None, robot)
    if not single:
        raise ValueError("ik_branches takes one position (3,)")
    return _ik_candidates(P, pitch_a, roll_a, robot).q[0]


def ik_pox(position, pitch, roll: float = 0.0, current=None, robot: RobotModel | None = None) -> np.ndarray:
    """The kit's own inverse kinematics, never the student's: what ik() returns (the same arguments, branches,
    joint limits, order and Unreachable reasons), solved numerically on the manufacturer's PoX model (damped
    Gauss-Newton per branch) instead of by the closed form of exercise ik.candidates. For the kit's truths (a
    simulated scene's arm pose, a kit recording), where a student's IK must change nothing; slower than ik()."""
    return _ik_general(position, pitch, roll, current, robot or rx200(), _numerical_candidates)


def _ik_general(position, pitch, roll, current, robot: RobotModel, candidates=None) -> np.ndarray:
    """ik() through the batch machinery (_prepare, the branch candidates, _rank) for one target; candidates: the
    solver of every branch (default _ik_candidates: the closed form, exercise ik.candidates)."""
    P, pitch_a, roll_a, cur, single = _prepare(position, pitch, roll, current, robot)
    if not single:
        raise ValueError("ik takes one position (3,); use ik_batch for (N, 3)")
    c = (candidates or _ik_candidates)(P, pitch_a, roll_a, robot)
    branches = np.flatnonzero(c.valid[0])
    if branches.size == 0:
        raise Unreachable(_explain(c, 0, robot, P[0], pitch_a[0]))
    if branches.size > 1:
        branches = _rank(c, cur)[0, : branches.size]  # ranking puts the valid branches first
    return c.q[0, branches]


@dataclass(frozen=True)
class IKResult:
    """What an IK solver found for one target: q (5,) rad, success, and reason ("" on success, else why not, in
    words). The closed-form ik() returns its solutions and raises Unreachable with the reason instead; IKBatchResult
    holds the same three per target."""

    q: np.ndarray
    success: bool
    reason: str


@dataclass(frozen=True, eq=False)
class IKBatchResult:
    """Best closed-form IK solution per target: q (N, 5) rad (NaN where none), success (N,) bool, branch (N,) index
    into the four branches or -1, and reason (N,) strings ("" where solved, else ik()'s Unreachable message;
    worded on first access, so the batch pays nothing for it)."""

    q: np.ndarray
    success: np.ndarray
    branch: np.ndarray
    _explain: Callable[[int], str] = field(repr=False)

    @functools.cached_property
    def reason(self) -> tuple[str, ...]:
        return tuple("" if ok else self._explain(i) for i, ok in enumerate(self.success.tolist()))

    @property
    def ok(self) -> np.ndarray:
        """Deprecated name of `success`."""
        warnings.warn("IKBatchResult.ok is deprecated: use .success", DeprecationWarning, stacklevel=2)
        return self.success


def ik_batch(positions, pitch, roll=0.0, current=None, robot: RobotModel | None = None) -> IKBatchResult:
    """Best closed-form IK solution for each of N targets (N, 3) mm, vectorised; pitch and roll scalar or (N,)."""
    robot = robot or rx200()
    P, pitch_a, roll_a, cur, _ = _prepare(positions, pitch, roll, current, robot)
    c = _ik_candidates(P, pitch_a, roll_a, robot)
    best = _rank(c, cur)[:, 0]
    rows = np.arange(P.shape[0])
    ok = c.valid[rows, best]
    q = np.where(ok[:, None], c.q[rows, best], np.nan)
    return IKBatchResult(q, ok, np.where(ok, best, -1), lambda i: _explain(c, i, robot, P[i], pitch_a[i]))


def steepest_pitch(position, roll: float = 0.0, max_pitch: float = np.pi / 2, min_pitch: float = 0.0,
                   step: float = np.radians(0.5), tol: float = 1e-7, robot: RobotModel | None = None) -> float:
    """The largest pitch in [min_pitch, max_pitch] (rad) at which `position` (world mm) is reachable.

    Top-down grasps (pi/2) fail at long reach; this finds the steepest approach that still works, by a scan
    in `step` rad followed by bisection of the boundary to `tol` rad. Raises Unreachable when no pitch works.
    """
    robot = robot or rx200()
    P = _check_position(position)
    if P.ndim != 1:
        raise ValueError("steepest_pitch takes one position (3,)")
    roll, min_pitch, max_pitch = (finite_float(v, n, what="rad") for v, n in
                                  ((roll, "roll"), (min_pitch, "min_pitch"), (max_pitch, "max_pitch")))
    if not min_pitch <= max_pitch:
        raise ValueError(f"min_pitch ({min_pitch} rad) must not exceed max_pitch ({max_pitch} rad)")
    step = finite_float(step, "step", positive=True, maximum=np.pi, what="rad")
    tol = finite_float(tol, "tol", positive=True, what="rad")
    grid = np.linspace(max_pitch, min_pitch, max(2, int(np.ceil((max_pitch - min_pitch) / step)) + 1))
    ok = ik_batch(np.repeat(P[None], grid.size, 0), grid, roll, robot=robot).success
    if not ok.any():
        raise Unreachable(f"no pitch between {np.degrees(min_pitch):.1f} and {np.degrees(max_pitch):.1f} deg "
                          f"reaches ({P[0]:.1f}, {P[1]:.1f}, {P[2]:.1f}) mm: "
                          + str(_explain(_ik_candidates(P[None], np.array([min_pitch]), np.array([roll]), robot),
                                         0, robot, P, min_pitch)).split(": ", 1)[1])
    k = int(np.argmax(ok))
    if k == 0:
        return float(grid[0])
    good, bad = grid[k], grid[k - 1]
    while bad - good > tol:
        mid = 0.5 * (good + bad)
        if ik_batch(P[None], mid, roll, robot=robot).success[0]:
            good = mid
        else:
            bad = mid
    return float(good)
