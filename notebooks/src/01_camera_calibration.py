# %% [markdown]
# # 01 · Camera calibration: from pixels and depth to board coordinates
#
# The arm works in **world (board) coordinates**; the camera sees **pixels** and **depth**. This notebook builds the
# bridge between them and measures how good it is, step by step, the way the lab report did it — and then goes past
# the errors the report saw:
#
# 1. the **pinhole model** (intrinsics $K$, distortion, extrinsic $T_{cam,world}$),
# 2. **intrinsics** from a set of checkerboard photos, against the factory $K$,
# 3. the **extrinsic** from the board's four AprilTags (a planar pose), against a tape-measured one,
# 4. a **top-down view** of the board: the report's four-tag homography and a distortion-aware one,
# 5. **pixel + depth → world** (and back), with a live readout,
# 6. the depth camera's **planar bias** and its correction,
# 7. **validation** on the printed 50 mm grid, before and after, as heatmaps over the board,
# 8. saving and loading the calibration.
#
# Two research questions — why each camera needs its own checkerboard photos, and whether depth could refine the
# extrinsic — are in the optional notebook **01 · going further** (`01_going_further.ipynb`).
#
# Everything runs on the simulated station; on the real one, only the first cell changes
# (`make_station("real")`, checkerboard photos taken with your camera). Units: **mm**, **px**, **rad** (angles
# printed in degrees). Comparisons with the lab report are labelled as such: the report's numbers come from the real
# L515 camera, ours from the simulated one.
#
# ### Exercises and how they are graded
#
# | exercise | what you write | points | kind | graded on |
# |---|---|---|---|---|
# | `calib.pinhole` | `project_pinhole`, `pixel_to_world_pinhole` (section 1) | 8 | code | hidden cameras |
# | `calib.zhang` | `intrinsics_from_homographies` (section 2) | 8 | code | hidden cameras and board poses |
# | `calib.tag_homography` | `dlt_homography` (`armlab/calibration/homography.py`) | 6 | code | hidden points |
# | `calib.tag_extrinsics` | `pose_from_corners` (`armlab/calibration/extrinsics.py`) | 8 | code | hidden poses |
# | `calib.depth_plane` | `fit_depth_correction` (`armlab/calibration/depth.py`) | 4 | code | hidden depth images |
# | `calib.q_views` | a written answer about the views-against-error figure (section 2) | 3 | written | by hand |
# | `calib.q_reprojection` | a written answer about the homography error figure | 3 | written | by hand |
#
# A **Check** cell (`# CHECK <id>`) tests your work; cells marked *demonstration* show the kit and are not graded.
# Restart the kernel after editing a package file.

# %%
import json
import tempfile
from pathlib import Path

import cv2
import ipywidgets as widgets
import matplotlib.pyplot as plt
import numpy as np
from IPython import get_ipython
from IPython.display import display

from armlab import calibration as cal
from armlab_course.exercises import references, require_written, rubric, with_reference
from armlab import make_station
from armlab.camera import Camera
from armlab.lab import lab_config
from armlab.sim.camera import CameraRealism
from armlab.sim.checkerboard import load_dataset

get_ipython().run_line_magic("matplotlib", "inline")
from armlab.viz.figures import readable

readable()                                             # figure size and fonts readable at 100 % zoom
np.set_printoptions(precision=3, suppress=True)
lab = lab_config()
views, meta = load_dataset()       # 16 checkerboard photos taken by the station's camera (data/checkerboard/)
# The simulated station whose camera took those photos, with an empty board (no block hides a grid point).
station = make_station("sim", seed=0, scene="empty", camera_realism=CameraRealism.realistic(meta["seed"]))
truth = station.camera.truth       # simulation only: the camera that really made the images, to grade against
frame = station.camera.capture()
print(f"{len(views)} checkerboard views; frame rgb {frame.rgb.shape} {frame.rgb.dtype}, "
      f"depth {frame.depth.shape} {frame.depth.dtype}")

# %% [markdown]
# ## 1 · The pinhole model
#
# The model (the report's equations (1) and (2)) in homogeneous coordinates: a world point $p_w$ (mm) and its pixel
# $(u, v)$ satisfy
#
# $$\lambda \begin{bmatrix} u \\ v \\ 1 \end{bmatrix} = K \,[\,R \mid t\,] \begin{bmatrix} p_w \\ 1
# \end{bmatrix}, \qquad K = \begin{bmatrix} f_x & s & c_x \\ 0 & f_y & c_y \\ 0 & 0 & 1 \end{bmatrix}
# \ (s = 0), \qquad T_{cam,world} = \begin{bmatrix} R & t \\ 0 & 1\end{bmatrix},$$
#
# for some scale $\lambda > 0$. A real lens also bends rays (the Brown–Conrady distortion, which `Camera` applies);
# here the camera is distortion-free. The depth camera reports, at every pixel, the $Z$ coordinate of the surface
# point **in the camera frame**. Work out on paper what $\lambda$ is, how to get $(u, v)$ from $p_w$, and how to invert
# the model when $Z$ is known.
#
# **Exercise `calib.pinhole` (8 points, code):** write both directions: `project_pinhole(K, T_cam_world,
# points_world)` for many points at once, and `pixel_to_world_pinhole(K, T_cam_world, uv, depth_mm)` for one pixel
# and its depth (section 5 uses it).

# %%
def project_pinhole(K, T_cam_world, points_world):
    """Pixels (N, 2) of world points (N, 3) mm through a distortion-free pinhole camera."""
    # BEGIN SOLUTION calib.pinhole
    p_cam = points_world @ T_cam_world[:3, :3].T + T_cam_world[:3, 3]
    uvw = p_cam @ K.T
    return uvw[:, :2] / uvw[:, 2:3]
    # END SOLUTION


def pixel_to_world_pinhole(K, T_cam_world, uv, depth_mm):
    """World point (3,) mm seen at pixel uv (2,) with camera-frame depth Z depth_mm, distortion-free."""
    # BEGIN SOLUTION calib.pinhole
    x = (uv[0] - K[0, 2]) / K[0, 0]
    y = (uv[1] - K[1, 2]) / K[1, 1]
    p_cam = depth_mm * np.array([x, y, 1.0])
    return T_cam_world[:3, :3].T @ (p_cam - T_cam_world[:3, 3])
    # END SOLUTION


tag_centres = np.array([[x, y, 0.0] for x, y in lab.tags.centres_mm.values()])
T_hand = cal.hand_measured_extrinsic()     # the nominal mount of data/lab.json, as measured with a tape
print("tag centres through the factory K and the tape-measured mount (px):")
print(project_pinhole(lab.factory_K, T_hand, tag_centres).round(1))

