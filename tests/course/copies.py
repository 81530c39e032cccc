"""Copies of region bodies disguised the way a copier does it, and honest solutions written independently of the
reference, for the tests of the similarity report (test_similarity.py, test_grading.py)."""

from __future__ import annotations

import ast
import textwrap


def disguised(body: str, prefix: str = "my", runnable: bool = False) -> str:
    """`body` with every variable it assigns renamed (`prefix`_0, ...), every number changed (with `runnable`, only
    the tolerances, below 1e-6, so that it computes what `body` does), its layout reflowed by ast.unparse
    (parentheses, spacing, line breaks) and a comment added: the same code to a reader, not to diff."""
    tree = ast.parse(textwrap.dedent(body))
    stored = sorted({n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store)})
    renamed = {name: f"{prefix}_{i}" for i, name in enumerate(stored)}
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and node.id in renamed:
            node.id = renamed[node.id]
        elif isinstance(node, ast.Constant) and type(node.value) in (int, float):
            if not runnable:
                node.value = node.value * 2 + 1
            elif 0 < abs(node.value) < 1e-6:
                node.value = node.value * 10
    text = f"# {prefix}: my own work\n" + ast.unparse(tree)
    assert text.count("\n") >= 1 and text != textwrap.dedent(body)
    return textwrap.indent(text, "    ")


# fk.euler written independently of the reference: the same maths read off other entries, in other shapes
EULER_BY_HAND = """\
    M = T[:3, :3]
    c = M[2, 2]
    s = math.sqrt(M[0, 2] ** 2 + M[1, 2] ** 2)
    theta = math.atan2(s, c)
    if abs(s) < 1e-9:
        psi = 0.0
        phi = math.atan2(M[1, 0], M[0, 0]) if c > 0 else math.atan2(-M[1, 0], -M[0, 0])
    else:
        phi = math.atan2(M[1, 2] / s, M[0, 2] / s)
        psi = math.atan2(M[2, 1] / s, -M[2, 0] / s)
    return np.array([phi, theta, psi])"""
EULER_FROM_THE_Z_AXIS = """\
    rotation = np.array(T, dtype=float)[0:3, 0:3]
    z_axis = rotation[:, 2]
    theta = math.acos(max(-1.0, min(1.0, z_axis[2])))
    if math.isclose(math.sin(theta), 0.0, abs_tol=1e-10):
        # gimbal lock: only phi + psi (or phi - psi) is defined
        angles = [math.atan2(rotation[1, 0] * z_axis[2], rotation[0, 0] * z_axis[2]), theta, 0.0]
    else:
        angles = [math.atan2(z_axis[1], z_axis[0]), theta, math.atan2(rotation[2, 1], -rotation[2, 0])]
    return np.array(angles)"""

# fk.dh_link_transform: the matrix written out row by row; the product of the four elementary motions (the kit's own
# stand-in, armlab.kinematics._dh_by_elementary_motions)
DH_ROWS = """\
    c_t, s_t = np.cos(theta), np.sin(theta)
    c_a, s_a = np.cos(alpha), np.sin(alpha)
    rows = [[c_t, -s_t * c_a, s_t * s_a, a * c_t],
            [s_t, c_t * c_a, -c_t * s_a, a * s_t],
            [np.zeros_like(c_t), s_a, c_a, d],
            [np.zeros_like(c_t), np.zeros_like(c_t), np.zeros_like(c_t), np.ones_like(c_t)]]
    A[...] = np.moveaxis(np.array(rows), (0, 1), (-2, -1))"""
DH_PRODUCT = """\
    zero = np.zeros_like(d)
    A[...] = (homogeneous(rot_z(theta)) @ homogeneous(None, np.stack([zero, zero, d], -1))
              @ homogeneous(None, np.stack([a, zero, zero], -1)) @ homogeneous(rot_x(alpha)))"""

# calib.pinhole (two regions: project, back-project): point by point; in homogeneous coordinates
PINHOLE_LOOP = ["""\
    R, t = T_cam_world[:3, :3], T_cam_world[:3, 3]
    out = []
    for p in points_world:
        x, y, z = R @ p + t
        out.append([K[0, 0] * x / z + K[0, 2], K[1, 1] * y / z + K[1, 2]])
    return np.array(out)""", """\
    R, t = T_cam_world[:3, :3], T_cam_world[:3, 3]
    ray = np.linalg.inv(K) @ np.array([uv[0], uv[1], 1.0])
    camera_point = ray / ray[2] * depth_mm
    return R.T @ camera_point - R.T @ t"""]
PINHOLE_HOMOGENEOUS = ["""\
    homog = np.hstack([points_world, np.ones((len(points_world), 1))])
    cam = (T_cam_world @ homog.T)[:3]
    pix = K @ cam
    return (pix[:2] / pix[2]).T""", """\
    inverse = np.linalg.inv(T_cam_world)
    u, v = uv
    p = np.array([(u - K[0, 2]) * depth_mm / K[0, 0], (v - K[1, 2]) * depth_mm / K[1, 1], depth_mm, 1.0])
    return (inverse @ p)[:3]"""]

INDEPENDENT = {   # per exercise: two honest solutions, each written without the reference or the other
    "fk.euler": ([EULER_BY_HAND], [EULER_FROM_THE_Z_AXIS]),
    "fk.dh_link_transform": ([DH_ROWS], [DH_PRODUCT]),
    "calib.pinhole": (PINHOLE_LOOP, PINHOLE_HOMOGENEOUS),
}
