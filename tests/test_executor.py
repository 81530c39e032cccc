"""One executor (armlab.tasks.executor, Session.run) for every motion of the task layer, on both backends (issue 33).

With a block held, a motion that takes the held block under the board (a safe hover, then down until the block's
bottom is HELD_BELOW_MM under the board while the pads and links stay above their floors) is refused before its
first command on every path that moves the arm: TaskMachine.execute (the control station's sliders and buttons go
through it), tasks.repeat (with a session, and with the session's arm alone), drop_with / place (the placement rule
and the check), and, after the executor told it what it holds, each backend's own move_to. Before the fix,
TaskMachine.execute moved the arm 0.74 rad and tasks.repeat 0.59 rad before the simulator refused, and the real arm
never refused. The real arm runs on the vendor stand-ins of tests/test_hardware.py (the contract suite's).
"""

from __future__ import annotations

import ast
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from test_hardware import vendors  # noqa: F401  (the fake vendor modules, a fixture)

from armlab import kinematics, make_station, motion_safety, planning, tasks
from armlab.station import MotionRefused
from armlab.tasks import GuardedArm, executor, move_path, teach

ROOT = Path(__file__).resolve().parents[1]
HELD_BELOW_MM = 6.0            # how far the held block's bottom would go under the board
TOP = np.array([0.0, 250.0, 38.0])  # the top-face centre of the large block picked (world mm)


def detected(top, edge: float = 38.0, yaw: float = 0.0, color: str = "red"):
    """A detection-like block (what tasks.pick takes) with its top-face centre at `top`."""
    return SimpleNamespace(position=np.asarray(top, float), yaw=yaw, size="large" if edge > 30 else "small",
                           color=color, edge_mm=edge)


@pytest.fixture(params=["sim", "real"])
def holding(request):
    """A session on either backend whose gripper holds a large block picked by tasks.pick (the real arm's fake
    driver reports a 38 mm object between the fingers)."""
    if request.param == "sim":
        scene = {"objects": [{"color": "red", "size": "large", "position_mm": list(TOP[:2]), "yaw_rad": 0.0}]}
        station = make_station("sim", seed=0, scene=scene)
        physical = lambda: station.arm.q_true          # noqa: E731
    else:
        fakes = request.getfixturevalue("vendors")
        station = make_station("real")
        fakes.world.object_width_mm = 38.0
        physical = lambda: np.array(fakes.world.q, float)    # noqa: E731
    with station:
        session = tasks.Session(station, GuardedArm(station.arm))
        assert tasks.pick(session, detected(TOP))
        assert session.held is not None and len(station.arm.held_blocks) == 1
        yield SimpleNamespace(session=session, station=station, physical=physical)


SPOT = np.array([150.0, 220.0])   # where the motions go down (world mm)


def hover_then_into_board(session, bottom: float = -HELD_BELOW_MM) -> np.ndarray:
    """Joint poses (2, 5) rad: over SPOT with the held block 100 mm up, then straight down until the held block's
    bottom is at `bottom` mm (default HELD_BELOW_MM under the board: the pads' and the tool point's lowest points stay
    above their floors)."""
    T_tool_block = np.asarray(session.held_in_tool, float)
    xy = SPOT
    def pose(bottom_z, current):
        # top-down tool: the block's centre is T_tool_block's offset turned by the tool's rotation
        q = kinematics.ik([*xy, 100.0], np.pi / 2, 0.0, current=current)[0]
        T = kinematics.fk_pox(q)
        centre = T[:3, :3] @ T_tool_block[:3, 3]
        tool_z = bottom_z + session.held_edge / 2 - centre[2]
        return kinematics.ik([*xy, tool_z], np.pi / 2, 0.0, current=q)[0]
    here = session.arm.joint_positions()
    hover = pose(100.0, here)
    return np.array([hover, pose(bottom, hover)])


def lowest_parts(session, q) -> tuple[float, float, float]:
    """(held block's lowest corner, pads' lowest corner, tool point) world z (mm) at q (5,) rad."""
    T = kinematics.fk_pox(q)
    held = motion_safety.HeldBlock(session.held_edge, np.asarray(session.held_in_tool, float))
    corners = (T @ held.T_tool_block)[:3, :3] @ (np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1)
                                                           for z in (-1, 1)]).T * held.edge_mm / 2)
    block_z = float(((T @ held.T_tool_block)[2, 3] + corners[2]).min())
    from armlab.gripper_geometry import GRIPPER
    pads_z = float(GRIPPER.pad_corners(T[None], held.edge_mm)[..., 2].min())
    return block_z, pads_z, float(T[2, 3])