# %% [markdown]
# **Check:** your projection must agree with `armlab.camera.Camera.project` (which also handles distortion) when the
# distortion is zero.

# %%
# CHECK calib.pinhole
camera_hand = Camera(lab.factory_K, np.zeros(5), T_hand)
reference = camera_hand.project(tag_centres)
err = np.abs(project_pinhole(lab.factory_K, T_hand, tag_centres) - reference).max()
if not err < 1e-9:                     # name the cause where the check can tell it
    moved = project_pinhole(lab.factory_K, T_hand, tag_centres - camera_hand.position)
    if np.abs(moved - reference).max() < 1e-6:
        raise AssertionError("project_pinhole leaves out T_cam_world's translation: it projects as if the camera "
                             "sat at the world origin")
assert err < 1e-9, f"project_pinhole is {err:.2g} px off Camera.project at the tag centres"
print("OK: project_pinhole matches Camera.project on the 4 tag centres (within 1e-9 px)")

# %% [markdown]
# ## 2 · Intrinsics from checkerboard photos
#
# Zhang's method: show a flat checkerboard of known squares (9 × 6 inner corners, 25 mm) in many poses. Put the
# board's frame on the board ($Z = 0$): the pinhole model of section 1 then maps a board point $(X, Y)$ mm to its
# pixel by a **homography**, which the corners found in one photo determine (up to scale):
#
# $$\lambda \begin{bmatrix} u \\ v \\ 1 \end{bmatrix} = K\,[\,r_1\ r_2\ t\,] \begin{bmatrix} X \\ Y \\ 1
# \end{bmatrix}, \qquad H = [\,h_1\ h_2\ h_3\,] = \mu\, K\,[\,r_1\ r_2\ t\,]\ \ (\mu \ne 0 \text{ unknown, either
# sign}).$$
#
# The pose $r_1, r_2, t$ differs from view to view; $K$ does not. What ties them: $r_1$ and $r_2$ are two columns of
# a rotation, so they are **orthogonal and of equal length**. Since $r_i \propto K^{-1} h_i$, each view gives two
# equations in the symmetric matrix
#
# $$B = K^{-\top} K^{-1}: \qquad h_1^\top B\, h_2 = 0, \qquad h_1^\top B\, h_1 = h_2^\top B\, h_2,$$
#
# free of the pose and of $\mu$, and **linear in the entries of $B$**: stack them for all views into $V b = 0$
# ($b$ the unknown entries of $B$) and take $b$ as the right singular vector of $V$'s smallest singular value, as
# the DLT of section 3 does for $H$.
#
# * **How many views.** $B$ is symmetric (6 entries) and known only up to scale: 5 unknowns, so three views in
#   general. Here we assume **zero skew** ($s = 0$, true of this camera and of OpenCV's model), which removes one
#   entry of $B$; two views tilted about different axes then fix it in exact arithmetic, and every further view
#   averages the corners' noise.
# * **Why tilted views.** A board seen square-on looks the same to a camera with a longer focal length further away:
#   such a view only says $f_x/f_y$. It is the foreshortening of a tilted board that depends on $f$ and on the
#   principal point. Views of the board in parallel planes (only turned in its plane, or moved) repeat each
#   other's equations.
# * **Conditioning.** Pixel coordinates are in the hundreds, so $B$'s entries span six orders of magnitude (compare
#   $1/f^2$ with $c_x^2/f^2$): as for the DLT, first move the image coordinates to the image centre and scale them to
#   about ±1 with a similarity $N$ ($N H$ maps the board into those coordinates, and its camera matrix is $N K$), and
#   undo $N$ at the end. Each homography's scale is arbitrary: bring them to a common size before stacking.
# * **From $B$ to $K$.** The SVD returns $b$ with an arbitrary sign, while $B = K^{-\top}K^{-1}$ is positive
#   definite: fix the sign first. Then $K^{-1}$ is an upper-triangular factor of $B$ (a Cholesky factorisation does
#   it: work out which factor), or derive $K$'s entries from $B$'s by hand. $B$ was known only up to scale, so
#   normalise $K$ so that $K_{33} = 1$.
#
# **Exercise `calib.zhang` (8 points, code):** write `intrinsics_from_homographies(homographies, image_size)`: from
# the board-to-image homographies (each 3 × 3, any scale and sign) of two or more views and the image size
# (width, height) px, return $K$ (3 × 3, zero skew, $K_{33} = 1$). Raise `ValueError` for fewer than two views, a
# matrix that is not a finite 3 × 3, or views that do not fix $K$ ($B$ undetermined, or not positive definite).
#
# The kit's `calibration.calibrate_intrinsics` (`cv2.calibrateCamera`) starts from the same kind of closed-form
# estimate and then refines $K$, the lens distortion and every pose by minimising the reprojection error.

# %%
def intrinsics_from_homographies(homographies, image_size):
    """K (3, 3), zero skew, K[2, 2] = 1, from board-to-image homographies (3, 3) (any scale and sign) of two or
    more views of a plane; image_size (width, height) px."""
    # BEGIN SOLUTION calib.zhang
    Hs = [np.asarray(H, dtype=float) for H in homographies]
    if len(Hs) < 2:
        raise ValueError(f"the intrinsics need the homographies of two or more views, got {len(Hs)}")
    if any(H.shape != (3, 3) or not np.isfinite(H).all() for H in Hs):
        raise ValueError("each homography must be a finite 3 x 3 matrix")
    # condition: image coordinates moved to the image centre and scaled to about +-1
    width, height = float(image_size[0]), float(image_size[1])
    s = 2.0 / max(width, height)
    N = np.array([[s, 0.0, -s * width / 2], [0.0, s, -s * height / 2], [0.0, 0.0, 1.0]])

    def v(h_i, h_j):
        # the coefficients of h_i^T B h_j in b = (B11, B22, B13, B23, B33) (zero skew: B12 = 0)
        return np.array([h_i[0] * h_j[0], h_i[1] * h_j[1], h_i[0] * h_j[2] + h_i[2] * h_j[0],
                         h_i[1] * h_j[2] + h_i[2] * h_j[1], h_i[2] * h_j[2]])

    rows = []
    for H in Hs:
        G = N @ H
        G = G / np.linalg.norm(G)                  # any scale and sign: a common size for every view
        h1, h2 = G[:, 0], G[:, 1]
        rows += [v(h1, h2), v(h1, h1) - v(h2, h2)]
    _, sv, Vt = np.linalg.svd(np.array(rows))
    sv = np.concatenate([sv, np.zeros(5 - len(sv))])   # two views: 4 equations for 5 unknowns
    if sv[3] < 1e-8 * sv[0]:                       # a second null direction: b is not determined
        raise ValueError("the views do not fix K (their equations leave B undetermined): tilt the board in "
                         "planes that are not parallel")
    b = Vt[-1]
    B11, B22, B13, B23, B33 = b
    B = np.array([[B11, 0.0, B13], [0.0, B22, B23], [B13, B23, B33]])
    if B[0, 0] < 0:                                # the SVD's sign is arbitrary; B is positive definite
        B = -B
    try:
        L = np.linalg.cholesky(B)                  # B = L L^T with L = K'^-T
    except np.linalg.LinAlgError:
        raise ValueError("the views do not fix K (B is not positive definite): tilt the board more, in more "
                         "directions") from None
    K_n = np.linalg.inv(L.T)                       # the camera matrix in the conditioned coordinates, N K
    K = np.linalg.solve(N, K_n / K_n[2, 2])
    # END SOLUTION
    return K


