"""Scoring block detections against ground truth: visibility of each object's top face, matching, and the metrics
of the detection issue (recall, precision, colour / size / levels accuracy, position and yaw errors).

Ground truth is a list of objects with .color, .size, .shape, .edge, .position (centre, world mm), .yaw (rad),
.top_z, .bottom_z and footprint_world() (armlab.blocks.ObjectState). Which top faces the camera can see comes from an
exact (noise-free) depth image of the scene: a face point is visible when the image's depth there equals the
point's own depth. A face at least `min_visible` visible must be found; a face less visible (under a block of its
size, or mostly under the arm) is neither required nor a false positive when reported.

`sim_case` builds one seeded simulated test frame (through the public station API) for benchmarks and notebooks.
This lives with the simulator because only the simulator has ground truth: armlab.detection itself never imports the
simulator (DESIGN.md: detection does not know whether the station is simulated or real).
Units: mm and rad, world (board) frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from armlab.camera import Camera
from armlab.transforms import wrap_quarter

__all__ = ["TruthFace", "FrameScore", "DetectionScore", "truth_faces", "score_frame", "yaw_error", "sim_case", "Case",
           "SCENES", "case_specs", "labelled_faces", "fit_color_model", "TRAIN_SEEDS", "balanced_frame",
           "SegmentationScore", "score_segmentation"]

# The scenes of the evaluation sets: singles, stacks 2-3 high, the events' levels 2-3 (stacks and distractors).
SCENES = ("random", "stacks", "sort_stack_3", "line_up_3", "sky", "line_up_2", "sort_stack_2")
TRAIN_SEEDS = range(1000, 1024)    # the colour model's training frames: disjoint from every test set's seeds


@dataclass(frozen=True)
class TruthFace:
    """One object's top face: the object, its centre (3,) world mm, the visible fraction and the stack height."""

    obj: object
    centre: np.ndarray
    visible: float
    levels: int

    @property
    def is_block(self) -> bool:
        return self.obj.shape == "cube"


def yaw_error(a: float, b: float) -> float:
    """Smallest difference (rad, >= 0) between two square yaws (equal every quarter turn)."""
    return float(abs(wrap_quarter(a - b)))


def _stack_levels(obj, objects) -> int:
    """How many objects high the column under obj's centre is (obj included)."""
    below = [o for o in objects if o is not obj and o.top_z <= obj.bottom_z + 0.5
             and np.all(np.abs(o.position[:2] - obj.position[:2]) < o.edge / 2)]
    return 1 + len(below)


def _face_samples(obj, n: int = 9) -> np.ndarray:
    """Points (M, 3) world mm on the top face of obj (a grid inside its footprint polygons, inset from the edges)."""
    from matplotlib.path import Path as MplPath

    polys = obj.footprint_world()
    lo = np.min([p.min(axis=0) for p in polys], axis=0)
    hi = np.max([p.max(axis=0) for p in polys], axis=0)
    g = np.linspace(0.08, 0.92, n)
    X, Y = np.meshgrid(lo[0] + g * (hi[0] - lo[0]), lo[1] + g * (hi[1] - lo[1]))
    xy = np.column_stack([X.ravel(), Y.ravel()])
    inside = np.zeros(len(xy), bool)
    for p in polys:
        centre = p.mean(axis=0)
        inside |= MplPath(centre + 0.9 * (p - centre)).contains_points(xy)
    xy = xy[inside]
    return np.column_stack([xy, np.full(len(xy), obj.top_z)])


def truth_faces(objects, camera: Camera, exact_depth: np.ndarray, tol_mm: float = 1.0) -> list[TruthFace]:
    """Every object's top face with its visible fraction in `exact_depth` (H, W) mm seen through `camera`."""
    out = []
    H, W = exact_depth.shape
    for obj in objects:
        pts = _face_samples(obj)
        uv = np.rint(camera.project(pts)).astype(int)
        ok = (uv[:, 0] >= 0) & (uv[:, 0] < W) & (uv[:, 1] >= 0) & (uv[:, 1] < H)
        seen = np.zeros(len(pts), bool)
        z = camera.depth_of(pts)
        seen[ok] = np.abs(exact_depth[uv[ok, 1], uv[ok, 0]] - z[ok]) < tol_mm
        centre = np.array([obj.position[0], obj.position[1], obj.top_z])
        out.append(TruthFace(obj, centre, float(seen.mean()) if len(seen) else 0.0, _stack_levels(obj, objects)))
    return out


@dataclass
class FrameScore:
    """The pairs (detection, truth face) and the leftovers of one frame."""

    pairs: list = field(default_factory=list)
    missed: list = field(default_factory=list)          # required truth faces without a detection
    extra: list = field(default_factory=list)           # detections matching nothing