def assert_refused_before_moving(h, run, what: str) -> str:
    """run() raises MotionRefused, nothing was sent to the arm and it has not moved; returns the message."""
    sent, q = len(h.session.arm.sent), h.physical()
    with pytest.raises(MotionRefused) as refusal:
        run()
    assert len(h.session.arm.sent) == sent, f"{what}: {len(h.session.arm.sent) - sent} commands sent before refusal"
    moved = np.abs(h.physical() - q).max()
    assert moved < 1e-9, f"{what}: the arm moved {moved:.2f} rad before the refusal: {refusal.value}"
    return str(refusal.value)


def test_the_scenario_takes_only_the_held_block_through_the_board(holding):
    _, down = hover_then_into_board(holding.session)
    block_z, pads_z, tool_z = lowest_parts(holding.session, down)
    assert block_z == pytest.approx(-HELD_BELOW_MM, abs=0.5)
    assert pads_z > 0.0 and tool_z > motion_safety.REAL_LINK_MARGIN_MM, (pads_z, tool_z)


def test_task_machine_execute_refuses_before_the_first_command(holding):
    s = holding.session
    hover, down = hover_then_into_board(s)
    plan = planning.Plan((planning.MoveStep(planning.joint_move(s.arm.joint_positions(), hover), "hover"),
                          planning.MoveStep(planning.joint_move(hover, down), "down")))
    machine = tasks.TaskMachine(s)
    message = assert_refused_before_moving(holding, lambda: machine.execute(plan), "TaskMachine.execute")
    assert "held red block" in message and "step 1 (down)" in message, message
    assert machine.state == "idle"


def test_task_machine_execute_refuses_the_held_block_into_a_known_block(holding):
    s = holding.session
    s.known = [*s.known, detected([*SPOT, 38.0], color="blue")]
    hover, down = hover_then_into_board(s, bottom=20.0)             # 18 mm down into the blue block, above the board
    plan = planning.Plan((planning.MoveStep(planning.joint_move(s.arm.joint_positions(), hover), "hover"),
                          planning.MoveStep(planning.joint_move(hover, down), "down")))
    message = assert_refused_before_moving(holding, lambda: tasks.TaskMachine(s).execute(plan), "into a known block")
    assert "held red block" in message and "known block at (150.0, 220.0) mm" in message, message


@pytest.mark.parametrize("mover", ["session", "arm"])
def test_teach_and_repeat_refuses_before_the_first_command(holding, mover):
    s = holding.session
    program = teach.TeachProgram(hover_then_into_board(s), ("closed", "closed"), "into the board")
    target = s if mover == "session" else s.arm
    message = assert_refused_before_moving(holding, lambda: tasks.repeat(target, program), "tasks.repeat")
    assert "held red block" in message, message


def test_the_sag_fit_refuses_before_the_first_command(holding):
    """tasks.calibrate_sag moves the arm alone through the executor: a pose taking the held block (the arm says it
    holds it) into the board is refused before anything moves, and the measuring function is never called."""
    s = holding.session
    _, down = hover_then_into_board(s)
    measured = []

    def fit():
        tasks.calibrate_sag(holding.station.arm, lambda: measured.append(1) or np.zeros(3), poses=[down])
    message = assert_refused_before_moving(holding, fit, "fitting the sag model: pose 1 of 1")
    assert "held red block" in message and not measured, message


def test_the_station_panels_sliders_refuse_before_the_first_command(holding):
    """The control station's sliders and buttons move through TaskMachine.execute (StationPanel.move); the same
    refusal, through the panel's own call."""
    s = holding.session
    hover, down = hover_then_into_board(s)
    s.arm.move_to(hover)
    machine = tasks.TaskMachine(s)
    plan = planning.Plan((planning.MoveStep(planning.joint_move(s.arm.joint_positions(), down), "sliders"),))
    message = assert_refused_before_moving(holding, lambda: machine.execute(plan), "the sliders")
    assert "held red block" in message, message