board_xy = cal.checkerboard_points(tuple(meta["pattern_size"]), meta["square_mm"])[:, :2].astype(float)
view_corners = [cal.find_checkerboard(v, tuple(meta["pattern_size"])) for v in views]
homographies = [cv2.findHomography(board_xy, c.astype(float), 0)[0] for c in view_corners if c is not None]
# your function; while it is blank OpenCV's initial guess stands in for the table and figure below (it says so once)
my_intrinsics = with_reference(intrinsics_from_homographies, "calib.zhang", references.intrinsics_by_opencv,
                               "the closed-form K is OpenCV's initial guess (principal point at the image centre)")
K_zhang = my_intrinsics(homographies, (1280, 720))
print(f"{len(homographies)} homographies (board mm -> pixels); closed-form K:")
print(K_zhang.round(1) + 0.0)

# %%
intrinsics = cal.calibrate_intrinsics(views, tuple(meta["pattern_size"]), meta["square_mm"])
print(intrinsics.summary())
fig, axes = plt.subplots(1, 3, figsize=(9, 2.9))
for ax, i in zip(axes[:2], (0, 7)):
    corners = cal.find_checkerboard(views[i], (9, 6))
    ax.imshow(views[i], cmap="gray")
    ax.plot(corners[:, 0], corners[:, 1], "r.", ms=3)
    ax.set(title=f"view {i}: {len(corners)} corners found", xlabel="u (px)", ylabel="v (px)", xticks=(0, 600, 1200))
axes[2].bar(intrinsics.used_views, intrinsics.per_view_rms, color="tab:blue")
axes[2].set(xlabel="view (index)", ylabel="RMS reprojection (px)",
            title=f"every view within {np.max(intrinsics.per_view_rms):.1f} px")
fig.tight_layout()

# %% [markdown]
# How do the result, the factory $K$ the device reports, and (simulation only) the true $K$ compare? The lab report
# found the same pattern on its L515: its averaged checkerboard $K$ had focal lengths 1.2 % / 1.5 % below the
# factory ones and a principal point 15.7 px lower.

# %%
K_true = np.array(meta["true_K"])
report_K = np.array([[891.57, 0, 654.68], [0, 889.95, 392.87], [0, 0, 1]])
report_factory = np.array([[902.57, 0, 660.20], [0, 903.04, 377.16], [0, 0, 1]])
rows = {"closed form (yours)": K_zhang, "checkerboard": intrinsics.K, "factory (device)": lab.factory_K,
        "true (simulation)": K_true}
print(f"{'':>19} {'fx':>8} {'fy':>8} {'cx':>8} {'cy':>8}   focal vs true")
for name, K in rows.items():
    rel = cal.compare_intrinsics(K, K_true)["focal_rel_pct"]
    print(f"{name:>19} {K[0, 0]:8.2f} {K[1, 1]:8.2f} {K[0, 2]:8.2f} {K[1, 2]:8.2f}   {rel:+6.2f} %")
rel = cal.compare_intrinsics(report_K, report_factory)
print(f"lab report: checkerboard vs factory focal {rel['focal_rel_pct']:+.2f} %, cy {rel['dcy_px']:+.1f} px")
print("distortion k1 k2 p1 p2 k3:", intrinsics.dist.round(4), " true:", np.round(meta["true_dist"], 4))

# %% [markdown]
# **More views: does the error keep falling?** The next figure plots your closed form's error against the
# simulator's true $K$ as views are added (in the order they were taken), next to the kit's `calibrate_intrinsics` on
# all of them (dashed), which also fits the lens distortion and minimises the reprojection error instead of the
# algebraic error $\lVert V b \rVert$.
#
# *Predict before you run the cell* (write it at the top of your answer to `calib.q_views` below): with 3, 6 and 16
# views, roughly how far off will the focal length (%) and the principal point (px) be?

# %%
counts = np.arange(3, len(homographies) + 1)
closed = [cal.compare_intrinsics(my_intrinsics(homographies[:n], (1280, 720)), K_true) for n in counts]
kit = cal.compare_intrinsics(intrinsics.K, K_true)
focal_err = np.array([max(abs(d["dfx_px"]) / K_true[0, 0], abs(d["dfy_px"]) / K_true[1, 1]) * 100 for d in closed])
centre_err = np.array([np.hypot(d["dcx_px"], d["dcy_px"]) for d in closed])
kit_focal = max(abs(kit["dfx_px"]) / K_true[0, 0], abs(kit["dfy_px"]) / K_true[1, 1]) * 100
fig, axes = plt.subplots(1, 2, figsize=(9, 2.9))
for ax, err, kit_err, what in [(axes[0], focal_err, kit_focal, "focal length error (%)"),
                               (axes[1], centre_err, np.hypot(kit["dcx_px"], kit["dcy_px"]),
                                "principal point error (px)")]:
    ax.semilogy(counts, err, "o-", color="tab:blue", ms=4)
    ax.axhline(kit_err, color="k", ls="--", lw=1)
    ax.text(counts[-1], kit_err * 1.25, "calibrate_intrinsics", ha="right", va="bottom", fontsize=9)
    ax.text(counts[0] + 0.3, err[0], "closed form", color="tab:blue", va="center", fontsize=9)
    ax.set(xlabel="views used (count)", ylabel=what, title=what.split(" (")[0] + " against views used")
