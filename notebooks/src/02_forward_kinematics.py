# %% [markdown]
# # 02 · Forward kinematics: from joint angles to the tool pose
#
# Forward kinematics (FK) answers: *with the joints at $q = (q_1, \dots, q_5)$, where is the tool and which way does it
# point?* In this notebook you
# 1. read the arm's geometry off the manufacturer's description and a side-view sketch,
# 2. write the **Denavit–Hartenberg (DH) link transform** the kit chains (in `armlab/kinematics.py`),
# 3. assign the RX200's **DH frames** and write its **DH table**, checked against the manufacturer's own
#    **product-of-exponentials (PoX)** model,
# 4. recover **Euler angles** from a pose (the lab report's `get_euler_angles_from_T`),
# 5. answer a question about your frames figure, and see what the lab report's numbers (its Table I, from the real
#    arm) cost in millimetres at the tool of the model.
#
# ### Exercises and how they are graded
#
# | exercise | what you write | points | kind | graded on |
# |---|---|---|---|---|
# | `fk.dh_link_transform` | `dh_link_transform` (`armlab/kinematics.py`) | 4 | code | hidden link parameters |
# | `fk.dh_table` | `dh_table(h0, L1, beta, L2, Lt)`: frames and table | 8 | code | PoX at hidden poses, geometries |
# | `fk.euler` | `euler_angles_from_T(T)`: ZYZ Euler angles | 5 | code | hidden poses, singular ones too |
# | `fk.q_frames` | a written answer about your frames figure | 3 | written | by hand |
# | `fk.q_table_error` | a written answer about the Table I error map (section 6) | 3 | written | by hand |
#
# A **Check** cell (`# CHECK <id>`) tests your work; cells marked *demonstration* show the kit and are not graded.
# Restart the kernel after editing a package file.
#
# Units: millimetres and radians. Frames: the world (board) frame, origin on the board below the waist axis, +y away
# from the robot, +z up.

# %%
import numpy as np
import matplotlib.pyplot as plt
from IPython import get_ipython

from armlab import kinematics
from dataclasses import replace

from armlab_course.exercises import ExerciseNotWritten, require_written, rubric, with_reference
from armlab.robot import rx200
from armlab.transforms import exp_se3, homogeneous, matrix_from_euler_zyz, rot_x, rot_y, rot_z

get_ipython().run_line_magic("matplotlib", "inline")  # figures appear below their cell
from armlab.viz.figures import readable

readable()                                             # figure size and fonts readable at 100 % zoom
np.set_printoptions(precision=3, suppress=True)
robot = rx200()
rng = np.random.default_rng(2)


def random_q(n):
    """n random joint vectors (n, 5) rad, uniform within the joint limits."""
    return rng.uniform(robot.lower, robot.upper, (n, 5))


print("joints:", ", ".join(robot.joint_names))

# %% [markdown]
# ## 1 · The arm and its frames
#
# The manufacturer (Interbotix) describes the RX200 as a chain of joints whose origins are offset from each other by
# fixed vectors, in its `base_link` frame (x forward along the arm at home, z up; mm):
#
# | joint | origin from the previous joint | axis | limits |
# |---|---|---|---|
# | waist | (0, 0, 65.66) | z | ±180° |
# | shoulder | (0, 0, 38.91) | y | −108° … +113° |
# | elbow | (50, 0, 200) | y | −108° … +93° |
# | wrist_angle | (200, 0, 0) | y | −100° … +123° |
# | wrist_rotate | (65, 0, 0) | x | ±180° |
# | tool point `ee_gripper_link` | (43 + 23 + 27.575, 0, 0) | – | – |
#
# Positive shoulder, elbow and wrist_angle tip the arm forward and down. The world frame is `base_link` turned +90°
# about z, so at home the arm points along world +y. Everything below the waist turns in one vertical plane: the
# **arm's plane**. Seen from the side it is a planar 3-link arm on top of a turntable.

# %%
limits = np.degrees(np.stack([robot.lower, robot.upper], 1))
for name, (lo, hi) in zip(robot.joint_names, limits):
    print(f"{name:13s} {lo:8.1f} … {hi:6.1f} deg")

