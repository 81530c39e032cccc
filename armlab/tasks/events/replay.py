"""Replays of an event: the arm's joint trajectory and gripper opening over simulated time, and world snapshots.

Recorder listens to the simulated world's clock (World.add_listener) and samples the arm's physical joints
(arm.q_true) every `dt` simulated seconds; snapshots of every object are taken on request (after each move) and,
once, at the event's time limit (what the judges would score). Replay saves to / loads from NPZ (no pickles) and
plays in the meshcat Viewer (Viewer.animate, then the final objects). Units: s, rad, mm; world (board) frame.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from armlab.blocks import ObjectState
from armlab.files import atomic_path

__all__ = ["Replay", "Recorder", "snapshot_objects", "objects_from_snapshot"]


def snapshot_objects(objects) -> list[dict]:
    """JSON-ready copies of objects (id, colour, size, shape, edge, centre position mm, yaw rad, tilt rad)."""
    return [{"id": int(o.id), "color": o.color, "size": o.size, "shape": o.shape, "edge": float(o.edge),
             "position": [float(v) for v in o.position], "yaw": float(o.yaw),
             "tilt": [float(v) for v in np.asarray(o.tilt, float)]} for o in objects]


def objects_from_snapshot(snapshot: list[dict]) -> list[ObjectState]:
    """ObjectState copies from a snapshot (snapshot_objects)."""
    return [ObjectState(d["color"], d["size"], d["edge"], np.array(d["position"]), d["yaw"], d["shape"], d["id"],
                        np.array(d.get("tilt", [0.0, 0.0]))) for d in snapshot]


@dataclass
class Replay:
    """times (N,) s from the event's start, q (N, 5) rad, gripper (N,) mm opening; snapshots: (time s, label,
    objects as snapshot_objects) in time order."""

    times: np.ndarray
    q: np.ndarray
    gripper: np.ndarray
    snapshots: list[tuple[float, str, list[dict]]] = field(default_factory=list)

    @property
    def duration(self) -> float:
        return float(self.times[-1]) if len(self.times) else 0.0

    def objects_at(self, t: float) -> list[ObjectState]:
        """The objects of the last snapshot taken at or before time t (s)."""
        chosen = self.snapshots[0]
        for snap in self.snapshots:
            if snap[0] <= t + 1e-9:
                chosen = snap
        return objects_from_snapshot(chosen[2])

    def save(self, path) -> Path:
        """Write the replay as NPZ (arrays + the snapshots as a JSON string), atomically."""
        path = Path(path)
        with atomic_path(path, suffix=".npz") as tmp:
            np.savez_compressed(tmp, times=self.times, q=self.q, gripper=self.gripper,
                                snapshots=np.array(json.dumps(self.snapshots)))
        return path

    @classmethod
    def load(cls, path) -> Replay:
        """Read a replay written by save(); ValueError naming the file when it is not one."""
        try:
            with np.load(path, allow_pickle=False) as z:
                snaps = [(float(t), str(label), objs) for t, label, objs in json.loads(str(z["snapshots"]))]
                return cls(z["times"], z["q"], z["gripper"], snaps)
        except (OSError, KeyError, ValueError) as e:
            raise ValueError(f"{path}: not an armlab replay ({e})") from None

    def to_viewer(self, viewer, fps: int = 10) -> None:
        """Load the joint trajectory as the viewer's animation (one key frame per 1/fps s, which keeps a saved page
        small) and draw the objects as they end."""
        grid = np.append(np.arange(0.0, self.duration, 1.0 / fps), self.duration)
        keep = np.unique(np.clip(np.searchsorted(self.times, grid), 0, len(self.times) - 1))
        viewer.animate(self.times[keep], self.q[keep], self.gripper[keep], fps=fps)
        viewer.draw_objects(objects_from_snapshot(self.snapshots[-1][2]))


class Recorder:
    """Samples a simulated station's arm every dt simulated seconds from now on (see the module notes)."""

    def __init__(self, station, dt: float = 0.1, limit_s: float | None = None):
        self.world, self.arm = station.world, station.arm
        self.t0 = self.world.time_s
        self.dt, self.limit_s = float(dt), limit_s
        self._t, self._q, self._g = [], [], []
        self.snapshots: list[tuple[float, str, list[dict]]] = []
        self.at_limit: list[dict] | None = None
        self.active = True
        self._sample(self.t0)
        self.snapshot("start")
        self.world.add_listener(self._on_time)

    def _sample(self, t: float) -> None:
        self._t.append(t - self.t0)
        self._q.append(self.arm.q_true)
        self._g.append(float(self.arm.gripper_opening_mm))

    def _on_time(self, t: float) -> None:
        if not self.active:
            return
        if t - self.t0 - self._t[-1] >= self.dt - 1e-9:
            self._sample(t)
        if self.limit_s is not None and self.at_limit is None and t - self.t0 >= self.limit_s:
            self.at_limit = snapshot_objects(self.world.objects)

    def snapshot(self, label: str) -> None:
        """Keep a copy of every object now, labelled."""
        self.snapshots.append((self.world.time_s - self.t0, label, snapshot_objects(self.world.objects)))

    def stop(self) -> Replay:
        """Take the last sample and snapshot, stop listening and return the Replay."""
        if self._t[-1] < self.world.time_s - self.t0 - 1e-9:
            self._sample(self.world.time_s)
        self.snapshot("end")
        self.active = False
        return Replay(np.array(self._t), np.array(self._q), np.array(self._g), self.snapshots)