fig.tight_layout()
print(f"closed form: {focal_err[0]:.0f} % / {centre_err[0]:.0f} px off the truth with 3 views, "
      f"{focal_err[-1]:.1f} % / {centre_err[-1]:.0f} px with {counts[-1]}; "
      f"calibrate_intrinsics: {kit_focal:.2f} % / {np.hypot(kit['dcx_px'], kit['dcy_px']):.1f} px")

# %% [markdown]
# **Exercise `calib.q_views` (3 points, written).** Compare the figure with your prediction. Describe how each of
# the two errors changes from 3 to 16 views (read the numbers off the figure). Does adding views make the closed
# form converge to the true $K$? Explain what limits each error, and why the principal point behaves differently
# from the focal length. (Your prediction, then three to five sentences.)

# %% [markdown]
# <!-- BEGIN ANSWER calib.q_views -->
# Prediction: both errors fall as views are added and settle somewhere.
# Observed: the focal length error falls from 27 % with 3 views to about 1.6 % with 5 and then stays between 1 and 2 %
# up to 16 views. The principal point error falls from 47 px to 1.3 px at 6 views, then jumps to 9 px at 8 views and
# stays at 6-10 px (7 px with 16): it does not converge, and the good value at 6 views is chance. Both stay far above
# calibrate_intrinsics (dashed: 0.01 % and 0.7 px). The closed form fits an undistorted pinhole to homographies of a
# distorted lens, so every homography carries a bias; more views average out noise, not a bias, so the error stops
# falling. The principal point is the parameter the views constrain least (it trades off against the board's tilt in
# each view and against the radial distortion about the centre), so each new tilted view whose corners lie near the
# image border, where the distortion is largest, moves it by px, while the focal length, set by the scale of every
# view, moves by a fraction of a percent.
# <!-- END ANSWER -->

# %% [markdown]
# **Check:** on exact homographies (the true camera at the 16 board poses `calibrate_intrinsics` found, each matrix
# scaled by an arbitrary factor of either sign) your $K$ is the true one to 1e-6 px; on the photos' homographies it
# is within 2 % in each focal length and 15 px in the principal point of `calibrate_intrinsics`' $K$ (a loose
# tolerance: your answer to `calib.q_views` says why it has to be).

# %%
# CHECK calib.zhang
rng = np.random.default_rng(1)
exact = []
for rvec, tvec in zip(intrinsics.rvecs, intrinsics.tvecs):
    R = cv2.Rodrigues(np.asarray(rvec, dtype=float))[0]
    scale = rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-3, 3)
    exact.append(scale * K_true @ np.column_stack([R[:, 0], R[:, 1], tvec]))


def exact_K_of(views):                 # your K from these exact views, or None when your function refuses them
    try:
        return np.asarray(intrinsics_from_homographies(views, (1280, 720)), dtype=float)
    except ValueError:
        return None


try:
    K_exact = np.asarray(intrinsics_from_homographies(exact, (1280, 720)), dtype=float)
except ValueError:                     # name the cause where the check can tell it
    fewer = (exact[:8], exact[8:], exact[::2], exact[1::2], exact[:2], exact[2:4])
    if any(K is not None and K.shape == (3, 3) and np.abs(K - K_true).max() < 1e-6 for K in map(exact_K_of, fewer)):
        raise AssertionError("intrinsics_from_homographies refuses exact views it solves in smaller sets: the SVD "
                             "gives b with either sign, fix B's sign (B is positive definite)") from None
    raise
assert K_exact.shape == (3, 3), f"intrinsics_from_homographies returned shape {K_exact.shape}, not (3, 3)"
assert abs(K_exact[2, 2] - 1.0) < 1e-9, f"K[2, 2] is {K_exact[2, 2]:.3g}: normalise K (B is known only up to scale)"
exact_err = np.abs(K_exact - K_true).max()
if not exact_err < 1e-6:               # the same camera, the board's origin moved in its plane
    K_moved = exact_K_of([H @ np.array([[1.0, 0.0, 50.0], [0.0, 1.0, -30.0], [0.0, 0.0, 1.0]]) for H in exact])
    if K_moved is not None and K_moved.shape == (3, 3) and np.abs(K_moved - K_exact).max() > 1e-6:
        raise AssertionError("your K changes when the board's origin moves (H's third column), which says nothing "
                             "of K: the two constraints use H's first two columns")
assert exact_err < 1e-6, f"K is {exact_err:.3g} px off the true K on exact homographies: check the two constraints " \
                         "(columns of H), the sign of B and the conditioning"
K_mine = np.asarray(intrinsics_from_homographies(homographies, (1280, 720)), dtype=float)
d = cal.compare_intrinsics(K_mine, intrinsics.K)
focal_off = 100 * max(abs(d["dfx_px"]) / intrinsics.K[0, 0], abs(d["dfy_px"]) / intrinsics.K[1, 1])
centre_off = max(abs(d["dcx_px"]), abs(d["dcy_px"]))
assert focal_off < 2.0, f"your focal lengths are {focal_off:.1f} % off calibrate_intrinsics' (more than 2 %): " \
                        "did you condition the homographies?"
assert centre_off < 15.0, f"your principal point is {centre_off:.0f} px off calibrate_intrinsics' (more than 15 px)"
print(f"OK: closed-form K exact on noise-free homographies (within 1e-6 px); on the {len(homographies)} photos "
      f"within {np.ceil(focal_off):.0f} % and {np.ceil(centre_off):.0f} px of calibrate_intrinsics' K")

# %% [markdown]
# *Demonstration* (the kit's calibration against the simulator's truth, not graded): the checkerboard $K$ is within
# 0.1 % of the truth in focal length and 1.5 px in principal point, and
# the whole lens model (K and distortion) sends every ray within 1.5 px of where the true lens does.

# %%
d = cal.compare_intrinsics(intrinsics.K, K_true)
v, u = np.mgrid[0:720:20, 0:1280:20]
grid_px = np.column_stack([u.ravel(), v.ravel()]).astype(float)
rays = np.column_stack([truth.normalized_rays(grid_px), np.ones(len(grid_px))])
model_err = np.linalg.norm(truth.with_intrinsics(intrinsics.K, intrinsics.dist).project_camera(rays) - grid_px, axis=1)
assert abs(d["focal_rel_pct"]) < 0.1, f"focal length {d['focal_rel_pct']:+.2f} % off the truth: check views, corners"
assert max(abs(d["dcx_px"]), abs(d["dcy_px"])) < 1.5, \
    f"principal point off by ({d['dcx_px']:+.1f}, {d['dcy_px']:+.1f}) px"
