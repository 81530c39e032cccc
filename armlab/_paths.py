"""Where the kit's data files live (the repository's `data/` folder, or $ARMLAB_DATA)."""

from __future__ import annotations

import os
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent


def data_dir() -> Path:
    """The data folder: $ARMLAB_DATA when set, else `data/` beside the package."""
    return Path(os.environ.get("ARMLAB_DATA", REPO_ROOT / "data"))


def data_path(name: str) -> Path:
    """Path of a file in the data folder."""
    return data_dir() / name
