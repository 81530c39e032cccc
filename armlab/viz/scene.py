"""The kernel's own copy of the meshcat scene, and the window that keeps it while sending commands.

meshcat-python sends each drawing command (set_object, set_transform, set_property, set_animation, delete) as one
msgpack blob. `SceneRecord` keeps the latest blob of each kind per scene path, the way meshcat's server does for a
browser that connects late, so that a view opened at any time (a widget shown again, a page reloaded) is sent the
whole scene in order. `MirroredWindow` is the meshcat window the Viewer draws through: it forwards each command to
the meshcat server (when there is one) and to the record, and hands the blobs of one drawing call to every live
inline view as one message (see armlab.viz.widget).
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable, Iterator

import umsgpack
from meshcat.servers.tree import SceneTree, find_node, walk

__all__ = ["SceneRecord", "MirroredWindow", "COMMANDS"]

COMMANDS = ("set_object", "set_transform", "set_property", "set_animation", "delete")


def _path_parts(path: str) -> list[str]:
    return [part for part in str(path).split("/") if part]


class SceneRecord:
    """The latest drawing commands per scene path (packed msgpack blobs), replayable in meshcat's order."""

    def __init__(self):
        self._tree = SceneTree()
        self._lock = threading.Lock()

    def apply(self, kind: str, path: str, packed: bytes) -> bool:
        """Record one command; False when it changes nothing a view shows (the same object sent again)."""
        if kind not in COMMANDS:
            raise ValueError(f"not a meshcat drawing command: {kind!r} (expected one of {', '.join(COMMANDS)})")
        parts = _path_parts(path)
        with self._lock:
            if kind == "delete":
                if not parts:
                    self._tree = SceneTree()
                else:
                    parent = find_node(self._tree, parts[:-1])
                    parent.pop(parts[-1], None)
                return True
            node = find_node(self._tree, parts)
            if kind == "set_object":
                if node.object == packed:
                    return False
                node.object, node.properties = packed, []
            elif kind == "set_transform":
                node.transform = packed
            elif kind == "set_property":
                node.properties.append(packed)
            else:
                node.animation = packed
        return True

    def replay(self) -> list[bytes]:
        """Every recorded command, parents before children: object, properties, transform, animation."""
        out: list[bytes] = []
        with self._lock:
            for node in walk(self._tree):
                if node.object is not None:
                    out.append(node.object)
                out.extend(node.properties)
                for blob in (node.transform, node.animation):
                    if blob is not None:
                        out.append(blob)
        return out


class MirroredWindow:
    """A meshcat window (what meshcat.Visualizer draws through) that records every command and forwards it.

    Args:
        zmq_socket: a connected zmq REQ socket of a meshcat server, or None to draw for inline views only.
        web_url: that server's page (None without a server).
    """

    def __init__(self, zmq_socket=None, web_url: str | None = None):
        self.zmq_socket, self.web_url = zmq_socket, web_url
        self.record = SceneRecord()
        self._views: list[Callable[[list[bytes]], None]] = []
        self._pending: list[bytes] | None = None
        self._depth = 0

    def add_view(self, push: Callable[[list[bytes]], None]) -> None:
        """Call push(blobs) with the commands of each later drawing call (a view that was sent replay() already)."""
        self._views.append(push)

    def remove_view(self, push: Callable[[list[bytes]], None]) -> None:
        with contextlib.suppress(ValueError):
            self._views.remove(push)

    @contextlib.contextmanager
    def batch(self) -> Iterator[None]:
        """Hold the commands sent inside this block and hand them to the views as one message at its end."""
        if self._depth == 0:
            self._pending = []
        self._depth += 1
        try:
            yield
        finally:
            self._depth -= 1
            if self._depth == 0:
                blobs, self._pending = self._pending, None
                if blobs:
                    self._publish(blobs)

    def _publish(self, blobs: list[bytes]) -> None:
        for push in list(self._views):
            push(blobs)

    def send(self, command) -> None:
        """meshcat's ViewerWindow.send: the server (if any) first, so that a dead server raises before a record."""
        data = command.lower()
        packed = umsgpack.packb(data)
        if self.zmq_socket is not None:
            self.zmq_socket.send_multipart([data["type"].encode(), data["path"].encode(), packed])
            self.zmq_socket.recv()
        if self.record.apply(data["type"], data["path"], packed):
            if self._pending is not None:
                self._pending.append(packed)
            else:
                self._publish([packed])

    def get_scene(self) -> str:
        """The server's self-contained page of the scene (meshcat's static_html)."""
        if self.zmq_socket is None:
            raise RuntimeError("static_html needs a meshcat server (Viewer(server=True))")
        self.zmq_socket.send(b"get_scene")
        return self.zmq_socket.recv().decode("utf-8")