assert model_err.max() < 1.5, f"the fitted lens model is {model_err.max():.1f} px off the true lens somewhere"
factory_rel = cal.compare_intrinsics(lab.factory_K, K_true)["focal_rel_pct"]
print(f"OK: checkerboard focal error {abs(d['focal_rel_pct']):.2f} % (factory {factory_rel:+.2f} %), "
      f"lens model within {model_err.max():.1f} px over the image")

# %% [markdown]
# ## 3 · The extrinsic from the board's AprilTags
#
# The four tags sit at known board positions; pupil-apriltags finds their 16 corners in the image (shifted by
# −0.5 px into OpenCV's pixel convention; decodes that needed corrected bits are dropped). The corners lie on the
# board ($Z = 0$), so after undistorting the pixels to normalised image points $x = K^{-1}(u, v, 1)^\top$ a board
# point maps by a homography (Zhang's observation):
#
# $$ s\,x = K^{-1}\!\begin{bmatrix} u \\ v \\ 1 \end{bmatrix} = [\,r_1\ r_2\ t\,]\begin{bmatrix} X \\ Y \\ 1
# \end{bmatrix} = H \begin{bmatrix} X \\ Y \\ 1 \end{bmatrix} $$
#
# **Package exercises** (in `armlab/calibration/`): `dlt_homography` (`calib.tag_homography`), the normalised direct
# linear transform: two rows of $A h = 0$ per point pair, $h$ the singular vector of $A$'s smallest singular value;
# and `pose_from_corners` (`calib.tag_extrinsics`): scale $H$ so that $\lVert r_1 \rVert = \lVert r_2 \rVert = 1$
# with $t_z > 0$, $r_3 = r_1 \times r_2$, the nearest rotation by SVD; the kit then refines the pose by
# Levenberg–Marquardt on the reprojection error — with whichever intrinsics we give it. While they are blank,
# `cv2.findHomography` and `cv2.solvePnP` stand in (the kit says so in one line).

# %%
tags = cal.detect_tags(frame.rgb)
fig, ax = plt.subplots(figsize=(7, 4.2))
ax.imshow(frame.rgb)
for t in tags:
    ax.plot(*np.vstack([t.corners, t.corners[:1]]).T, "-", color="lime", lw=1)
    ax.annotate(str(t.tag_id), t.center + (15, -15), color="yellow", fontsize=10)
ax.set(title="the board's four AprilTags, found with their ids", xlabel="u (px)", ylabel="v (px)")
fig.tight_layout()
print("tags found:", [(t.tag_id, t.hamming) for t in tags], "(id, corrected bits)")

# %%
extrinsics = {
    "factory K": cal.extrinsics_from_detections(tags, lab.factory_K, lab.factory_dist),
    "checkerboard K": cal.extrinsics_from_detections(tags, intrinsics.K, intrinsics.dist),
    "true K (simulation)": cal.extrinsics_from_detections(tags, truth.K, truth.dist),
}
print(f"{'intrinsics used':>22} {'camera position (mm)':>28} {'vs truth':>9} {'angle':>8} {'RMS':>8}")
for name, result in extrinsics.items():
    diff = cal.compare_extrinsics(result.T_cam_world, truth.T_cam_world)
    pos = Camera(truth.K, truth.dist, result.T_cam_world).position
    print(f"{name:>22} ({pos[0]:7.1f}, {pos[1]:7.1f}, {pos[2]:7.1f}) {diff['position_mm']:7.2f} mm "
          f"{diff['angle_deg']:5.2f} deg {result.rms_px:5.2f} px")
hand = cal.compare_extrinsics(T_hand, truth.T_cam_world)
print(f"{'tape-measured':>22} {'':>28} {hand['position_mm']:7.2f} mm {hand['angle_deg']:5.2f} deg")

# %% [markdown]
# The lab report compared its hand-calculated extrinsic (its eq. 17) with the program's (eq. 18). Ours side by side:
# the same structure (a rotation of about 180° + 12° about x: the camera looks down, tilted), the tags' one a few mm
# and a fraction of a degree away from the tape measure. With the factory $K$ the tags still reproject well (small
# RMS), yet the camera lands ~20 mm off: a focal length 1.2 % too long is "explained" by a camera 1.2 % too far.

# %%
# NBVAL_IGNORE_OUTPUT
# (illustrative: the raw matrices; the check below compares them)
T_tags = extrinsics["checkerboard K"].T_cam_world
print("tape-measured T_cam_world:\n", T_hand.round(3) + 0.0)  # + 0.0 turns -0 into 0
print("AprilTag T_cam_world (checkerboard K):\n", T_tags.round(3) + 0.0)

# %% [markdown]
# **Check:** with the checkerboard intrinsics the tag extrinsic puts the camera within 1 mm and 0.1° of the truth;
# with the factory intrinsics it is more than 10 mm off.

# %%
# CHECK calib.tag_extrinsics
require_written("calib.tag_extrinsics")
good = cal.compare_extrinsics(T_tags, truth.T_cam_world)
bad = cal.compare_extrinsics(extrinsics["factory K"].T_cam_world, truth.T_cam_world)
if not (good["position_mm"] < 1.0 and good["angle_deg"] < 0.1):   # name the cause where the check can tell it
    found = extrinsics["checkerboard K"].detections
    world = np.concatenate([lab.tags.corners_world(t.tag_id) for t in found])
    corners = np.concatenate([t.corners for t in found])
    poses = [cal.extrinsics.pose_from_corners(world, uv, K, dist, refine=False) for uv, K, dist in
             [(corners, intrinsics.K, intrinsics.dist), (corners, lab.factory_K, np.zeros(5)),
              (corners + 3.0, intrinsics.K, intrinsics.dist)]]
    if np.array_equal(poses[0], poses[1]) and not np.array_equal(poses[0], poses[2]):
        raise AssertionError("your pose_from_corners gives the same pose whatever K and dist: find H from the "
                             "normalised image points, not the pixels")
assert good["position_mm"] < 1.0 and good["angle_deg"] < 0.1, \
    f"tag extrinsic {good['position_mm']:.1f} mm / {good['angle_deg']:.2f} deg off the truth: check the PnP inputs"
assert bad["position_mm"] > 10.0, f"the factory K gave only {bad['position_mm']:.1f} mm of error (expected > 10 mm)"
print(f"OK: tag extrinsic {good['position_mm']:.1f} mm / {good['angle_deg']:.2f} deg from the truth with the "
      f"checkerboard K ({bad['position_mm']:.0f} mm with the factory K)")

