# %% [markdown]
# # 03 · Inverse kinematics: from a grasp to joint angles
#
# Inverse kinematics (IK) runs FK backwards: *given where the tool should be and how it should point, which joint
# angles put it there?* The RX200 has 5 joints, so we cannot ask for any pose: we ask for a **position**
# $(x, y, z)$, a **pitch** $\psi$ (the approach direction's angle below horizontal, in the vertical plane through the
# base axis and the target: 0 = horizontal, $\pi/2$ = straight down) and a **roll** (the wrist_rotate angle).
# In this notebook you
# 1. derive the closed-form solution geometrically and write its planar core yourself,
# 2. draw the four branches (waist facing or flipped × elbow up or down) and see which the joint limits allow,
# 3. map which board cells can be grasped straight down, and how steep the approach can be elsewhere,
# 4. compare with the lab report's equations (4)–(14).
#
# Units: millimetres and radians; world (board) frame.

# %%
import numpy as np
import matplotlib.pyplot as plt
from IPython import get_ipython

from armlab import kinematics
from armlab.exercises import references, require_written, with_reference
from armlab.lab import lab_config
from armlab.robot import rx200

get_ipython().run_line_magic("matplotlib", "inline")  # figures appear below their cell
from armlab.viz.figures import readable

readable()                                             # figure size and fonts readable at 100 % zoom
np.set_printoptions(precision=3, suppress=True)
robot = rx200()
lab = lab_config()
rng = np.random.default_rng(3)

h0 = robot.dh[0, 1]                 # shoulder height, 104.57 mm
L1 = robot.dh[1, 2]                 # upper arm (hypotenuse of the 50 x 200 mm L), 206.155 mm
L2 = robot.dh[2, 2]                 # forearm, 200 mm
Lt = robot.dh[4, 1]                 # wrist_angle axis to the tool point, 158.575 mm
beta = np.arctan2(50.0, 200.0)      # the L's angle from vertical
print(f"h0 = {h0:.2f} mm, L1 = {L1:.3f} mm, L2 = {L2:.1f} mm, Lt = {Lt:.3f} mm, beta = {np.degrees(beta):.2f} deg")

# %% [markdown]
# ## 1 · The geometry
#
# **Waist.** Everything below the waist moves in one vertical plane, so the waist must turn that plane through the
# target. At home the arm points along +y, and positive waist turns it towards −x:
#
# $$q_1 = \operatorname{atan2}(y, x) - \tfrac{\pi}{2} \quad\text{(facing)}, \qquad q_1 + \pi \quad\text{(flipped:
# the arm reaches backwards over its own base)}.$$
#
# **Wrist centre.** In the arm's plane let $r = \sqrt{x^2 + y^2}$ be the distance from the base axis and $z$ the
# height. The wrist_angle axis sits $L_t$ behind the tool point along the approach direction, which points
# $\psi$ below horizontal; relative to the shoulder (height $h_0$) the wrist centre is at
#
# $$r_w = r - L_t \cos\psi, \qquad z_w = z - h_0 + L_t \sin\psi .$$
#
# **Law of cosines.** Shoulder, elbow and wrist centre form a triangle with sides $L_1$, $L_2$ and
# $d = \sqrt{r_w^2 + z_w^2}$. The forearm's angle $\delta$ from the upper arm's line satisfies
#
# $$\cos\delta = \frac{d^2 - L_1^2 - L_2^2}{2 L_1 L_2}, \quad |\cos\delta| \le 1 \iff |L_1 - L_2| \le d \le L_1 + L_2,$$
#
# two solutions $\pm\delta$: **elbow up** ($\delta < 0$, the forearm bends down from an upper arm raised above the
# shoulder–wrist line) and **elbow down**. The upper arm's elevation above horizontal is
# $\varepsilon = \operatorname{atan2}(z_w, r_w) - \operatorname{atan2}(L_2 \sin\delta, L_1 + L_2 \cos\delta)$.
#
# **The 50 mm offset.** The upper arm is L-shaped: at $q_2 = 0$ its hypotenuse is raised $\pi/2 - \beta$, and the
# forearm is then horizontal, so the elbow joint angle also carries $\pi/2 - \beta$. With positive joints tipping
# the arm down:
#
# $$q_2 = \left(\tfrac{\pi}{2} - \beta\right) - \varepsilon, \qquad q_3 = -\delta - \left(\tfrac{\pi}{2} - \beta\right),
# \qquad q_4 = \psi - q_2 - q_3, \qquad q_5 = \text{roll}.$$
#
# ### Exercise: the planar core
#
# Write `planar_ik(r, z, psi, elbow_up)`: joints 2–4 (rad) for a target at distance `r` (mm) in front of the arm
# (negative = behind it) and height `z` (mm), approached at `psi` below the arm's forward horizontal. Return NaNs when
# the wrist centre is out of reach. It must work on numpy arrays.

