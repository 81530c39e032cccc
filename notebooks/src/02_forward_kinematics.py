# %% [markdown]
# # 02 · Forward kinematics: from joint angles to the tool pose
#
# Forward kinematics (FK) answers: *with the joints at $q = (q_1, \dots, q_5)$, where is the tool and which way does it
# point?* In this notebook you
# 1. place a frame on every joint of the RX200 and read the arm's geometry off the manufacturer's description,
# 2. build the **Denavit–Hartenberg (DH) table** step by step and write the DH link transform and the chain yourself,
# 3. cross-check it against the manufacturer's own **product-of-exponentials (PoX)** model,
# 4. see what the slightly different numbers of a real lab report (Table I) cost in millimetres at the tool.
#
# Units: millimetres and radians. Frames: the world (board) frame, origin on the board below the waist axis, +y away
# from the robot, +z up.

# %%
import numpy as np
import matplotlib.pyplot as plt
from IPython import get_ipython

from armlab import kinematics
from armlab.exercises import references, require_written, with_reference
from armlab.robot import DH_TOOL_ROTATION, rx200
from armlab.transforms import exp_se3, homogeneous, rot_z

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
# ## 2 · The DH table, step by step
#
# Standard DH puts joint $i$'s axis on $z_{i-1}$ and describes link $i$ by four numbers: rotate $\theta_i$ about $z$,
# move $d_i$ along $z$, move $a_i$ along the new $x$, twist $\alpha_i$ about the new $x$:
#
# $$A_i = R_z(\theta_i)\,T_z(d_i)\,T_x(a_i)\,R_x(\alpha_i), \qquad \theta_i = q_i + \theta_i^{\text{offset}},
# \qquad T_{world,5} = A_1 A_2 A_3 A_4 A_5 .$$
#
# Reading the geometry off the table above:
#
# * **Shoulder height.** The shoulder axis sits $65.66 + 38.91 = 104.57$ mm above the board: $d_1 = 104.57$. The
#   waist turns about world $z$; a twist $\alpha_1 = -90°$ lays $z_1$ horizontal, along the shoulder axis, and the
#   offset $\theta_1^{\text{offset}} = +90°$ makes $x_1$ point along world +y at home.
# * **The L-shaped upper arm.** From the shoulder to the elbow the arm goes 50 mm forward and 200 mm up. DH wants a
#   straight link, so $x_2$ runs along the hypotenuse: $a_2 = \sqrt{50^2 + 200^2} = 206.155$ mm, tilted
#   $\beta = \arctan(50/200) = 14.04°$ from vertical, i.e. $90° - \beta$ above horizontal:
#   $\theta_2^{\text{offset}} = -(90° - \beta)$ (negative: our positive shoulder tips the arm *down*).
# * **Forearm.** The forearm is horizontal at home, so the elbow undoes that tilt: $\theta_3^{\text{offset}} =
#   +(90° - \beta)$, $a_3 = 200$ mm.
# * **Wrist to tool.** The wrist_angle joint needs no length but must turn $z$ onto the approach direction for the
#   wrist_rotate joint: $\theta_4^{\text{offset}} = -90°$, $\alpha_4 = -90°$. Then $d_5 = 65 + 93.575 = 158.575$ mm
#   from the wrist_angle axis to the tool point.
#
# Finally a fixed rotation relabels the DH axes into the tool frame `ee_gripper_link` (tool x = approach = $z_5$).

# %%
h0 = 65.66 + 38.91                       # shoulder height (mm)
L1 = np.hypot(50.0, 200.0)               # upper arm, shoulder to elbow (mm)
beta = np.arctan2(50.0, 200.0)           # the L's angle from vertical (rad)
L2 = 200.0                               # forearm, elbow to wrist (mm)
Lt = 65.0 + 43.0 + 23.0 + 27.575         # wrist_angle axis to the tool point (mm)


def dh_table(h0, L1, beta, L2, Lt):
    """RX200 DH rows (theta_offset rad, d mm, a mm, alpha rad) for the given geometry."""
    return np.array([
        [np.pi / 2, h0, 0.0, -np.pi / 2],
        [-(np.pi / 2 - beta), 0.0, L1, 0.0],
        [np.pi / 2 - beta, 0.0, L2, 0.0],
        [-np.pi / 2, 0.0, 0.0, -np.pi / 2],
        [0.0, Lt, 0.0, 0.0],
    ])


table = dh_table(h0, L1, beta, L2, Lt)
print(f"beta = {np.degrees(beta):.2f} deg, L1 = {L1:.3f} mm")
print("   theta_off(deg)   d(mm)     a(mm)  alpha(deg)")
for name, (th, d, a, al) in zip(robot.joint_names, table):
    print(f"{name:13s} {np.degrees(th):6.2f} {d:9.3f} {a:9.3f} {np.degrees(al):7.1f}")

# %%
assert np.allclose(table, robot.dh, atol=1e-12), "the hand-built table differs from data/rx200_dh.csv"
print("OK: the hand-built DH table equals the kit's data/rx200_dh.csv")

