"""The sandbox around every process that runs student code (Linux only).

A sandboxed run sees its own copy of the work tree (read-write, at WORK inside), the Python environment and the
system's programs and libraries read-only, the grader's own files read-only at GRADER, a private /tmp and home, and
nothing else: not the instructor's checkout, not other students, not the grader's output or temporary trees. It has
no network, its own PID namespace (every process it starts dies with it, whatever session or process group it put
itself in) and the CPU-seconds, address-space and file-size limits of `Limits`, set by util-linux's `prlimit` inside
the sandbox (no `preexec_fn`, which Python documents as unsafe in a threaded program such as `grade --jobs`).

Backends, chosen by `detect()` once per process (or by ARMLAB_SANDBOX=bwrap|user|none):
- "bwrap": bubblewrap (Debian's `bubblewrap`), the tool Flatpak builds its sandboxes with: Linux namespaces
  (mount, PID, network, IPC, UTS, cgroup) without a daemon. It is the default wherever it can start.
- "user": for a grader that is root where namespaces are not allowed (Gradescope's Docker containers): the run goes
  to an unprivileged user of its own (setpriv: a uid from USER_UIDS, no groups, no capabilities), which cannot read
  the instructor's files (the caller makes them root-only: `lock_down`), and every process of that uid is killed when
  the run ends. No network isolation here: the container's own.
- "none": no sandbox; only with the instructor's explicit --unsafe-no-sandbox.
"""

from __future__ import annotations

import fcntl
import itertools
import json
import os
import shutil
import stat
import subprocess
import sys
import sysconfig
import threading
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from .watch import entries
from .watch import kill_until_gone as _kill_until_gone

__all__ = ["GRADER", "HOME", "WORK", "USER_UIDS", "Limits", "Sandbox", "SandboxUnavailable", "detect", "lock_down",
           "RUN_USERS", "uid_lock_dir", "uids_in_use", "remove_owned", "SHARED_TMP", "owner_only",
           "refuse_shared_network", "python_outside"]

@dataclass(frozen=True)
class Limits:
    """One run's limits (defined here, where the sandbox applies them; armlab_course.grading.run re-exports it):
    - timeout_s: wall-clock seconds for the run;
    - cpu_s: CPU seconds per process (RLIMIT_CPU);
    - memory_mb: address space per process (RLIMIT_AS), and the resident memory of all the run's processes together
      (the watch);
    - max_procs: processes of the run at once (RLIMIT_NPROC of a uid or user namespace of the run's own, a pids
      cgroup where there is one, and the watch's count);
    - disk_mb: the largest file (RLIMIT_FSIZE, which also caps the run's console output) and what the run may add
      to its work tree and home (the watch);
    - scratch_mb: the size of each of the sandbox's memory-backed folders (/tmp, the home, /dev/shm);
    - max_files: files and folders the run may add (the watch)."""

    timeout_s: float = 300.0
    cpu_s: int = 300
    memory_mb: int = 8192
    max_procs: int = 256
    disk_mb: int = 1024
    scratch_mb: int = 512
    max_files: int = 20_000


WORK = "/home/student/work"        # the work tree, inside a "bwrap" sandbox
HOME = "/home/student"
GRADER = "/grader"                 # the grader's files (read-only), inside a "bwrap" sandbox
USER_UIDS = range(64000, 64016)    # the unprivileged users of the "user" backend, one per concurrent run
_SYSTEM = ("/usr", "/bin", "/sbin", "/lib", "/lib64", "/lib32")
# what of /etc the runs need (the dynamic loader's cache, time zone, user and host names, the alternatives' links,
# fonts, MIME types); never all of it (shadow, gshadow, sudoers, keys)
_ETC = ("ld.so.cache", "ld.so.conf", "ld.so.conf.d", "localtime", "timezone", "passwd", "group", "nsswitch.conf",
        "hosts", "host.conf", "alternatives", "fonts", "mime.types", "os-release", "matplotlibrc")
# the shared temporary folders a run under a uid of its own may write to (the "user" backend): emptied of what the
# run's uid owns after each run
SHARED_TMP = ("/tmp", "/var/tmp", "/dev/shm")
_WATCH = (Path(__file__).parent / "watch.py").read_text(encoding="utf-8")    # read now: see watch.py


class SandboxUnavailable(RuntimeError):
    """No sandbox can run student code here; the message says why and what to do."""


