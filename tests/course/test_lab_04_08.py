"""Notebooks 04-08 as labs (issue 23, branch lab23b): the exercises' hidden checks score the blank stub 0 and a wrong
answer loses its own exercise only; the kit's pieces the exercises stand on (move_path's runners and input checks,
the TaskMachine's replaceable transition, the segmentation scorer, non-colliding detection labels)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from armlab_course.exercises.markers import stub_lines
from armlab_course.grading.run import Limits

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "course"))
MINE = ("detect.segment", "detect.face", "grab.click_target", "grab.move_path", "events.sort_stack",
        "station.transition")
CHEAP = ("detect.face", "grab.click_target", "station.transition")      # hidden checks without a simulator run


@pytest.fixture(scope="module")
def grader():
    """One Grader of MINE and detect.stacks for the whole file: the expected values of all seven exercises from one
    harness run on the instructor's copy (each test made its own Grader: five, two of them the same twice)."""
    from armlab_course.grading.grade import Grader

    with Grader(ROOT, Limits(timeout_s=600, cpu_s=400), [*MINE, "detect.stacks"]) as made:
        yield made


def _blank(exercise_id: str) -> list[str]:
    from wrong_answers import reference_bodies as _reference_bodies

    return ["\n".join("    " + line for line in stub_lines(exercise_id))] * len(_reference_bodies(exercise_id))


def test_the_blank_stubs_fail_every_hidden_check(grader):
    got = grader.hidden_checks_together({e: _blank(e) for e in MINE})
    for exercise_id in MINE:
        assert got[exercise_id] and not any(c.passed for c in got[exercise_id]), (exercise_id, got[exercise_id])


@pytest.mark.parametrize("round_", [0, 1])
def test_a_wrong_answer_loses_its_own_exercise_only(grader, round_):
    """Each cheap exercise wrong in turn (its round_-th wrong answer of wrong_answers.HIDDEN_WRONG) while the other
    holds the reference: the wrong one fails a hidden check, the other passes every one."""
    from wrong_answers import check_each_wrong_loses_only_its_own

    check_each_wrong_loses_only_its_own(grader, CHEAP, round_)


@pytest.fixture(scope="module")
def blank_stacks(grader):
    """The hidden checks of detect.stacks blank beside detect.face's reference: the same run for both rounds below."""
    from wrong_answers import reference_bodies as _reference_bodies

    return grader.hidden_checks_together({"detect.stacks": _blank("detect.stacks"),
                                          "detect.face": _reference_bodies("detect.face")})


@pytest.mark.parametrize("round_", [0, 1])
def test_a_wrong_stack_answer_loses_detect_stacks_only(grader, blank_stacks, round_):
    """detect.stacks (section 6 of notebook 04) blank or wrong (its round_-th wrong answer) while detect.face, another
    cheap exercise of the notebook, holds the reference: detect.stacks fails a hidden check (blank: every one),
    detect.face passes every one."""
    from wrong_answers import HIDDEN_WRONG
    from wrong_answers import reference_bodies as _reference_bodies

    label, bodies = list(HIDDEN_WRONG["detect.stacks"].items())[round_]
    wrong = grader.hidden_checks_together({"detect.stacks": bodies, "detect.face": _reference_bodies("detect.face")})
    for what, got in ((label, wrong), ("blank", blank_stacks)):
        assert got["detect.stacks"] and not all(c.passed for c in got["detect.stacks"]), what
        if what == "blank":
            assert not any(c.passed for c in got["detect.stacks"]), got["detect.stacks"]
        assert all(c.passed for c in got["detect.face"]), (what, [c.message for c in got["detect.face"]])


def test_the_stack_renderer_of_the_hidden_checks_sees_the_stack():
    """The hidden checks' ray-cast stack: the mask's highest returns are the top face at the cubes' summed edges,
    the sides reach down towards the board, and the lost returns are NaN or 0."""
    from armlab.camera import Camera
    from armlab_course.grading.hidden import detect_stacks

    K, T, blocks, _, lost, seed = detect_stacks._stacks(np.random.default_rng(3))[0][0]
    depth, mask = detect_stacks.render_stack(K, T, blocks, 0.0, lost, seed)
    v, u = np.nonzero(mask)
    d = depth[v, u]
    assert 0.02 < np.isnan(d).mean() + (d == 0).mean() < 0.2
    ok = np.isfinite(d) & (d > 0)
    z = Camera(K, np.zeros(5), T).pixel_to_world(np.column_stack([u[ok], v[ok]]).astype(float), d[ok])[:, 2]
    assert abs(np.percentile(z, 80) - sum(b[3] for b in blocks)) < 0.5 and z.min() < 0.6 * sum(b[3] for b in blocks)


