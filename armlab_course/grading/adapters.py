"""The child's adapters (copied into the sandbox as armlab_grader.adapters, beside the harness): each builds what a
student's function takes (a Camera, a colour model, a TeachProgram, a sim arm, detections) from the plain data of
one request, calls it, and turns what it returns into plain data (numbers, arrays, strings). They hold no input
generator, seed, reference, scorer or key: the judge (armlab_course.grading.judge, the grader's process) makes the
inputs, and compares or scores what comes back. They reach the kit only through its public parameters.

An adapter is called adapter(function, *args), `function` the student's (a notebook function or a package one)."""

from __future__ import annotations

import numpy as np

__all__ = ["plan_to_plain", "block_from_plain"]


def _camera(K, T, width: int = 1280, height: int = 720):
    from armlab.camera import Camera

    return Camera(np.asarray(K, float), np.zeros(5), np.asarray(T, float), int(width), int(height))


# -- calibration ------------------------------------------------------------------------------------------------
def _call_depth_plane(function, depth, K, T):
    """fit_depth_correction(depth, camera, step=2) on the judge's depth image (90 x 160 mm): [a, b, c, residual mm,
    inliers]."""
    fit = function(np.asarray(depth, np.float32), _camera(K, T, 160, 90), step=2)
    return [fit.a, fit.b, fit.c, fit.residual_mm, fit.inliers]


def _call_initial_pose(function, world, pixels, K, dist):
    """pose_from_corners(refine=False): the region's own R and t, before the Levenberg-Marquardt refinement, with
    the kit's own homography (OpenCV's) in place of the student's dlt_homography while it runs: this check grades
    the pose from a homography, calib.tag_homography grades the homography (a wrong DLT costs that one only)."""
    from armlab.calibration import homography

    students = homography.dlt_homography
    homography.dlt_homography = homography.opencv_homography
    try:
        return function(*(np.asarray(a, float) for a in (world, pixels, K, dist)), refine=False)
    finally:
        homography.dlt_homography = students


def _call_intrinsics(function, homographies, image_size):
    """The student's K with its pixel rows in units of 1000 px (atol 1e-6: 1e-3 px, about 1e-6 of a focal length)
    and its last row as is (0, 0, 1)."""
    K = np.asarray(function([np.asarray(H, dtype=float) for H in homographies], tuple(image_size)), dtype=float)
    if K.shape != (3, 3):
        raise ValueError(f"K has shape {K.shape}, not (3, 3)")
    return np.concatenate([K[:2].ravel() / 1000.0, K[2]]).tolist()


# -- detection --------------------------------------------------------------------------------------------------
def _call_classify(function, names, means, stds, rgb):
    """ColorModel(names, means, stds).classify(rgb): the class indices and the margins."""
    model = function(tuple(str(n) for n in names), np.asarray(means, float), np.asarray(stds, float))
    best, margin = model.classify(np.asarray(rgb, float))
    return [[float(model.names.index(b)) for b in best], np.asarray(margin, float).tolist()]


def _call_stack(function, depth, mask, K, T, edges):
    """stack_from_depth on the judge's rendered depth and mask: [top_z mm, centre x, centre y mm, 10 x levels] (a
    level off is 10 units, beyond any atol of a height)."""
    top_z, levels, centre = function(np.asarray(depth, float), np.asarray(mask, bool), _camera(K, T), tuple(edges))
    centre = np.asarray(centre, dtype=float)
    return [float(top_z), float(centre[0]), float(centre[1]), 10.0 * float(levels)]


def _call_face(function, mask, mm_per_px):
    """face_geometry(mask, mm_per_px) on the judge's drawn square: [u, v, yaw, size class]."""
    u, v, yaw, size = function(np.asarray(mask, np.uint8), float(mm_per_px))
    return [float(u), float(v), float(yaw), str(size)]


def _call_segment(function, rgb):
    """segment_colours with the student's own tuned_hsv_ranges() on the judge's frame: the label image."""
    ranges = function.__globals__["tuned_hsv_ranges"]()
    return np.asarray(function(np.asarray(rgb, np.uint8), ranges))


# -- kinematics -------------------------------------------------------------------------------------------------
def _call_dls(function, T_target, q0):
    """The joints (5,) the student's solve_ik_dls reaches from q0 for T_target (the judge checks them)."""
    result = function(np.asarray(T_target, dtype=float), np.asarray(q0, dtype=float))
    return np.asarray(result[0], dtype=float).ravel()