# %% [markdown]
# ## 4 · A top-down view of the board
#
# The camera is tilted, so the rectangular board looks like a trapezoid. The lab report fixed this with a
# homography $H$ (its eq. 3): your `dlt_homography` from the four tag centres in the image to where they
# belong in a top-down view, then `cv2.warpPerspective`. `BoardView` instead projects every view pixel's board
# point through the whole calibrated camera model of section 2 and samples there (`cv2.remap`).
#
# *Predict before you run the cell* (write it at the top of your answer to `calib.q_reprojection` below): the
# homography is fitted to the four tag centres only. Where on the board do you expect its error to be largest, and
# roughly how large (mm)?

# %%
camera = Camera(intrinsics.K, intrinsics.dist, T_tags)      # the calibrated camera
view = cal.BoardView(camera, mm_per_px=1.0)                 # 1000 x 650 px, 1 px = 1 mm
H = cal.tag_homography(tags, view)
top_h = cv2.warpPerspective(frame.rgb, H, (view.width, view.height))
top_b = view.warp(frame.rgb)
grid = lab.grid_points()
grid_uv = truth.project(grid)          # where the image shows each grid point (on a real board: click or detect)
mapped = view.to_world(cv2.perspectiveTransform(grid_uv.reshape(-1, 1, 2), H).reshape(-1, 2))
err_h = np.linalg.norm(mapped - grid[:, :2], axis=1)
err_b = np.linalg.norm(view.to_world(view.from_world(camera.pixel_to_plane(grid_uv))) - grid[:, :2], axis=1)
fig = plt.figure(figsize=(9, 6.8))
layout = fig.add_gridspec(2, 2)
axes = [fig.add_subplot(layout[0, 0]), fig.add_subplot(layout[0, 1]), fig.add_subplot(layout[1, :])]
extent = (*lab.board_x, *lab.board_y)
for ax, img, title in [(axes[0], top_h, "by the four-tag homography"), (axes[1], top_b, "by BoardView")]:
    ax.imshow(img, extent=extent)
    ax.set(title=title, xlabel="x (mm)", ylabel="y (mm)", xticks=range(-400, 401, 200))
sc = axes[2].scatter(grid[:, 0], grid[:, 1], c=err_h, cmap="viridis", marker="s", s=22, vmin=0)
axes[2].plot(*np.array(list(lab.tags.centres_mm.values())).T[:2], "r+", ms=12, mew=2)
axes[2].set(xlabel="x (mm)", ylabel="y (mm)", aspect="equal", xticks=range(-400, 401, 200),
            yticks=range(-200, 401, 200),
            title="homography: each grid point's error (+: the tag centres)")
fig.colorbar(sc, ax=axes[2], label="board error (mm)")
fig.tight_layout()
print(f"homography error: {err_h.mean():.2f} mm mean, {err_h.max():.2f} mm max (at the borders); "
      f"BoardView: {err_b.max():.2f} mm max")

# %% [markdown]
# **Exercise `calib.q_reprojection` (3 points, written).** Compare the error map (bottom) with your prediction.
# Where is the homography exact, and where is it off most? Name the property of the camera that a homography cannot
# represent, say why its effect grows where it does, and why the error vanishes where it does. (Your prediction, then
# two or three sentences.)

# %% [markdown]
# <!-- BEGIN ANSWER calib.q_reprojection -->
# Prediction: largest at the board's far corners, a few mm.
# Observed: zero at the four tag centres, growing between and beyond them to about 4 mm at the board's near corners.
# A homography is exact only for an ideal pinhole camera looking at a plane; the real lens adds radial (and
# tangential) distortion, which is not a projective map. The radial term grows with the distance r from the image
# centre (k1 r², k2 r⁴, ...), so points far out, at the board's corners, are displaced most. The homography is fit
# through the four tag centres exactly (four point pairs fix its eight parameters), so the distortion there is
# absorbed and the error is zero at the tags and grows between and beyond them.
# <!-- END ANSWER -->

# %% [markdown]
# **Check:** the tags found again in the BoardView image sit where they are on the board (within 0.5 mm), and the
# homography's error map is the one the figure shows (more than 2 mm somewhere more than 400 mm from the board's
# centre).

# %%
# CHECK calib.tag_homography
require_written("calib.tag_homography")
ids = sorted(lab.tags.centres_mm)[:4]
centres_px = np.array([next(t.center for t in tags if t.tag_id == i) for i in ids])
targets = view.from_world(np.array([lab.tags.centres_mm[i] for i in ids]))
miss = np.abs(cv2.perspectiveTransform(centres_px.reshape(-1, 1, 2), H).reshape(-1, 2) - targets).max()
if miss > 1e-6:                        # name the cause where the check can tell it
    T_src, T_dst = (cal.homography._normalising_similarity(p) for p in (centres_px, targets))
    undone = np.linalg.solve(T_dst, H @ T_src)
    if np.abs(cv2.perspectiveTransform(centres_px.reshape(-1, 1, 2), undone).reshape(-1, 2) - targets).max() < 1e-6:
        raise AssertionError("your homography maps the normalised points, not the points: undo the normalisation "
                             "(H = inverse(T_dst) @ H_normalised @ T_src)")
    if np.allclose(cal.homography.dlt_homography(centres_px + 7.0, targets * 2.0), H):
        raise AssertionError("your dlt_homography returns the same H whatever the points: compute it from src, dst")
assert miss < 1e-6, f"your homography puts the four tag centres up to {miss:.3g} px from where they belong"
again = cal.detect_tags(top_b)
offset = max(np.abs(t.center - view.from_world([lab.tags.centres_mm[t.tag_id]])[0]).max() for t in again)
far = np.linalg.norm(grid[:, :2] - [0, 150], axis=1) > 400
assert [t.tag_id for t in again] == [1, 2, 3, 4], f"tags {[t.tag_id for t in again]} found in the BoardView image"
assert offset < 0.5, f"BoardView tags {offset:.2f} mm from where they are on the board"
assert err_h[far].max() > 2.0, "the tag homography is within 2 mm everywhere: is it the four-tag homography?"
print(f"OK: BoardView tags within {offset:.2f} mm; homography off by up to {err_h[far].max():.1f} mm at the borders")

# %% [markdown]
# ## 5 · Pixel + depth → world, and back
#
# With the calibration, a pixel and the depth there give a world point: your `pixel_to_world_pinhole` of section 1,
# with the lens distortion undone first (`Camera.pixel_to_world` is the kit's). `Camera.project` goes the other way.
# The readout below reads the depth as the median of a 5 × 5 window (robust to missing returns).

