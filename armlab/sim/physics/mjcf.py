"""The MJCF (MuJoCo's XML model format) of the objects on the board, built from the lab's and the catalogue's values.

Frames and units: MuJoCo works in SI, so the model is in metres, kg and s; the world frame is the kit's board frame
(origin on the board below the waist axis, +z up). The board's top is the plane z = 0 (the table around it is flat
too, so an object pushed past the board's edge stays on the plane and the world's validation names it).

Bodies:
    the objects: one free body each ("object<k>", k the object's place in the list), a box for a cube and, for a
        distractor, one convex prism mesh per convex piece of its footprint (armlab.blocks.footprint), the wood's
        density giving the mass and inertia;
    "pusher": a kinematic (mocap) plate, 20 mm wide, 10 mm high and 4 mm thick, that a push (engine.Physics.push)
        drives against an object's side; parked below the board otherwise. Mocap bodies move exactly as commanded
        and are not moved by contacts: what pushes is driven, as a servo-held pad is.
    "hand" (with a Hand): the gripper, a weightless free body welded to a kinematic target "hand_target" that
        follows the simulated arm's tool pose (its frame is the tool frame: x the approach, y the closing direction),
        carrying the two finger pads "pad0" (+y) and "pad1" (-y) on slide joints along y, coupled to move together
        as the one horn drives them, each pushed closed by a motor ("squeeze0", "squeeze1": the servo's force, N)
        against a damper (the servo's back-EMF). A mocap body itself has no velocity in MuJoCo's contact solver,
        so it pushes by penetration but drags nothing by friction (measured: a block squeezed with 627 N did not
        rise 1 um when mocap pads rose 10 mm); a welded body moves with a velocity and does.
    "arm<k>" (with arm shapes): the simulated arm's bodies (arm_bodies: link capsules, the gripper bar, the fingers),
        kinematic (mocap) bodies the engine poses where the arm stands, parked below the board otherwise.

The model depends only on the objects' shapes and sizes, not their poses (engine caches compiled models by them).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from armlab.blocks import footprint
from armlab.sim.physics.materials import CONTACT, WOOD, ContactSettings, Wood

__all__ = ["scene_mjcf", "Hand", "PUSHER_HALF_M", "PARK_Z_M", "PAD_FRICTION"]

PUSHER_HALF_M = (0.002, 0.010, 0.005)   # the pusher plate's half extents (thickness, width, height), m
PARK_Z_M = -1.0                         # where the pusher waits (below the board, touching nothing), m
PAD_FRICTION = 0.8                      # the finger pads' rubber on wood (MuJoCo takes the larger of two geoms')
PAD_MASS_KG = 0.02                      # each finger pad body (weightless: gravity compensated)
HAND_MASS_KG = 0.1                      # the hand body carrying the pads (weightless: gravity compensated)
HAND_WELD_SOLREF = (0.004, 1.0)         # how stiffly the hand follows its kinematic target (time constant s, damping)


@dataclass(frozen=True)
class Hand:
    """The gripper in the model: pad_half_mm the finger pads' half extents along the tool's x, y, z (mm);
    min_gap_mm, max_gap_mm the gap between the pads fully closed and fully open (mm); damping_n_s_m the damper on
    each pad's slide (N s/m) and armature_kg the servo's rotor inertia as a mass on it (kg: both
    armlab.sim.physics.gripper_servo)."""

    pad_half_mm: tuple[float, float, float]
    min_gap_mm: float
    max_gap_mm: float
    damping_n_s_m: float
    armature_kg: float


def _fmt(values) -> str:
    return " ".join(f"{v:.9g}" for v in values)


def _object_body(k: int, shape: str, edge_mm: float, wood: Wood) -> tuple[str, list[str]]:
    """The body of object k (XML) and the meshes it needs (XML assets)."""
    h = edge_mm / 2000.0
    geoms, meshes = [], []
    if shape == "cube":
        geoms.append(f'<geom type="box" size="{_fmt((h, h, h))}"/>')
    else:
        for j, poly in enumerate(footprint(shape, edge_mm)):
            xy = poly / 1000.0
            vertices = [(x, y, z) for z in (-h, h) for x, y in xy]
            name = f"object{k}_{j}"
            meshes.append(f'<mesh name="{name}" vertex="{_fmt(v for p in vertices for v in p)}"/>')
            geoms.append(f'<geom type="mesh" mesh="{name}"/>')
    body = (f'<body name="object{k}"><freejoint/>' + "".join(geoms) + "</body>")
    return body, meshes


def _hand(hand: Hand, wood: Wood) -> tuple[str, str, str]:
    """The hand's kinematic target, the hand with its pads, and the hand's weld and the pads' coupling (XML)."""
    half = _fmt(h / 1000.0 for h in hand.pad_half_mm)
    open_y = (hand.max_gap_mm / 2 + hand.pad_half_mm[1]) / 1000.0
    travel = (hand.max_gap_mm - hand.min_gap_mm) / 2000.0
    target = f'<body name="hand_target" mocap="true" pos="0 0 {PARK_Z_M}"/>'
    pads = "".join(
        f'<body name="pad{k}" pos="0 {sign * open_y:.9g} 0" gravcomp="1">'
        f'<joint name="slide{k}" type="slide" axis="0 {-sign} 0" range="0 {travel:.9g}" '
        f'damping="{hand.damping_n_s_m:.9g}" armature="{hand.armature_kg:.9g}"/>'
        f'<geom type="box" size="{half}" mass="{PAD_MASS_KG:.9g}" '
        f'friction="{_fmt((PAD_FRICTION, wood.torsional_m, 0.0))}"/></body>'
        for k, sign in ((0, 1), (1, -1)))
    body = (f'<body name="hand" pos="0 0 {PARK_Z_M}" gravcomp="1"><freejoint/>'
            f'<inertial pos="0 0 0" mass="{HAND_MASS_KG:.9g}" diaginertia="1e-4 1e-4 1e-4"/>{pads}</body>')
    constraints = (f'<equality><weld body1="hand" body2="hand_target" solref="{_fmt(HAND_WELD_SOLREF)}"/>'
                   '<joint joint1="slide1" joint2="slide0"/></equality>'
                   '<actuator><motor name="squeeze0" joint="slide0"/><motor name="squeeze1" joint="slide1"/>'
                   '</actuator>')
    return target, body, constraints