# -- teach and repeat -------------------------------------------------------------------------------------------
def _call_teach(function, seed, poses, gripper):
    """teach_program on a fresh sim arm (the station's noise seed is an input of the request): the recorded q
    (N x 5), the gripper states (1 closed) and the torque."""
    from armlab.station import make_station

    station = make_station("sim", seed=int(seed), scene="swap")
    program = function(station.arm, np.asarray(poses, float), list(gripper), name="hidden")
    return np.concatenate([np.asarray(program.q, float).ravel(), [g == "closed" for g in program.gripper],
                           [float(station.arm.torque_enabled)]])


def _call_scaled_durations(function, q, speed):
    from armlab.robot import rx200
    from armlab.tasks.teach import TeachProgram

    function.__globals__["robot"] = rx200()       # the notebook's `robot` (its cell ran definitions only)
    q = np.asarray(q, float)
    return function(TeachProgram(q, ("open",) * len(q), "hidden"), float(speed))


def _call_scaled_plan(function, q, gripper, durations):
    """scaled_plan on a TeachProgram: per step [1, duration, end joints (5)] for a move, [0, 1 close / 0 open, 0 x 5]
    for a gripper step."""
    from armlab import planning
    from armlab.tasks.teach import TeachProgram

    plan = function(TeachProgram(np.asarray(q, float), tuple(gripper), "hidden"), np.asarray(durations, float))
    rows = []
    for step in plan.steps:
        if isinstance(step, planning.MoveStep):
            rows.append([1.0, float(step.duration), *np.asarray(step.trajectory.end, float)])
        else:
            rows.append([0.0, float(step.action == "close"), 0.0, 0.0, 0.0, 0.0, 0.0])
    return rows


# -- the station's state machine --------------------------------------------------------------------------------
class _Arm:
    """The stand-in arm: it only hears the stop and the reset."""

    def __init__(self):
        self.stops = 0

    def emergency_stop(self):
        self.stops += 1

    def reset(self):
        pass


class _Station:
    def __init__(self):
        self.arm = _Arm()


def _work(machine, command, kind: str, k: int):
    """The work of a scripted command of this kind (see _call_transition)."""
    from armlab.tasks.machine import MachineBusy

    def stop():
        from armlab.station.contract import EmergencyStopped

        raise EmergencyStopped("the arm stopped")

    def fail():
        raise ValueError("the work failed")

    def stop_then_fail():
        machine.estop()
        raise ValueError("the work failed after the stop")

    def nested():                                  # another command from inside: refused, the outer one goes on
        try:
            command("detect", lambda: -1)
        except MachineBusy:
            return k
        return -2

    return {"ok": lambda: k, "arm_stop": stop, "button_stop": lambda: (machine.estop(), k)[1], "error": fail,
            "error_after_stop": stop_then_fail}.get(kind, nested)


def _call_transition(function, script):
    """Per event of the script: [what the call gave (0 the action's result, 1 EmergencyStopped, 2 MachineBusy,
    3 ValueError, 4 anything else or a wrong result), the state after (index in STATES)], then the history (indices)."""
    from armlab.station.contract import EmergencyStopped
    from armlab.tasks.machine import STATES, MachineBusy, TaskMachine
    from armlab.tasks.session import Session

    station = _Station()
    machine = TaskMachine(Session(station, station.arm), transition=function)   # a stand-in session: no calibration

    def command(state, work):
        return machine.transition(machine, state, work)

    out = []
    for k, (kind, state) in enumerate(script):
        if kind == "estop":
            machine.estop()
            code = 0
        elif kind == "reset":
            machine.reset()
            code = 0
        else:
            try:
                code = 0 if command(state, _work(machine, command, kind, k)) == k else 4
            except EmergencyStopped:
                code = 1
            except MachineBusy:
                code = 2
            except ValueError:
                code = 3
            except Exception:
                code = 4
        out += [float(code), float(STATES.index(machine.state))]
    return out + [float(STATES.index(s)) for s in machine.history]


