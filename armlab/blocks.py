"""The lab's objects: block colours and sizes, their mean colours under lab lighting, and object footprints.

Every object on the board is an upright extruded shape: a footprint (one or more convex polygons in the object's own
horizontal frame, mm) raised to a height. A cube is a square footprint; distractors (arch, semicircle, triangle,
cylinder) use other footprints. Positions are world mm (object centre), yaw in rad about world +z.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from armlab.lab import lab_config

__all__ = ["COLORS", "SIZES", "SHAPES", "LAB_RGB", "ObjectState", "footprint", "block_edge"]

COLORS: tuple[str, ...] = ("red", "orange", "yellow", "green", "blue", "violet")   # rainbow order
SIZES: tuple[str, ...] = ("large", "small")
SHAPES: tuple[str, ...] = ("cube", "arch", "semicircle", "triangle", "cylinder")     # cube = block; others distract

# Mean colours as the L515 sees the blocks under lab lighting (the lab handout gives B, G, R; these are R, G, B).
LAB_RGB: dict[str, tuple[int, int, int]] = {
    "red": (127, 10, 10),
    "orange": (150, 75, 30),
    "yellow": (200, 150, 30),
    "green": (20, 60, 20),
    "blue": (0, 50, 100),
    "violet": (80, 40, 100),
}


def block_edge(size: str) -> float:
    """Cube edge (mm) of a size class ("large" 38 mm or "small" 25 mm by default, from the lab config)."""
    edges = lab_config().block_edges_mm
    if size not in edges:
        raise ValueError(f"unknown block size {size!r}: expected one of {sorted(edges)}")
    return edges[size]


def footprint(shape: str, edge: float) -> list[np.ndarray]:
    """Convex polygons (each (K, 2), counter-clockwise, mm) whose union is the shape's footprint, centred at 0."""
    h = edge / 2
    if shape == "cube":
        return [np.array([[-h, -h], [h, -h], [h, h], [-h, h]])]
    if shape == "triangle":
        return [np.array([[-h, -h], [h, -h], [0.0, h]])]
    if shape == "cylinder":
        a = np.linspace(0, 2 * np.pi, 24, endpoint=False)
        return [np.column_stack([h * np.cos(a), h * np.sin(a)])]
    if shape == "semicircle":
        a = np.linspace(0, np.pi, 13)
        return [np.column_stack([h * np.cos(a), h * np.sin(a) - h / 2])]
    if shape == "arch":  # a bridge seen from above: two pillars joined by a span (top view of an arch block)
        w = edge / 4
        return [np.array([[-h, -h], [-h + w, -h], [-h + w, h], [-h, h]]),
                np.array([[h - w, -h], [h, -h], [h, h], [h - w, h]]),
                np.array([[-h + w, h - w], [h - w, h - w], [h - w, h], [-h + w, h]])]
    raise ValueError(f"unknown shape {shape!r}: expected one of {SHAPES}")


@dataclass
class ObjectState:
    """One object on the board (ground truth in simulation).

    Attributes:
        color: one of COLORS.
        size: "large" or "small".
        edge: height and footprint edge (mm).
        position: (3,) world mm of the object's centre (for a cube: the cube centre).
        yaw: rotation about world +z (rad).
        shape: one of SHAPES ("cube" for blocks).
        id: a number unique within a world.
    """

    color: str
    size: str
    edge: float
    position: np.ndarray
    yaw: float = 0.0
    shape: str = "cube"
    id: int = 0
    tilt: np.ndarray = field(default_factory=lambda: np.zeros(2))  # roll, pitch (rad) while tipping; 0 at rest

    def __post_init__(self):
        if self.color not in COLORS:
            raise ValueError(f"unknown colour {self.color!r}: expected one of {COLORS}")
        if self.shape not in SHAPES:
            raise ValueError(f"unknown shape {self.shape!r}: expected one of {SHAPES}")
        self.position = np.asarray(self.position, dtype=float).reshape(3)
        if not np.all(np.isfinite(self.position)) or not np.isfinite(self.yaw) or self.edge <= 0:
            raise ValueError(f"object {self.id}: position, yaw must be finite and edge positive")

    @property
    def is_block(self) -> bool:
        """True for cubes (the blocks the events score), False for distractors."""
        return self.shape == "cube"

    @property
    def top_z(self) -> float:
        """World z (mm) of the top face."""
        return float(self.position[2] + self.edge / 2)

    @property
    def bottom_z(self) -> float:
        """World z (mm) of the bottom face."""
        return float(self.position[2] - self.edge / 2)

    def footprint_world(self) -> list[np.ndarray]:
        """The footprint polygons turned by yaw and placed at the object's (x, y): list of (K, 2) world mm."""
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        R = np.array([[c, -s], [s, c]])
        return [poly @ R.T + self.position[:2] for poly in footprint(self.shape, self.edge)]

    def corners(self) -> np.ndarray:
        """(8, 3) world corners of the object's bounding box (bottom four, then top four)."""
        h = self.edge / 2
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        sq = np.array([[-h, -h], [h, -h], [h, h], [-h, h]]) @ np.array([[c, -s], [s, c]]).T + self.position[:2]
        bottom = np.column_stack([sq, np.full(4, self.bottom_z)])
        top = np.column_stack([sq, np.full(4, self.top_z)])
        return np.vstack([bottom, top])
