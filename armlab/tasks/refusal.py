"""The refusal of a click that cannot be acted on, shared by click-to-grab (armlab.tasks.click, which exports it) and
the kit's click rule (armlab.tasks.click_rule, instructor only)."""

from __future__ import annotations

__all__ = ["ClickRefused"]


class ClickRefused(ValueError):
    """A click that cannot be acted on (off the board, on the robot, nothing there, out of reach); nothing moved."""