def _arm(arm: Sequence[tuple[str, tuple[float, ...]]]) -> str:
    """The arm's kinematic bodies (XML): one per (kind, size mm) of arm_bodies.ArmPart."""
    out = []
    for k, (kind, size) in enumerate(arm):
        size_m = _fmt(v / 1000.0 for v in size)
        out.append(f'<body name="arm{k}" mocap="true" pos="0 0 {PARK_Z_M}"><geom type="{kind}" size="{size_m}"/>'
                   '</body>')
    return "".join(out)


def scene_mjcf(shapes: Sequence[tuple[str, float]], settings: ContactSettings = CONTACT, wood: Wood = WOOD,
               hand: Hand | None = None, arm: Sequence[tuple[str, tuple[float, ...]]] = ()) -> str:
    """The MJCF text of a board with one free body per (shape, edge mm) in `shapes`, and the pusher; with a Hand also
    the gripper, with `arm` ((kind, size mm) each) the arm's bodies (module notes), parked below the board like the
    pusher. The hand comes after the objects, so the
    objects' joints stay first in qpos (then the hand's free joint and the two slides)."""
    s = settings
    bodies, assets = [], []
    for k, (shape, edge) in enumerate(shapes):
        body, meshes = _object_body(k, shape, float(edge), wood)
        bodies.append(body)
        assets.extend(meshes)
    px, py, pz = PUSHER_HALF_M
    target, gripper, constraints = ("", "", "") if hand is None else _hand(hand, wood)
    return f"""<mujoco model="armlab board">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{s.timestep_s:.9g}" cone="{s.cone}" impratio="{s.impratio:.9g}" iterations="{s.iterations}"
          noslip_iterations="{s.noslip_iterations}" integrator="implicitfast" gravity="0 0 -9.81"/>
  <default>
    <geom density="{wood.density_kg_m3:.9g}" friction="{_fmt((wood.sliding, wood.torsional_m, wood.rolling_m))}"
          condim="{s.condim}" solref="{_fmt(s.solref)}" solimp="{_fmt(s.solimp)}" margin="0"/>
  </default>
  <asset>{"".join(assets)}</asset>
  <worldbody>
    <geom name="board" type="plane" size="0 0 0.01"/>
    <body name="pusher" mocap="true" pos="0 0 {PARK_Z_M}">
      <geom type="box" size="{_fmt((px, py, pz))}"/>
    </body>
    {target}
    {_arm(arm)}
    {"".join(bodies)}
    {gripper}
  </worldbody>
  {constraints}
</mujoco>
"""
