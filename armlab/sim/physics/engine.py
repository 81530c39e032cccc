"""A compiled MuJoCo model of the objects on the board, with its state: load the objects' poses, push one, step until
everything rests, read the poses back.

Units: the kit's world mm and rad at this module's interface, SI (m, kg, s) inside MuJoCo. Deterministic: MuJoCo's
step is a pure function of the model and the state (one thread, no randomness), so the same objects give the same
result; the compiled model is cached by the objects' shapes and sizes (mjcf.scene_mjcf does not depend on poses).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from functools import lru_cache

import mujoco
import numpy as np

from armlab.blocks import ObjectState
from armlab.sim.physics.arm_bodies import ArmPart
from armlab.sim.physics.materials import CONTACT, WOOD, ContactSettings, Wood
from armlab.sim.physics.mjcf import PARK_Z_M, PUSHER_HALF_M, Hand, scene_mjcf
from armlab.sim.physics.rest import object_rotation
from armlab.transforms import matrix_from_rpy

__all__ = ["Physics", "PhysicsError", "REST_SPEED_MM_S", "REST_SPIN_RAD_S", "MAX_SETTLE_S", "SWAY_S", "SWAY_DAMPING"]

REST_SPEED_MM_S = 2.0        # every body slower than this (and REST_SPIN_RAD_S) for REST_HOLD_S counts as at rest
REST_SPIN_RAD_S = 0.02
REST_HOLD_S = 0.05
SWAY_S = 2.0                 # run_to_rest: still moving after this much physics time, the objects' motion is damped
SWAY_DAMPING = (0.02, 0.02, 0.02, 2e-5, 2e-5, 2e-5)    # per free joint: N s/m (x, y, z), N m s/rad (3 turns)
MAX_SETTLE_S = 15.0          # run_to_rest gives up after this much physics time: a tower of eight rocked on its base
                             # for 5.2 s after a block landed hard on it (to the sky, seed 2), then rested
PUSH_SPEED_MM_S = 100.0      # how fast the pusher plate advances (a pad's pace)
_PUSH_GAP_MM = 0.2           # the pusher starts this far behind the object's face


class PhysicsError(RuntimeError):
    """The physics did not come to rest, or was given a state it cannot simulate (names the problem)."""


@lru_cache(maxsize=64)
def _model(shapes: tuple[tuple[str, float], ...], settings: ContactSettings, wood: Wood,
           hand: Hand | None = None, arm: tuple[tuple[str, tuple[float, ...]], ...] = ()) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_string(scene_mjcf(shapes, settings, wood, hand, arm))


_DIGITS = 6                  # what enters MuJoCo is rounded to 1e-6 (m: 1 um; quaternion units): see _metres


def _metres(p_mm) -> np.ndarray:
    """World mm (3,) as MuJoCo's metres, rounded to 1 um. The poses come from numpy's kinematics and the kit's
    iterative solvers (IK, the sag fit), whose results differ between CPUs' SIMD kernels (tools/nbval-numerics) by up
    to about 1e-8 mm at a release, and a tilted block's landing or a tall tower's fall is chaotic: unrounded (and
    rounded to 1 nm), to the sky (seed 0) built 12 levels natively and 10 without AVX-512. MuJoCo's own arithmetic
    does not depend on those settings, so inputs rounded far coarser than those differences give the same physics
    (unless a value lies within about 1e-8 mm of a rounding boundary: about 1 in 10^5 values)."""
    return np.round(np.asarray(p_mm, dtype=float) / 1000.0, _DIGITS)


def _unit(q: np.ndarray) -> np.ndarray:
    """q (4,) over its norm, computed with correctly rounded scalar math (the same on every CPU)."""
    norm = math.sqrt(math.fsum(float(v) * float(v) for v in q))
    return np.array([float(v) / norm for v in q])


def _quat(R: np.ndarray) -> np.ndarray:
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(R, dtype=float).ravel())
    return q


def _rounded_quat(R: np.ndarray) -> np.ndarray:
    """The rotation R (3, 3) as MuJoCo's unit quaternion, rounded as every input is (_DIGITS, then normalised with
    correctly rounded scalar math: _unit)."""
    return _unit(np.round(_quat(R), _DIGITS))


class Physics:
    """The objects (ObjectState, world mm) as free MuJoCo bodies on the board, loaded at their present poses at rest.

    Attributes:
        objects: the objects simulated, in body order; model, data: MuJoCo's compiled model and state;
        time_s: physics time simulated so far (s).
    """

    def __init__(self, objects: Sequence[ObjectState], settings: ContactSettings = CONTACT, wood: Wood = WOOD,
                 hand: Hand | None = None, arm: Sequence[ArmPart] = ()):
        self.objects = list(objects)
        shapes = tuple((o.shape, float(o.edge)) for o in self.objects)
        arm = list(arm)
        self.model = _model(shapes, settings, wood, hand, tuple((p.kind, tuple(round(v, 3) for v in p.size_mm))
                                                                 for p in arm))
        self.hand = hand
        self._hand_mocap = int(self.model.body("hand_target").mocapid[0]) if hand is not None else -1
        self.data = mujoco.MjData(self.model)
        self._body0 = self.model.body("object0").id if self.objects else 0
        for k, o in enumerate(self.objects):
            self.data.qpos[7 * k:7 * k + 3] = _metres(o.position)
            self.data.qpos[7 * k + 3:7 * k + 7] = _rounded_quat(object_rotation(o))
        self._park()
        self.arm_left_out = self._place_arm(arm)
        self.time_s = 0.0

    def _park(self) -> None:
        for m in range(self.model.nmocap):
            self.data.mocap_pos[m] = (0.0, 0.0, PARK_Z_M)
            self.data.mocap_quat[m] = (1.0, 0.0, 0.0, 0.0)

    def _place_arm(self, arm: list[ArmPart]) -> list[str]:
        """Pose the arm's bodies (rounded as every input is); a part that overlaps an object stays parked. Returns
        the names of the parts left out."""
        ids = []
        for k, part in enumerate(arm):
            m = int(self.model.body(f"arm{k}").mocapid[0])
            self.data.mocap_pos[m] = _metres(part.pose[:3, 3])
            self.data.mocap_quat[m] = _rounded_quat(part.pose[:3, :3])
            ids.append((m, self.model.body(f"arm{k}").id))
        mujoco.mj_forward(self.model, self.data)
        objects = set(range(self._body0, self._body0 + len(self.objects)))
        touching = set()
        for c in self.data.contact[:self.data.ncon]:
            bodies = {int(self.model.geom_bodyid[c.geom1]), int(self.model.geom_bodyid[c.geom2])}
            if c.dist < 0 and bodies & objects:
                touching |= bodies
        left_out = []
        for (m, body), part in zip(ids, arm, strict=True):
            if body in touching:
                self.data.mocap_pos[m] = (0.0, 0.0, PARK_Z_M)
                left_out.append(part.name)
        if left_out:
            mujoco.mj_forward(self.model, self.data)
        return left_out

    # -- the gripper (a model built with a Hand) --------------------------------------------------------------
    def set_hand(self, T_tool_mm, teleport: bool = False) -> None:
        """Move the hand's kinematic target to the tool pose T_tool_mm (4, 4) world mm (rounded as every input is:
        _metres); the hand follows it by its weld, and with teleport is put there at once, at rest."""
        T = np.asarray(T_tool_mm, dtype=float)
        m = self._hand_mocap
        self.data.mocap_pos[m] = _metres(T[:3, 3])
        self.data.mocap_quat[m] = _rounded_quat(T[:3, :3])
        if teleport:
            n = 7 * len(self.objects)
            self.data.qpos[n:n + 3] = self.data.mocap_pos[m]
            self.data.qpos[n + 3:n + 7] = self.data.mocap_quat[m]
            self.data.qvel[6 * len(self.objects):] = 0.0
            mujoco.mj_forward(self.model, self.data)

    def set_gap(self, gap_mm: float) -> None:
        """Put the pads gap_mm apart at once, at rest (within the hand's travel)."""
        h = self.hand
        slide = min(max((h.max_gap_mm - float(gap_mm)) / 2000.0, 0.0), (h.max_gap_mm - h.min_gap_mm) / 2000.0)
        n = 7 * len(self.objects) + 7
        self.data.qpos[n:n + 2] = round(slide, _DIGITS)
        self.data.qvel[6 * len(self.objects) + 6:] = 0.0
        mujoco.mj_forward(self.model, self.data)

    def squeeze(self, force_n: float) -> None:
        """Drive each pad closed with force_n (N; 0 lets them go)."""
        self.data.ctrl[:] = float(force_n)

    def gap_mm(self) -> float:
        """The gap between the pads now (mm)."""
        return self.hand.max_gap_mm - 2000.0 * float(self.data.qpos[7 * len(self.objects) + 7])

    def gap_speed_mm_s(self) -> float:
        """How fast the pads close now (mm/s, each)."""
        return 1000.0 * float(self.data.qvel[6 * len(self.objects) + 6])

    # -- stepping -------------------------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """Advance the physics by n steps of the model's timestep."""
        mujoco.mj_step(self.model, self.data, nstep=int(n))
        self.time_s += n * self.model.opt.timestep

    def at_rest(self) -> bool:
        """True when every body moves slower than REST_SPEED_MM_S and turns slower than REST_SPIN_RAD_S."""
        if not self.objects:
            return True
        v = self.data.qvel[:6 * len(self.objects)].reshape(-1, 6)
        return bool(np.all(np.linalg.norm(v[:, :3], axis=1) * 1000.0 < REST_SPEED_MM_S)
                    and np.all(np.linalg.norm(v[:, 3:], axis=1) < REST_SPIN_RAD_S))

    def run_to_rest(self, max_s: float = MAX_SETTLE_S) -> float:
        """Step until every body has rested for REST_HOLD_S; returns the physics time taken (s). PhysicsError when
        something still moves after max_s of physics time (or the state blew up).

        A tall stack can keep swaying on its soft contacts long after a block landed hard on it: to the sky's tower
        of eleven (seed 0) swayed for 16 s of physics before it rested, one of ten with condim 4 for more than 15 s.
        A real wooden tower loses that energy at its contacts within a swing or two; so after SWAY_S of physics with
        something still moving, every object's motion is damped (SWAY_DAMPING: 0.02 N s/m, 2e-5 N m s/rad, a time
        constant of about 1.6 s for a large block's motion and 0.4 s for its turning). That tower then rested 3.0 s
        later (damping 2.5x as strong: 4.4 s), standing as before. The model's damping is restored afterwards (models
        are shared by the cache). Deterministic: the switch happens at the same step."""
        dt = self.model.opt.timestep
        hold = max(1, int(round(REST_HOLD_S / dt)))
        start, still = self.time_s, 0
        damping = self.model.dof_damping.copy()
        n = 6 * len(self.objects)
        try:
            while self.time_s - start < max_s:
                if still == 0 and self.time_s - start >= SWAY_S and not damping[:n].any():
                    self.model.dof_damping[:n] = np.tile(SWAY_DAMPING, len(self.objects))
                self.step()
                if not np.all(np.isfinite(self.data.qpos)):
                    raise PhysicsError("the physics state became non-finite (objects placed inside one another?)")
                still = still + 1 if self.at_rest() else 0
                if still >= hold:
                    return self.time_s - start
        finally:
            self.model.dof_damping[:] = damping
        moving = [o.id for o, v in zip(self.objects, self.data.qvel[:n].reshape(-1, 6), strict=True)
                  if np.linalg.norm(v[:3]) * 1000.0 >= REST_SPEED_MM_S or np.linalg.norm(v[3:]) >= REST_SPIN_RAD_S]
        raise PhysicsError(f"objects {moving} still move after {max_s:.1f} s of physics")

    # -- pushing --------------------------------------------------------------------------------------------
    def push(self, k: int, direction, distance_mm: float, speed_mm_s: float = PUSH_SPEED_MM_S) -> None:
        """Drive the pusher plate (mjcf.PUSHER_HALF_M) against object k's side from behind, low on it, along the
        horizontal `direction` (2,) for distance_mm (the object moves that far if nothing holds it; speed_mm_s is the
        mean speed of a smooth start and stop), then park it."""
        d = np.asarray(direction, dtype=float)[:2]
        d = d / np.linalg.norm(d)
        o = self.objects[k]
        pos, R = self.pose(k)
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * o.edge / 2
        reach = float(np.max(-(corners @ R.T)[:, :2] @ d))          # how far the object extends behind its centre
        bottom = float(np.min((corners @ R.T)[:, 2])) + pos[2]
        half = np.array(PUSHER_HALF_M) * 1000.0
        start = pos[:2] - d * (reach + half[0] + _PUSH_GAP_MM)
        z = bottom + 1.0 + half[2]
        self.data.mocap_quat[0] = _rounded_quat(matrix_from_rpy(np.array([0.0, 0.0, np.arctan2(d[1], d[0])])))
        dt = self.model.opt.timestep
        n = max(1, int(np.ceil((distance_mm + _PUSH_GAP_MM) / (speed_mm_s * dt))))
        for i in range(1, n + 1):
            u = i / n                                                # a smooth start and stop, as a servo moves
            xy = start + d * (distance_mm + _PUSH_GAP_MM) * (3 * u ** 2 - 2 * u ** 3)
            self.data.mocap_pos[0] = _metres([xy[0], xy[1], z])
            self.step()
        back = start + d * (distance_mm - 5.0)                      # step back off the face before parking
        self.data.mocap_pos[0] = _metres([back[0], back[1], z])
        self.step()
        self.data.mocap_pos[0] = (0.0, 0.0, PARK_Z_M)

    # -- reading --------------------------------------------------------------------------------------------
    def pose(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """Object k's centre (3,) world mm and rotation (3, 3)."""
        b = self._body0 + k
        return self.data.xpos[b] * 1000.0, self.data.xmat[b].reshape(3, 3).copy()