def test_move_path_refuses_bad_input_and_plans_a_straight_descent():
    from armlab import kinematics, planning
    from armlab.tasks.move_path import move_path

    q0 = np.zeros(5)
    for bad, why in (({"action": "push"}, "action"), ({"target": [0.0, 200.0]}, "target"),
                     ({"edge": -1.0}, "edge")):
        args = {"target": [0.0, 250.0, 38.0], "yaw": 0.0, "edge": 38.0, "action": "grasp", **bad}
        with pytest.raises(ValueError, match=why):
            move_path(q0, args["target"], args["yaw"], args["edge"], args["action"])
    plan = move_path(q0, [100.0, 250.0, 38.0], 0.3, 38.0, "grasp")
    moves = [s for s in plan.steps if isinstance(s, planning.MoveStep)]
    grips = [s.action for s in plan.steps if isinstance(s, planning.GripperStep)]
    assert grips == ["open", "close"]
    low = kinematics.fk(moves[1].trajectory.end)[:3, 3]
    assert np.allclose(low, [100.0, 250.0, 19.0], atol=1e-6)          # a 38 mm cube gripped at its centre
    high = kinematics.fk(moves[1].trajectory.start)[:3, 3]
    assert np.allclose(high[:2], low[:2], atol=1e-6) and high[2] > low[2] + 50.0


def test_a_task_machine_runs_every_command_through_its_transition():
    from armlab.station.contract import EmergencyStopped
    from armlab.tasks.machine import MachineBusy, TaskMachine
    from armlab.tasks.session import Session
    from armlab.tasks.transition import command_transition

    class Arm:
        def emergency_stop(self):
            pass

        def reset(self):
            pass

    station = type("Station", (), {"arm": Arm()})()
    seen = []

    def spy(machine, state, action):
        seen.append(state)
        return command_transition(machine, state, action)

    machine = TaskMachine(Session(station, station.arm), transition=spy)     # a stand-in session: no camera
    assert machine._run("detect", lambda: 5) == 5 and seen == ["detect"]
    with pytest.raises(MachineBusy):
        machine._run("execute", lambda: machine._run("detect", lambda: None))
    assert machine.state == "idle"
    machine.estop()
    with pytest.raises(EmergencyStopped):
        machine._run("detect", lambda: None)
    assert machine.history[-1] == "estop" and machine.stop_requested
    with pytest.raises(ValueError, match="unknown state"):
        machine.enter("dancing")


def test_detection_labels_do_not_overlap():
    from armlab.detection.draw import _label_origin

    taken = []
    for u, v in [(400, 300), (405, 302), (398, 310), (410, 296)]:      # four blocks' centres a few px apart
        _label_origin("green large", u, v, taken, (720, 1280, 3))
    for i, a in enumerate(taken):
        for b in taken[i + 1:]:
            assert a[2] <= b[0] or b[2] <= a[0] or a[3] <= b[1] or b[3] <= a[1], (a, b)


def test_the_segmentation_score_names_a_bad_label_image():
    from armlab.sim.detection_eval import balanced_frame, score_segmentation, sim_case

    case = sim_case("random", 7)
    rgb, board = balanced_frame(case)
    assert rgb.dtype == np.uint8 and board.mean() > 0.3
    with pytest.raises(ValueError, match="label image"):
        score_segmentation(case, np.zeros((10, 10), int), board)
    nothing = score_segmentation(case, np.full(case.rgb.shape[:2], -1), board)
    assert nothing.pairs and nothing.face_accuracy == 0.0 and nothing.board_labelled == 0.0


class _CommandsOnly:
    """A partial machine of one's own (commands, a stop and a reset; no teaching, no refusal rules) for the panel."""

    def __init__(self, port, hears_the_stop=True):
        self.port, self.hears_the_stop = port, hears_the_stop
        self.state, self.history, self.program = "idle", ["idle"], None

    def press(self, button, *args):
        if button == "estop" and not self.hears_the_stop:
            raise RuntimeError("this machine's estop is broken")
        if button in ("estop", "reset"):
            getattr(self.port, "halt" if button == "estop" else "restart")()
        else:
            self.history.append(button)
            try:
                return self.port.work(button, *args)
            finally:
                self.history.append("idle")
        self.state = "estop" if button == "estop" else "idle"
        self.history.append(self.state)
        return None


def test_a_machine_of_ones_own_drives_the_panel_and_the_estop_never_goes_through_it():
    """station_panel(session, machine=OwnMachine(session, StationMachine)) presses the machine's buttons (a move is its
    "execute"; a button it does not know is refused in the log); the E-STOP halts the arm through the port first, so
    a machine whose estop raises still stops the station: the next move is refused by the guarded arm, nothing moves."""
    from armlab import make_station, tasks
    from armlab.tasks.port import OwnMachine
    from armlab.ui import station_panel

    station = make_station("sim", seed=0, scene={"objects": []})
    session = tasks.start_session(station, "factory", sag=tasks.SagModel())     # no sag fit, no checkerboard: faster
    panel = station_panel(session, machine=OwnMachine(session, _CommandsOnly), look=False)
    panel.home()
    assert "moved to" in panel.wait(), panel.messages
    assert panel.machine.history[-2:] == ["execute", "idle"]
    assert "teach refused" in panel.teach() and panel.machine.state == "idle"
    broken = station_panel(session, machine=OwnMachine(session, lambda port: _CommandsOnly(port, False)), look=False)
    q = station.arm.joint_positions().copy()
    broken.estop()
    assert isinstance(broken.machine.estop_error, RuntimeError) and broken.machine.stop_requested
    broken.sleep()
    assert "EmergencyStopped" in broken.wait(), broken.messages
    np.testing.assert_allclose(station.arm.joint_positions(), q, atol=0.005)     # encoder readings jitter