# %%
def planar_ik(r, z, psi, elbow_up=True):
    """(q2, q3, q4) rad in the arm's plane; NaN where the wrist centre is out of reach. r, z mm; psi rad."""
    # BEGIN SOLUTION ik.planar_ik
    rw = r - Lt * np.cos(psi)
    zw = z - h0 + Lt * np.sin(psi)
    cos_delta = (rw**2 + zw**2 - L1**2 - L2**2) / (2 * L1 * L2)
    delta = np.arccos(np.where(np.abs(cos_delta) <= 1, cos_delta, np.nan)) * (-1 if elbow_up else 1)
    elevation = np.arctan2(zw, rw) - np.arctan2(L2 * np.sin(delta), L1 + L2 * np.cos(delta))
    q2 = (np.pi / 2 - beta) - elevation
    q3 = -delta - (np.pi / 2 - beta)
    q4 = psi - q2 - q3
    return q2, q3, q4
    # END SOLUTION


def wrap(a):
    """Angles wrapped to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(a), 2 * np.pi)


def four_branches(p, pitch, roll=0.0, solve=None):
    """All four candidate joint vectors (4, 5) for target p (mm): facing/flipped x elbow up/down (NaN = no reach),
    each from solve(r, z, psi, elbow_up) (default: your planar_ik).

    Flipping the waist mirrors the arm's plane: the target is then at -r, the approach at pi - pitch from the arm's
    forward horizontal, and what looks like elbow up from the target's side is the arm's elbow-down solution."""
    x, y, z = p
    r, q1 = np.hypot(x, y), np.arctan2(y, x) - np.pi / 2
    rows = []
    for flipped in (False, True):
        for up in (True, False):
            args = (-r, z, np.pi - pitch, not up) if flipped else (r, z, pitch, up)
            rows.append([q1 + np.pi * flipped, *(solve or planar_ik)(*args), roll])
    return wrap(np.array(rows))


BRANCHES = ["facing, elbow up", "facing, elbow down", "flipped, elbow up", "flipped, elbow down"]
print(np.round(four_branches([150.0, 200.0, 60.0], 0.8), 3) + 0.0)  # + 0.0 turns -0 into 0

# %% [markdown]
# Check: FK of every branch that is in reach must land on the target with the requested pitch, over many random
# targets (made by FK of random joint angles, so they are reachable).

# %%
# CHECK ik.planar_ik
Q = rng.uniform(robot.lower, robot.upper, (2000, 5))
T = kinematics.fk(Q)
P, approach = T[:, :3, 3], T[:, :3, 0]
radial = P[:, :2] / np.linalg.norm(P[:, :2], axis=1, keepdims=True)
pitches = np.arctan2(-approach[:, 2], np.sum(approach[:, :2] * radial, axis=1))
worst, found = 0.0, 0
for p, pitch, q in zip(P, pitches, Q):
    cand = four_branches(p, pitch, q[4])
    cand = cand[~np.isnan(cand).any(axis=1)]
    Tc = kinematics.fk(cand, check_limits=False)
    worst = max(worst, np.abs(Tc[:, :3, 3] - p).max())
    assert np.allclose(Tc[:, :3, 0], kinematics.fk(q)[:3, 0], atol=1e-9), \
        f"a branch for target {p.round(1)} mm points the tool another way: check q4 = psi - q2 - q3"
    found += np.abs(wrap(cand - q)).max(axis=1).min() < 1e-9
assert worst < 1e-9, f"a branch misses its target by {worst:.2g} mm: check the law of cosines and the wrist angle"
assert found == len(Q), f"the original joints are among the branches for only {found} of {len(Q)} targets"
print(f"OK: planar_ik: every branch lands on its target (within 1e-9 mm) and the original joint angles are "
      f"among the branches for all {found} targets")

# %% [markdown]
# ## 2 · Four branches, side by side
#
# Each target has up to four solutions. Which ones the arm can use depends on the joint limits. `kinematics.ik`
# returns only those within limits, best first: elbow up before elbow down, then the least motion from the current
# joint angles. Below: a target at (60, 380, 60) mm near the edge of the top-down reach, approached straight down,
# seen from the side in the vertical plane through the base axis and the target (horizontal axis: distance towards
# the target). From the side a flipped branch draws the same shape as its facing twin: the waist turned half a turn,
# the shoulder leaning back past vertical and the wrist rolled over. Only the joint limits tell them apart.

# %%
# your planar_ik; while it is blank the kit's numerical reference draws the branches (it says so once)
planar = with_reference(planar_ik, "ik.planar_ik", references.planar_ik_numerical,
                        "the branches come from a numerical solve on the kit's FK")
target, pitch = np.array([60.0, 380.0, 60.0]), np.pi / 2
cand = four_branches(target, pitch, solve=planar)
u = np.append(target[:2] / np.linalg.norm(target[:2]), 0.0)
fig, axes = plt.subplots(2, 2, figsize=(9, 6.6), sharey=True)
axes = axes.ravel()
for ax, name, q in zip(axes, BRANCHES, cand):
    pts = kinematics.joint_positions(q)
    bad = robot.limit_violations(q)
    ax.plot(pts @ u, pts[:, 2], "-o", lw=3, ms=4, color="tab:red" if bad else "tab:green")
    ax.plot(target @ u, target[2], "kx", ms=10, mew=2)
    ax.axhline(0, color="peru", lw=4)
    verdict = "OK" if not bad else "breaks " + ", ".join(b.split(" = ")[0] for b in bad)
    degrees = np.round(np.degrees(q[:4])).astype(int)
    ax.set_title(f"{name}\nq1-4 = {degrees} deg\n{verdict}")
    ax.set(xlabel="towards the target (mm)", aspect="equal", xlim=(-120, 430), ylim=(-40, 330))
for ax in axes[::2]:
    ax.set_ylabel("z (mm)")
fig.tight_layout()

# %%
# CHECK ik.candidates
require_written("ik.candidates")
solutions = kinematics.ik(target, pitch)
order = ["facing, elbow up", "flipped, elbow up", "facing, elbow down"]   # elbow up first, then least motion
within = [name for name, q in zip(BRANCHES, cand) if not robot.limit_violations(q)]
assert within == sorted(order, key=BRANCHES.index), \
    f"the branches within the joint limits are {within}, expected {sorted(order, key=BRANCHES.index)}"
assert np.allclose(solutions, [cand[BRANCHES.index(name)] for name in order]), \
    "kinematics.ik's solutions are not your branches in the order elbow up first, then least motion"
print(f"OK: kinematics.ik returns {len(solutions)} solutions, in the order {order}")

# %% [markdown]
# ## 3 · Which board cells can be grasped straight down?
#
# For a top-down grasp ($\psi = \pi/2$) the wrist centre sits right above the target, $L_t$ higher, so the law of
# cosines caps the reach at
#
# $$r_{\max} = \sqrt{(L_1 + L_2)^2 - (z + L_t - h_0)^2}.$$
#
# Beyond it the arm must tilt the gripper: the **steepest pitch** that still works is the fallback (a long-reach
# grasp at 60° still picks a block). `kinematics.ik_batch` solves many targets in one vectorised call, so the whole
# board × a ladder of pitches is a single call.

# %%
z_grasp = lab.block_edges_mm["large"] / 2
xs = np.arange(lab.board_x[0], lab.board_x[1] + 1, 20.0)        # includes x = 0
ys = np.arange(lab.board_y[0], lab.board_y[1] + 1, 20.0)
X, Y = np.meshgrid(xs, ys)
cells = np.stack([X.ravel(), Y.ravel(), np.full(X.size, z_grasp)], 1)
ladder = np.radians(np.arange(90.0, -0.1, -1.0))           # 90, 89, ..., 0 deg
res = kinematics.ik_batch(np.repeat(cells, len(ladder), 0), np.tile(ladder, len(cells)))
ok = res.success.reshape(len(cells), len(ladder))
steepest = np.where(ok.any(1), ladder[np.argmax(ok, axis=1)], np.nan).reshape(X.shape)
top_down = ok[:, 0].reshape(X.shape)
r_max = np.sqrt((L1 + L2) ** 2 - (z_grasp + Lt - h0) ** 2)
print(f"{len(cells)} cells x {len(ladder)} pitches solved in one call; r_max for top-down grasps = {r_max:.1f} mm")
print(f"top-down: {top_down.mean():.0%} of the board; some pitch: {np.isfinite(steepest).mean():.0%}")

# %%
fig, ax = plt.subplots(figsize=(8, 5))
im = ax.pcolormesh(X, Y, np.degrees(steepest), shading="nearest", cmap="viridis", vmin=0, vmax=90)
ax.contour(X, Y, top_down.astype(float), levels=[0.5], colors="white", linewidths=1.5)
a = np.linspace(0, np.pi, 100)
ax.plot(r_max * np.cos(a), r_max * np.sin(a), "r--", lw=1, label=f"r_max = {r_max:.0f} mm")
ax.plot(0, 0, "r^", ms=9)
ax.set(title="steepest approach pitch per board cell (deg); white: top-down boundary", xlabel="world x (mm)",
       ylabel="world y (mm)", aspect="equal")
ax.legend(loc="lower right")
fig.colorbar(im, ax=ax, shrink=0.8)
fig.tight_layout()

# %% [markdown]
# The top-down region is the disc of radius $r_{\max}$, with one exception: the column straight behind the base
# ($x = 0$, $y < 0$) needs the waist at exactly ±180°, and the manufacturer's limits stop $10^{-5}$ rad short (right
# next to the base the flipped waist still reaches back over it; a millimetre to the side works everywhere). Beyond
# $r_{\max}$ the pitch falls smoothly until even a horizontal approach cannot reach (the corners of the board).
# `kinematics.steepest_pitch(p)` finds the boundary for one target to $10^{-7}$ rad by bisection.

# %%
# CHECK ik.candidates
require_written("ik.candidates")
r_cells = np.hypot(X, Y)
behind = (X == 0) & (Y < 0)
assert np.all(top_down[(r_cells < r_max - 15) & ~behind]), "a cell well inside r_max cannot be reached top-down"
assert not np.any(top_down[r_cells > r_max + 1e-9]), "a cell beyond r_max is reached top-down"
assert behind.sum() >= 8 and not np.any(top_down[behind & (r_cells > 50)]), \
    "a cell behind the base, more than 50 mm out, is reached top-down"
assert top_down[behind & (r_cells < 20)].all(), "a cell right at the base axis is not reached top-down"
for p in cells[np.isfinite(steepest.ravel()) & ~top_down.ravel()][::40]:
    s = kinematics.steepest_pitch(p)
    assert abs(s - steepest.ravel()[np.all(cells == p, axis=1)][0]) < np.radians(1) + 1e-9, \
        f"steepest_pitch at {p.round(0)} mm disagrees with the 1-degree ladder"
    _ = kinematics.ik(p, s)                                     # reachable at its steepest pitch ...
    try:
        kinematics.ik(p, s + 1e-6)                              # ... and not a hair steeper
        raise AssertionError("a steeper pitch worked")
    except kinematics.Unreachable:
        pass
print(f"OK: top-down grasps reach exactly the r < {r_max:.1f} mm disc (minus the line straight behind the base); "
      "steepest_pitch agrees with the map")

# %% [markdown]
# When a grasp fails, `kinematics.ik` says why — out of reach (how far), or which joint limit each branch breaks:

# %%
for p, pitch in [((0.0, 450.0, 19.0), np.pi / 2), ((0.0, -150.0, 19.0), np.pi / 2)]:
    try:
        kinematics.ik(p, pitch)
    except kinematics.Unreachable as e:
        print(str(e)[:300], "...\n" if len(str(e)) > 300 else "\n")

# %% [markdown]
# ## 4 · The lab report's equations (4)–(14)
#
# The report (ROB 550, AM Group 9) derives the same solution:
#
# * (4) $\theta_1 = \tan^{-1}(-x_e / y_e)$ and (5) the same $+\pi$ — **dropped** ("the arm mostly needs to be within
#   quadrants I and II"). With a one-argument $\tan^{-1}$, (4) alone is right only for $y_e > 0$; behind the base it
#   turns the arm away from the target.
# * (6)–(9) the wrist centre: $r_c = r_e - l_5 \cos\psi$ in (8) uses $l_5$ where (7) uses $l_4 + l_5$ for $z_c$ —
#   both need the full wrist-to-tool length $L_t$.
# * (10)–(11) the law of cosines — only **elbow up** kept; (12)–(13) the offset angle $\beta$; (14) $\theta_4 = \psi
#   - \theta_2 - \theta_3$; $\theta_5 = 0$ (no roll, so blocks cannot be grasped at their yaw).
#
# Here is that solution with the manufacturer's lengths (and $L_t$ in both (7) and (8)), against `kinematics.ik`,
# over the board at the steepest working pitch of each cell:

# %%
def report_ik(p, psi):
    """The report's equations (4), (6)-(14): waist from (4) only, elbow up only, wrist_rotate 0."""
    x, y, z = np.asarray(p, dtype=float).T
    theta1 = np.arctan(-x / y)                                # (4); (5) dropped
    r_e = np.sqrt((-x) ** 2 + y**2)                           # (6)
    q2, q3, q4 = planar(r_e, z, psi, elbow_up=True)           # (7)-(14), your planar_ik
    return np.stack([theta1, q2, q3, q4, np.zeros_like(x)], -1)


