"""What the grader's child-side files share (they run inside the sandbox, imported as armlab_grader.*): the run's
key read from standard input before any student code starts, result files signed with it, and the one-line
message of a failure."""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import re

__all__ = ["read_key", "read_rest", "close_stdin", "hide_memory", "write_signed", "first_line"]

_ANSI = re.compile(r"(\x1b|#x1B)\[[0-9;]*m")


def read_key() -> bytes:
    """The run's key: the first line of standard input (hex), read from the file descriptor itself (close_stdin
    then makes standard input /dev/null, so that nothing started later can read it)."""
    line = b""
    while not line.endswith(b"\n"):
        chunk = os.read(0, 1)
        if not chunk:
            break
        line += chunk
    return bytes.fromhex(line.decode().strip())


def read_rest() -> bytes:
    """The rest of standard input (after the key line)."""
    parts = []
    while True:
        chunk = os.read(0, 1 << 16)
        if not chunk:
            return b"".join(parts)
        parts.append(chunk)


def close_stdin() -> None:
    """Standard input becomes /dev/null."""
    devnull = os.open(os.devnull, os.O_RDONLY)
    os.dup2(devnull, 0)
    os.close(devnull)


def hide_memory() -> None:
    """Make this process undumpable (prctl PR_SET_DUMPABLE 0): other processes of the run, though of the same user,
    can then read neither its memory nor its open files through /proc."""
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(4, 0, 0, 0, 0)
    except (OSError, AttributeError):
        pass


def write_signed(path: str, payload: object, key: bytes) -> None:
    """Write `payload` as JSON with its HMAC-SHA256 under `key`, atomically (a temporary file, then rename)."""
    text = json.dumps(payload)
    signed = json.dumps({"payload": text, "hmac": hmac.new(key, text.encode(), hashlib.sha256).hexdigest()})
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(signed)
    os.replace(tmp, path)


def first_line(text: str, limit: int = 600) -> str:
    """The exception line of a failure report (terminal colours removed), shortened: the last line naming an error
    with its message (a traceback ends with it), else the last one naming an error, else the first line."""
    lines = [re.sub(r"^E\s+", "", ln.strip()) for ln in _ANSI.sub("", text).splitlines() if ln.strip()]
    named = [ln for ln in lines if re.match(r"^[A-Za-z_.]*(Error|Exception|Timeout)\b", ln)
             and "most recent call last" not in ln]
    with_message = [ln for ln in named if re.match(r"^[A-Za-z_.]*(Error|Exception|Timeout)\b:", ln)]
    pick = (with_message or named or lines or ["failed"])[-1]
    return pick[:limit]