# %% [markdown]
# ## 2 · The DH link transform (in the package)
#
# Standard DH describes link $i$ by four numbers and one rule: starting from frame $i-1$, **rotate $\theta_i$ about
# $z_{i-1}$, move $d_i$ along $z_{i-1}$, move $a_i$ along the new $x_i$, twist $\alpha_i$ about the new $x_i$**. The
# link transform $A_i$ (a 4×4 homogeneous matrix, mm) is the product of those four elementary motions, in that order,
# and the tool pose is the chain $T_{world,5} = A_1 A_2 A_3 A_4 A_5$ (joint $i$ adds $q_i$ to $\theta_i$'s offset).
#
# **Exercise `fk.dh_link_transform` (4 points, code).** Open `armlab/kinematics.py` and write the region of
# `dh_link_transform(theta, d, a, alpha)`: fill the (..., 4, 4) array `A` for arrays of link parameters at once (no
# Python loop over links). Derive its entries by multiplying the four elementary matrices on paper. The kit's FK, the
# viewer's DH frames and every later notebook use your function; while it is blank the kit multiplies the four
# matrices numerically instead (and says so once). Restart the kernel after editing the package.

# %%
# CHECK fk.dh_link_transform
require_written("fk.dh_link_transform")
params = np.column_stack([rng.uniform(-np.pi, np.pi, 500), rng.uniform(-300, 300, 500),
                          rng.uniform(-300, 300, 500), rng.uniform(-np.pi, np.pi, 500)])
A = kinematics.dh_link_transform(*params.T)
zero = np.zeros(len(params))
by_motions = (homogeneous(rot_z(params[:, 0])) @ homogeneous(None, np.stack([zero, zero, params[:, 1]], 1))
              @ homogeneous(None, np.stack([params[:, 2], zero, zero], 1)) @ homogeneous(rot_x(params[:, 3])))
assert A.shape == (500, 4, 4), f"dh_link_transform of 500 links gave shape {A.shape}, expected (500, 4, 4)"
assert np.allclose(A[:, 3], [0, 0, 0, 1], atol=0), "the last row of a link transform must be (0, 0, 0, 1)"
err = np.abs(A - by_motions).max()
if err >= 1e-9:                        # name the cause where the check can tell it
    for k, name in enumerate(("theta", "d", "a", "alpha")):
        flipped = params * np.where(np.arange(4) == k, -1.0, 1.0)
        assert np.abs(kinematics.dh_link_transform(*flipped.T) - by_motions).max() > 1e-9, \
            f"your link transform is right with {name} negated: check {name}'s sign"
    row = int(np.argmax(np.abs(A - by_motions).max(axis=(0, 2))))
    off_mm, off_rot = np.abs(A - by_motions)[:, :3, 3].max(), np.abs(A - by_motions)[:, :3, :3].max()
assert err < 1e-9, (f"your link transforms differ from Rz Tz Tx Rx by up to {off_mm:.2g} mm in position and "
                    f"{off_rot:.2g} in a rotation matrix entry (unitless), first in row {row}: multiply the four "
                    f"matrices again and compare that row, entry by entry")
print("OK: dh_link_transform equals Rz(theta) Tz(d) Tx(a) Rx(alpha) for 500 random links within 1e-9")

# %% [markdown]
# ## 3 · The RX200's DH frames and table
#
# **The rules.** Frame $i-1$'s $z$ axis lies along joint $i$'s axis. $x_i$ lies along the common normal from
# $z_{i-1}$ to $z_i$ (any perpendicular to both where they intersect, pointing from one to the other where they are
# parallel). The $\theta_i$ offset is the angle from $x_{i-1}$ to $x_i$ about $z_{i-1}$ when $q_i = 0$ (the joint
# at its zero), $d_i$ the distance along $z_{i-1}$, $a_i$ the distance along $x_i$, $\alpha_i$ the angle from $z_{i-1}$
# to $z_i$ about $x_i$.
#
# **Pinned by the kit** (so that everyone's chain ends in the same tool frame):
# * frame 0 is the **world** frame (on the board under the waist, $z_0$ up);
# * frame 5 sits on the **tool point**, with $z_5$ along the approach direction (out of the gripper) and, at home,
#   $x_5$ pointing **up** (world +z); the kit's fixed rotation `DH_TOOL_ROTATION` then relabels frame 5 into the
#   manufacturer's tool frame `ee_gripper_link`;
# * the signs are the manufacturer's: positive shoulder, elbow and wrist_angle tip the arm forward and down.
#
# **The geometry** (section 1 and the sketch below): the shoulder axis is $h_0$ above the board; the upper arm is an
# L, $L_1$ long from shoulder to elbow along its hypotenuse, tilted $\beta$ from vertical; the forearm is $L_2$ long and
# horizontal at home; the wrist_angle axis is $L_t$ from the tool point. Read the report's Section II.B for how its
# authors placed frame 2 along the hypotenuse.

