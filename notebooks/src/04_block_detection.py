# %% [markdown]
# # 04 Block detection
#
# Goal: find every block on the board in one RGB-D frame — its **colour**, **size**, **top-face centre** in the
# world (mm), **yaw** and **stack height** — and tell blocks from distractors (arches, triangles, cylinders).
#
# Pipeline (`armlab.detection.detect_blocks`):
# 1. depth → world height of every pixel (the calibrated camera);
# 2. mask off the board's border, the robot base and the arm (from its joint angles);
# 3. flat top faces = plateaus of the height map;
# 4. per face: outline → world footprint (on the face's plane) → centre, edge, yaw, shape;
# 5. colour: white balance from the board, then the nearest colour class.

# %%
import cv2
import matplotlib.pyplot as plt
import numpy as np
from IPython import get_ipython

from armlab.blocks import COLORS, LAB_RGB
from armlab.detection import default_color_model, detect_objects, draw_detections, height_from_depth
from armlab.detection import hsv_table_classify
from armlab.detection.color import LAB_HSV_TABLE, white_balance_gains
from armlab.exercises import references, require_written, with_reference
from armlab.sim.detection_eval import DetectionScore, corrected_depth, score_frame, sim_case

get_ipython().run_line_magic("matplotlib", "inline")
from armlab.viz.figures import readable

readable()                                             # figure size and fonts readable at 100 % zoom
case = sim_case("line_up_3", 300, arm_over_board=True)      # seeded: the same frame every run
depth = corrected_depth(case)                                   # depth-plane correction of notebook 01
print(f"{case.scene}: {sum(t.is_block for t in case.truth)} blocks, "
      f"{sum(not t.is_block for t in case.truth)} distractors, arm over the board")

# %% [markdown]
# ## 1. Colour spaces, and why HSV thresholds fail
#
# The lab report classified colours with fixed OpenCV HSV ranges (H in 0–180):

# %%
for name, (lo, hi) in LAB_HSV_TABLE.items():
    print(f"{name:>7}: H {lo[0]:3d}-{hi[0]:3d}  S {lo[1]:3d}-{hi[1]}  V {lo[2]:3d}-{hi[2]}")

# %% [markdown]
# Blue (96–130) and violet (110–141) overlap, and red is only 140–180 although red sits at H ≈ 0: a pure red is
# missed. The hue of dark, weakly saturated faces (green, blue) also moves with noise and lighting.
#
# Instead: (1) **white balance** — the board is neutral, so gains $g_c = \bar m / m_c$ that make the board's mean
# colour $m$ grey remove the light's tint; (2) **chromaticity** $r = R/(R+G+B)$, $g = G/(R+G+B)$, which ignores
# brightness (shading, vignetting); (3) the **nearest class** by the distance
# $\sqrt{\sum_k ((x_k-\mu_{ck})/\sigma_{ck})^2}$
# to class means $\mu_c$ with spreads $\sigma_c$ fitted on labelled faces of other seeds (`data/color_model.json`).


# %%
def face_colours(cases):
    """Mean colours (raw and white-balanced) and true colours of the detected block faces matched to true blocks."""
    raw, balanced, truth = [], [], []
    for c in cases:
        found = detect_objects(c.rgb, corrected_depth(c), c.camera, c.arm_q)
        for d, t in score_frame(found, c.truth).pairs:
            if t.is_block and d.shape == "cube" and t.visible >= 0.5:   # faces at least half visible
                raw.append(d.mean_rgb)
                balanced.append(d.mean_rgb * d.white_balance)
                truth.append(t.obj.color)
    return np.array(raw), np.array(balanced), truth


cases = [case] + [sim_case(s, seed) for s, seed in [("random", 301), ("sky", 302), ("line_up_2", 303),
                                                     ("stacks", 304), ("sort_stack_3", 305)]]
raw, balanced, truth = face_colours(cases)
hsv_labels = hsv_table_classify(raw)
model_labels, _ = default_color_model().classify(balanced)


def confusion(truth, labels, columns):
    m = np.zeros((len(COLORS), len(columns)), int)
    for t, p in zip(truth, labels):
        m[COLORS.index(t), columns.index(p)] += 1
    return m


fig, axes = plt.subplots(1, 2, figsize=(9, 4.2))
for ax, labels, title, cols in [(axes[0], hsv_labels, "lab HSV table", list(COLORS) + ["none"]),
                                (axes[1], model_labels, "white balance + chromaticity", list(COLORS))]:
    m = confusion(truth, labels, cols)
    ax.imshow(m, cmap="Blues")
    for (i, j), v in np.ndenumerate(m):
        ax.text(j, i, str(v), ha="center", va="center")
    ax.set_xticks(range(len(cols)), cols, rotation=45)
    ax.set_yticks(range(len(COLORS)), COLORS)
    ax.set_xlabel("predicted")
    ax.set_ylabel("true")
    ax.set_title(f"{title}: {np.mean(np.array(labels) == np.array(truth)):.0%}")
