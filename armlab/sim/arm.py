"""The simulated RX200 arm: the manufacturer's time-based motion in simulated time, the driver's refusals, board
collisions, collisions of a held block with the other objects, gravity sag, backlash, encoder noise, torque-off
teaching, the gripper and an emergency stop.

The motion contract is the real arm's (armlab.station.contract.Arm): every change of the arm's state runs under the
world's lock (World.lock), and a move re-checks the stop under it just before it starts, so a stop from another
thread always wins; a blocking move ended by a stop raises EmergencyStopped; a move asked for during a non-blocking
one waits for it; Ctrl+C while the arm waits for a move (or for the gripper) holds it where it is, then the
KeyboardInterrupt propagates; after close() every command raises StationClosed.

Units: rad, s, mm; world (board) frame. Three joint vectors are kept apart:
- the motor positions (what the servos are commanded to and hold),
- `q_true`: the physical joint angles = motors + homing offsets + backlash + gravity deflection (what the camera
  sees and what grasps and collisions use),
- `joint_positions()`: what the encoders report (motor positions, quantised, with read noise).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, fields, replace

import numpy as np

from armlab import kinematics, motion_safety
from armlab.blocks import ObjectState, footprint
from armlab.gripper_geometry import GRIPPER
from armlab.profile import trapezoid_fraction
from armlab.robot import RobotModel, rx200
from armlab.sim.gripper import GripperGeometry, close_on, push_with_pads
from armlab.sim.physics.arm_bodies import arm_parts
from armlab.sim.physics.grasp import DEFAULT_PRESSURE
from armlab.sim.physics.gripper_servo import duty
from armlab.sim.physics.materials import WOOD
from armlab.sim.physics.rest import object_rotation, tilt_angle
from armlab.sim.world import World, describe_object
from armlab.station.contract import EmergencyStopped, MotionRefused, StationClosed
from armlab.station.parking import park_and_close
from armlab.transforms import homogeneous, invert_transform, rot_z, rpy_from_matrix

__all__ = ["ArmRealism", "SimArm", "gravity_deflection"]

GRAVITY = 9.81                 # m/s^2
HELD_CONTACT_TOL_MM = motion_safety.HELD_CONTACT_TOL_MM     # the held-block rule's allowance (motion_safety)


@dataclass(frozen=True)
class ArmRealism:
    """How far the simulated arm departs from its ideal model. `ArmRealism.preset("realistic" | "ideal")`.

    Gravity sag: each of shoulder and elbow bends by compliance x the gravity moment of everything beyond it
    (link masses at their midpoints, the wrist and gripper between the wrist joint and the tool point, a held block
    at the tool point), in the direction that lowers the arm. The defaults give about 4 mm at 250 mm reach and
    10-12 mm near 400 mm reach, the 5-15 mm students measure at long reach on real RX200s.

    Attributes:
        shoulder_compliance_rad_per_nm, elbow_compliance_rad_per_nm: joint deflection per N m of gravity moment.
        upper_arm_kg, forearm_kg, gripper_kg: link masses (kg).
        block_density_kg_m3: density of the wooden blocks (for a held block's weight).
        backlash_rad: gear play per joint: the link stays put until the motor has taken up the play, then trails it by
            half the play (a play operator: the link moves continuously with the motor, never jumps).
        joint_offset_std_rad: std of the per-joint homing offsets (drawn once per arm from its seed).
        encoder_noise_rad: std of the read noise on joint_positions() (seeded).
        encoder_ticks: encoder counts per turn (readings are quantised; 0 = not quantised).
    """

    shoulder_compliance_rad_per_nm: float = 0.012
    elbow_compliance_rad_per_nm: float = 0.009
    upper_arm_kg: float = 0.30
    forearm_kg: float = 0.20
    gripper_kg: float = 0.25
    block_density_kg_m3: float = WOOD.density_kg_m3     # the physics world's wood (armlab.sim.physics)
    backlash_rad: float = 0.003
    joint_offset_std_rad: float = 0.002
    encoder_noise_rad: float = 0.0005
    encoder_ticks: int = 4096

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"ArmRealism.{f.name} must be a finite number >= 0, got {value}")

    @classmethod
    def preset(cls, name: str) -> ArmRealism:
        """"realistic" (the defaults) or "ideal" (no sag, backlash, offsets or noise; unquantised encoders)."""
        if name == "realistic":
            return cls()
        if name == "ideal":
            return replace(cls(), shoulder_compliance_rad_per_nm=0.0, elbow_compliance_rad_per_nm=0.0,
                           backlash_rad=0.0, joint_offset_std_rad=0.0, encoder_noise_rad=0.0, encoder_ticks=0)
        raise ValueError(f"unknown arm realism preset {name!r}: expected 'realistic' or 'ideal'")


def gravity_deflection(q, realism: ArmRealism, payload_kg: float = 0.0, robot: RobotModel | None = None):
    """Joint deflections (..., 5) rad that gravity adds to the joint angles q (..., 5) rad (shoulder, elbow).

    Moment about a joint = g * sum(mass * horizontal distance beyond the joint along the arm's heading); a positive
    moment (mass in front of the joint) tips the arm forward and down, which is positive shoulder and elbow.
    """
    q = np.asarray(q, dtype=float)
    P = kinematics.joint_positions(q, robot)                   # (..., 7, 3)
    heading = q[..., 0] + np.pi / 2                            # the arm points along +y at waist = 0
    h = np.stack([np.cos(heading), np.sin(heading)], axis=-1)
    r = np.einsum("...kj,...j->...k", P[..., :2], h) / 1000.0  # (..., 7) horizontal reach in m
    # one arm pose (the simulator's step): the rest in Python floats, the same IEEE operations as on numpy scalars
    r = r.tolist() if q.ndim == 1 else [r[..., k] for k in range(r.shape[-1])]
    upper, fore, grip = (r[2] + r[3]) / 2, (r[3] + r[4]) / 2, (r[4] + r[6]) / 2
    m_up, m_fore, m_grip = realism.upper_arm_kg, realism.forearm_kg, realism.gripper_kg

    def moment(pivot, parts):
        return GRAVITY * sum(m * (x - pivot) for m, x in parts)

    beyond_elbow = [(m_fore, fore), (m_grip, grip), (payload_kg, r[6])]
    out = np.zeros(q.shape)
    out[..., 1] = realism.shoulder_compliance_rad_per_nm * moment(r[2], [(m_up, upper), *beyond_elbow])
    out[..., 2] = realism.elbow_compliance_rad_per_nm * moment(r[3], beyond_elbow)
    return out


def _xyz(p) -> str:
    return f"({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f})"


def _prism(o: ObjectState) -> motion_safety.Prism:
    """An object as the held-block rule's upright prism (its footprint, its edge high, where it stands now)."""
    return motion_safety.Prism(tuple(footprint(o.shape, o.edge)), o.edge / 2, homogeneous(rot_z(o.yaw), o.position),
                               describe_object(o))


@dataclass
class _Motion:
    t0: float
    q0: np.ndarray
    q1: np.ndarray
    moving_time: float
    accel_time: float


class SimArm:
    """A simulated RX200 with gripper in a World (same interface as the real arm, armlab.station.Arm).

    Args:
        world: the block world (its clock drives the motion).
        realism: "realistic", "ideal" or an ArmRealism.
        gripper: finger pad geometry (default armlab.gripper_geometry.GRIPPER).
        seed: seeds the homing offsets and the encoder noise.
        real_time: blocking moves take wall-clock time too (else they return at once, in simulated time).
        gripper_time_s: simulated time an open or close takes (the manufacturer's default delay is 1 s).
        gripper_pressure: the grasp's effort, 0..1 (the manufacturer's set_pressure, default 0.5): how hard the pads
            squeeze (armlab.sim.physics.gripper_servo).
    """

    def __init__(self, world: World, realism: str | ArmRealism = "realistic", gripper: GripperGeometry | None = None,
                 seed: int = 0, real_time: bool = False, robot: RobotModel | None = None,
                 gripper_time_s: float = 1.0, gripper_pressure: float = DEFAULT_PRESSURE):
        self.robot = robot or rx200()
        duty(gripper_pressure)                              # refuses a pressure outside 0..1, naming it
        self.gripper_pressure = float(gripper_pressure)
        self.world = world
        self.realism = ArmRealism.preset(realism) if isinstance(realism, str) else realism
        if not isinstance(self.realism, ArmRealism):
            raise TypeError(f"realism must be 'realistic', 'ideal' or an ArmRealism, got {realism!r}")
        self.gripper_geometry = gripper or GRIPPER
        self.real_time = bool(real_time)
        self.gripper_time_s = float(gripper_time_s)
        self.seed = int(seed)
        offsets_rng, self._noise_rng = (np.random.default_rng(s) for s in np.random.SeedSequence(seed).spawn(2))
        self._offsets = offsets_rng.normal(0.0, self.realism.joint_offset_std_rad, 5)
        self._motor = self.robot.sleep.astype(float)       # the lab's arm starts asleep
        self._link = self._motor.copy()                     # where the gears hold the links (backlash state)
        self._motion: _Motion | None = None
        self._torque = True
        self._estopped = False
        self.closed = False
        self._held: list[tuple[object, np.ndarray]] = []    # (object, its pose in the tool frame)
        self._told: tuple[motion_safety.HeldBlock, ...] = ()  # what the task layer says it holds (set_held_blocks)
        self.gripper_opening_mm = self.gripper_geometry.max_opening_mm
        self.last_release: dict[int, float] = {}    # open_gripper: each released object's id -> its tilt (rad) then
        self._pose_memo: tuple | None = None    # (key, realism, robot, q_true, tool pose): _pose
        self._q_true = self._physical(self._motor)
        world.add_listener(self._on_time)
        world.arm = self._bodies

    # -- physical model -------------------------------------------------------------------------------------
    def _payload_kg(self) -> float:
        return sum(self.realism.block_density_kg_m3 * (o.edge / 1000.0) ** 3 for o, _ in self._held)

    def _geared(self, motor) -> np.ndarray:
        """Link angles (..., 5) rad behind the gears for motor positions (..., 5) reached from the present link state
        along a path on which each joint moves one way (a straight joint move): the play operator
        clip(link, motor - b/2, motor + b/2). Continuous in the motor positions, so a motion of 1e-12 rad moves the
        link by at most that much (no jump of the whole play when a joint barely moves, or not at all)."""
        half = 0.5 * self.realism.backlash_rad
        motor = np.asarray(motor, dtype=float)
        return np.clip(self._link, motor - half, motor + half)

    def _physical(self, motor) -> np.ndarray:
        """Physical joint angles (..., 5) for motor positions (..., 5) reached from the present state by a straight
        joint move, under the current load and torque state."""
        motor = np.asarray(motor, dtype=float)
        if not self._torque:                        # held by hand: no servo, no gear load
            return motor + self._offsets
        q = self._geared(motor) + self._offsets
        return q + gravity_deflection(q, self.realism, self._payload_kg(), self.robot)

    @property
    def q_true(self) -> np.ndarray:
        """The physical joint angles (5,) rad (ground truth: what the camera sees and the world feels)."""
        self.world.sync()
        return self._q_true.copy()

    def empty_board_twin(self) -> SimArm:
        """The same arm (realism, seed: the same homing offsets, sag and backlash; gripper, robot) asleep over an empty
        board of its own, for measurements a lab makes before the blocks are set out (e.g. the sag fit of
        tasks.calibrate_sag): moving it touches nothing of this arm's world and takes none of its time."""
        return SimArm(World(), self.realism, self.gripper_geometry, self.seed, robot=self.robot,
                      gripper_time_s=self.gripper_time_s, gripper_pressure=self.gripper_pressure)

    def _bodies(self, hand: bool) -> list:
        """The arm's bodies where it stands now, for the world's physics (armlab.sim.physics.arm_bodies)."""
        return arm_parts(self._q_true, self.robot, self.gripper_geometry, self.gripper_opening_mm, hand)

    def tool_pose_true(self) -> np.ndarray:
        """The physical tool pose (4, 4) in the world (ground truth, mm)."""
        return kinematics.fk_pox(self.q_true, self.robot, check_limits=False)

    @property
    def holding(self) -> list:
        """The objects held between the pads (the grasped block and anything stacked on it)."""
        return [o for o, _ in self._held]

    def _on_time(self, t: float) -> None:
        if self._estopped:              # marked by a stop still waiting for the lock: halt at this step already
            self._motion = None
        m = self._motion
        if m is not None:
            s = trapezoid_fraction(t - m.t0, m.moving_time, m.accel_time)
            self._motor = m.q0 + s * (m.q1 - m.q0)
            if t - m.t0 >= m.moving_time - 1e-12:
                self._motor, self._motion = m.q1.copy(), None
        self._refresh()

    def _refresh(self) -> None:
        """Recompute the physical pose, carry held objects, and let the pads push what they run into."""
        self._link = self._geared(self._motor) if self._torque else self._motor.copy()
        self._q_true, T = self._pose()
        for obj, T_rel in self._held:
            T_obj = T @ T_rel
            obj.position = T_obj[:3, 3].copy()
            roll, pitch, yaw = rpy_from_matrix(T_obj[:3, :3])
            obj.yaw, obj.tilt = float(yaw), np.array([roll, pitch])
        push_with_pads(self.world, T, self.gripper_geometry, self.gripper_opening_mm)

    def _pose(self) -> tuple[np.ndarray, np.ndarray]:
        """The physical joint angles (5,) rad and the physical tool pose (4, 4) mm for the present motor positions,
        link state, torque and load. What they depend on is the key of a one-entry memo: the clock's steps while
        the arm stands (a gripper's second, a look) would compute the very same numbers again. The arrays are the
        memo's own, read-only (a write raises ValueError)."""
        key = (self._motor.tobytes(), self._link.tobytes(), self._torque, self._payload_kg())
        memo = self._pose_memo
        if memo is None or memo[0] != key or memo[1] is not self.realism or memo[2] is not self.robot:
            q = self._physical(self._motor)
            T = kinematics.fk_pox(q, self.robot, check_limits=False)
            q.setflags(write=False)                    # the memo's own: a write into them raises
            T.setflags(write=False)
            memo = self._pose_memo = (key, self.realism, self.robot, q, T)
        return memo[3], memo[4]

    # -- readings -------------------------------------------------------------------------------------------
    def joint_positions(self) -> np.ndarray:
        """What the encoders report (5,) rad: the motor positions, quantised, with read noise."""
        self.world.sync()
        r = self.realism
        q = self._motor + self._noise_rng.normal(0.0, r.encoder_noise_rad, 5) if r.encoder_noise_rad else \
            self._motor.copy()
        if r.encoder_ticks:
            step = 2 * np.pi / r.encoder_ticks
            q = np.round(q / step) * step
        return q

    def is_moving(self) -> bool:
        """True while a move is under way (in simulated time)."""
        self.world.sync()
        return self._motion is not None

    @property
    def torque_enabled(self) -> bool:
        """True when the motors hold the arm."""
        return self._torque

    @property
    def emergency_stopped(self) -> bool:
        """True after emergency_stop() until reset()."""
        return self._estopped

    # -- checks ---------------------------------------------------------------------------------------------
    def _check_open(self, what: str) -> None:
        if self.closed:
            raise StationClosed(f"{what} refused: the station is closed; open a new one with make_station('sim')")

    def _check_ready(self, what: str) -> None:
        self._check_open(what)
        if self._estopped:
            raise EmergencyStopped(f"{what} refused: the arm is emergency-stopped; call reset() first")

    @property
    def held_blocks(self) -> tuple[motion_safety.HeldBlock, ...]:
        """What the arm was told it holds (set_held_blocks; the contract's, armlab.station.contract.Arm): () after
        open_gripper(). The objects truly between the pads are `holding`."""
        return self._told

    def set_held_blocks(self, blocks) -> None:
        """Record the blocks the gripper holds, as the task layer believes them (motion_safety.HeldBlock: edge mm, pose
        in the tool frame): every later move checks them against the board too, on the commanded angles as the real
        arm does (_told_collision), besides the true held objects on the physical ones."""
        blocks = tuple(blocks)
        if not all(isinstance(b, motion_safety.HeldBlock) for b in blocks):
            raise TypeError("set_held_blocks takes motion_safety.HeldBlock values (edge mm, T_tool_block (4, 4) mm)")
        self._told = blocks

    def _held_parts(self) -> list[motion_safety.HeldBlock]:
        """The held blocks, for the board check: each a cube at its pose in the tool frame."""
        return [motion_safety.HeldBlock(obj.edge, T_rel, f"held {obj.color} block") for obj, T_rel in self._held]

    def _told_collision(self, q0, q1) -> str | None:
        """Why the straight path q0 -> q1 (motor positions, rad) would take a block the arm was told it holds
        (held_blocks) below the board, or None: checked on the commanded angles with the contact floor, exactly as
        the real arm checks them (it cannot know its sag), so a belief that the sag puts a little low at a grasp is
        not refused here for what the arm's true held objects are checked for."""
        if not self._told:
            return None
        return motion_safety.board_intrusion(q0, q1, motion_safety.SIM_CLEARANCE, self.robot, held=self._told)

    def _board_collision(self, q0, q1, physical) -> str | None:
        """Why the straight joint-space path q0 -> q1 would put a link, a pad or a held block below the board
        (motion_safety.SIM_CLEARANCE on the angles physical(q) the links take), or None."""
        return motion_safety.board_intrusion(q0, q1, motion_safety.SIM_CLEARANCE, self.robot, self.gripper_geometry,
                                             self.gripper_opening_mm, self._held_parts(), physical)

    def _held_collision(self, q0, q1, physical) -> str | None:
        """Why the straight joint-space path q0 -> q1 (motor positions) would drive a held object into another object
        of the world, or None.

        Each held object is its footprint prism (bottom to top face) carried with the tool; each other object is its
        upright footprint prism where it stands (world frame, mm). At every path sample
        (motion_safety.held_path_fractions) their penetration depth is found by the separating axis theorem
        (geometry.convex_penetration), and motion_safety.held_intrusion applies the rule: no deeper than
        HELD_CONTACT_TOL_MM and than at the start of the path (the block a held block rests on when the lift starts,
        pressed a little further in by the weight the arm took on at the grasp). Objects held together (a grasped
        block and what is stacked on it) move as one.
        """
        if not self._held:
            return None
        others = [o for o in self.world.objects if o.id not in self.world.held]
        if not others:
            return None
        dq = np.asarray(q1) - np.asarray(q0)
        s = motion_safety.held_path_fractions(q0, q1)
        T = kinematics.fk_pox(physical(q0 + s[:, None] * dq), self.robot, check_limits=False)     # (n, 4, 4)
        fixed = [(o, _prism(o)) for o in others]
        first = None       # (sample where the depth first exceeds the allowance, held, other, depth (n,), centres)
        for held, T_rel in self._held:
            poses = T @ T_rel                                                                       # (n, 4, 4)
            centres = poses[:, :3, 3]
            for other, prism in fixed:
                depth = motion_safety.held_depths(_prism(held), poses, prism)   # the pre-check's geometry too
                hit = motion_safety.held_intrusion(depth, HELD_CONTACT_TOL_MM)
                if hit is not None and (first is None or hit < first[0]):
                    first = (hit, held, other, depth, centres)
        if first is None:
            return None
        k, held, other, depth, centres = first
        i = int(np.argmax(depth))
        return (f"the held {describe_object(held)} would go {depth[i]:.1f} mm into {describe_object(other)}, with "
                f"its centre at {_xyz(centres[i])} mm, {100 * s[i]:.0f}% of the way along the move (it would hit it at "
                f"{100 * s[k]:.0f}%, centre at {_xyz(centres[k])} mm)")

    # -- motion ---------------------------------------------------------------------------------------------
    def move_to(self, q, moving_time: float | None = None, accel_time: float | None = None,
                blocking: bool = True) -> None:
        """Move to joint positions q (5,) rad in moving_time s (default: the lab's rule, profile.default_moving_time)
        with accel_time s ramps (default ACCEL_FRACTION x moving_time). Raises MotionRefused before anything moves
        when the move breaks armlab.motion_safety's rules (joint limits, time profile, velocity limits, a link, pad
        or held block below the board: the real arm's rules, with the simulator's floors) or would drive a held
        block into another object (deeper than HELD_CONTACT_TOL_MM and than it already is).

        A move asked for while a non-blocking one runs waits for it to end first (as the real arm does). The checks
        and the start run under the world's lock and the stop is re-checked there, so a stop from another thread
        either refuses the move (EmergencyStopped) or halts it; a blocking move that a stop ends raises
        EmergencyStopped."""
        self._check_ready("motion")
        self.wait()
        with self.world.lock:
            self._check_ready("motion")
            if not self._torque:
                raise MotionRefused("motion refused: torque is off (the arm is being moved by hand); "
                                    "call set_torque(True) first")
            self.world.sync()
            start = self._motor.copy()
            T, Ta = motion_safety.check_move(start, q, moving_time, accel_time, self.robot,
                                             motion_safety.SIM_CLEARANCE, self.gripper_geometry,
                                             self.gripper_opening_mm, self._held_parts(), self._physical)
            q = np.asarray(q, dtype=float)
            hit = self._told_collision(start, q)
            if hit:
                raise motion_safety.refusal("collision with the board", hit)
            hit = self._held_collision(start, q, self._physical)
            if hit:
                raise motion_safety.refusal("collision of the held block", hit)
            self._check_ready("motion")           # the stop is marked before its lock: it wins here too
            self._motion = _Motion(self.world.time_s, start, q, T, Ta)
        if blocking:
            self.wait()
            if self._estopped:
                raise EmergencyStopped("the arm was emergency-stopped during the move (it holds where it stopped)")

    def _step_motion(self) -> float | None:
        """One step of the clock towards the end of the current move, under the world's lock: None when no move
        runs, else the wall-clock seconds to sleep before the next step (0 in simulated time)."""
        with self.world.lock:
            self.world.sync()
            m = self._motion
            if m is None:
                return None
            remaining = max(m.t0 + m.moving_time - self.world.time_s, 0.0)
            if self.real_time:
                return min(remaining, self.world.max_step_s)
            self.world.advance(min(remaining, self.world.max_step_s))   # a step at a time: a stop can come between
            return 0.0

    def wait(self) -> None:
        """Let simulated time run until the current move ends (in real-time mode, the wall clock too). Ctrl+C
        (KeyboardInterrupt) while waiting holds the arm where it is (hold()), then propagates."""
        try:
            while (pause := self._step_motion()) is not None:
                if pause:
                    time.sleep(pause)
        except KeyboardInterrupt:
            self.hold()
            raise

    def hold(self) -> None:
        """Stop the current move and hold where the arm is now (not an emergency stop: moves stay allowed)."""
        with self.world.lock:
            self.world.sync()
            self._motion = None

    def home(self, moving_time: float | None = None) -> None:
        """Move to the home pose (all zeros), blocking."""
        self.move_to(self.robot.home, moving_time)

    def sleep(self, moving_time: float | None = None) -> None:
        """Move to the sleep pose (safe to power off), blocking."""
        self.move_to(self.robot.sleep, moving_time)

    def _pass_gripper_time(self) -> None:
        if not self.real_time:
            self.world.advance(self.gripper_time_s)
            return
        try:
            time.sleep(self.gripper_time_s)
        except KeyboardInterrupt:
            self.hold()
            raise
        self.world.sync()

    # -- gripper --------------------------------------------------------------------------------------------
    def open_gripper(self) -> None:
        """Open the pads fully; a held block falls onto whatever is below it and settles by the world's physics
        (it topples off when the centre of mass of what it carries is not over what bears it). `last_release` keeps
        how tilted each released object was when let go (a block carried tilted tips flat on landing, off by up to
        armlab.sim.physics.rest.tipping_shift_mm)."""
        self._check_ready("opening the gripper")
        self.wait()
        with self.world.lock:
            self._check_ready("opening the gripper")
            held = sorted(self.holding, key=lambda o: o.position[2])
            self.last_release = {o.id: tilt_angle(o) for o in held}
            self._held, self._told = [], ()
            self.world.held.difference_update(o.id for o in held)
            self.gripper_opening_mm = self.gripper_geometry.max_opening_mm
            for o in held:
                self.world.settle(o)
            self._refresh()
        self._pass_gripper_time()

    def close_gripper(self) -> bool:
        """Close the pads; True when a block is held (by contact physics: armlab.sim.gripper.close_on; why in
        last_grasp)."""
        self._check_ready("closing the gripper")
        self.wait()
        with self.world.lock:
            self._check_ready("closing the gripper")
            if self._held:
                return True
            T = kinematics.fk_pox(self._q_true, self.robot, check_limits=False)
            outcome = close_on(self.world, T, self.gripper_geometry, self.gripper_opening_mm, self.gripper_pressure)
            self.gripper_opening_mm = outcome.opening_mm
            self.last_grasp = outcome.reason
            T_tool_world = invert_transform(T)
            self._held = [(o, T_tool_world @ homogeneous(object_rotation(o), o.position)) for o in outcome.held]
            self.world.held.update(o.id for o in outcome.held)
            self._refresh()
        self._pass_gripper_time()
        return bool(outcome.held)

    # -- teaching and safety --------------------------------------------------------------------------------
    def set_torque(self, enabled: bool) -> None:
        """Torque on (the motors hold the present position) or off (the arm can be posed by hand, move_by_hand)."""
        self._check_open("setting the torque")
        with self.world.lock:
            self.world.sync()
            self._motion = None
            self._torque = bool(enabled)
            self._refresh()

    def move_by_hand(self, q) -> None:
        """With torque off, pose the arm by hand at physical joint angles q (5,) rad (a student's hand: no sag, no
        backlash); the encoders then read it back. Refused (MotionRefused) with torque on, past a joint's hard stop,
        through the board, or pushing a held block into another object."""
        self._check_open("moving the arm by hand")
        if self._torque:
            raise MotionRefused("the motors hold the arm: call set_torque(False) before moving it by hand")
        q = kinematics.check_joints(q, self.robot, check_limits=False).astype(float)
        limits = self.robot.limit_violations(q)
        if limits:
            raise MotionRefused("the hand cannot push past the hard stops: " + "; ".join(limits))
        hit = self._board_collision(self._q_true, q, lambda Q: Q)
        if hit:
            raise MotionRefused(f"the hand cannot push the arm through the board: {hit}")
        hit = self._held_collision(self._q_true, q, lambda Q: Q)
        if hit:
            raise MotionRefused(f"the hand cannot push the held block through another object: {hit}")
        with self.world.lock:
            self._motor = q - self._offsets
            self._refresh()

    def emergency_stop(self) -> None:
        """Halt at once where the arm is now; every further motion raises EmergencyStopped until reset(). Safe from
        any thread: the stop is marked before the world's lock is taken, so a move being started either sees it
        and starts nothing, or has started and is halted here (module notes)."""
        self._estopped = True
        with self.world.lock:
            self.world.sync()
            self._motion = None

    def reset(self) -> None:
        """Re-initialise after an emergency stop (the arm stays where it stopped, torque on)."""
        self._check_open("reset")
        with self.world.lock:
            self._estopped = False
            self._motion = None
            self._torque = True
            self._refresh()

    def close(self) -> None:
        """Park and end the arm (what closing its station does, armlab.station.parking): to its sleep pose unless
        emergency-stopped (then it holds where it is and a RuntimeWarning says so), torque on first if it was off;
        afterwards every command raises StationClosed. Idempotent. A refused sleep move still closes the arm and
        raises RuntimeError."""
        park_and_close(self, "the simulated arm")