# %%
h0 = 65.66 + 38.91                       # shoulder height (mm)
L1 = np.hypot(50.0, 200.0)               # upper arm, shoulder to elbow (mm)
beta = np.arctan2(50.0, 200.0)           # the L's angle from vertical (rad)
L2 = 200.0                               # forearm, elbow to wrist (mm)
Lt = 65.0 + 43.0 + 23.0 + 27.575         # wrist_angle axis to the tool point (mm)

pts = kinematics.joint_positions(robot.home)     # the manufacturer's joint points at home (PoX model)
fig, ax = plt.subplots(figsize=(8, 3.6))
ax.plot(pts[:, 1], pts[:, 2], "-", color="0.6", lw=6, solid_capstyle="round")
ax.axhline(0, color="peru", lw=4)
joints = (((0, h0), "shoulder (axis ⊙ out of the page)", "o"), ((pts[3, 1], pts[3, 2]), "elbow (⊙)", "o"),
          ((pts[4, 1], pts[4, 2]), "wrist_angle (⊙)", "o"), ((pts[6, 1], pts[6, 2]), "tool point", "s"))
for (y, z), name, marker in joints:
    ax.plot(y, z, marker, color="k", ms=8, mfc="w", mew=2)
    ax.annotate(name, (y, z), xytext=(6, 10), textcoords="offset points", fontsize=9)
ax.annotate("", (0, 60), (0, -10), arrowprops=dict(arrowstyle="->", lw=2, color="tab:purple"))
ax.text(6, 20, "waist axis (vertical)", color="tab:purple", fontsize=9)
ax.annotate("", (pts[6, 1] + 60, pts[6, 2]), (pts[6, 1], pts[6, 2]), arrowprops=dict(arrowstyle="->", lw=2,
                                                                                      color="tab:purple"))
ax.text(pts[6, 1] + 5, pts[6, 2] - 25, "wrist_rotate axis = approach", color="tab:purple", fontsize=9)
ax.plot([0, 0, pts[3, 1]], [h0, pts[3, 2], pts[3, 2]], ":", color="k", lw=1)
ax.text(-45, (h0 + pts[3, 2]) / 2, "200", fontsize=9)
ax.text(pts[3, 1] / 2 - 10, pts[3, 2] + 8, "50", fontsize=9)
ax.text(pts[3, 1] + 80, pts[3, 2] + 8, "L2 = 200", fontsize=9)
ax.text(pts[4, 1] + 40, pts[4, 2] + 8, "Lt", fontsize=9)
ax.text(-60, h0 / 2, "h0", fontsize=9)
ax.set(title="the RX200 at home, side view: joints and axes (no frames: you place them)", xlabel="world y (mm)",
       ylabel="world z (mm)", aspect="equal", xlim=(-80, 520), ylim=(-20, 380), yticks=range(0, 301, 100))
fig.tight_layout()

# %% [markdown]
# **Exercise `fk.dh_table` (8 points, code).** On paper, draw frames 0-5 on the sketch by the rules above; then write
# `dh_table(h0, L1, beta, L2, Lt)`: the (5, 4) array whose rows are (θ offset in rad, d in mm, a in mm, α in rad) for
# the waist, shoulder, elbow, wrist_angle and wrist_rotate, **as functions of the geometry** (the hidden checks try
# other arm geometries, so numbers copied from a file will not pass). The kit chains your table with your link
# transform; the check compares the tool pose with the manufacturer's PoX model (section 4) at random poses.