# -- the station's whole machine (station.machine) ---------------------------------------------------------------
class _ScriptedPort:
    """The port the student's StationMachine drives in a scripted session: every call is logged as numbers (halt 1,
    restart 2, torque off 3 / on 4, joints 5, a command's work 10 + its index in COMMANDS, a replay 20 then its
    waypoint count, the sum of its joints and its closed grippers); a command's work and a replay do what the
    script says for the press under way (see _call_machine)."""

    def __init__(self):
        self.log: list[float] = []
        self.machine, self.outcome, self.k, self.reads = None, "ok", 0, 0

    def halt(self):
        self.log.append(1.0)

    def restart(self):
        self.log.append(2.0)

    def set_torque(self, on):
        self.log.append(4.0 if on else 3.0)

    def joints(self):
        self.reads += 1
        self.log.append(5.0)
        return np.array([0.01, -0.02, 0.03, -0.04, 0.05]) * self.reads

    def work(self, command, *args):
        from armlab.tasks.port import COMMANDS

        self.log.append(10.0 + COMMANDS.index(command))
        return self._do()

    def replay(self, joints, grippers):
        joints = np.asarray(joints, float).reshape(-1, 5)
        self.log += [20.0, float(len(joints)), float(joints.sum()), float(sum(g == "closed" for g in grippers))]
        return self._do()

    def _do(self):
        from armlab.station.contract import EmergencyStopped
        from armlab.tasks.machine import MachineBusy

        if self.outcome == "arm_stop":
            raise EmergencyStopped("the arm stopped")
        if self.outcome == "error":
            raise ValueError("the work failed")
        if self.outcome == "button_stop":            # the button, pressed while the work runs
            self.machine.press("estop")
        elif self.outcome == "nested":               # another button from inside: refused, the work goes on
            try:
                self.machine.press("detect")
            except MachineBusy:
                return self.k
            return -2
        return self.k


def _call_machine(function, script):
    """A scripted session of the student's StationMachine(port): per press [what it gave (0 a result, 1
    EmergencyStopped, 2 MachineBusy, 3 ValueError, 4 anything else), the result as a number (a command's: 1 when it
    is the work's; a vector's sum; a count; 0 for None), the state after (index in STATES, -1 another)], then the
    port's log, the history (indices) and the program's length. A press is [button, outcome or argument].

    The machine's commands run through the kit's stand-in transition (latching_transition) in place of the
    notebook's run_command, the same for the reference and for the student: what exercise station.transition's
    answer does (written, blank or wrong) changes nothing here, so a wrong transition costs its own exercise only."""
    from armlab.station.contract import EmergencyStopped
    from armlab.tasks.machine import STATES, MachineBusy, latching_transition

    namespace = getattr(getattr(function, "press", None), "__globals__", None)
    if isinstance(namespace, dict) and "run_command" in namespace:
        namespace["run_command"] = latching_transition
    port = _ScriptedPort()
    machine = port.machine = function(port)
    out = []
    for k, (button, arg) in enumerate(script):
        port.outcome, port.k = str(arg), k
        args = (arg,) if button == "record" else ()
        try:
            got = machine.press(button, *args)
            code = 0
            if got is None:
                value = 0.0
            elif button not in ("record", "finish"):
                value = float(got == k) if isinstance(got, int) and not isinstance(got, bool) else -1.0
            else:
                value = float(np.sum(np.asarray(got, dtype=float)))
        except EmergencyStopped:
            code, value = 1, 0.0
        except MachineBusy:
            code, value = 2, 0.0
        except ValueError:
            code, value = 3, 0.0
        except Exception:
            code, value = 4, 0.0
        state = machine.state
        out += [float(code), value, float(STATES.index(state)) if state in STATES else -1.0]
    history = [float(STATES.index(s)) if s in STATES else -1.0 for s in machine.history]
    return out + port.log + history + [float(len(machine.program or ()))]


# -- open tasks: what the robot would be told ---------------------------------------------------------------------
def plan_to_plain(plan) -> list[dict]:
    """A planning.Plan as the arm's commands: per move step its start joints and its waypoints [q (5), moving time
    s, ramp s] (what planning.execute sends), per gripper step its action and duration."""
    from armlab import planning

    if not isinstance(plan, planning.Plan):
        raise TypeError(f"move_path must return a planning.Plan, got {type(plan).__name__}")
    steps = []
    for step in plan.steps:
        if isinstance(step, planning.MoveStep):
            steps.append({"start": np.asarray(step.trajectory.start, float).tolist(), "label": str(step.label),
                          "waypoints": [[np.asarray(w.q, float).tolist(), float(w.moving_time), float(w.accel_time)]
                                        for w in step.trajectory.waypoints()]})
        else:
            steps.append({"gripper": str(step.action), "label": str(step.label), "duration": float(step.duration)})
    return steps