def _python_roots() -> list[str]:
    """The folders the Python environment lives in (the venv and the interpreter it was made from)."""
    roots = {sys.prefix, sys.base_prefix, sys.exec_prefix, sys.base_exec_prefix,
             str(Path(os.path.realpath(sys.executable)).parents[1])}
    for key in ("purelib", "platlib", "stdlib", "platstdlib"):
        roots.add(sysconfig.get_paths()[key])
    roots.update(p for p in sys.path if p.endswith(("site-packages", "dist-packages")) and os.path.isdir(p))
    kept: list[str] = []
    for root in sorted(roots, key=len):
        if not any(root == k or root.startswith(k.rstrip("/") + "/") for k in kept):
            kept.append(root)
    return kept


def _limits_argv(limits, nproc: bool = False) -> list[str]:
    """`prlimit` with the run's limits: CPU seconds (soft: SIGXCPU, hard 5 s later: SIGKILL), address space, file
    size, no core files; with `nproc`, the process count of the run's own uid or user namespace."""
    cap = limits.memory_mb * 2**20
    size = limits.disk_mb * 2**20
    procs = [f"--nproc={limits.max_procs}:{limits.max_procs}"] if nproc else []
    return ["prlimit", f"--cpu={limits.cpu_s}:{limits.cpu_s + 5}", f"--as={cap}:{cap}", f"--fsize={size}:{size}",
            "--core=0:0", *procs, "--"]


def _drop_to(uid: int) -> list[str]:
    """setpriv to `uid`: its own group, no supplementary groups, no capabilities (none to inherit, an empty bounding
    set), no privilege from a set-uid program."""
    return ["setpriv", f"--reuid={uid}", f"--regid={uid}", "--clear-groups", "--inh-caps=-all",
            "--bounding-set=-all", "--no-new-privs", "--"]


def _watched(argv: list[str], worktree: Path, limits, uid: int | None) -> list[str]:
    """`argv` under the watch (armlab_course.grading.watch), with the run's caps."""
    caps = {"procs": limits.max_procs + 8, "rss_mb": limits.memory_mb, "disk_mb": limits.disk_mb,
            "files": limits.max_files, "trees": [str(worktree.parent)], "uid": uid,
            "shared": [p for p in SHARED_TMP if os.path.isdir(p)]}
    return [sys.executable, "-I", "-S", "-c", _WATCH, json.dumps(caps), "--", *argv]


_PIDS_V1 = Path("/sys/fs/cgroup/pids")


class PidsGroup:
    """A cgroup of the pids controller for one run (cgroup v1 here, where a root grader can make one): at most
    `max_procs` processes (a fork bomb stops there), and every process in it listed and killed when the run ends,
    whatever it did to its session, group or namespace. `available()` says whether this machine has one."""

    def __init__(self, max_procs: int) -> None:
        self.path = _PIDS_V1 / f"armlab-{os.getpid()}-{next(_GROUP_IDS)}"
        self.path.mkdir()
        (self.path / "pids.max").write_text(str(max_procs))

    @staticmethod
    def available() -> bool:
        return os.getuid() == 0 and (_PIDS_V1 / "cgroup.procs").is_file() and os.access(_PIDS_V1, os.W_OK)

    def wrap(self, argv: list[str]) -> list[str]:
        """`argv` started inside the group (a shell moves itself in, then execs it)."""
        return ["sh", "-c", 'echo $$ > "$0/cgroup.procs" && exec "$@"', str(self.path), *argv]

    def _members(self) -> list[int]:
        try:
            return [int(p) for p in (self.path / "cgroup.procs").read_text().split()]
        except OSError:
            return []

    def close(self) -> None:
        """Kill every process of the group until none is left, then remove it."""
        _kill_until_gone(self._members)
        try:
            self.path.rmdir()
        except OSError:
            pass


_GROUP_IDS = itertools.count()