# %%
def dh_table(h0, L1, beta, L2, Lt):
    """RX200 DH rows (theta offset rad, d mm, a mm, alpha rad), (5, 4), for shoulder height h0, upper arm L1 tilted
    beta rad from vertical, forearm L2 and wrist-to-tool Lt (mm)."""
    # BEGIN SOLUTION fk.dh_table
    return np.array([
        [np.pi / 2, h0, 0.0, -np.pi / 2],
        [-(np.pi / 2 - beta), 0.0, L1, 0.0],
        [np.pi / 2 - beta, 0.0, L2, 0.0],
        [-np.pi / 2, 0.0, 0.0, -np.pi / 2],
        [0.0, Lt, 0.0, 0.0],
    ])
    # END SOLUTION


def fk_from_table(q, table):
    """Tool pose(s) (4, 4) or (N, 4, 4) for joints q (5,) or (N, 5) rad by chaining a DH table (5, 4) with the kit's
    dh_link_transform (the kit's fk_dh with the table in the robot model's place)."""
    return kinematics.fk_dh(q, replace(robot, dh=np.asarray(table, dtype=float)), check_limits=False)


def fk_of_lengths(h0, L1, beta, L2, Lt):
    """The forward kinematics q -> tool pose of an arm with these lengths: your dh_table chained link by link."""
    table = dh_table(h0, L1, beta, L2, Lt)
    return lambda q: fk_from_table(q, table)


def pox_of_lengths(h0, L1, beta, L2, Lt):
    """The stand-in while dh_table is blank: the manufacturer's PoX model (screw axes through the shoulder, elbow
    and wrist; the tool Lt beyond the wrist) with these lengths put in."""
    y_elbow, z_elbow = L1 * np.sin(beta), h0 + L1 * np.cos(beta)
    screws = np.array([[0, 0, 1, 0, 0, 0], [-1, 0, 0, 0, -h0, 0], [-1, 0, 0, 0, -z_elbow, y_elbow],
                       [-1, 0, 0, 0, -z_elbow, y_elbow + L2], [0, 1, 0, -z_elbow, 0, 0]], dtype=float)
    M = homogeneous(robot.M[:3, :3], [0.0, y_elbow + L2 + Lt, z_elbow])
    model = replace(robot, screws=screws, M=M)
    return lambda q: kinematics.fk_pox(q, model, check_limits=False)


# your dh_table; while it is blank the PoX model stands in for section 6's error maps (it says so once)
my_fk_of = with_reference(fk_of_lengths, "fk.dh_table", pox_of_lengths,
                          "section 6's error maps use the PoX model with those lengths")


try:
    table = dh_table(h0, L1, beta, L2, Lt)                  # yours only: the kit's table is never shown here
except ExerciseNotWritten:
    table = None
    print("dh_table is not written yet: write it above to see your table here and your frames below")
else:
    print("   theta_off(deg)   d(mm)     a(mm)  alpha(deg)")
    for name, (th, d, a, al) in zip(robot.joint_names, table):
        print(f"{name:13s} {np.degrees(th) + 0.0:6.2f} {d:9.3f} {a:9.3f} {np.degrees(al) + 0.0:7.1f}")

# %% [markdown]
# ### The frames of your table
#
# Drawn from your table at three poses: DH frame $i$'s $x$ axis (red) and $z$ axis (blue) where they lie in the arm's
# plane (an axis out of the page is drawn as a dot). Frames 3 and 4 share the wrist. While `dh_table` is blank only
# the links are drawn.

# %%
poses = {"home": robot.home, "sleep": robot.sleep, "grasp at (0, 280, 19)": np.array([0.0, 0.308, 0.23, 1.033, 0.0])}
label_offsets = {1: (-30, -8), 2: (-28, 6), 3: (-4, -22), 4: (10, 10), 5: (8, -20)}
fig, axes = plt.subplots(3, 1, figsize=(8, 9.6))
for ax, (title, q) in zip(axes, poses.items()):
    links = kinematics.joint_positions(q)
    ax.plot(links[:, 1], links[:, 2], "-", color="0.75", lw=5, solid_capstyle="round", zorder=1)
    frames = kinematics.dh_frames(q, replace(robot, dh=table), check_limits=False) if table is not None else []
    for i, F in enumerate(frames[1:6], start=1):
        o = F[:3, 3]
        for col, c in ((0, "tab:red"), (2, "tab:blue")):
            v = F[:3, col] * 60
            if np.hypot(v[1], v[2]) > 6:
                ax.annotate("", (o[1] + v[1], o[2] + v[2]), (o[1], o[2]), zorder=3,
                            arrowprops=dict(arrowstyle="-|>", lw=2, color=c, mutation_scale=14))
            else:
                ax.plot(o[1], o[2], "o", color=c, ms=7, mfc="w", mew=2, zorder=4)
        if i != 4 or not np.allclose(o, frames[4, :3, 3]):
            label = "3, 4" if i == 3 and np.allclose(o, frames[4, :3, 3]) else str(i)
            ax.annotate(label, (o[1], o[2]), xytext=label_offsets[i], textcoords="offset points", fontsize=10,
                        bbox=dict(boxstyle="round,pad=0.15", fc="w", ec="0.6"), zorder=5)
    ax.axhline(0, color="peru", lw=4, zorder=0)
    ax.set(title=f"{title}: q = {np.round(q, 2)} rad", ylabel="world z (mm)", aspect="equal", xlim=(-280, 540),
           ylim=(-30, 400))