fig.tight_layout()

# %%
# CHECK detect.classify
require_written("detect.classify")
hsv_acc = np.mean(np.array(hsv_labels) == np.array(truth))
model_acc = np.mean(np.array(model_labels) == np.array(truth))
assert model_acc == 1.0, f"the colour model names {model_acc:.0%} of the faces right (expected all)"
assert hsv_acc < 0.8, f"the lab's HSV table got {hsv_acc:.0%}: this scene should show its failures"
print(f"OK: on {len(truth)} faces the colour model is right on {model_acc:.0%}, the HSV table on {hsv_acc:.0%}")

# %% [markdown]
# ## 1b. Your own HSV segmentation
#
# Thresholds are not hopeless once the light's tint is gone. Take the white-balanced image (gains from the board
# pixels, found by their height), convert it to HSV, and give each colour a box $[H_{lo}, H_{hi}] \times [S_{lo},
# 255] \times [V_{lo}, 255]$:
# - the board is grey, so a **saturation floor** separates it from every block;
# - **red wraps around** $H = 0$: a box with $H_{lo} > H_{hi}$ means $H \ge H_{lo}$ or $H \le H_{hi}$;
# - the first box (in `COLORS` order) that holds a pixel names it; no box: $-1$.
#
# **Exercise:** write `segment_colours(rgb, ranges)` and tune `tuned_hsv_ranges()` on this frame with the picture:
# every block face one solid colour, the board, the arm and the distractors black.


# %%
def balanced_frame(c):
    """A case's RGB image white-balanced on its board pixels (height within 3 mm of the board), and those pixels."""
    h = height_from_depth(corrected_depth(c), c.camera)
    board = np.isfinite(h) & (np.abs(h) < 3.0)
    gains = white_balance_gains(c.rgb[board].mean(axis=0))
    return np.clip(c.rgb * gains, 0, 255).astype(np.uint8), board


def tuned_hsv_ranges():
    """{colour: ((H_lo, S_lo, V_lo), (H_hi, S_hi, V_hi))} in OpenCV's HSV (H 0-180) for white-balanced images."""
    # BEGIN SOLUTION detect.segment
    return {"red": ((170, 120, 60), (5, 255, 255)), "orange": ((7, 120, 60), (17, 255, 255)),
            "yellow": ((19, 120, 60), (30, 255, 255)), "green": ((40, 100, 30), (85, 255, 255)),
            "blue": ((98, 120, 60), (118, 255, 255)), "violet": ((122, 100, 60), (150, 255, 255))}
    # END SOLUTION


def segment_colours(rgb, ranges):
    """Label image (H, W) int of an RGB uint8 image (H, W, 3): the index in COLORS of the first colour (in COLORS
    order) whose HSV box holds the pixel, -1 for none. A box with H_lo > H_hi wraps around H = 0."""
    # BEGIN SOLUTION detect.segment
    hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)
    labels = np.full(rgb.shape[:2], -1, int)
    for name in [c for c in COLORS if c in ranges]:
        (h0, s0, v0), (h1, s1, v1) = ranges[name]
        if h0 <= h1:
            inside = cv2.inRange(hsv, (h0, s0, v0), (h1, s1, v1)) > 0
        else:
            inside = ((cv2.inRange(hsv, (h0, s0, v0), (180, s1, v1)) > 0)
                      | (cv2.inRange(hsv, (0, s0, v0), (h1, s1, v1)) > 0))
        labels[inside & (labels < 0)] = COLORS.index(name)
    return labels
    # END SOLUTION


def label_picture(labels):
    """An RGB picture of a label image: each colour's reference RGB, black for -1."""
    palette = np.array([LAB_RGB[c] for c in COLORS] + [(0, 0, 0)], np.uint8)
    return palette[np.where(labels < 0, len(COLORS), labels)]


# your segmentation; while it is blank the kit's colour model labels the pixels (it says so once)
segment = with_reference(lambda rgb: segment_colours(rgb, tuned_hsv_ranges()), "detect.segment",
                         references.segment_by_colour_model, "pixels are labelled by the kit's colour model")
balanced, board_px = balanced_frame(case)
fig, axes = plt.subplots(1, 2, figsize=(10, 3.2))
axes[0].imshow(label_picture(segment(balanced)))
axes[0].set_title("your HSV boxes, white-balanced")
axes[1].imshow(label_picture(segment_colours(case.rgb, LAB_HSV_TABLE)))
axes[1].set_title("the lab report's table, raw image")
for ax in axes:
    ax.set_axis_off()