def _call_move_path(function, q_start, target, yaw, edge, action):
    """The student's move_path for one grasp or release the judge's station asks for: the plan as commands."""
    return plan_to_plain(function(np.asarray(q_start, float), np.asarray(target, float), float(yaw), float(edge),
                                  str(action)))


_FIELDS = ("color", "size", "position", "yaw", "pixel", "edge_mm", "shape", "levels", "color_margin")


def block_from_plain(plain: dict):
    """A detection.Block from the judge's plain detection (its contour and colours left out)."""
    from armlab.detection.types import Block

    kwargs = {k: plain[k] for k in _FIELDS}
    kwargs["position"] = np.asarray(kwargs["position"], float)
    kwargs["pixel"] = tuple(float(p) for p in kwargs["pixel"])
    return Block(**kwargs)


_SEQUENCE: dict[str, object] = {}


def _call_sequence(function, op, *args):
    """The student's click sequence, driven by the judge's clicks: "start" makes ClickSequence(); "click" point (3,)
    seen (plain detections) gives ["grab", index in seen], ["drop", position (3,), yaw] or ["refuse", why] (a
    ClickRefused); "after" ok tells it the last action's outcome."""
    from armlab.tasks import ClickRefused

    if op == "start":
        _SEQUENCE.clear()
        _SEQUENCE["object"], _SEQUENCE["last"] = function(), None
        return None
    sequence = _SEQUENCE["object"]
    if op == "click":
        seen = [block_from_plain(b) for b in args[1]]
        try:
            action = sequence.on_click(np.asarray(args[0], float), seen)
        except ClickRefused as e:
            return ["refuse", str(e)[:200]]
        _SEQUENCE["last"] = action
        if action[0] == "grab":
            index = next((i for i, b in enumerate(seen) if b is action[1]), None)
            if index is None:
                raise ValueError("a grab must name a block of `seen`")
            return ["grab", index]
        if action[0] == "drop":
            return ["drop", np.asarray(action[1], float).tolist(), float(action[2])]
        raise ValueError(f"unknown action {action[0]!r}")
    if op == "after":
        sequence.after(_SEQUENCE["last"], bool(args[0]))
        return None
    raise ValueError(f"unknown click request {op!r}")


_STRATEGY: dict[str, object] = {}


def _call_strategy(function, op, *args):
    """The student's event strategy (SortStackStrategy, LineUpStrategy, SkyStrategy), driven by the judge's run of
    the event: "start" level makes the strategy object of that level; "next_move" seen (plain detections) gives
    [index of the block in seen, to (3,), yaw, why, clearance] or None with the stop reason; "placed" index... hears
    the move placed; "cannot_place" why gives True/False; "obstacles" gives [[x, y, top, radius], ...]."""
    if op == "start":
        _STRATEGY.clear()
        _STRATEGY["object"], _STRATEGY["moves"] = function(int(args[0])), []
        return None
    strategy = _STRATEGY["object"]
    if op == "next_move":
        seen = [block_from_plain(b) for b in args[0]]
        move = strategy.next_move(seen)
        if move is None:
            return [None, str(getattr(strategy, "stopped", "") or "")]
        index = next((i for i, b in enumerate(seen) if b is move.block), None)
        if index is None:
            raise ValueError("next_move must return a Move of a block from `seen`")
        _STRATEGY["moves"].append(move)
        return [index, np.asarray(move.to, float).tolist(), float(move.yaw), str(move.why), float(move.clearance)]
    if op == "placed":
        strategy.placed(_STRATEGY["moves"][-1])
        return None
    if op == "cannot_place":
        own = getattr(strategy, "cannot_place", None)
        return bool(own(str(args[0]))) if callable(own) else False
    if op == "obstacles":
        own = getattr(strategy, "obstacles", None)
        return [[float(o.x), float(o.y), float(o.top), float(o.radius)] for o in (own() if callable(own) else [])]
    raise ValueError(f"unknown strategy request {op!r}")
