"""The lab report's click-to-reach experiment (Tables II and III) on a station, and a plain-text table formatter
shared by notebooks and benchmarks.

reach_experiment: for each board location (x, y) the simulated student clicks the pixel where the point appears
in the image (on the simulator: the TRUE camera's projection, station.camera.truth; on the real arm pass the
clicked pixels), the click becomes a world point (tasks.click_world: calibrated camera + corrected depth), the tool
goes top-down to (x, y, z) through the given arm (from above, like the lab), and the tool point reached is measured
(a `measure` function; on the simulator the ground truth arm.tool_pose_true). Each approach (above, then down) and
each way back up is one plan run through the session's executor (session.run: checked whole before it moves).
Units: px, mm; world (board) frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from armlab import kinematics, planning

from .click import click_world
from .session import Session, as_session

__all__ = ["LAB_LOCATIONS_MM", "LAB_TABLE_II_ACTUAL_MM", "LAB_TABLE_III_ERROR_MM", "LAB_Z_MM", "ReachRow",
           "reach_experiment", "format_table"]

LAB_LOCATIONS_MM = np.array([[100, 225], [-150, -75], [200, 25], [-150, 125], [0, 225], [150, 125]], float)
LAB_Z_MM = 37.0
LAB_TABLE_II_ACTUAL_MM = np.array([[91, 216, 53], [-141, -76, 48], [200, 19, 50], [-141, 109, 49], [-4, 211, 50],
                                   [136, 116, 53]], float)
LAB_TABLE_III_ERROR_MM = np.array([[9, 9, 0], [9, 1, 5], [0, 6, 3], [9, 16, 4], [4, 14, 3], [14, 9, 0]], float)


@dataclass(frozen=True)
class ReachRow:
    """One location: desired tool point (3,), the click's world point (3,), the tool point reached (3,), mm."""

    desired: np.ndarray
    clicked: np.ndarray
    actual: np.ndarray

    @property
    def error(self) -> np.ndarray:
        """|actual - desired| per axis (mm)."""
        return np.abs(self.actual - self.desired)


def reach_experiment(session: Session, arm, measure, locations=LAB_LOCATIONS_MM, z: float = LAB_Z_MM, pixels=None,
                     hover_mm: float = 60.0) -> list[ReachRow]:
    """Click, convert, reach and measure at each location (see the module notes), in a task session
    (tasks.start_session(station): its calibration converts the clicks). arm: e.g. the raw session.station.arm (no
    compensation) or session.arm (sag-compensated); measure() -> tool point (3,) mm."""
    session = as_session(session, "reach_experiment")
    station = session.station
    frame = session.last.frame if session.last is not None else station.camera.capture()
    locs = np.asarray(locations, dtype=float)
    if pixels is None:
        pixels = station.camera.truth.project(np.column_stack([locs, np.zeros(len(locs))]))
    rows = []
    for xy, uv in zip(locs, np.asarray(pixels, float)):
        clicked = click_world(session, uv, frame)
        target = np.array([clicked[0], clicked[1], z])
        roll = 0.0
        here = np.asarray(arm.joint_positions(), float)
        above = kinematics.ik(target + [0, 0, hover_mm], np.pi / 2, roll, current=here)[0]
        down = kinematics.ik(target, np.pi / 2, roll, current=above)[0]
        what = f"reaching ({target[0]:.0f}, {target[1]:.0f}, {target[2]:.0f}) mm"
        session.run(planning.joint_moves(here, above, down), what, arm=arm)
        rows.append(ReachRow(np.array([xy[0], xy[1], z]), clicked, np.asarray(measure(), float)))
        session.run(planning.joint_moves(np.asarray(arm.joint_positions(), float), above), f"{what}: back up", arm=arm)
    return rows


def format_table(headers, rows, floatfmt: str = "{:.1f}") -> str:
    """A plain-text table: headers (list of str), rows (lists of str / numbers), columns right-aligned."""
    cells = [[c if isinstance(c, str) else floatfmt.format(c) for c in row] for row in rows]
    widths = [max(len(str(h)), *(len(r[i]) for r in cells)) for i, h in enumerate(headers)]
    line = "  ".join(str(h).rjust(w) for h, w in zip(headers, widths))
    out = [line, "-" * len(line)]
    out += ["  ".join(c.rjust(w) for c, w in zip(r, widths)) for r in cells]
    return "\n".join(out)
