"""The simulated world's physics: MuJoCo rigid-body contact dynamics for the objects on the board.

Modules, one job each:
    materials: the wood's density and friction and the contact settings (solver, cone, solref), with their sources.
    mjcf: the MJCF model text of a set of objects (board, free bodies, a kinematic pusher), in metres and kg.
    engine: a compiled model with its state: load the objects' poses, step to rest, read the poses back.
    rest: the pose of a body at rest as the kit's ObjectState (world mm, yaw; flat faces snapped flat).
    gripper_servo: the gripper's servo: the pads' squeeze (N) at the manufacturer's grasp pressure, its damping.
    grasp: the finger pads as bodies squeezing and lifting a block (friction holds it or not): SimArm's grasp.
    arm_bodies: the arm's links, gripper bar and fingers as kinematic bodies where the simulated arm stands.

The world (armlab.sim.world.World) keeps the objects as ObjectState and calls the engine whenever something moves
them (a release, a push, a scene's dropped blocks); the objects' poses feed the kit's own renderer as before.

A grasp runs here (World.grip); a block once held is carried kinematically in the pads, at the pose the grasp's
physics left it in, until it is released. Where a pad runs into an object while the arm moves, the push it gives
runs here too (World.shove). Every run has the arm's bodies standing where the arm is (arm_bodies). Not modelled:
contact while the arm moves, except its pads' pushes (a link that sweeps through a block passes through it; the
planners keep the tool and a held block above the objects, armlab.motion_safety checks the links against the board
only), and so contact during the carry (a held block cannot slip once lifted).
"""

import os

# MuJoCo renders nothing here (the camera keeps the kit's own renderer): without a GL backend, importing mujoco loads
# no windowing library (its default, glfw, probes its version in a subprocess whose output it evals, which fails in
# some hosts, e.g. the API reference's build). A user's own MUJOCO_GL wins.
os.environ.setdefault("MUJOCO_GL", "disable")

from armlab.sim.physics.engine import Physics, PhysicsError  # noqa: E402
from armlab.sim.physics.materials import CONTACT, WOOD, ContactSettings, Wood  # noqa: E402

__all__ = ["Physics", "PhysicsError", "CONTACT", "WOOD", "ContactSettings", "Wood"]