def score_frame(detections, truth: list[TruthFace], min_visible: float = 0.5, max_xy_mm: float = 15.0,
                max_dz_mm: float = 12.0) -> FrameScore:
    """Match detections (.position top-face centre) to truth faces one to one, nearest first (within max_xy_mm
    horizontally and max_dz_mm vertically)."""
    cand = []
    for i, d in enumerate(detections):
        for j, t in enumerate(truth):
            dxy = float(np.hypot(*(d.position[:2] - t.centre[:2])))
            dz = abs(float(d.position[2] - t.centre[2]))
            if dxy < max_xy_mm and dz < max_dz_mm:
                cand.append((dxy + dz, i, j))
    cand.sort()
    used_d, used_t = set(), set()
    score = FrameScore()
    for _, i, j in cand:
        if i in used_d or j in used_t:
            continue
        used_d.add(i)
        used_t.add(j)
        score.pairs.append((detections[i], truth[j]))
    score.missed = [t for j, t in enumerate(truth) if j not in used_t and t.visible >= min_visible]
    score.extra = [d for i, d in enumerate(detections) if i not in used_d]
    return score


@dataclass
class DetectionScore:
    """Metrics over many frames (see summary())."""

    frames: list[FrameScore] = field(default_factory=list)
    min_visible: float = 0.5

    def add(self, frame: FrameScore) -> None:
        self.frames.append(frame)

    def block_pairs(self) -> list:
        """(detection, truth) pairs where both are blocks."""
        return [(d, t) for f in self.frames for d, t in f.pairs if d.shape == "cube" and t.is_block]

    def metrics(self) -> dict[str, float]:
        """recall and precision of blocks; distractor recall (reported as distractors); colour, size and levels
        accuracy over the matched blocks whose faces are at least min_visible visible (as the errors); position error
        (mm) mean and max; yaw error (deg) mean and max; counts."""
        matched = self.block_pairs()
        pairs = [(d, t) for d, t in matched if t.visible >= self.min_visible]     # the faces that must be found
        required = sum(1 for f in self.frames for _, t in f.pairs if t.is_block and t.visible >= self.min_visible)
        required += sum(1 for f in self.frames for t in f.missed if t.is_block)
        found = sum(1 for d, t in pairs if t.visible >= self.min_visible)
        reported = sum(1 for f in self.frames for d, _ in f.pairs if d.shape == "cube")
        reported += sum(1 for f in self.frames for d in f.extra if d.shape == "cube")
        distractors = [(d, t) for f in self.frames for d, t in f.pairs if not t.is_block]
        distractors_required = len(distractors) + sum(1 for f in self.frames for t in f.missed if not t.is_block)
        pos = np.array([np.linalg.norm(d.position - t.centre) for d, t in pairs]) if pairs else np.zeros(1)
        yaw = np.degrees([yaw_error(d.yaw, t.obj.yaw) for d, t in pairs]) if pairs else np.zeros(1)
        n = max(len(pairs), 1)
        return {
            "blocks": required, "recall": found / max(required, 1), "precision": len(matched) / max(reported, 1),
            "distractor_recall": sum(d.shape != "cube" for d, _ in distractors) / max(distractors_required, 1),
            "color_acc": sum(d.color == t.obj.color for d, t in pairs) / n,
            "size_acc": sum(d.size == t.obj.size for d, t in pairs) / n,
            "levels_acc": sum(d.levels == t.levels for d, t in pairs) / n,
            "pos_mean_mm": float(pos.mean()), "pos_max_mm": float(pos.max()),
            "yaw_mean_deg": float(np.mean(yaw)), "yaw_max_deg": float(np.max(yaw)),
        }


@dataclass(frozen=True)
class Case:
    """One simulated test frame: rgb, depth (raw), the true camera, the arm's measured joint angles (5,) rad, the
    truth faces, scene name and seed."""

    rgb: np.ndarray
    depth: np.ndarray
    camera: Camera
    arm_q: np.ndarray
    truth: list[TruthFace]
    scene: str
    seed: int


def sim_case(scene: str, seed: int, arm_over_board: bool = False) -> Case:
    """A seeded simulated frame of a scene preset (realistic camera). With arm_over_board the arm is posed with
    its gripper pointing down 40-70 mm beside one object and just above the tallest top, so it hides parts of
    the blocks near it (as it does when students detect without parking the arm)."""
    from armlab import kinematics, make_station
    from armlab.sim.render import render_exact

    station = make_station("sim", seed=seed, scene=scene)
    arm, world, cam = station.arm, station.world, station.camera
    if arm_over_board and world.objects:
        rng = np.random.default_rng([seed, 0xA7])
        for _ in range(20):
            obj = world.objects[int(rng.integers(len(world.objects)))]
            a = rng.uniform(0, 2 * np.pi)
            xy = obj.position[:2] + rng.uniform(40, 70) * np.array([np.cos(a), np.sin(a)])
            z = max(o.top_z for o in world.objects) + rng.uniform(35, 80)
            try:
                q = kinematics.ik_pox(np.array([xy[0], xy[1], z]), np.pi / 2)[0]   # the kit's IK
                arm.move_to(q)
                break
            except ValueError:
                continue
    frame = cam.capture()
    _, exact = render_exact(cam.truth, list(world.objects), arm.q_true, arm.gripper_opening_mm, arm.gripper_geometry)
    return Case(frame.rgb, frame.depth, cam.truth, arm.joint_positions(),
                truth_faces(world.objects, cam.truth, exact), scene, seed)