for ax in axes:
    ax.set_xlabel("world y (mm)")
fig.tight_layout()

# %% [markdown]
# **Exercise `fk.q_frames` (3 points, written).** Look at your frames figure. (a) Frames 3 and 4 sit at the same
# point: what does frame 4 contribute to the chain, if it adds no length? (b) Like the report (Section II.B), frame
# 2's $x$ axis runs along the hypotenuse of the L-shaped upper arm. What would go wrong in the DH table if you tried
# to run $x_2$ along the 200 mm segment instead? Answer in two or three sentences each in the cell below.

# %% [markdown]
# <!-- BEGIN ANSWER fk.q_frames -->
# (a) Frame 4 adds no length but turns the z axis: the wrist_rotate joint turns about the approach direction, which
# is perpendicular to the wrist_angle axis, so DH needs a frame whose z lies along that new axis (alpha4 = -90°)
# before the last link can move along it (d5 = Lt). Without it, a link could only rotate about parallel axes.
# (b) The shoulder-to-elbow link is an L, not a straight segment: a DH link has only one length along x (a) and one
# along the previous z (d), and z1 is the shoulder axis, across the arm's plane. Along the 200 mm segment x2 would
# not end at the elbow axis: the 50 mm offset would have no parameter to go into, so the table could not put the
# elbow in the right place. Along the hypotenuse one length a2 = L1 reaches the elbow, and the tilt beta goes into
# the theta offsets of joints 2 and 3.
# <!-- END ANSWER -->

# %% [markdown]
# ## 4 · The manufacturer's product of exponentials
#
# The manufacturer's SDK does not use DH. It describes each joint by a **screw axis** $S_i = (\omega_i, v_i)$ in the
# space frame ($\omega$ the axis direction, $v = -\omega \times p$ for a point $p$ on the axis) and the tool pose at
# home $M$, and computes
#
# $$T(q) = e^{[S_1] q_1} e^{[S_2] q_2} \cdots e^{[S_5] q_5} M .$$
#
# Its numbers are in **metres** and in `base_link`: e.g. $S_3 = (0, 1, 0,\ -0.30457, 0, 0.05)$ is the elbow axis,
# along y, through the point $(0.05, 0, 0.30457)$. We convert them to the world frame (turn +90° about z) and to mm,
# and evaluate the product with `armlab.transforms.exp_se3` — nothing shared with the DH code.

# %%
S_base = np.array([[0, 0, 1, 0, 0, 0], [0, 1, 0, -0.10457, 0, 0], [0, 1, 0, -0.30457, 0, 0.05],
                   [0, 1, 0, -0.30457, 0, 0.25], [1, 0, 0, 0, 0.30457, 0]], float)
M_base = homogeneous(None, [0.408575, 0.0, 0.30457])
R_wb = rot_z(np.pi / 2)                              # base_link -> world (same origin)
S_world = np.hstack([S_base[:, :3] @ R_wb.T, 1000.0 * S_base[:, 3:] @ R_wb.T])   # rotate w and v, metres -> mm
M_world = homogeneous(R_wb, 1000.0 * R_wb @ M_base[:3, 3])


def fk_pox(Q):
    """Tool poses (N, 4, 4) by the product of exponentials, vectorised over joint vectors Q (N, 5)."""
    E = exp_se3(S_world, Q)                          # (N, 5, 4, 4)
    return E[:, 0] @ E[:, 1] @ E[:, 2] @ E[:, 3] @ E[:, 4] @ M_world