# %%
calibration = cal.Calibration(camera)                       # no depth correction yet (section 6)


def readout(u: int, v: int) -> str:
    """The world point under pixel (u, v) of the frame, as text."""
    x, y, z = calibration.pixel_to_world([[u, v]], frame.depth)[0]
    return f"pixel ({u}, {v}) -> world ({x:.1f}, {y:.1f}, {z:.1f}) mm"


for u, v in [(640, 360), (200, 600), (1100, 120)]:
    print(readout(u, v))

# %% [markdown]
# **Live:** in JupyterLab, move the sliders to read the world position under any pixel (headless runs just show
# the panel's name; the function `readout(u, v)` above is the same thing).

# %%
class PixelReadout(widgets.VBox):
    def __repr__(self) -> str:  # short and deterministic: nbval compares a displayed widget's text
        return "PixelReadout(u, v sliders -> world mm)"


u_slider = widgets.IntSlider(value=640, min=0, max=camera.width - 1, description="u (px)")
v_slider = widgets.IntSlider(value=360, min=0, max=camera.height - 1, description="v (px)")
text = widgets.Label(readout(640, 360))
for s in (u_slider, v_slider):
    s.observe(lambda _change: setattr(text, "value", readout(u_slider.value, v_slider.value)), names="value")
display(PixelReadout([u_slider, v_slider, text]))

# %% [markdown]
# **Check:** world → pixel → world returns the grid points when the depth is exact, and your pinhole
# back-projection matches `Camera.pixel_to_world` for a distortion-free camera.

# %%
# CHECK calib.pinhole
round_trip = camera.pixel_to_world(camera.project(grid), camera.depth_of(grid))
pinhole = Camera(intrinsics.K, np.zeros(5), T_tags)
p = grid[100]
mine = pixel_to_world_pinhole(pinhole.K, T_tags, pinhole.project(p)[0], pinhole.depth_of(p)[0])
if not np.abs(mine - p).max() < 1e-6:  # name the cause where the check can tell it
    transposed = T_tags.copy()
    transposed[:3, :3] = T_tags[:3, :3].T
    if np.abs(pixel_to_world_pinhole(pinhole.K, transposed, pinhole.project(p)[0], pinhole.depth_of(p)[0])
              - p).max() < 1e-6:
        raise AssertionError("pixel_to_world_pinhole is right with T_cam_world's rotation transposed: from the "
                             "camera back to the world takes R's inverse, not R")
assert np.abs(round_trip - grid).max() < 1e-6, f"the round trip misses by {np.abs(round_trip - grid).max():.2g} mm"
assert np.abs(mine - p).max() < 1e-6, \
    f"pixel_to_world_pinhole is {np.abs(mine - p).max():.2g} mm off the grid point it should give back"
print(f"OK: world -> pixel -> world within 1e-6 mm at {len(grid)} grid points; "
      f"pinhole back-projection exact")

# %% [markdown]
# ## 6 · The depth camera's planar bias
#
# On the flat, empty board every pixel should read the depth of the plane $z = 0$ that the extrinsic predicts. It
# doesn't: the L515 reads a slightly tilted plane (about 20 mm across the image in the lab), which turns into a world
# $z$ error that grows towards the borders. Model it as a plane in pixel coordinates,
# $\mathrm{bias}(u, v) = a u + b v + c$, fit it by least squares on the board's pixels (rejecting the arm and
# anything else sticking out, `fit_depth_correction`), and subtract it.

# %%
correction = cal.fit_depth_correction(frame.depth, camera)
expected, on_board = cal.board_depth(camera, step=4)
raw = frame.depth[::4, ::4] - expected
fixed = correction.apply(frame.depth)[::4, ::4] - expected
fig, axes = plt.subplots(1, 2, figsize=(9, 2.9))
for ax, image, title in [(axes[0], raw, "board depth error: a tilted plane"),
                         (axes[1], fixed, "after the correction: flat")]:
    im = ax.imshow(np.where(on_board, image, np.nan), cmap="coolwarm", vmin=-25, vmax=25,
                   extent=(0, 4 * image.shape[1], 4 * image.shape[0], 0))
    ax.set(title=title, xlabel="u (px)", ylabel="v (px)", xticks=(0, 600, 1200))
fig.colorbar(im, ax=axes, label="depth error (mm)")
print(f"bias plane: a = {correction.a:.4f} mm/px, b = {correction.b:.4f} mm/px, c = {correction.c:.1f} mm; "
      f"span {correction.span_mm(camera.image_shape):.1f} mm over the image; "
      f"residual {correction.residual_mm:.1f} mm RMS (sensor noise)")

# %% [markdown]
# **Check:** after the correction the board's median depth error is below 0.5 mm in every quarter of the image
# (before: several mm), and the fitted plane matches the simulator's bias within 1 mm (simulation only), also with a
# box 20 mm high lying on the board (nearer than 30 mm: only your rejection keeps it out of the fit).