@dataclass(frozen=True)
class Sandbox:
    """How student code is run: kind is "bwrap", "user" or "none" (see the module's text)."""

    kind: str

    def inside(self, worktree: Path) -> str:
        """The work tree's path as the sandboxed process sees it."""
        return WORK if self.kind == "bwrap" else str(worktree)

    def grader_inside(self, grader: Path) -> str:
        """The grader's read-only folder as the sandboxed process sees it."""
        return GRADER if self.kind == "bwrap" else str(grader)

    @property
    def own_uid(self) -> bool:
        """Whether each run gets a uid of its own from USER_UIDS: the "user" backend, and "bwrap" when the grader is
        root (student code never runs as root, even in a namespace)."""
        return self.kind == "user" or (self.kind == "bwrap" and os.getuid() == 0)

    def argv(self, cmd: list[str], worktree: Path, grader: Path, limits, uid: int | None = None) -> list[str]:
        """The command line that runs `cmd` (its paths already as seen inside) in this sandbox, under the watch."""
        bounded = _limits_argv(limits, nproc=self.kind != "none") + cmd
        if self.own_uid:
            assert uid is not None
            bounded = _drop_to(uid) + bounded
        if self.kind == "bwrap":
            return _watched(self._bwrap(worktree, grader, limits, uid is not None) + bounded, worktree, limits, uid)
        return _watched(bounded, worktree, limits, uid)

    @staticmethod
    def _bwrap(worktree: Path, grader: Path, limits, as_root: bool) -> list[str]:
        """bubblewrap's part of the command line. As root: no user namespace (the run's uid is a real, unprivileged
        one, dropped to by setpriv inside, so that root-owned files stay root's); otherwise a user namespace of the
        run's own (which also gives RLIMIT_NPROC a count of the run's processes alone) and no capabilities. The
        root, /dev and the bound system folders are read-only; /tmp, the home and /dev/shm are memory-backed and
        `scratch_mb` each."""
        size = str(limits.scratch_mb * 2**20)
        binds: list[str] = []
        for path in _SYSTEM:
            binds += ["--ro-bind-try", path, path]
        binds += ["--perms", "0755", "--dir", "/etc"]
        for name in _ETC:
            binds += ["--ro-bind-try", f"/etc/{name}", f"/etc/{name}"]
        made: set[str] = set()
        for root in _python_roots():
            for parent in reversed(Path(root).parents[:-1]):    # bwrap would make them owner-only
                if str(parent) not in made and not str(parent).startswith(_SYSTEM):
                    made.add(str(parent))
                    binds += ["--perms", "0755", "--dir", str(parent)]
            binds += ["--ro-bind", root, root]
        namespaces = (["--unshare-ipc", "--unshare-pid", "--unshare-net", "--unshare-uts", "--unshare-cgroup-try"]
                      if as_root else ["--unshare-all", "--cap-drop", "ALL"])
        # the private /tmp and home first: a bind below them (a venv under /tmp, say) must come after
        return ["bwrap", "--die-with-parent", "--new-session", *namespaces, "--proc", "/proc",
                "--dev", "/dev", "--perms", "1777", "--size", size, "--tmpfs", "/dev/shm", "--remount-ro", "/dev",
                "--perms", "1777", "--size", size, "--tmpfs", "/tmp",
                "--perms", "0755", "--dir", str(Path(HOME).parent), "--perms", "0777", "--size", size, "--tmpfs", HOME,
                *binds,
                "--bind", str(worktree), WORK, "--ro-bind", str(grader), GRADER, "--remount-ro", "/",
                "--chdir", WORK, "--"]

    def home(self, worktree: Path) -> str:
        """HOME for the run: a private tmpfs in "bwrap", else a folder beside the work tree."""
        return HOME if self.kind == "bwrap" else str(worktree.parent / "home")

    @contextmanager
    def slot(self, worktree: Path, grader: Path):
        """Prepare one run (with a uid of its own: take a free one, hand the work tree and a home to it) and clean up
        after it (kill every process of that uid; for "user", remove what it left in the shared temporary folders).
        Yields the uid or None."""
        if not self.own_uid:
            if self.kind == "none":
                Path(self.home(worktree)).mkdir(exist_ok=True)
            yield None
            return
        uid = RUN_USERS.take()
        try:
            _kill_user(uid)                                # a crashed grader's leftovers (its lock died with it)
            run_dir = worktree.parent                      # the run's own folder: the work tree and a home
            if self.kind == "user":
                Path(self.home(worktree)).mkdir(exist_ok=True)
                for base in (run_dir.parent, grader.parent):
                    for parent in (base, *base.parents):   # traversable by the run's user, not listable
                        mode = parent.stat().st_mode
                        if parent.stat().st_uid == os.getuid() and not mode & 0o001:
                            parent.chmod((mode & ~0o004) | 0o001)
            _chown_tree(run_dir, uid)
            run_dir.chmod(0o700)
            _readable_tree(grader)
            yield uid
        finally:
            _kill_user(uid)
            if self.kind == "user":
                remove_owned(uid, SHARED_TMP)
            RUN_USERS.give(uid)


