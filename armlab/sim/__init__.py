"""The simulated lab station: RX200 arm with gripper, block world with scenes, and RGB-D camera.

`make_sim_station(seed=0, scene="random")` (or `armlab.make_station("sim", ...)`) builds all three; the arm and
camera offer the same interfaces as the real ones (armlab.station.Arm, RGBDCamera). Ground truth for checking is
kept apart from what a student pipeline should use: `station.world.objects` / `.blocks` (true object poses),
`station.arm.q_true` (true joint angles) and `station.camera.truth` (the true camera model).
Units: mm, rad, s; world (board) frame.
"""

from __future__ import annotations

import os
from collections.abc import Callable

import numpy as np

from armlab.arguments import MAX_SEED, plain
from armlab.sim.arm import ArmRealism, SimArm
from armlab.sim.gripper import GripperGeometry
from armlab.sim.scenes import PRESETS, SceneError, load_scene, save_scene, scene_objects
from armlab.sim.world import World
from armlab.station.contract import Capabilities, Pacing, SagReference, Station
from armlab.station.interrupt import install_sigint

__all__ = ["make_sim_station", "SimArm", "ArmRealism", "GripperGeometry", "World", "PRESETS", "SceneError",
           "scene_objects", "load_scene", "save_scene"]


def make_sim_station(seed: int = 0, scene: str | os.PathLike | dict = "random",
                     realism: str | ArmRealism = "realistic", real_time: bool = False,
                     gripper: GripperGeometry | None = None, camera_realism: str | None = None,
                     **scene_options) -> Station:
    """A simulated station: Station(kind="sim", arm, camera, world) with the simulator's capabilities: the camera
    photographs a checkerboard itself (camera_intrinsics) and the sag is fitted on an empty-board twin of the arm
    with the true tool pose (sag_reference); the arm can be posed by hand with torque off (pose_by_hand) and the
    simulated clock can follow the wall clock (pacing).

    Args:
        seed: one seed for everything (scene, arm errors, camera noise): same seed, same station.
        scene: a preset name (armlab.sim.PRESETS), a JSON scene file or a scene dict; scene_options go to the
            preset (e.g. n=8 for "random").
        realism: "realistic" or "ideal" for arm and camera, or an ArmRealism for the arm (camera: "realistic").
        real_time: blocking moves also take wall-clock time.
        gripper: finger pad geometry (default GripperGeometry()).
        camera_realism: the camera's realism when it should differ from the arm's: "realistic", "ideal" or a
            CameraRealism (armlab.sim.realism: e.g. CameraRealism.realistic(0), the camera of data/checkerboard).
    The arm starts at the sleep pose with the gripper open, as the real lab's arm does. Closing the station
    (close(), the end of its `with` block) parks the arm in its sleep pose as the real station does; every later
    command raises StationClosed. While it is open, Ctrl+C holds the arm where it is, then raises KeyboardInterrupt,
    as on the real station (armlab.station.interrupt; when made in the main thread).
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise ValueError(f"seed must be an integer, got {plain(seed)}")
    if not 0 <= seed <= MAX_SEED:
        raise ValueError(f"seed must be an integer from 0 to {MAX_SEED}, got {plain(seed)}")
    scene_seed, arm_seed, camera_seed = (int(s.generate_state(1)[0]) for s in np.random.SeedSequence(seed).spawn(3))
    world = World(scene_objects(scene, scene_seed, **scene_options), real_time=real_time)
    arm = SimArm(world, realism=realism, gripper=gripper, seed=arm_seed, real_time=real_time)
    if camera_realism is None:
        camera_realism = realism if isinstance(realism, str) else "realistic"
    from armlab.sim.camera import SimCamera  # the renderer is heavier: import it only when a station is built

    camera = SimCamera(world, arm, realism=camera_realism, seed=camera_seed)
    restore_sigint = install_sigint(arm.hold, warn_outside_main=False)
    return Station(kind="sim", arm=arm, camera=camera, world=world,
                   capabilities=Capabilities(camera_intrinsics=lambda: _camera_intrinsics(camera),
                                             sag_reference=lambda: _sag_reference(arm),
                                             pose_by_hand=arm.move_by_hand, pacing=_pacing(world, arm)),
                   _closer=lambda: _close(arm, camera, restore_sigint))


def _close(arm: SimArm, camera, restore_sigint: Callable[[], None]) -> None:
    """What closing a simulated station does, as on the real one: Ctrl+C stops holding the arm, the arm parks
    (SimArm.close), then the camera stops; afterwards both refuse every command (StationClosed). The world's ground
    truth stays readable."""
    restore_sigint()
    try:
        arm.close()
    finally:
        camera.closed = True


def _camera_intrinsics(camera) -> tuple[np.ndarray, np.ndarray]:
    """K (3, 3), dist (5,) from checkerboard views the simulated camera renders of itself (~1.5 s once, cached)."""
    from armlab.sim.checkerboard import sim_camera_intrinsics  # renders the views: imported when first asked

    result = sim_camera_intrinsics(camera)
    return result.K.copy(), result.dist.copy()


def _sag_reference(arm: SimArm) -> SagReference:
    """The arm's empty-board twin (its calibration poses go down to 40 mm over the work area, where they would shove
    the scene's blocks) and its true tool point (3,) world mm, a stand-in for a lab's touch-off measurements."""
    twin = arm.empty_board_twin()
    return SagReference(twin, lambda: twin.tool_pose_true()[:3, 3])


def _pacing(world: World, arm: SimArm) -> Pacing:
    """Switch the world's and the arm's clocks together; the world's wall clock restarts at the switch, so no idle
    time is caught up."""

    def set_real_time(on: bool) -> None:
        world.advance(0.0)
        world.real_time = arm.real_time = bool(on)

    return Pacing(lambda: arm.real_time, set_real_time)