def case_specs(n: int, first_seed: int) -> list[tuple[str, int, bool]]:
    """n (scene, seed, arm_over_board) triples cycling through SCENES, seeds first_seed..., every other frame with
    the arm over the board."""
    return [(SCENES[k % len(SCENES)], first_seed + k, k % 2 == 1) for k in range(n)]


def corrected_depth(case: Case, camera: Camera | None = None) -> np.ndarray:
    """The case's depth with the planar bias fitted on its own board pixels removed (the arm left out)."""
    from armlab.calibration import fit_depth_correction
    from armlab.detection.masks import arm_mask

    camera = camera or case.camera
    return fit_depth_correction(case.depth, camera, exclude=arm_mask(camera, case.arm_q)).apply(case.depth)


def labelled_faces(cases) -> tuple[np.ndarray, list[str]]:
    """White-balanced mean colours (N, 3) of the detected block faces matched to true blocks, and their true
    colours: training data for ColorModel.fit."""
    from armlab.detection.detect import detect_objects

    colours, labels = [], []
    for case in cases:
        found = detect_objects(case.rgb, corrected_depth(case), case.camera, case.arm_q)
        for d, t in score_frame(found, case.truth).pairs:
            if t.is_block and t.visible >= 0.5:
                colours.append(d.mean_rgb * d.white_balance)
                labels.append(t.obj.color)
    return np.array(colours), labels


def fit_color_model(seeds=TRAIN_SEEDS):
    """A ColorModel fitted on the block faces of simulated frames with these seeds (scenes cycling as in
    case_specs)."""
    from armlab.detection.color import ColorModel

    specs = [(SCENES[k % len(SCENES)], seed, k % 3 == 1) for k, seed in enumerate(seeds)]
    colours, labels = labelled_faces([sim_case(*s) for s in specs])
    return ColorModel.fit(colours, labels), len(labels)


def balanced_frame(case: Case) -> tuple[np.ndarray, np.ndarray]:
    """The case's RGB image white-balanced on its board pixels (height within 3 mm of the board, from the corrected
    depth), uint8 (H, W, 3), and those board pixels (H, W) bool."""
    from armlab.detection import height_from_depth
    from armlab.detection.color import white_balance_gains

    h = height_from_depth(corrected_depth(case), case.camera)
    board = np.isfinite(h) & (np.abs(h) < 3.0)
    gains = white_balance_gains(case.rgb[board].mean(axis=0))
    return np.clip(case.rgb * gains, 0, 255).astype(np.uint8), board


@dataclass(frozen=True)
class SegmentationScore:
    """A label image (index into armlab.blocks.COLORS, -1 none) against a case's truth: per visible block face
    (at least half visible) the majority label of the 7 x 7 pixels at its centre and its true index; the fraction
    of board pixels given a colour."""

    pairs: list[tuple[int, int]]
    board_labelled: float

    @property
    def face_accuracy(self) -> float:
        return float(np.mean([p == t for p, t in self.pairs])) if self.pairs else 1.0


def score_segmentation(case: Case, labels: np.ndarray, board: np.ndarray) -> SegmentationScore:
    """Score a label image (H, W) int of the case (see SegmentationScore); ValueError naming the problem when it is
    not an integer image of the frame's shape."""
    from armlab.blocks import COLORS

    labels = np.asarray(labels)
    if labels.shape != case.rgb.shape[:2] or labels.dtype.kind not in "iu":
        raise ValueError(f"a label image must be integers of shape {case.rgb.shape[:2]}, got {labels.dtype} "
                         f"{labels.shape}")
    pairs = []
    for t in case.truth:
        if t.is_block and t.visible >= 0.5:
            u, v = np.round(case.camera.project(t.centre[None])[0]).astype(int)
            values, counts = np.unique(labels[v - 3:v + 4, u - 3:u + 4], return_counts=True)
            pairs.append((int(values[counts.argmax()]), COLORS.index(t.obj.color)))
    return SegmentationScore(pairs, float(np.mean(labels[board] >= 0)))