reach = np.isfinite(steepest.ravel())
pts, psi = cells[reach], steepest.ravel()[reach]
q_report = report_ik(pts, psi)
finite = np.isfinite(q_report).all(1)
in_limits = finite & robot.within_limits(np.where(finite[:, None], q_report, 0.0))
err = np.full(len(pts), np.inf)
err[finite] = np.linalg.norm(kinematics.fk(q_report[finite], check_limits=False)[:, :3, 3] - pts[finite], axis=1)
right = in_limits & (err < 1e-6)
ours = kinematics.ik_batch(pts, psi)
print(f"reachable cells: {len(pts)}; kinematics.ik solves {ours.success.sum()}; the report's equations put the tool on "
      f"target within limits at {right.sum()}")
print(f"cells the report misses: {(~right).sum()}, all behind the base (y < 0): {bool(np.all(pts[~right, 1] < 0))}; "
      f"worst tool error there {err[~right & finite].max():.0f} mm")

# %%
# CHECK ik.candidates
require_written("ik.candidates")
assert ours.success.all(), f"kinematics.ik fails at {(~ours.success).sum()} reachable cells"
assert np.abs(kinematics.fk(ours.q)[:, :3, 3] - pts).max() < 1e-6, "an IK solution misses its cell"
assert np.all(right[pts[:, 1] > 0]) and not np.any(right[pts[:, 1] < 0]), "the report's equations fail in front"
print(f"OK: kinematics.ik reaches all {len(pts)} reachable board cells; the report's equation (4) without (5) misses "
      f"the {(~right).sum()} cells behind the base")

