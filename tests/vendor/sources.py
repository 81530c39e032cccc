"""Where the tests find the vendors' files at the pinned commits (tests/vendor/facts.py), never in this repository.

Looked up in a cache, $ARMLAB_VENDOR_CACHE or ~/.cache/armlab-vendor/<owner>+<name>/<commit>/<path>, each file
checked against its git blob id when one is pinned. Fill the cache with
    python tests/vendor/sources.py                         # downloads from GitHub (raw.githubusercontent.com)
    python tests/vendor/sources.py --git OWNER/NAME=GITDIR  # or copies from a local clone (bare or not)
A file that is missing makes the tests that need it skip, saying how to get it.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import subprocess
import sys
import urllib.request
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from vendor import facts
else:
    from . import facts

HOW = "fill the cache with `python tests/vendor/sources.py` (network) or `--git OWNER/NAME=GITDIR`"


def cache_root() -> Path:
    return Path(os.environ.get("ARMLAB_VENDOR_CACHE", Path.home() / ".cache" / "armlab-vendor"))


def blob_id(data: bytes) -> str:
    """git's blob id of these bytes."""
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()


def cached(repo: str, commit: str, path: str) -> Path:
    return cache_root() / repo.replace("/", "+") / commit / path


def read(repo: str, commit: str, path: str, blob: str | None = None) -> bytes | None:
    """The file's bytes from the cache, or None; ValueError when they are not the pinned blob."""
    file = cached(repo, commit, path)
    if not file.is_file():
        return None
    data = file.read_bytes()
    if blob is not None and blob_id(data) != blob:
        raise ValueError(f"{file} is not {repo}@{commit[:7]}:{path} (blob {blob_id(data)}, expected {blob})")
    return data


def wanted() -> list[tuple[str, str, str, str | None]]:
    """(repo, commit, path, blob or None) of every file the tests use."""
    files = [(facts.TOOLBOXES, facts.TOOLBOXES_COMMIT, path, blob) for path, blob in facts.TOOLBOX_MODULES.values()]
    for fact in facts.FACTS:
        item = (fact.repo, fact.commit, fact.path, None)
        if not any(f[:3] == item[:3] for f in files):
            files.append(item)
    return files


def _from_git(gitdir: str, commit: str, path: str) -> bytes | None:
    try:
        return subprocess.run(["git", f"--git-dir={gitdir}", "show", f"{commit}:{path}"], capture_output=True,
                              check=True, timeout=30).stdout
    except (subprocess.SubprocessError, OSError):
        try:
            return subprocess.run(["git", "-C", gitdir, "show", f"{commit}:{path}"], capture_output=True,
                                  check=True, timeout=30).stdout
        except (subprocess.SubprocessError, OSError):
            return None


def _download(repo: str, commit: str, path: str) -> bytes | None:
    try:
        with urllib.request.urlopen(f"https://raw.githubusercontent.com/{repo}/{commit}/{path}", timeout=15) as r:
            return r.read()
    except OSError:
        return None


def fill(gitdirs: dict[str, str]) -> int:
    """Put every wanted file into the cache (from gitdirs[repo] if given, else GitHub); returns how many are missing."""
    missing = 0
    for repo, commit, path, blob in wanted():
        if read(repo, commit, path, blob) is not None:
            continue
        data = _from_git(gitdirs[repo], commit, path) if repo in gitdirs else _download(repo, commit, path)
        if data is None or (blob is not None and blob_id(data) != blob):
            print(f"missing: {repo}@{commit[:7]}:{path}", file=sys.stderr)
            missing += 1
            continue
        target = cached(repo, commit, path)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(data)
    return missing


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--git", action="append", default=[], metavar="OWNER/NAME=GITDIR")
    args = parser.parse_args()
    missing = fill(dict(item.split("=", 1) for item in args.git))
    print(f"vendor cache {cache_root()}: {len(wanted()) - missing} of {len(wanted())} files")
    sys.exit(0)                    # a missing file only makes its tests skip