fig.tight_layout()

# %%
# CHECK detect.segment
def face_labels(c, labels):
    """The majority label of the 7 x 7 pixels at each visible true block face's centre, and the true colour."""
    out = []
    for t in c.truth:
        if t.is_block and t.visible >= 0.5:
            u, v = np.round(c.camera.project(t.centre[None])[0]).astype(int)
            values, counts = np.unique(labels[v - 3:v + 4, u - 3:u + 4], return_counts=True)
            out.append((int(values[counts.argmax()]), COLORS.index(t.obj.color)))
    return out


held_out = [sim_case(s, seed) for s, seed in [("random", 401), ("sky", 402), ("line_up_2", 403), ("stacks", 404),
                                              ("sort_stack_3", 405)]]
pairs, board_hits, lab_pairs = [], [], []
for c in held_out:
    rgb_b, board = balanced_frame(c)
    labels = segment_colours(rgb_b, tuned_hsv_ranges())
    assert labels.shape == c.rgb.shape[:2] and labels.dtype.kind == "i", \
        f"segment_colours returned {labels.dtype} {labels.shape}: expected an int label image {c.rgb.shape[:2]}"
    pairs += face_labels(c, labels)
    board_hits.append(np.mean(labels[board] >= 0))
    lab_pairs += face_labels(c, segment_colours(c.rgb, LAB_HSV_TABLE))
face_acc = np.mean([p == t for p, t in pairs])
lab_acc = np.mean([p == t for p, t in lab_pairs])
missed = sorted({COLORS[t] for p, t in pairs if p != t})
assert face_acc >= 0.95, f"your boxes name {face_acc:.0%} of {len(pairs)} held-out faces right; wrong: {missed}"
assert max(board_hits) < 0.005, f"{max(board_hits):.1%} of the board's pixels fall in a colour box: raise S_lo"
assert face_acc > lab_acc + 0.3, f"the lab's table gets {lab_acc:.0%}: yours should do far better"
print(f"OK: HSV segmentation: {face_acc:.0%} of {len(pairs)} held-out faces right, under 0.5 % of the board's "
      f"pixels labelled (the lab's table on raw images: {lab_acc:.0%})")

# %% [markdown]
# ## 2. Depth segmentation
#
# With the camera's per-pixel ray $k(u,v)$ (world direction per mm of depth) and centre $t$, a pixel with depth $Z$
# sees the world point $Z\,k(u,v) + t$; its height is $z = Z\,k_z(u,v) + t_z$. Everything higher than half a small
# block (10 mm) is an object; each object's flat top faces are peaks of its height histogram.

# %%
height = height_from_depth(depth, case.camera)
fig, ax = plt.subplots(figsize=(8, 4.5))
im = ax.imshow(np.clip(height, -5, 120), cmap="viridis")
fig.colorbar(im, label="height above the board (mm)")
_ = ax.set_title("height map (arm in yellow: it is high)")

# %% [markdown]
# ## 3. Contours and moments
#
# A face's pixel mask gives its outline (`cv2.findContours`) and its image moments
# $m_{pq} = \sum_{u,v} u^p v^q$: the centroid is $(\bar u, \bar v) = (m_{10}/m_{00}, m_{01}/m_{00})$. Exercise:
# compute the centroid of a mask from its moments.


# %%
def centroid(mask: np.ndarray) -> tuple[float, float]:
    """Pixel centroid (u, v) of a binary mask (H, W) from its image moments."""
    # BEGIN SOLUTION detect.centroid
    m = cv2.moments(mask.astype(np.uint8), binaryImage=True)
    return m["m10"] / m["m00"], m["m01"] / m["m00"]
    # END SOLUTION


found = detect_objects(case.rgb, depth, case.camera, case.arm_q)
block = next(b for b in found if b.shape == "cube")
mask = np.zeros(depth.shape, np.uint8)
cv2.fillPoly(mask, [block.contour.astype(np.int32)], 1)
# your centroid; while it is blank scipy's centre of mass stands in (it says so once)
u, v = with_reference(centroid, "detect.centroid", references.centroid_by_scipy, "centroids come from scipy")(mask)
print(f"{block.color} {block.size}: moment centroid ({u:.1f}, {v:.1f}) px, "
      f"projected face centre ({block.pixel[0]:.1f}, {block.pixel[1]:.1f}) px")

