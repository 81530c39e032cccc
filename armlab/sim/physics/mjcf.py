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

The model depends only on the objects' shapes and sizes, not their poses (engine caches compiled models by them).
"""

from __future__ import annotations

from collections.abc import Sequence

from armlab.blocks import footprint
from armlab.sim.physics.materials import CONTACT, WOOD, ContactSettings, Wood

__all__ = ["scene_mjcf", "PUSHER_HALF_M", "PARK_Z_M", "PAD_FRICTION"]

PUSHER_HALF_M = (0.002, 0.010, 0.005)   # the pusher plate's half extents (thickness, width, height), m
PARK_Z_M = -1.0                         # where the pusher waits (below the board, touching nothing), m
PAD_FRICTION = 0.8                      # the finger pads' rubber on wood (MuJoCo takes the larger of two geoms')
PAD_MASS_KG = 0.02                      # each finger pad body (weightless: gravity compensated)
PAD_WELD_SOLREF = (0.004, 1.0)          # how stiffly a pad follows its kinematic target (time constant s, damping)


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


def scene_mjcf(shapes: Sequence[tuple[str, float]], settings: ContactSettings = CONTACT, wood: Wood = WOOD,
               pad_half_mm: tuple[float, float, float] | None = None) -> str:
    """The MJCF text of a board with one free body per (shape, edge mm) in `shapes`, and the pusher; with
    pad_half_mm (the finger pads' half extents along the tool's x, y, z, mm) also the two finger pads, "pad0" and
    "pad1": boxes of PAD_FRICTION, each welded (PAD_WELD_SOLREF) to a kinematic (mocap) target "pad<k>_target" that
    follows the simulated finger, parked below the board like the pusher. A mocap body itself has no velocity in
    MuJoCo's contact solver, so it pushes by penetration but drags nothing by friction (measured: a block squeezed
    with 627 N did not rise 1 um when mocap pads rose 10 mm); a welded body moves with a velocity and does. The pads
    come after the objects, so the objects' joints stay first in qpos."""
    s = settings
    bodies, assets = [], []
    for k, (shape, edge) in enumerate(shapes):
        body, meshes = _object_body(k, shape, float(edge), wood)
        bodies.append(body)
        assets.extend(meshes)
    px, py, pz = PUSHER_HALF_M
    targets = pads = welds = ""
    if pad_half_mm is not None:
        half = _fmt(h / 1000.0 for h in pad_half_mm)
        targets = "".join(f'<body name="pad{k}_target" mocap="true" pos="0 0 {PARK_Z_M}"/>' for k in range(2))
        pads = "".join(
            f'<body name="pad{k}" pos="0 0 {PARK_Z_M}" gravcomp="1"><freejoint/><geom type="box" size="{half}" '
            f'mass="{PAD_MASS_KG:.9g}" friction="{_fmt((PAD_FRICTION, wood.torsional_m, 0.0))}"/></body>'
            for k in range(2))
        welds = "<equality>" + "".join(
            f'<weld body1="pad{k}" body2="pad{k}_target" solref="{_fmt(PAD_WELD_SOLREF)}"/>' for k in range(2)
        ) + "</equality>"
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
    {targets}
    {"".join(bodies)}
    {pads}
  </worldbody>
  {welds}
</mujoco>
"""