# %% [markdown]
# ### Exercise: the DH link transform and the chain
#
# Write `dh_transform(theta, d, a, alpha)`, the 4×4 matrix $R_z(\theta)\,T_z(d)\,T_x(a)\,R_x(\alpha)$, and
# `fk_from_table(q, table)`, which chains the five links (adding each joint's offset) and finishes with the fixed
# tool rotation `DH_TOOL_ROTATION`:
#
# $$A = \begin{bmatrix} c_\theta & -s_\theta c_\alpha & s_\theta s_\alpha & a c_\theta \\
# s_\theta & c_\theta c_\alpha & -c_\theta s_\alpha & a s_\theta \\ 0 & s_\alpha & c_\alpha & d \\ 0 & 0 & 0 & 1
# \end{bmatrix}$$

# %%
def dh_transform(theta, d, a, alpha):
    """4x4 DH link transform Rz(theta) Tz(d) Tx(a) Rx(alpha); lengths in mm, angles in rad."""
    # BEGIN SOLUTION fk.dh_transform
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct],
                     [st, ct * ca, -ct * sa, a * st],
                     [0.0, sa, ca, d],
                     [0.0, 0.0, 0.0, 1.0]])
    # END SOLUTION


def fk_from_table(q, table):
    """Tool pose (4, 4) in the world for joint angles q (5,) rad and a DH table (5, 4)."""
    # BEGIN SOLUTION fk.fk_from_table
    T = np.eye(4)
    for qi, (offset, d, a, alpha) in zip(q, table):
        T = T @ dh_transform(qi + offset, d, a, alpha)
    return T @ homogeneous(DH_TOOL_ROTATION)
    # END SOLUTION


print("tool point at home (mm):", fk_from_table(robot.home, table)[:3, 3].round(1))

# %%
# CHECK fk.dh_transform fk.fk_from_table
Q = random_q(1000)
ours = np.stack([fk_from_table(q, table) for q in Q])
err = np.abs(ours[:, :3, 3] - kinematics.fk(Q)[:, :3, 3]).max()
home = fk_from_table(robot.home, table)[:3, 3]
assert np.allclose(home, [0, 408.575, 304.57], atol=1e-9), \
    f"tool point {home.round(1)} mm at the home pose, expected (0, 408.6, 304.6): check the signs of theta and alpha"
assert err < 1e-9, f"your tool point is up to {err:.2g} mm off kinematics.fk: check the order of Rz, Tz, Tx, Rx"
assert np.allclose(ours[:, :3, :3], kinematics.fk(Q)[:, :3, :3], atol=1e-12), "the tool orientation is off"
print("OK: your FK matches armlab.kinematics.fk at 1000 random poses within 1e-9 mm")

# %% [markdown]
# ## 3 · A side view of the frames
#
# `kinematics.link_frames(q)` returns every DH frame in the world; `kinematics.joint_positions(q)` the points the
# links run between. With the waist at 0 the arm's plane is the world y–z plane; the arrows show DH frame $i$'s x
# (red) and z (blue) axes where they lie in that plane (the shoulder, elbow and wrist axes $z_1, z_2, z_3$ point out
# of the page). Frames 3 and 4 share the wrist; frame 5 sits on the tool point with $z_5$ along the approach.

# %%
poses = {"home": robot.home, "sleep": robot.sleep, "grasp at (0, 280, 19)": np.array([0.0, 0.308, 0.23, 1.033, 0.0])}
fig, axes = plt.subplots(1, 3, figsize=(9, 3.4), sharey=True)
for ax, (title, q) in zip(axes, poses.items()):
    pts = kinematics.joint_positions(q)
    frames = kinematics.link_frames(q)
    ax.plot(pts[:, 1], pts[:, 2], "-o", color="0.3", lw=3, ms=5)
    for i, F in enumerate(frames[1:6], start=1):
        o = F[:3, 3]
        ax.annotate(str(i), (o[1], o[2]), xytext=(-14 + 10 * (i == 4), -14), textcoords="offset points", fontsize=9)
        for col, c in ((0, "tab:red"), (2, "tab:blue")):
            v = F[:3, col] * 40
            if np.hypot(v[1], v[2]) > 1:  # skip axes pointing out of the page
                ax.arrow(o[1], o[2], v[1], v[2], color=c, width=1.5, length_includes_head=True)
    ax.axhline(0, color="peru", lw=4)
    ax.set(title=f"{title}\nq = {np.round(q, 2)}", xlabel="world y (mm)", aspect="equal", xlim=(-240, 460),
           ylim=(-20, 420))
axes[0].set_ylabel("world z (mm)")
fig.tight_layout()

# %% [markdown]
# The frames obey their definitions: frame 1 sits on the shoulder axis whatever the joints do, the links have the
# manufacturer's lengths, and everything below the waist stays in the arm's plane.

