"""The station's state machine's states and its refusal of a second command: shared by the kit's machine
(armlab.tasks.machine), its transition (armlab.tasks.transition, instructor only) and a machine of one's own."""

from __future__ import annotations

__all__ = ["STATES", "MachineBusy"]

STATES: tuple[str, ...] = ("idle", "estop", "calibrate", "detect", "execute", "teach", "repeat", "click-grab",
                           "click-drop")


class MachineBusy(RuntimeError):
    """A command arrived while another one (or teaching) is under way."""
