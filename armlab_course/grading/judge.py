"""The judge: the grader's side of the hidden checks, in the grader's own process. It talks to one sandboxed child
(armlab_grader.harness) over a pipe in plain data (armlab_course.grading.wire; docs/grading.md, "The judge"):

1. it sends the jobs: per job the function to find, the child's adapter, the prelude and the forbidden names
   (no inputs, no seed);
2. the child answers {"nonce", "ready"} once it has wired its tripwires;
3. per call it sends {"seq", "job", "args"} (the arguments as plain data, made here) and reads
   {"nonce", "seq", "value" | "error", "forbidden"}; an answer of another nonce or sequence number is refused;
4. it sends {"end": true}.

A job's judge-side hook (HiddenSpec.judge, a function of the exercise's hidden module) turns one hidden case into
calls: it renders inputs, asks the child, and turns the answers into the numbers compared or scored -- for an open
task it replays what the student's code would tell the robot on the judge's own simulator and scores the outcome
from the simulator's ground truth. Without a hook a case's arguments are sent as they are and the answer is the
value. The child decides nothing: whatever it sends is the student's answer, checked here.
"""

from __future__ import annotations

import re
import secrets
import subprocess
from collections.abc import Callable

from .wire import LineReader, WireError, decode, dumps, encode, loads

__all__ = ["ChildError", "ChildGone", "Child", "run_jobs", "where_of", "MAX_FRAMES"]

_ERROR_CHARS = 300
MAX_FRAMES = 8                                    # the student's frames shown with an error (innermost last)
_FUNCTION = re.compile(r"<[a-z]{1,12}>|[A-Za-z_]\w{0,59}")      # a function's name, or <module>, <lambda>...


class ChildError(Exception):
    """The student's code raised (or returned what cannot be sent): the message is the child's one line; `where`
    the frames the child says were the student's own (where_of: plain [place, line, function] triples only)."""

    def __init__(self, message: str, where: list | None = None) -> None:
        super().__init__(message)
        self.where = where or []


def where_of(sent) -> list[list]:
    """The frames a child sent with an error, kept only when each is [place, line, function] with a short place,
    a line number and a function name (at most MAX_FRAMES, innermost last); anything else is dropped. The grader
    then shows only those of the exercise's own file (grade.py: they are what the student's process says)."""
    if not isinstance(sent, list):
        return []
    out = []
    for frame in sent[-MAX_FRAMES:]:
        if isinstance(frame, list) and len(frame) == 3 and isinstance(frame[0], str) and len(frame[0]) <= 200 \
                and type(frame[1]) is int and 0 < frame[1] < 1_000_000 and isinstance(frame[2], str) \
                and _FUNCTION.fullmatch(frame[2]):
            out.append([frame[0], frame[1], frame[2]])
    return out


class ChildGone(Exception):
    """The child stopped answering (it ended, timed out or broke the protocol): no further call is made."""


class Child:
    """The judge's end of the pipe to one child process: call(job, *args) -> the decoded value, or ChildError."""

    def __init__(self, proc: subprocess.Popen, jobs: list[dict], deadline: float):
        self.proc, self.deadline = proc, deadline
        self.nonce = secrets.token_hex(16)
        self.forbidden: list[set[str]] = [set() for _ in jobs]
        self._reader = LineReader(proc.stdout.fileno())
        self._seq = 0
        self._send({"nonce": self.nonce, "jobs": [
            {k: job.get(k) for k in ("notebook", "function", "adapter", "prelude", "forbidden")} for job in jobs]})
        ready = self._receive()
        if ready.get("ready") != len(jobs):
            raise ChildGone("the hidden checks' process did not start its jobs")

    def _send(self, message: dict) -> None:
        try:
            self.proc.stdin.write(dumps(message))
            self.proc.stdin.flush()
        except (BrokenPipeError, OSError, ValueError):
            raise ChildGone("the hidden checks' process ended") from None

    def _receive(self) -> dict:
        try:
            message = loads(self._reader.line(self.deadline))
        except TimeoutError:
            raise ChildGone("the hidden checks did not finish in time") from None
        except EOFError:
            raise ChildGone("the hidden checks' process ended") from None
        except WireError as e:
            raise ChildGone(f"the hidden checks' process broke the protocol ({e})") from None
        if message.get("nonce") != self.nonce:
            raise ChildGone("an answer that is not this run's (its nonce differs)")
        return message

    def call(self, job: int, *args):
        """The value of one call of job `job` on `args` (plain data: arrays allowed); ChildError with the student's
        error; ChildGone when the child no longer answers."""
        self._seq += 1
        self._send({"seq": self._seq, "job": job, "args": encode(list(args))})
        answer = self._receive()
        if answer.get("seq") != self._seq:
            raise ChildGone("an answer out of turn (its sequence number differs)")
        forbidden = answer.get("forbidden", [])
        if isinstance(forbidden, list):
            self.forbidden[job] |= {str(f) for f in forbidden[:50]}
        if "error" in answer:
            raise ChildError(str(answer["error"])[:_ERROR_CHARS], where_of(answer.get("where")))
        if "value" not in answer:
            raise ChildGone("an answer with neither a value nor an error")
        try:
            return decode(answer["value"])
        except (WireError, ValueError) as e:
            raise ChildError(f"a result that is not plain data ({e})") from None

    def end(self) -> None:
        try:
            self._send({"end": True})
        except ChildGone:
            pass


def _direct(call: Callable, *args):
    return call(*args)


def run_jobs(proc: subprocess.Popen, jobs: list[dict], deadline: float) -> tuple[list | None, str]:
    """Every case of every job asked of the child `proc` before `deadline` (time.monotonic()): per job {"results":
    per case {"value": ...} or {"error": ..., "where": the student's frames, if any}, "forbidden": sorted names},
    and '' -- or, when the child stops answering part way, the results so far with an error for every case left,
    and why. (None, why) when it never started. A job: {"notebook", "function", "adapter", "prelude", "forbidden",
    "cases": [args...], "judge": hook(call, *args) or None}."""
    try:
        child = Child(proc, jobs, deadline)
    except ChildGone as e:
        return None, str(e)
    problem = ""
    out = []
    for j, job in enumerate(jobs):
        hook = job.get("judge") or _direct
        results = []
        for args in job["cases"]:
            if problem:
                results.append({"error": problem})
                continue
            try:
                results.append({"value": hook(lambda *a, j=j: child.call(j, *a), *args)})
            except ChildError as e:
                results.append({"error": str(e), "where": e.where})
            except ChildGone as e:
                problem = str(e)
                results.append({"error": problem})
            except Exception as e:              # the judge could not use what the child sent (a wrong shape, say)
                results.append({"error": f"the result could not be used ({type(e).__name__})"})
        out.append({"results": results, "forbidden": sorted(child.forbidden[j])})
    if not problem:
        child.end()
    return out, problem