# %%
# CHECK fk.dh_link_transform
require_written("fk.dh_link_transform")
Q = random_q(1000)
P = kinematics.joint_positions(Q)
lengths = np.linalg.norm(np.diff(P, axis=1), axis=-1)
expected = [65.66, 38.91, L1, L2, 65.0, Lt - 65.0]
heading = Q[:, 0] + np.pi / 2
across = np.stack([-np.sin(heading), np.cos(heading), np.zeros(len(Q))], 1)
assert np.allclose(lengths, expected, atol=1e-9), f"link lengths {np.round(lengths[0], 3)} mm, expected {expected}"
assert np.allclose(kinematics.link_frames(Q)[:, 1, :3, 3], [0, 0, h0], atol=1e-9), "the shoulder is not at (0, 0, h0)"
assert np.abs(np.sum(P * across[:, None], axis=-1)).max() < 1e-9, "a joint leaves the arm's vertical plane"
print(f"OK: link lengths {np.round(expected, 3).tolist()} mm and the arm's plane hold at 1000 random poses")

# %% [markdown]
# ## 4 · Cross-check: the manufacturer's product of exponentials
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

# %%
# CHECK fk.dh_link_transform
require_written("fk.dh_link_transform")
Q = random_q(1000)
T_dh, T_pox = kinematics.fk(Q), fk_pox(Q)
err_p = np.abs(T_dh[:, :3, 3] - T_pox[:, :3, 3]).max()
err_R = np.abs(T_dh[:, :3, :3] - T_pox[:, :3, :3]).max()
assert err_p < 1e-9, f"DH and PoX tool points differ by {err_p:.2g} mm at random poses"
assert err_R < 1e-12, f"DH and PoX tool orientations differ by {err_R:.2g}"
print("OK: FK matches the manufacturer's PoX model at 1000 random poses within 1e-9 mm and 1e-12 in rotation")

# %% [markdown]
# ## 5 · The lab report's Table I: small numbers, real millimetres
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
report_tables = {"report, 152.575 mm": dh_table(103.91, 205.73, beta, L2, 152.575),
                 "other reports, 174.15 mm": dh_table(103.91, 205.73, beta, L2, 174.15)}
xs, ys = np.arange(-450.0, 451.0, 25.0), np.arange(-175.0, 476.0, 25.0)
X, Y = np.meshgrid(xs, ys)
targets = np.stack([X.ravel(), Y.ravel(), np.full(X.size, 19.0)], 1)   # half a large block above the board
sol = kinematics.ik_batch(targets, np.pi / 2)
print(f"{sol.success.sum()} of {len(targets)} grid points reachable top-down")

# your fk_from_table; while it is blank the kit's DH chain stands in (it says so once)
chain = with_reference(fk_from_table, "fk.fk_from_table", references.fk_by_kit_dh,
                       "the report's tables go through the kit's DH chain")
errors = {}
for name, tab in report_tables.items():
    e = np.full(len(targets), np.nan)
    solved = sol.success
    e[solved] = np.linalg.norm(np.stack([chain(q, tab)[:3, 3] for q in sol.q[solved]]) - targets[solved],
                               axis=1)
    errors[name] = e.reshape(X.shape)
    Q = random_q(1000)                                                   # anywhere in the workspace
    e_any = np.linalg.norm(np.stack([chain(q, tab)[:3, 3] for q in Q]) - kinematics.fk(Q)[:, :3, 3], axis=1)
    print(f"{name}: top-down grasps on the board off by {np.nanmin(e):.1f} to {np.nanmax(e):.1f} mm "
          f"(mean {np.nanmean(e):.1f}); 1000 random poses: {e_any.min():.1f} to {e_any.max():.1f} mm")

# %%
fig, axes = plt.subplots(1, 2, figsize=(9, 3.2))
for ax, (name, e) in zip(axes, errors.items()):
    im = ax.pcolormesh(X, Y, e, shading="nearest", cmap="viridis")
    ax.plot(0, 0, "r^", ms=8)
    ax.set(title=f"{name}: |error| (mm)", xlabel="world x (mm)", ylabel="world y (mm)", aspect="equal")
    fig.colorbar(im, ax=ax, shrink=0.8)
fig.tight_layout()

# %% [markdown]
# For top-down grasps the tool axis is vertical, so a wrong wrist-to-tool length shows up almost one-for-one as a
# height error (6 mm short, or 15.6 mm long), combined with the 0.66 mm lower shoulder and the 0.4 mm shorter
# hypotenuse (which move the tool the other way for the short variant: about 5 and 16.5 mm in all). A few millimetres
# is half the clearance of a 25 mm block in the gripper: the model must use the manufacturer's numbers, and measured
# corrections (gravity sag) belong on top of it, not in it.

# %%
e1, e2 = (errors[name] for name in report_tables)
ok = ~np.isnan(e1)
assert ok.sum() > 300, f"only {ok.sum()} board points were compared"
assert np.nanmin(e1) > 4.0 and np.nanmax(e1) < 7.0, "152.575 mm: expected about 5 mm of error"
assert np.nanmin(e2) > 15.0 and np.nanmax(e2) < 18.0, "174.15 mm: expected about 16.5 mm of error"
print(f"OK: Table I's numbers misplace a top-down grasp by {np.nanmin(e1):.1f}-{np.nanmax(e1):.1f} mm "
      f"(174.15 mm variant: {np.nanmin(e2):.1f}-{np.nanmax(e2):.1f} mm) at {ok.sum()} board points")