class _UidPool:
    """The USER_UIDS, each held by one run at a time across every grader process on the machine: a run holds an
    exclusive lock (flock) on its uid's file in a root-only folder (uid_lock_dir) for as long as it runs, so two
    graders (two `grade` commands, two autograders, two test runs) never give one uid to two runs, and one run's
    clean-up never kills another's processes. Within a process, threads wait on a condition for a uid to be free."""

    def __init__(self) -> None:
        self._held: dict[int, int] = {}                 # uid -> the open lock file's descriptor
        self._cond = threading.Condition()

    def _try(self, uid: int) -> bool:
        fd = os.open(uid_lock_dir() / f"uid-{uid}.lock", os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            return False
        self._held[uid] = fd
        return True

    def take(self) -> int:
        with self._cond:
            while True:
                for uid in USER_UIDS:
                    if uid not in self._held and self._try(uid):
                        return uid
                self._cond.wait(timeout=0.5)            # another process may free one meanwhile

    def give(self, uid: int) -> None:
        with self._cond:
            os.close(self._held.pop(uid))               # closing the descriptor releases the lock
            self._cond.notify()


def uid_lock_dir() -> Path:
    """The root-only folder of the uid locks (/run/armlab-grading, or one under the temporary folder): created with
    mode 0700; refused (SandboxUnavailable) if it is a symlink, not ours, or open to others."""
    import tempfile

    base = Path("/run") if os.access("/run", os.W_OK) else Path(tempfile.gettempdir())
    folder = base / "armlab-grading-uids"
    try:
        folder.mkdir(mode=0o700)
    except FileExistsError:
        pass
    info = folder.lstat()
    if not stat.S_ISDIR(info.st_mode) or info.st_uid != os.getuid() or info.st_mode & 0o077:
        raise SandboxUnavailable(f"{folder} (the grader's uid locks) must be a folder of the grader's own, mode 0700")
    return folder


def uids_in_use() -> list[int]:
    """The USER_UIDS some run (of any grader process) holds now."""
    busy = []
    for uid in USER_UIDS:
        fd = os.open(uid_lock_dir() / f"uid-{uid}.lock", os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW, 0o600)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            busy.append(uid)
        finally:
            os.close(fd)
    return busy


RUN_USERS = _UidPool()    # the "user" backend's uids: take() one for a run, give() it back


def _chown_tree(path: Path, uid: int) -> None:
    os.chown(path, uid, uid)
    for root, dirs, files in os.walk(path):
        for name in dirs + files:
            os.chown(os.path.join(root, name), uid, uid, follow_symlinks=False)


def _readable_tree(path: Path) -> None:
    """Make the grader's own read-only folder readable by the run's user (it holds nothing secret: the harness and
    the kernel's start-up file)."""
    for root, _dirs, files in os.walk(path):
        os.chmod(root, 0o755)
        for name in files:
            os.chmod(os.path.join(root, name), 0o644)


def _pids_of(uid: int) -> list[int]:
    pids = []
    for entry in os.scandir("/proc"):
        if entry.name.isdigit():
            try:
                if entry.stat().st_uid == uid:
                    pids.append(int(entry.name))
            except OSError:
                continue
    return pids


def _kill_user(uid: int) -> None:
    """Kill every process of `uid` until none is left."""
    _kill_until_gone(lambda: _pids_of(uid))


def remove_owned(uid: int, folders: tuple[str, ...]) -> list[str]:
    """Remove every entry of `folders` (not below them: the shared temporary folders are sticky, so a uid can only
    have made entries at their top or inside its own) that `uid` owns; the paths removed."""
    gone = []
    for folder in folders:
        for entry, _info in entries(folder, uid):
            try:
                if entry.is_dir(follow_symlinks=False):
                    shutil.rmtree(entry.path, ignore_errors=True)
                else:
                    os.unlink(entry.path)
                gone.append(entry.path)
            except OSError:
                continue
    return gone


@contextmanager
def owner_only(*paths: Path):
    """Make each existing folder of `paths` owner-only (mode & 0o700) while the block runs, then give each its mode
    back: what the "user" backend's uids must not read (the instructor's checkout, the submissions, the output)."""
    modes = {}
    try:
        for path in paths:
            if path.is_dir() and not path.is_symlink():
                modes[path] = path.stat().st_mode & 0o7777
                path.chmod(modes[path] & 0o700)
        yield
    finally:
        for path, mode in modes.items():
            try:
                path.chmod(mode)
            except OSError:
                pass


def refuse_shared_network(sandbox: Sandbox, allowed: bool) -> None:
    """SandboxUnavailable, saying why, for the "user" backend unless the instructor allowed it: without namespaces
    student code shares the machine's network (127.0.0.1 included, which the notebook's kernel itself needs, so no
    filter can tell the two apart)."""
    if sandbox.kind == "user" and not allowed:
        raise SandboxUnavailable("student code would run in the uid fallback (root without namespaces), which cannot "
                                 "take the network away: a region could send the hidden checks out or reach a "
                                 "service on 127.0.0.1. Grade where bubblewrap runs, or pass --allow-shared-network "
                                 "(Gradescope: ARMLAB_ALLOW_SHARED_NETWORK=1) to grade anyway")


def python_outside(paths: list[Path]) -> None:
    """SandboxUnavailable when the grader's Python lives inside one of `paths` (which the "user" backend makes
    owner-only: the run's uid could not start it)."""
    here = [Path(os.path.realpath(p)) for p in (sys.prefix, sys.executable)]
    for path in paths:
        inside = [h for h in here if h == path.resolve() or path.resolve() in h.parents]
        if inside:
            raise SandboxUnavailable(f"the grader's Python ({inside[0]}) lives inside {path}, which the uid fallback "
                                     f"makes owner-only: run the grader with a Python outside it")


def lock_down(*paths: Path) -> None:
    """Make the grader's own folders (the instructor's files, the output) unreadable to the "user" backend's users:
    owner-only permissions on each folder itself."""
    for path in paths:
        if path.exists():
            path.chmod(path.stat().st_mode & 0o700)


def _bwrap_works() -> tuple[bool, str]:
    if shutil.which("bwrap") is None:
        return False, "bubblewrap is not installed (Debian: apt-get install bubblewrap)"
    try:
        usage = subprocess.run(["bwrap", "--help"], capture_output=True, text=True, timeout=30).stdout
    except (OSError, subprocess.TimeoutExpired) as e:
        return False, f"bubblewrap did not start ({e})"
    if "--size" not in usage:
        return False, ("this bubblewrap cannot size a tmpfs (--size, bubblewrap 0.8 and later): the sandbox's /tmp "
                       "would be unbounded memory; install a newer bubblewrap")
    probe = Sandbox("bwrap")
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "w").mkdir()
        (Path(tmp) / "g").mkdir()
        with probe.slot(Path(tmp) / "w", Path(tmp) / "g") as uid:
            cmd = probe.argv([sys.executable, "-c", "print('ok')"], Path(tmp) / "w", Path(tmp) / "g", Limits(), uid)
            try:
                done = subprocess.run(cmd, capture_output=True, text=True, timeout=60, stdin=subprocess.DEVNULL)
            except (OSError, subprocess.TimeoutExpired) as e:
                return False, f"bubblewrap did not start ({e})"
    if done.returncode != 0 or done.stdout.strip() != "ok":
        return False, f"bubblewrap cannot make namespaces here: {done.stderr.strip()[:200]}"
    return True, ""


