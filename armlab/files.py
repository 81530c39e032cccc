"""Atomic file writes (a file is either its old self or completely new, never half-written) and JSON reads that
fail with one clear error naming the file.

Everything the kit saves (calibrations, scenes, teach programs, colour models, replays, images) goes through here:
the data is written to a temporary file in the same folder, which then replaces the target in one rename.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from armlab.schemas import validate

__all__ = ["atomic_path", "write_bytes_atomic", "write_text_atomic", "write_json_atomic", "read_json", "MAX_JSON_BYTES"]

MAX_JSON_BYTES = 64 * 2**20     # the kit's JSON files are kilobytes; a larger one is not one of them


@contextmanager
def atomic_path(path, suffix: str | None = None, make_parents: bool = False) -> Iterator[Path]:
    """A temporary path beside `path` to write to; when the block ends without error it replaces `path` (mode 0644),
    otherwise it is removed and `path` is left untouched.

    `suffix` (default: the target's own, e.g. ".png") lets writers that pick the format from the file name work.
    """
    path = Path(path)
    if make_parents:
        path.parent.mkdir(parents=True, exist_ok=True)
    elif not path.parent.is_dir():
        raise FileNotFoundError(f"cannot write {path}: folder {path.parent} does not exist")
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=suffix or path.suffix or ".tmp")
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        os.chmod(tmp_path, 0o644)
        os.replace(tmp_path, path)
    finally:
        tmp_path.unlink(missing_ok=True)


def write_bytes_atomic(path, data: bytes, make_parents: bool = False) -> Path:
    """Write bytes to `path` atomically; returns the path."""
    with atomic_path(path, make_parents=make_parents) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_text_atomic(path, text: str, make_parents: bool = False) -> Path:
    """Write UTF-8 text to `path` atomically; returns the path."""
    return write_bytes_atomic(path, text.encode("utf-8"), make_parents)


def write_json_atomic(path, data, indent: int = 1, make_parents: bool = False) -> Path:
    """Write `data` as JSON (NaN and infinity refused, trailing newline) to `path` atomically; returns the path."""
    return write_text_atomic(path, json.dumps(data, indent=indent, allow_nan=False) + "\n", make_parents)


def read_json(path, kind: str, error: type[Exception] = ValueError, schema: dict | None = None):
    """Parse the JSON file at `path` and, given a `schema` (armlab.schemas), validate it; a missing, unreadable,
    oversized, corrupt or invalid file raises `error` with a message naming the file and `kind` (e.g. "<path>: scene
    file not found") or the field at fault ("<path>: board.grid_mm: must be greater than 0, got 0.0"). Never a raw
    OSError (a symlink loop, no permission), RecursionError (deep nesting) or OverflowError."""
    path = Path(path)
    try:
        if path.stat().st_size > MAX_JSON_BYTES:
            raise error(f"{path}: {path.stat().st_size} bytes is too large for a {kind} file "
                        f"(at most {MAX_JSON_BYTES} bytes)")
        raw = json.loads(path.read_bytes().decode("utf-8"))
    except FileNotFoundError:
        raise error(f"{path}: {kind} file not found") from None
    except IsADirectoryError:
        raise error(f"{path}: is a folder, not a {kind} file") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise error(f"{path}: not valid JSON, a corrupt {kind} file? ({e})") from None
    except RecursionError:
        raise error(f"{path}: nested too deeply to be a {kind} file") from None
    except ValueError as e:      # e.g. an integer of more digits than Python converts
        raise error(f"{path}: not a readable {kind} file ({e})") from None
    except OSError as e:         # a symlink loop, no permission, a name too long, an I/O error
        raise error(f"{path}: cannot read the {kind} file ({e.strerror or e})") from None
    if schema is not None:
        validate(raw, schema, path, error)
    return raw
