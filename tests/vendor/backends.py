"""The two toolboxes armlab.hardware.interbotix is tested through, under the Interbotix module names:

- "vendor files": the Interbotix Python files themselves, unmodified, at facts.TOOLBOXES_COMMIT (facts.TOOLBOX_MODULES,
  from the cache of tests/vendor/sources.py; unavailable, with the reason, on a machine without that cache);
- "behaviour fake": tests/vendor/behaviour/*.py, written for armlab (no vendor code), which model exactly the vendor
  behaviours the tests depend on: the register cache that writes only a value that differs, the process-global node
  that refuses a second creation and that robot_shutdown() leaves in place, the order "register writes, then
  publish", the float type assertion of the messages (through tests/vendor/ros.py), rclpy.init() with its signal
  handlers when ROS is not up, the constructor that blocks while ROS is up. Always available.

Both run over the fake ROS boundary of tests/vendor/ros.py. tests/test_hardware_vendor.py checks the behaviour fake
against the vendor files (signatures of what armlab calls, and the same service calls, messages, errors and waits
under the same calls) wherever the vendor files are cached, so the fake cannot drift from the pinned commit.
"""

from __future__ import annotations

import importlib.util
import sys
import types
from collections.abc import Callable
from pathlib import Path

from . import facts, ros, sources

VENDOR_FILES, BEHAVIOUR_FAKE = "vendor files", "behaviour fake"
BACKENDS = (VENDOR_FILES, BEHAVIOUR_FAKE)

_BEHAVIOUR = Path(__file__).resolve().parent / "behaviour"
BEHAVIOUR_MODULES: dict[str, Path] = {
    "interbotix_common_modules.common_robot.exceptions": _BEHAVIOUR / "exceptions.py",
    "interbotix_common_modules.common_robot.robot": _BEHAVIOUR / "robot.py",
    "interbotix_xs_modules.xs_robot.core": _BEHAVIOUR / "core.py",
    "interbotix_xs_modules.xs_robot.gripper": _BEHAVIOUR / "gripper.py",
    "interbotix_xs_modules.xs_robot.arm": _BEHAVIOUR / "arm.py",
}
PACKAGES = ("interbotix_common_modules", "interbotix_common_modules.common_robot", "interbotix_xs_modules",
            "interbotix_xs_modules.xs_robot")


class Unavailable(Exception):
    """This backend's files are not on this machine (the message says how to get them)."""


def toolbox_files(backend: str) -> dict[str, Path]:
    """Module name -> file to execute, in import order; Unavailable when the vendor files are not cached."""
    if backend == BEHAVIOUR_FAKE:
        return dict(BEHAVIOUR_MODULES)
    if backend != VENDOR_FILES:
        raise ValueError(f"unknown toolbox backend {backend!r}: {BACKENDS}")
    files = {}
    for name, (path, blob) in facts.TOOLBOX_MODULES.items():
        if sources.read(facts.TOOLBOXES, facts.TOOLBOXES_COMMIT, path, blob) is None:
            raise Unavailable(f"{facts.TOOLBOXES}@{facts.TOOLBOXES_COMMIT[:7]}:{path} is not cached: {sources.HOW}")
        files[name] = sources.cached(facts.TOOLBOXES, facts.TOOLBOXES_COMMIT, path)
    return files


def load_toolbox(backend: str, setitem: Callable[[str, types.ModuleType], None]) -> dict[str, types.ModuleType]:
    """Execute the backend's files as the Interbotix modules (fresh module objects: a fresh process-global state),
    putting them into sys.modules through setitem(name, module). The fake ROS modules must be in place already."""
    files = toolbox_files(backend)
    for name in PACKAGES:
        package = types.ModuleType(name)
        package.__path__ = []
        setitem(name, package)
    setitem("interbotix_common_modules.angle_manipulation", types.ModuleType("angle_manipulation"))
    setitem("modern_robotics", ros.modern_robotics_stub())
    loaded = {}
    for name, file in files.items():
        spec = importlib.util.spec_from_file_location(name, file)
        module = importlib.util.module_from_spec(spec)
        setitem(name, module)
        spec.loader.exec_module(module)
        parent, _, child = name.rpartition(".")
        setattr(sys.modules[parent], child, module)
        loaded[name] = module
    return loaded