_DETECTED: list[Sandbox] = []
_LOCK = threading.Lock()


def detect(unsafe: bool = False) -> Sandbox:
    """The sandbox to use: ARMLAB_SANDBOX if set, else bubblewrap if it starts here, else the unprivileged-user
    backend if the grader is root; else SandboxUnavailable (or "none" when `unsafe`)."""
    wanted = os.environ.get("ARMLAB_SANDBOX", "").strip()
    if unsafe or wanted == "none":
        return Sandbox("none")
    if wanted and wanted not in ("bwrap", "user"):
        raise SandboxUnavailable(f"ARMLAB_SANDBOX must be bwrap, user or none, got {wanted!r}")
    with _LOCK:
        if wanted == "user" or (not wanted and _DETECTED and _DETECTED[0].kind == "user"):
            if os.getuid() != 0 or shutil.which("setpriv") is None:
                raise SandboxUnavailable("the unprivileged-user sandbox needs the grader to run as root, with "
                                         "util-linux's setpriv")
            return Sandbox("user")
        if _DETECTED:
            return _DETECTED[0]
        ok, why = _bwrap_works()
        if ok:
            _DETECTED.append(Sandbox("bwrap"))
        elif wanted == "bwrap":
            raise SandboxUnavailable(why)
        elif os.getuid() == 0 and shutil.which("setpriv"):
            _DETECTED.append(Sandbox("user"))
        else:
            raise SandboxUnavailable(f"no sandbox for student code: {why}; and the grader is not root, so it cannot "
                                     f"run student code as another user. Install bubblewrap, or pass "
                                     f"--unsafe-no-sandbox to grade without one (student code then sees everything "
                                     f"you see)")
        return _DETECTED[0]
