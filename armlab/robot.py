"""The RX200 description: joint names, limits, named poses, DH and PoX parameters loaded from `data/`.

Units: millimetres and radians. Frames: the world (board) frame of the lab (z up, the arm at home along +y).
Joint order everywhere: waist, shoulder, elbow, wrist_angle, wrist_rotate; the gripper is separate.
"""

from __future__ import annotations

import csv
import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armlab._paths import data_path
from armlab.transforms import homogeneous, rotvec_to_matrix

__all__ = ["JOINT_NAMES", "LIMIT_TOL_RAD", "RobotModel", "RobotDataError", "load_robot", "rx200", "DH_TOOL_ROTATION"]

JOINT_NAMES: tuple[str, ...] = ("waist", "shoulder", "elbow", "wrist_angle", "wrist_rotate")

# The last DH frame has z along the approach direction (standard DH puts joint axes on z), while the tool frame
# ee_gripper_link has x along the approach, y across the fingers and z completing the frame. This fixed
# rotation relabels the axes: tool x = DH z5, tool y = -DH y5, tool z = DH x5 (no translation).
DH_TOOL_ROTATION = np.array([[0.0, 0.0, 1.0], [0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])


class RobotDataError(ValueError):
    """A robot description file is missing or malformed; the message names the file, row and problem."""


LIMIT_TOL_RAD = 1e-9   # a joint this far past its limit (rad) still counts as within it (rounding)


@dataclass(frozen=True, repr=False)
class RobotModel:
    """Kinematic description of a 5-joint arm.

    Attributes:
        joint_names: the 5 joint names in order.
        lower, upper: position limits (5,), rad.
        velocity: velocity limits (5,), rad/s.
        home, sleep: named poses (5,), rad.
        dh: (5, 4) standard DH rows (theta_offset rad, d mm, a mm, alpha rad) from the world frame, or None where
            the kit has no DH table (the student release: the table is exercise fk.dh_table; nothing of the kit
            but notebook 02's DH chain, kinematics.dh_frames and fk_dh, uses it).
        screws: (5, 6) space-frame screw axes (w, v), v in mm, world frame.
        M: (4, 4) tool frame ee_gripper_link in the world at q = 0 (mm).
        frames_home: (5, 4, 4) link frames 1..5 (the poses of DH frames 1..5) in the world at q = 0 (mm).
        points_home: (2, 3) the top of the waist (on link 1) and the wrist_rotate joint (on link 4) in the world at
            q = 0 (mm): the drawing's points between the link frames' origins.
    """

    joint_names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    home: np.ndarray
    sleep: np.ndarray
    dh: np.ndarray | None
    screws: np.ndarray
    M: np.ndarray
    frames_home: np.ndarray
    points_home: np.ndarray

    def limit_violations(self, q, tol: float = LIMIT_TOL_RAD) -> list[str]:
        """Human-readable list of the joints of q (5,) outside their limits (empty when all are within); NaN and
        infinity are violations too (a NaN compares false with every limit, so it is named on its own)."""
        q = np.asarray(q, dtype=float)
        if q.shape != (len(self.joint_names),):
            raise ValueError(f"joint angles must have shape ({len(self.joint_names)},), got shape {q.shape}")
        out = []
        for name, value, lo, hi in zip(self.joint_names, q, self.lower, self.upper, strict=True):
            if not np.isfinite(value):
                out.append(f"{name} = {value} is not a finite angle (limits [{lo:.6f}, {hi:.6f}] rad)")
            elif not lo - tol <= value <= hi + tol:
                out.append(f"{name} = {value:.6f} rad ({np.degrees(value):.1f} deg) is outside its limits "
                           f"[{lo:.6f}, {hi:.6f}] rad")
        return out

    def within_limits(self, q, tol: float = LIMIT_TOL_RAD) -> np.ndarray:
        """Boolean (...,) telling which joint vectors q (..., 5) respect every position limit."""
        q = np.asarray(q, dtype=float)
        return ((q >= self.lower - tol) & (q <= self.upper + tol)).all(axis=-1)

    @functools.cached_property
    def points_on_links(self) -> np.ndarray:
        """points_home in their links' frames (2, 3) mm: the waist top in link frame 1, the wrist_rotate joint in link
        frame 4 (what kinematics.joint_positions carries along with those frames)."""
        local = [np.linalg.solve(self.frames_home[link], np.append(point, 1.0))[:3]
                 for link, point in zip((0, 3), self.points_home, strict=True)]
        return np.array(local)

    @functools.cached_property
    def bounds(self) -> tuple[tuple[float, float], ...]:
        """Per joint (lower - LIMIT_TOL_RAD, upper + LIMIT_TOL_RAD) rad as Python floats: within_limits' rule for
        code that tests one joint vector without numpy's per-call cost (the single-target IK)."""
        return tuple(zip((self.lower - LIMIT_TOL_RAD).tolist(), (self.upper + LIMIT_TOL_RAD).tolist()))

    def __repr__(self) -> str:
        """The joint table (limits, home, deg), the DH table (deg, mm) and the PoX screws (world frame, mm)."""
        deg = np.degrees
        rows = [f"RobotModel: {len(self.joint_names)} joints (world frame: the board's; mm, deg)",
                "joints (deg)      lower    upper     home  vel (deg/s)"]
        for name, lo, hi, home, vel in zip(self.joint_names, deg(self.lower), deg(self.upper), deg(self.home),
                                           deg(self.velocity)):
            rows.append(f"  {name:12} {lo:8.1f} {hi:8.1f} {home:8.1f} {vel:10.1f}")
        if self.dh is not None:
            rows.append("DH (standard)     theta0 (deg)   d (mm)   a (mm)  alpha (deg)")
            for name, (theta0, d, a, alpha) in zip(self.joint_names, self.dh):
                rows.append(f"  {name:12} {deg(theta0):13.2f} {d:8.2f} {a:8.2f} {deg(alpha):12.2f}")
        rows.append("PoX screws (world)   wx     wy     wz      vx (mm)   vy (mm)   vz (mm)")
        for name, (wx, wy, wz, vx, vy, vz) in zip(self.joint_names, self.screws):
            rows.append(f"  {name:12} {wx:6.2f} {wy:6.2f} {wz:6.2f} {vx:10.2f} {vy:9.2f} {vz:9.2f}")
        x, y, z = self.M[:3, 3]
        rows.append(f"  tool at q = 0 (M): ({x:.2f}, {y:.2f}, {z:.2f}) mm")
        return "\n".join(rows)

    __str__ = __repr__


def _read_rows(path: Path, header: list[str]) -> list[tuple[int, dict[str, str]]]:
    """Rows of a CSV file with '#' comment lines, as (line number, dict); validates the header."""
    if not path.is_file():
        raise RobotDataError(f"{path}: file not found")
    lines = path.read_text().splitlines()
    numbered = [(i + 1, line) for i, line in enumerate(lines) if line.strip() and not line.lstrip().startswith("#")]
    if not numbered:
        raise RobotDataError(f"{path}: no header row")
    reader = csv.reader([line for _, line in numbered])
    rows = list(reader)
    got = [c.strip() for c in rows[0]]
    if got != header:
        raise RobotDataError(f"{path}, line {numbered[0][0]}: header is {got}, expected {header}")
    out = []
    for (lineno, _), row in zip(numbered[1:], rows[1:]):
        if len(row) != len(header):
            raise RobotDataError(f"{path}, line {lineno}: {len(row)} fields, expected {len(header)}")
        out.append((lineno, dict(zip(header, (c.strip() for c in row)))))
    return out


def _number(path: Path, lineno: int, row: dict[str, str], key: str) -> float:
    try:
        value = float(row[key])
    except ValueError:
        raise RobotDataError(f"{path}, line {lineno}: {key} = {row[key]!r} is not a number") from None
    if not np.isfinite(value):
        raise RobotDataError(f"{path}, line {lineno}: {key} = {row[key]!r} is not finite")
    return value


def _named_table(path: Path, header: list[str], names: tuple[str, ...]) -> tuple[np.ndarray, list[int]]:
    """Numeric table whose first column names rows in the order `names`, and the file line of each row."""
    rows = _read_rows(path, header)
    for k, name in enumerate(names):
        if k >= len(rows):
            raise RobotDataError(f"{path}: row {name!r} is missing (rows must be {list(names)})")
        lineno, row = rows[k]
        if row[header[0]] != name:
            raise RobotDataError(f"{path}, line {lineno}: row {row[header[0]]!r} where {name!r} was expected "
                                 f"(rows must be {list(names)})")
    if len(rows) > len(names):
        raise RobotDataError(f"{path}, line {rows[len(names)][0]}: unexpected extra row "
                             f"{rows[len(names)][1][header[0]]!r} (rows must be {list(names)})")
    return np.array([[_number(path, n, r, k) for k in header[1:]] for n, r in rows]), [n for n, _ in rows]


def load_robot(joints_csv: Path | str | None = None, dh_csv: Path | str | None = None,
               pox_csv: Path | str | None = None) -> RobotModel:
    """Load and validate a robot description; defaults to the RX200 files in `data/`. The DH table is optional: with
    no dh_csv given and no rx200_dh.csv in the data folder (the student release leaves it out: it is the answer of
    exercise fk.dh_table) the model's dh is None."""
    joints_path = Path(joints_csv or data_path("rx200_joints.csv"))
    dh_path = Path(dh_csv or data_path("rx200_dh.csv"))
    dh_given = dh_csv is not None
    pox_path = Path(pox_csv or data_path("rx200_pox.csv"))

    joints, joint_lines = _named_table(
        joints_path, ["joint", "lower_rad", "upper_rad", "velocity_rad_s", "home_rad", "sleep_rad"], JOINT_NAMES)
    lower, upper, velocity, home, sleep = joints.T
    for i, name in enumerate(JOINT_NAMES):
        where = f"{joints_path}, line {joint_lines[i]}: joint {name}"
        if not lower[i] < upper[i]:
            raise RobotDataError(f"{where}: lower limit {lower[i]} is not below upper {upper[i]}")
        if velocity[i] <= 0:
            raise RobotDataError(f"{where}: velocity limit {velocity[i]} must be positive")
        for pose, value in (("home", home[i]), ("sleep", sleep[i])):
            if not lower[i] <= value <= upper[i]:
                raise RobotDataError(f"{where}: {pose} pose {value} is outside its limits")

    dh = _named_table(dh_path, ["joint", "theta_offset_rad", "d_mm", "a_mm", "alpha_rad"], JOINT_NAMES)[0] \
        if dh_given or dh_path.is_file() else None

    frame_rows = tuple(f"frame{i}_home" for i in range(1, 6))
    pox, pox_lines = _named_table(pox_path, ["name", "wx", "wy", "wz", "vx", "vy", "vz"],
                                  JOINT_NAMES + ("ee_home",) + frame_rows + ("waist_top_home", "wrist_rotate_home"))
    screws = pox[:5]
    norms = np.linalg.norm(screws[:, :3], axis=1)
    for name, norm, lineno in zip(JOINT_NAMES, norms, pox_lines):
        if abs(norm - 1.0) > 1e-9:
            raise RobotDataError(f"{pox_path}, line {lineno}: joint {name}: rotation axis has length {norm}, "
                                 "expected 1")
    M = homogeneous(rotvec_to_matrix(pox[5, :3]), pox[5, 3:])
    frames_home = np.array([homogeneous(rotvec_to_matrix(row[:3]), row[3:]) for row in pox[6:11]])
    points_home = pox[11:, 3:]

    arrays = [np.array(a, dtype=float) for a in (lower, upper, velocity, home, sleep)]
    for a in arrays + [dh, screws, M, frames_home, points_home]:
        if a is not None:
            a.setflags(write=False)
    return RobotModel(JOINT_NAMES, *arrays, dh=dh, screws=screws, M=M, frames_home=frames_home,
                      points_home=points_home)


@functools.lru_cache(maxsize=1)
def rx200() -> RobotModel:
    """The RX200 model from the kit's data files (loaded once)."""
    return load_robot()
