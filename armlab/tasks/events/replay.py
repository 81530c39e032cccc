"""Replays of an event: the arm's joint trajectory and gripper opening over simulated time, and world snapshots.

ReplayRecorder listens to the simulated world's clock (World.add_listener) and samples the arm's physical joints
(arm.q_true) and every object's pose (centre, yaw, tilt) every `dt` simulated seconds; snapshots of every object are
taken on request (after each move) and, once, at the event's time limit (what the judges would score). Replay saves
to / loads from NPZ (no pickles) and plays in the meshcat Viewer (Viewer.animate with the objects' tracks: blocks
are carried, towers grow). Units: s, rad, mm; world (board) frame.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from armlab.blocks import ObjectState
from armlab.files import atomic_path
from armlab.station.contract import Station

__all__ = ["Replay", "ReplayRecorder", "snapshot_objects", "objects_from_snapshot"]


def snapshot_objects(objects) -> list[dict]:
    """JSON-ready copies of objects (id, colour, size, shape, edge, centre position mm, yaw rad, tilt rad)."""
    return [{"id": int(o.id), "color": o.color, "size": o.size, "shape": o.shape, "edge": float(o.edge),
             "position": [float(v) for v in o.position], "yaw": float(o.yaw),
             "tilt": [float(v) for v in np.asarray(o.tilt, float)]} for o in objects]


def objects_from_snapshot(snapshot: list[dict]) -> list[ObjectState]:
    """ObjectState copies from a snapshot (snapshot_objects)."""
    return [ObjectState(d["color"], d["size"], d["edge"], np.array(d["position"]), d["yaw"], d["shape"], d["id"],
                        np.array(d.get("tilt", [0.0, 0.0]))) for d in snapshot]


_POSE_FIELDS = 6      # object pose per sample: x, y, z (centre, mm), yaw, tilt roll, tilt pitch (rad)


def _pose(o) -> list[float]:
    return [*map(float, o.position), float(o.yaw), *map(float, np.asarray(o.tilt, float))]


@dataclass
class Replay:
    """times (N,) s from the event's start, q (N, 5) rad, gripper (N,) mm opening; snapshots: (time s, label,
    objects as snapshot_objects) in time order; object_ids (M,) and object_poses (N, M, 6): every object's centre
    (mm), yaw and tilt (rad) at each sample, NaN while it is not in the world (e.g. not yet handed over); None in
    replays saved without them."""

    times: np.ndarray
    q: np.ndarray
    gripper: np.ndarray
    snapshots: list[tuple[float, str, list[dict]]] = field(default_factory=list)
    object_ids: np.ndarray | None = None
    object_poses: np.ndarray | None = None

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

    def objects_at_sample(self, k: int) -> list[ObjectState]:
        """The objects (ObjectState) as sampled at sample k: poses from object_poses, the rest from the snapshots."""
        if self.object_ids is None:
            return self.objects_at(float(self.times[k]))
        kinds = {d["id"]: d for _, _, objs in self.snapshots for d in objs}
        out = []
        for oid, pose in zip(self.object_ids, self.object_poses[k]):
            if np.all(np.isfinite(pose)) and int(oid) in kinds:
                d = kinds[int(oid)]
                out.append(ObjectState(d["color"], d["size"], d["edge"], pose[:3].copy(), float(pose[3]), d["shape"],
                                       int(oid), pose[4:6].copy()))
        return out

    def save(self, path) -> Path:
        """Write the replay as NPZ (arrays + the snapshots as a JSON string), atomically."""
        path = Path(path)
        tracks = {} if self.object_ids is None else {"object_ids": self.object_ids, "object_poses": self.object_poses}
        with atomic_path(path, suffix=".npz") as tmp:
            np.savez_compressed(tmp, times=self.times, q=self.q, gripper=self.gripper,
                                snapshots=np.array(json.dumps(self.snapshots)), **tracks)
        return path

    @classmethod
    def load(cls, path) -> Replay:
        """Read a replay written by save(); ValueError naming the file when it is not one."""
        try:
            with np.load(path, allow_pickle=False) as z:
                snaps = [(float(t), str(label), objs) for t, label, objs in json.loads(str(z["snapshots"]))]
                ids, poses = (z["object_ids"], z["object_poses"]) if "object_ids" in z.files else (None, None)
                if poses is not None and poses.shape != (len(z["times"]), len(ids), _POSE_FIELDS):
                    raise ValueError(f"object_poses has shape {poses.shape}, expected "
                                     f"({len(z['times'])}, {len(ids)}, {_POSE_FIELDS})")
                return cls(z["times"], z["q"], z["gripper"], snaps, ids, poses)
        except (OSError, KeyError, ValueError) as e:
            raise ValueError(f"{path}: not an armlab replay ({e})") from None

    def to_viewer(self, viewer, fps: int = 10) -> None:
        """Load the replay as the viewer's animation (one key frame per 1/fps s, which keeps a saved page small): the
        arm, and the objects moving with it (replays without object tracks: the objects drawn as they end)."""
        grid = np.append(np.arange(0.0, self.duration, 1.0 / fps), self.duration)
        keep = np.unique(np.clip(np.searchsorted(self.times, grid), 0, len(self.times) - 1))
        if self.object_ids is None:
            viewer.animate(self.times[keep], self.q[keep], self.gripper[keep], fps=fps)
            viewer.draw_objects(objects_from_snapshot(self.snapshots[-1][2]))
        else:
            viewer.animate(self.times[keep], self.q[keep], self.gripper[keep], fps=fps,
                           objects=[self.objects_at_sample(int(k)) for k in keep])


class ReplayRecorder:
    """Records an event's Replay (teach.Recorder records taught waypoints instead): samples a simulated station's
    arm every dt simulated seconds from now on (see the module notes)."""

    def __init__(self, station: Station, dt: float = 0.1, limit_s: float | None = None):
        self.world, self.arm = station.world, station.arm
        self.t0 = self.world.time_s
        self.dt, self.limit_s = float(dt), limit_s
        self._t, self._q, self._g, self._poses = [], [], [], []
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
        self._poses.append({int(o.id): _pose(o) for o in self.world.objects})

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
        ids = np.array(sorted({i for p in self._poses for i in p}), dtype=int)
        poses = np.full((len(self._t), len(ids), _POSE_FIELDS), np.nan)
        for k, sample in enumerate(self._poses):
            for j, oid in enumerate(ids):
                if int(oid) in sample:
                    poses[k, j] = sample[int(oid)]
        return Replay(np.array(self._t), np.array(self._q), np.array(self._g), self.snapshots, ids, poses)