print("screw axes in the world frame (w, v in mm):")
print(S_world + 0.0)  # + 0.0 turns -0 into 0

# %% [markdown]
# ### Check: your DH table against the manufacturer's model

# %%
# CHECK fk.dh_table
Q = random_q(1000)
yours = dh_table(h0, L1, beta, L2, Lt)
assert np.shape(yours) == (5, 4), f"dh_table returned shape {np.shape(yours)}, expected (5, 4): one row per joint"
T_dh, T_pox = fk_from_table(Q, yours), fk_pox(Q)
home = fk_from_table(robot.home, yours)[:3, 3]
err_p = np.abs(T_dh[:, :3, 3] - T_pox[:, :3, 3]).max()
err_R = np.abs(T_dh[:, :3, :3] - T_pox[:, :3, :3]).max()
if not np.allclose(fk_from_table(Q[:50], yours), fk_pox(Q[:50]), atol=1e-6):   # name the cause where it can tell
    for i, j in np.ndindex(5, 4):
        other = np.array(yours, dtype=float)
        other[i, j] = -other[i, j]
        column = ("theta offset", "d", "a", "alpha")[j]
        assert other[i, j] == 0 or not np.allclose(fk_from_table(Q[:50], other), fk_pox(Q[:50]), atol=1e-6), \
            f"your table is right with row {i + 1}'s {column} negated: check its sign (which way z{i + 1} points)"
    for i, step in np.ndindex(5, 2):
        other = np.array(yours, dtype=float)
        other[i, 0] += (2 * beta, -2 * beta)[step]
        assert not np.allclose(fk_from_table(Q[:50], other), fk_pox(Q[:50]), atol=1e-6), \
            f"row {i + 1}'s theta offset is off by 2 beta: the L's tilt beta is taken off there where you add it " \
            "(or added where you take it off)"
assert np.allclose(home, [0, 408.575, 304.57], atol=1e-6), \
    f"your table puts the tool at {home.round(1)} mm at home, expected (0, 408.6, 304.6)"
assert err_p < 1e-6, f"your table's tool point is up to {err_p:.2g} mm off the PoX model at random poses: " \
    "check the theta offsets and the twists"
assert err_R < 1e-9, f"your table's tool orientation is up to {err_R:.2g} off the PoX model: check frame 5"
print("OK: your DH table matches the manufacturer's PoX model at 1000 random poses within 1e-6 mm")

# %% [markdown]
# ## 5 · Euler angles from a pose
#
# The report's `get_euler_angles_from_T` returns the tool's orientation as three **ZYZ Euler angles**
# $(\phi, \theta, \psi)$ with $R = R_z(\phi)\,R_y(\theta)\,R_z(\psi)$ (the rotation part of the 4×4 pose). Multiply
# the three rotations out on paper and find which entries of $R$ give $\theta$ and which pairs give $\phi$ and $\psi$
# (use `np.arctan2`, never `arccos`/`arcsin` alone). Take $\theta \in [0, \pi]$. Where $\sin\theta = 0$ only a sum or
# difference of $\phi$ and $\psi$ is defined: there set $\psi = 0$ and let $\phi$ carry the rotation.
#
# **Exercise `fk.euler` (5 points, code).** Write `euler_angles_from_T(T)` for one pose T (4, 4): the array
# (φ, θ, ψ) in rad.

# %%
def euler_angles_from_T(T):
    """ZYZ Euler angles (phi, theta, psi) rad of the rotation of pose T (4, 4): R = Rz(phi) Ry(theta) Rz(psi),
    theta in [0, pi]; psi = 0 where sin(theta) = 0."""
    # BEGIN SOLUTION fk.euler
    R = np.asarray(T, dtype=float)[:3, :3]
    sin_theta = np.hypot(R[0, 2], R[1, 2])
    theta = np.arctan2(sin_theta, R[2, 2])
    if sin_theta > 1e-12:
        phi = np.arctan2(R[1, 2], R[0, 2])
        psi = np.arctan2(R[2, 1], -R[2, 0])
    elif R[2, 2] > 0:
        phi, psi = np.arctan2(R[1, 0], R[0, 0]), 0.0
    else:
        phi, psi = np.arctan2(-R[1, 0], -R[0, 0]), 0.0
    return np.array([phi, theta, psi])
    # END SOLUTION