# %% [markdown]
# The fix is `atan2`, which keeps the quadrant, plus the flipped-waist branch (5) for the poses only it can reach.
# How often is that? Among random reachable poses of the whole workspace, count those that **only** a flipped
# waist reaches:

# %%
# CHECK ik.candidates
require_written("ik.candidates")
Q = rng.uniform(robot.lower, robot.upper, (3000, 5))
T = kinematics.fk(Q)
P, approach = T[:, :3, 3], T[:, :3, 0]
radial = P[:, :2] / np.linalg.norm(P[:, :2], axis=1, keepdims=True)
pitches = np.arctan2(-approach[:, 2], np.sum(approach[:, :2] * radial, axis=1))
only_flipped = 0
for p, pitch, q in zip(P, pitches, Q):
    sols = kinematics.ik(p, pitch, q[4])
    facing = np.abs(wrap(sols[:, 0] - (np.arctan2(p[1], p[0]) - np.pi / 2))) < 1e-6
    only_flipped += not facing.any()
assert 0 < only_flipped < len(Q), f"{only_flipped} of {len(Q)} poses need the flipped waist"
print(f"OK: {only_flipped} of {len(Q)} random reachable poses ({only_flipped / len(Q):.0%}) need the flipped waist; "
      "dropping equation (5) loses them")
