"""The watch around one sandboxed run: a small process of the grader's own (outside the sandbox, standard library
only, started with `python -I -S`) that starts the run's command and, every POLL seconds until it ends, adds up what
the run uses and stops it, saying why on the run's output, the moment one total passes its cap:
- processes: every process the run started (the watch is their child subreaper, so a process that leaves its session
  and parent stays counted);
- memory: their resident set sizes, summed;
- disk: the bytes and files under the run's writable folders (its work tree and home), and, for a run under a uid of
  its own, what that uid owns in the shared temporary folders.

These totals hold whether or not the machine has cgroups. The per-process limits (CPU seconds, address space, file
size, RLIMIT_NPROC) are set by prlimit inside the sandbox and stop most runs before the watch sees them; the watch
bounds what they cannot: the sum over processes and files. When the command ends, every process the run left is
killed. Exit status: the command's (a signal it died of is passed on), or 137 when the watch stopped it.

    python -I -S watch.py CAPS_JSON -- COMMAND...
"""

from __future__ import annotations

import ctypes
import json
import os
import signal
import subprocess
import sys
import time

POLL = 0.2
_PAGE = os.sysconf("SC_PAGE_SIZE")
PR_SET_CHILD_SUBREAPER = 36


def _children() -> dict[int, list[int]]:
    """Every process's children, from /proc."""
    kids: dict[int, list[int]] = {}
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat", "rb") as f:
                stat = f.read()
        except OSError:
            continue
        ppid = int(stat[stat.rindex(b")") + 2:].split()[1])
        kids.setdefault(ppid, []).append(int(name))
    return kids


def descendants(root: int) -> list[int]:
    """The processes below `root` (not itself)."""
    kids, out, todo = _children(), [], [root]
    while todo:
        for child in kids.get(todo.pop(), []):
            out.append(child)
            todo.append(child)
    return out


def resident_bytes(pids: list[int]) -> int:
    total = 0
    for pid in pids:
        try:
            with open(f"/proc/{pid}/statm", "rb") as f:
                total += int(f.read().split()[1]) * _PAGE
        except (OSError, ValueError, IndexError):
            continue
    return total


def entries(folder: str, owner: int | None = None) -> list[tuple[os.DirEntry, os.stat_result]]:
    """The entries of `folder` with their own status (symbolic links not followed), only those `owner` owns if
    given; [] when the folder cannot be read."""
    try:
        found = list(os.scandir(folder))
    except OSError:
        return []
    out = []
    for entry in found:
        try:
            info = entry.stat(follow_symlinks=False)
        except OSError:
            continue
        if owner is None or info.st_uid == owner:
            out.append((entry, info))
    return out


def tree_usage(paths: list[str], stop_files: int, owner: int | None = None) -> tuple[int, int]:
    """(bytes allocated, entries) under `paths` (not following symbolic links); with `owner`, only the top entries
    of each path that uid owns. Stops counting past `stop_files` entries."""
    size = files = 0
    todo = list(paths)
    top = set(paths) if owner is not None else set()
    while todo and files <= stop_files:
        folder = todo.pop()
        for entry, info in entries(folder, owner if folder in top else None):
            files += 1
            size += info.st_blocks * 512
            if entry.is_dir(follow_symlinks=False):
                todo.append(entry.path)
    return size, files


def over(caps: dict, pids: list[int], base: tuple[int, int]) -> str:
    """Why the run must stop now ('' when it may go on)."""
    if len(pids) > caps["procs"]:
        return f"it had more than {caps['procs']} processes at once"
    if resident_bytes(pids) > caps["rss_mb"] * 2**20:
        return f"its processes held more than {caps['rss_mb']} MB of memory together"
    size, files = tree_usage(caps["trees"], caps["files"])
    if caps.get("uid") is not None:
        shared = tree_usage(caps["shared"], caps["files"], caps["uid"])
        size, files = size + shared[0], files + shared[1]
    if size - base[0] > caps["disk_mb"] * 2**20:
        return f"it wrote more than {caps['disk_mb']} MB of files"
    if files - base[1] > caps["files"]:
        return f"it made more than {caps['files']} files"
    return ""


def kill_until_gone(members, between=lambda: None) -> None:
    """SIGKILL every pid members() lists, again until it lists none (a process may fork while it is being killed;
    at most 100 rounds), calling between() after each round."""
    for _ in range(100):
        pids = members()
        if not pids:
            return
        for pid in pids:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        time.sleep(0.02)
        between()


def _kill_all(me: int, keep: int) -> None:
    """SIGKILL every process below the watch until none is left but `keep` (the command, waited for by Popen)."""
    kill_until_gone(lambda: [p for p in descendants(me) if p != keep], lambda: _reap(me, keep))


def _reap(me: int, keep: int) -> None:
    """Wait for the watch's finished children other than `keep` (orphans it adopted as their subreaper)."""
    for pid in _children().get(me, []):
        if pid != keep:
            try:
                os.waitpid(pid, os.WNOHANG)
            except ChildProcessError:
                pass


def main(argv: list[str]) -> int:
    caps = json.loads(argv[0])
    command = argv[2:]
    ctypes.CDLL(None, use_errno=True).prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)
    base = tree_usage(caps["trees"], caps["files"])
    me = os.getpid()
    child = subprocess.Popen(command)
    why = ""
    while child.poll() is None:
        time.sleep(POLL)
        _reap(me, child.pid)
        why = over(caps, descendants(me), base)
        if why:
            break
    if why:
        print(f"\narmlab sandbox: the run was stopped: {why}", file=sys.stderr, flush=True)
    if why:
        os.kill(child.pid, signal.SIGKILL)
    code = child.wait()
    _kill_all(me, -1)
    if why:
        return 137
    if code < 0:
        signal.signal(-code, signal.SIG_DFL)
        os.kill(me, -code)
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