# %%
# CHECK calib.depth_plane
require_written("calib.depth_plane")
def quarter_medians(residual):
    h, w = residual.shape
    masked = np.where(on_board, residual, np.nan)
    return np.array([np.nanmedian(masked[i * h // 2:(i + 1) * h // 2, j * w // 2:(j + 1) * w // 2])
                     for i in (0, 1) for j in (0, 1)])


def plane(fit):
    return fit.a, fit.b, fit.c


bu, bv, b0 = station.camera.realism.depth_bias_mm
vv, uu = np.mgrid[0:720:8, 0:1280:8]
true_bias = bu * (uu / 1280 - 0.5) + bv * (vv / 720 - 0.5) + b0
bias_err = np.abs(correction.bias(camera.image_shape)[::8, ::8] - true_bias).max()
before_q, after_q = np.abs(quarter_medians(raw)), np.abs(quarter_medians(fixed))
if not (after_q.max() < 0.5 and bias_err < 1.0):      # name the cause where the check can tell it
    stricter = cal.fit_depth_correction(frame.depth, camera, inlier_mm=3.0)
    if plane(stricter) == plane(correction) != plane(cal.fit_depth_correction(frame.depth, camera, iterations=1)):
        raise AssertionError("your bias plane is the same whatever inlier_mm: drop the pixels farther than inlier_mm "
                             "from each fit before refitting")
assert after_q.max() < 0.5, f"after correction a quarter of the image is still {after_q.max():.2f} mm off the board"
assert before_q.max() > 3.0 and bias_err < 1.0, f"the fitted bias plane is {bias_err:.2f} mm off the simulator's"
boxed = frame.depth.copy()
boxed[300:420, 500:700] -= 20.0                        # a box 20 mm high on part of the board
box_fit = cal.fit_depth_correction(boxed, camera)
box_err = np.abs(box_fit.bias(camera.image_shape)[::8, ::8] - true_bias).max()
if not box_err < 1.0:                                  # name the cause where the check can tell it
    one_round = cal.fit_depth_correction(boxed, camera, iterations=1)
    if plane(one_round) == plane(box_fit) != plane(correction):
        raise AssertionError("your bias plane is the same after 1 round as after 6 (iterations): reject the pixels "
                             "far from each fit, then fit again")
assert box_err < 1.0, f"a box 20 mm high on the board moves your bias plane {box_err:.2f} mm off the simulator's"
print(f"OK: quarter medians {before_q.max():.1f} mm -> {after_q.max():.2f} mm; bias plane within {bias_err:.2f} mm "
      f"of the simulator's")

# %% [markdown]
# ## 7 · Validation on the 50 mm grid: before and after
#
# The printed grid has a point every 50 mm. For each point we know its world position and where the image shows it
# (simulation: the true camera's projection; on a real board you would click or detect it). Pixel + depth → world
# through a calibration gives an estimate; its distance to the truth is the calibration's error there.
#
# * **before**: factory $K$, tape-measured extrinsic, raw depth (what you have on day one),
# * **after**: checkerboard $K$, AprilTag extrinsic, corrected depth.
#
# Points hidden by the sleeping arm and its base cannot be checked (`visible_grid_points`).

# %%
visible = cal.visible_grid_points(truth, frame.depth, grid, grid_uv)
g_world, g_uv = grid[visible], grid_uv[visible]
before = cal.grid_world_error(Camera(lab.factory_K, lab.factory_dist, T_hand), frame.depth, g_world, g_uv)
after = cal.grid_world_error(camera, correction.apply(frame.depth), g_world, g_uv)
print(f"{int((~visible).sum())} of {len(grid)} grid points hidden by the arm")
for name, g in [("before", before), ("after", after)]:
    mean_xyz = np.abs(g.error).mean(axis=0)
    print(f"{name:>6}: {g.summary()}; |error| x/y/z {mean_xyz[0]:.1f}/{mean_xyz[1]:.1f}/{mean_xyz[2]:.1f} mm; "
          f"growth {g.border_growth():+.2f} mm per 100 mm from the centre")

# %%
fig = plt.figure(figsize=(9, 6.6))
grid_spec = fig.add_gridspec(2, 2)
axes = [fig.add_subplot(grid_spec[0, 0]), fig.add_subplot(grid_spec[0, 1]), fig.add_subplot(grid_spec[1, :])]
for ax, g, title in [(axes[0], before, "factory camera"), (axes[1], after, "calibrated")]:
    sc = ax.scatter(g.world[:, 0], g.world[:, 1], c=g.norm, cmap="magma", marker="s", s=16, vmin=0)
    fig.colorbar(sc, ax=ax, label="world error (mm)", shrink=0.8)
    ax.set(title=f"{title}: mean {g.mean_mm:.1f} mm", xlabel="x (mm)", ylabel="y (mm)", aspect="equal",
           xlim=lab.board_x, ylim=lab.board_y, xticks=range(-400, 401, 200))
for g, name, where in [(before, "before", 0.93), (after, "after", 0.3)]:       # labels clear of the points
    r = g.distance_from_centre()
    dots, = axes[2].plot(r, g.norm, ".", ms=3)
    axes[2].plot(np.sort(r), np.polyval(np.polyfit(r, g.norm, 1), np.sort(r)), "k-", lw=1)
    axes[2].text(0.03, where, f"{name}: {g.border_growth():+.2f} mm per 100 mm", transform=axes[2].transAxes,
                 color=dots.get_color(), fontsize=9, va="top")
axes[2].set(xlabel="distance from the board centre (mm)", ylabel="world error (mm)",
            title="before, the error grows towards the borders; after, it is flat and small")
fig.tight_layout()

# %% [markdown]
# **Check:** after calibration the mean grid error is below 2 mm, the largest below 5 mm, and the error no longer
# grows towards the borders (less than 0.2 mm per 100 mm).

# %%
# CHECK calib.tag_extrinsics calib.depth_plane
require_written("calib.tag_extrinsics")
require_written("calib.depth_plane")
assert after.mean_mm < 2.0 and after.max_mm < 5.0, \
    f"grid error {after.mean_mm:.2f} mm mean, {after.max_mm:.2f} mm max after calibration"
assert abs(after.border_growth()) < 0.2, \
    f"the error still grows {after.border_growth():+.2f} mm per 100 mm towards the borders"
print(f"OK: grid error {before.mean_mm:.1f} mm -> {after.mean_mm:.2f} mm mean, max {after.max_mm:.2f} mm, "
      f"no growth towards the borders ({after.border_growth():+.2f} mm per 100 mm)")

# %% [markdown]
# ## 8 · Save and load the calibration
#
# Later notebooks (detection, click-to-grab) load the calibration instead of redoing it. The file is JSON, written
# atomically (a failed write leaves the old file intact), and checked on load (a missing or corrupt file gives a
# clear `CalibrationFileError`).

# %%
final = cal.Calibration(camera, correction, notes="notebook 01, simulated station seed 0")
with tempfile.TemporaryDirectory() as folder:
    path = cal.save_calibration(final, Path(folder) / "calibration.json")
    loaded = cal.load_calibration(path)
    print("saved fields:", ", ".join(json.loads(path.read_text())))
    (Path(folder) / "broken.json").write_text('{"format": "armlab-calibration/1", "K": [[')
    try:
        cal.load_calibration(Path(folder) / "broken.json")
    except cal.CalibrationFileError as e:
        print("a corrupt file is refused:", str(e).split(": ", 1)[1][:48], "...")

# %% [markdown]
# *Demonstration* (the kit's file format, not graded): the loaded calibration turns the grid pixels into the same
# world points as the one we saved.

# %%
same = np.nanmax(np.abs(loaded.pixel_to_world(g_uv, frame.depth) - final.pixel_to_world(g_uv, frame.depth)))
assert same == 0.0, f"the loaded calibration moves grid estimates by {same:.2g} mm: a field did not round-trip"
print(f"OK: the loaded calibration reproduces all {len(g_uv)} grid estimates exactly")

# %% [markdown]
# ## Your rubric
#
# Read from the saved notebook and package (save first): this notebook's exercises, points, how they are graded and
# whether each is still blank. `python -m armlab check` runs the checks.

# %%
rubric("01")