print("tool at home, ZYZ (deg):", np.degrees(euler_angles_from_T(kinematics.fk(robot.home))).round(2) + 0.0)

# %% [markdown]
# ### Check: Euler angles

# %%
# CHECK fk.euler
Q = random_q(300)
angles = np.array([euler_angles_from_T(T) for T in kinematics.fk(Q)])
assert angles.shape == (300, 3), f"euler_angles_from_T should return 3 angles, got shape {angles.shape[1:]}"
rebuilt = matrix_from_euler_zyz(angles)
R_tool = kinematics.fk(Q)[:, :3, :3]
err = np.abs(rebuilt - R_tool).max()
if err >= 1e-9:                        # name the cause where the check can tell it
    for k, name in enumerate(("phi", "theta", "psi")):
        for how, other in (("negated", -angles[:, k]), ("mirrored (pi minus it)", np.pi - angles[:, k])):
            fixed = angles.copy()
            fixed[:, k] = other
            assert np.abs(matrix_from_euler_zyz(fixed) - R_tool).max() > 1e-9, \
                f"your angles are right with {name} {how}: check the signs of the two entries of R it is read from"
turn = np.degrees(np.arccos(np.clip((np.einsum("nji,nji->n", rebuilt, R_tool) - 1) / 2, -1, 1))).max()
assert err < 1e-9, (f"Rz(phi) Ry(theta) Rz(psi) of your angles misses the tool's rotation by up to {turn:.2g} deg "
                    f"({err:.2g} in a rotation matrix entry, unitless)")
assert np.all((angles[:, 1] >= 0) & (angles[:, 1] <= np.pi)), "theta must lie in [0, pi]"
for a, flip in ((0.7, 0.0), (-2.0, np.pi)):                 # sin(theta) = 0: psi = 0, phi carries the rotation
    got = euler_angles_from_T(homogeneous(rot_z(a) @ rot_y(flip)))
    assert abs(got[2]) < 1e-12 and np.isclose(got[1], flip, atol=1e-12) and np.isclose(got[0], a, atol=1e-9), \
        f"at theta = {flip:.2f} expected (phi, theta, psi) = ({a}, {flip:.2f}, 0), got {np.round(got, 3)}: where " \
        "sin(theta) = 0 set psi = 0 and let phi carry the rotation (a singular case of its own)"
print("OK: your Euler angles rebuild the tool's rotation at 300 random poses within 1e-9 and the singular poses "
      "keep psi = 0")


# %% [markdown]
# ## 6 · The lab report's Table I: small numbers, real millimetres
#
# A lab report on this arm (ROB 550, AM Group 9) built the same DH table with slightly different lengths:
#
# | quantity | report | manufacturer |
# |---|---|---|
# | shoulder height $l_0 + l_1$ | 103.91 mm | 104.57 mm |
# | upper-arm hypotenuse $l_2$ | 205.73 mm | $\sqrt{50^2+200^2}$ = 206.155 mm |
# | wrist to tool $l_4 + l_5$ | 65 + 66 + 43.15/2 = 152.575 mm (other reports: 174.15) | 65 + 93.575 = 158.575 mm |
#
# (Their frames differ from ours — e.g. $\theta_2 = \theta_2^* + \pi/2 + \beta$ with $x_1$ pointing elsewhere — but
# the structure and $\beta = \arctan(50/200)$ are the same, so we drop their lengths into our table.) How far off is
# the tool point a model with those numbers predicts? We ask for every grid point of the board where the arm grasps a
# large block top-down — solve the joint angles with the true model, then run FK with the report's table — and for
# random poses anywhere in the workspace.

# %%
report_models = {"report, 152.575 mm": my_fk_of(103.91, 205.73, beta, L2, 152.575),
                 "other reports, 174.15 mm": my_fk_of(103.91, 205.73, beta, L2, 174.15)}
xs, ys = np.arange(-450.0, 451.0, 25.0), np.arange(-175.0, 476.0, 25.0)
X, Y = np.meshgrid(xs, ys)
targets = np.stack([X.ravel(), Y.ravel(), np.full(X.size, 19.0)], 1)   # half a large block above the board
sol = kinematics.ik_batch(targets, np.pi / 2)
print(f"{sol.success.sum()} of {len(targets)} grid points reachable top-down")