def test_the_backend_itself_refuses_the_held_block_into_the_board(holding):
    """Whatever sends the command (here the raw arm, bypassing the task layer), the arm knows what it holds."""
    s = holding.session
    hover, down = hover_then_into_board(s)
    s.arm.move_to(hover)
    raw = holding.station.arm
    q = holding.physical()
    with pytest.raises(MotionRefused, match="held red block"):
        raw.move_to(s.arm.sag.command(down, raw.robot))
    assert np.abs(holding.physical() - q).max() < 1e-9


def test_a_release_off_the_board_is_refused_by_the_placement_rule(holding):
    """drop_with (a student's move_path) and a taught program's open both go through the placement rule."""
    s = holding.session
    message = assert_refused_before_moving(
        holding, lambda: move_path.drop_with(s, [0.0, 20.0, 0.0], path=move_path.default_path()[0]), "drop_with")
    assert "base plate" in message, message


def test_clear_view_carries_the_held_block_through_the_executor(holding):
    """The move out of the camera's view (every look) is checked with the held block too: it is done, and the held
    block is still known afterwards."""
    s = holding.session
    tasks.clear_view(s)
    assert np.abs(s.arm.joint_positions() - planning.CAMERA_CLEAR_POSE).max() < 0.05
    assert s.held is not None and len(holding.station.arm.held_blocks) == 1


def test_the_executor_records_the_release_and_the_arm_forgets_the_block(holding):
    s = holding.session
    assert tasks.place(s, [120.0, 200.0, 0.0])
    assert s.held is None and holding.station.arm.held_blocks == ()
    assert any(np.allclose([k.x, k.y], [120.0, 200.0]) for k in s.known if isinstance(k, planning.Obstacle))


def test_the_task_layer_calls_planning_execute_only_in_the_executor():
    """No module of armlab.tasks (or the control station) calls planning.execute, or imports execute from
    armlab.planning, except the executor, nor commands an arm itself (move_to, open_gripper, close_gripper) except
    the guarded arm the executor runs plans on: every motion goes through Session.run (the sag fit's included)."""
    sources = [*(ROOT / "armlab" / "tasks").rglob("*.py"), ROOT / "armlab" / "ui" / "station_panel.py"]
    found = []
    for path in sources:
        if path.name == "executor.py" and path.parent.name == "tasks":
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if path.name != "guard.py" and isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and \
                    node.func.attr in ("move_to", "open_gripper", "close_gripper"):
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}: {node.func.attr}")
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("armlab.planning") and \
                    any(a.name == "execute" for a in node.names):
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}: imports execute")
            if isinstance(node, ast.Attribute) and node.attr == "execute" and \
                    isinstance(node.value, ast.Name) and node.value.id == "planning":
                found.append(f"{path.relative_to(ROOT)}:{node.lineno}: planning.execute")
    assert len(sources) > 10 and not found, found
    assert "planning.execute" in (ROOT / "armlab" / "tasks" / "executor.py").read_text()


def test_the_executor_refuses_what_is_not_a_plan(holding):
    with pytest.raises(TypeError, match="planning.Plan"):
        executor.run(holding.session, [np.zeros(5)], "a list")


def test_the_safety_checks_never_use_the_dh_chain(holding, monkeypatch):
    """One model: with the DH chain (the student's exercise) broken, the executor's checks, the placement rule at
    the release, the sag model and both backends still work: they use the manufacturer's PoX model only."""
    s = holding.session
    s.known = [*s.known, detected([-200.0, 150.0, 38.0], color="blue")]       # checked against, out of the way
    hover, _ = hover_then_into_board(s)
    spot = np.array([120.0, 200.0, 0.0])
    plan = planning.plan_place(s.arm.joint_positions(), spot + [0.0, 0.0, tasks.RELEASE_GAP_MM], s.held_edge,
                               obstacles=s.known, held_in_tool=s.held_in_tool)   # planning may use the DH chain

    def broken(*_args, **_kwargs):
        raise AssertionError("a safety check used the DH chain")
    for name in ("fk", "fk_dh", "dh_frames", "dh_link_transform"):
        monkeypatch.setattr(kinematics, name, broken)
    q = np.array([hover, hover + [0.0, 0.1, -0.1, 0.0, 0.0]] * 6)
    sag = tasks.fit_sag(q + np.linspace(0, 0.2, 12)[:, None], kinematics.fk_pox(q)[:, :3, 3])
    assert np.all(np.isfinite(sag.tool_error(q)))
    s.run(plan, "placing with the DH chain broken", release_top=spot + [0.0, 0.0, s.held_edge])
    assert s.held is None and holding.station.arm.held_blocks == ()