# %%
# CHECK detect.centroid
u, v = centroid(mask)
off = np.hypot(u - block.pixel[0], v - block.pixel[1])
assert off < 2.0, f"your centroid is {off:.1f} px from the face centre: sum u and v over the mask, divide by its area"
print("OK: the moment centroid lies within 2 px of the projected top-face centre")

# %% [markdown]
# ## 4. Orientation and world positions
#
# The outline's pixels are intersected with the horizontal plane of the face ($z$ = face height): with
# $Z = (z - t_z)/k_z$ each pixel becomes a world point without the per-pixel depth noise. The minimum-area rectangle
# of these points gives the centre and the edge, and a first yaw from the outline's directions. The yaw is then
# refined on the full-resolution image: across each side of the fitted square, the face ends where the colour distance
# to the face's colour rises half-way to what lies beyond; a line $s = a + b\,t$ through each side's edge points says
# how far the side is turned ($\delta = -\arctan b$), and the sides are averaged with the inverse variance of their
# slopes (sides hidden by the arm or another block left out). A square looks the same every quarter turn, so yaw is
# wrapped to $[-\pi/4, \pi/4)$. Exercise: the wrap.


# %%
def wrap_yaw(angle: float) -> float:
    """angle (rad) wrapped to [-pi/4, pi/4)."""
    # BEGIN SOLUTION detect.wrap_yaw
    return float((angle + np.pi / 4) % (np.pi / 2) - np.pi / 4)
    # END SOLUTION


# %%
# CHECK detect.wrap_yaw
assert np.isclose(wrap_yaw(np.pi / 2 + 0.1), 0.1), \
    "wrap_yaw(pi/2 + 0.1) should be 0.1: a cube turned 90 deg looks the same"
assert np.isclose(wrap_yaw(np.pi / 4), -np.pi / 4), "wrap_yaw must return angles in [-pi/4, pi/4)"
angles = np.random.default_rng(4).uniform(-20, 20, 500)
wrapped = np.array([wrap_yaw(a) for a in angles])
quarters = (angles - wrapped) / (np.pi / 2)
assert np.all((wrapped >= -np.pi / 4) & (wrapped < np.pi / 4)), "a wrapped yaw is outside [-pi/4, pi/4)"
assert np.allclose(quarters, np.round(quarters), atol=1e-9), "wrap_yaw must only remove whole quarter turns"
print("OK: wrap_yaw folds 500 random angles onto [-pi/4, pi/4) by whole quarter turns")

# %%
fig, ax = plt.subplots(figsize=(9, 5.1))
ax.imshow(draw_detections(case.rgb, found, case.camera))
ax.set_axis_off()
_ = ax.set_title("detections: outline, label, yaw axes (x red, y green)")

# %% [markdown]
# ## 5. Stacks
#
# A stack shows its top face; a lower block's top face counts where it is still visible (a large block under a small
# one). The stack height `levels` comes from the top face's height: the number of large (38 mm) and small (25 mm)
# blocks whose heights add up to it, larger blocks below.

# %%
for b in found:
    if b.shape == "cube" and b.levels > 1:
        print(f"{b.color:>7} {b.size:<5} top at z = {b.position[2]:5.1f} mm: {b.levels} blocks high")

# %% [markdown]
# ## Check: the detector on the seeded frames
#
# Every frame above is scored against the simulator's ground truth (faces at least half visible must be found).

# %%
# CHECK detect.classify
require_written("detect.classify")
score = DetectionScore()
for c in cases:
    score.add(score_frame(detect_objects(c.rgb, corrected_depth(c), c.camera, c.arm_q), c.truth))
m = score.metrics()
assert m["blocks"] >= 30 and m["recall"] >= 0.95 and m["precision"] == 1, m
assert m["color_acc"] == 1 and m["size_acc"] == 1 and m["levels_acc"] == 1, m
assert m["pos_mean_mm"] < 2 and m["pos_max_mm"] < 5 and m["yaw_max_deg"] < 2, m
print(f"OK: {m['blocks']} blocks in {len(cases)} frames: recall {m['recall']:.1%}, precision {m['precision']:.0%}, "
      f"colour, size and levels 100%, position error mean {m['pos_mean_mm']:.1f} / max {m['pos_max_mm']:.1f} mm, "
      f"yaw error mean {m['yaw_mean_deg']:.1f} / max {m['yaw_max_deg']:.1f} deg")

# %% [markdown]
# Open: faces partly hidden by the arm are the hardest — the odd one is missed (too little of its outline is free to
# prove it square). The yaw of a small face (about 22 px across) is near the image's limit: a side of 22 px that
# turns by 2 deg moves less than a pixel end to end, so the worst small faces are off by about 2 deg.
# `benchmarks/perception.py` scores a larger set.