errors = {}
for name, fk_report in report_models.items():
    e = np.full(len(targets), np.nan)
    solved = sol.success
    e[solved] = np.linalg.norm(np.stack([fk_report(q)[:3, 3] for q in sol.q[solved]]) - targets[solved], axis=1)
    errors[name] = e.reshape(X.shape)
    Q = random_q(1000)                                                   # anywhere in the workspace
    e_any = np.linalg.norm(np.stack([fk_report(q)[:3, 3] for q in Q]) - kinematics.fk(Q)[:, :3, 3], axis=1)
    print(f"{name}: top-down grasps on the board off by {np.nanmin(e):.1f} to {np.nanmax(e):.1f} mm "
          f"(mean {np.nanmean(e):.1f}); 1000 random poses: {e_any.min():.1f} to {e_any.max():.1f} mm")

# %% [markdown]
# *Predict before you run the next cell* (write it at the top of your answer to `fk.q_table_error` below): the
# report's wrist-to-tool length is 6 mm shorter than the manufacturer's (the other reports' 15.6 mm longer). Over the
# board, where will the tool point of a top-down grasp be off most, and by how much?

# %%
fig, axes = plt.subplots(1, 2, figsize=(9, 3.4), sharey=True)
for ax, (name, e) in zip(axes, errors.items()):
    im = ax.pcolormesh(X, Y, e, shading="nearest", cmap="viridis", vmin=0, vmax=20)    # one scale for both
    ax.plot(0, 0, "r^", ms=8)
    ax.set(title=f"{name}: {np.nanmin(e):.1f}-{np.nanmax(e):.1f} mm", xlabel="world x (mm)", aspect="equal",
           xticks=range(-400, 401, 200))
axes[0].set_ylabel("world y (mm)")
fig.colorbar(im, ax=axes, shrink=0.85, label="tool point error (mm)")

# %% [markdown]
# **Exercise `fk.q_table_error` (3 points, written).** Compare the maps with your prediction. How does the error vary
# over the board, and how large is it for each wrist-to-tool length? Explain, from the pose of a top-down grasp, why
# it has this shape and why its size is not exactly the 6 (or 15.6) mm the length is off by. What does it mean for
# grasping a 25 mm block? (Your prediction, then three or four sentences.)

# %% [markdown]
# <!-- BEGIN ANSWER fk.q_table_error -->
# Prediction: largest far from the base, where the arm is stretched.
# Observed: the error is the same all over the board to within about 0.5 mm: 4.9 to 5.4 mm with 152.575 mm and
# 16.2 to 16.7 mm with 174.15 mm (one colour scale, 0-20 mm). A top-down grasp holds the tool axis vertical wherever the
# target is, so a wrong wrist-to-tool length moves the tool point straight up or down by the same amount everywhere;
# the report's 0.66 mm lower shoulder and 0.4 mm shorter hypotenuse add a smaller error of nearly the same size
# everywhere, which takes about 1 mm off the 6 mm and adds about 1 mm to the 15.6 mm. A few millimetres is half the
# clearance of a 25 mm block in the fingers: the model must use the manufacturer's lengths, and measured corrections
# (the gravity sag) go on top of it, not into it.
# <!-- END ANSWER -->

# %% [markdown]
# *Demonstration* (the kit's numbers, not graded): the errors stay within the range the maps show.

# %%
e1, e2 = (errors[name] for name in report_models)
ok = ~np.isnan(e1)
assert ok.sum() > 300, f"only {ok.sum()} board points were compared"
assert np.nanmin(e1) > 4.0 and np.nanmax(e1) < 7.0, "152.575 mm: expected about 5 mm of error"
assert np.nanmin(e2) > 15.0 and np.nanmax(e2) < 18.0, "174.15 mm: expected about 16.5 mm of error"
print(f"OK: Table I's numbers misplace a top-down grasp by {np.nanmin(e1):.1f}-{np.nanmax(e1):.1f} mm "
      f"(174.15 mm variant: {np.nanmin(e2):.1f}-{np.nanmax(e2):.1f} mm) at {ok.sum()} board points")

# %% [markdown]
# ## Your rubric
#
# The table below is read from the saved notebook and package (save first): it lists this notebook's exercises,
# their points, how they are graded and whether each is still blank. `python -m armlab check` runs the checks.

# %%
rubric("02")
