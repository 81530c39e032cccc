"""Where the kit's data files live: inside the package (armlab/data, read through importlib.resources, so an
installed wheel finds them from any folder), overridable file by file by a lab's own folder in $ARMLAB_DATA.

A lab keeps its own lab.json, colour model or checkerboard_real/ in a folder and points ARMLAB_DATA at it: a file
or folder found there is used in place of the packaged one; everything else still comes from the package. Files the
kit writes (a refitted colour model, a saved checkerboard set) go to $ARMLAB_DATA when it is set.
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

__all__ = ["DATA_ENV", "packaged_data_dir", "data_dir", "data_path", "data_write_path"]

DATA_ENV = "ARMLAB_DATA"


def packaged_data_dir() -> Path:
    """The data folder shipped inside the armlab package."""
    return Path(str(resources.files("armlab") / "data"))


def data_dir() -> Path:
    """The folder the kit writes data to: $ARMLAB_DATA when set, else the packaged data folder."""
    override = os.environ.get(DATA_ENV)
    return Path(override) if override else packaged_data_dir()


def data_path(name: str) -> Path:
    """The data file or folder `name` (e.g. "lab.json", "checkerboard"): $ARMLAB_DATA/name when ARMLAB_DATA is set
    and holds it, else the packaged one. When neither exists, the path looked at first (so that a caller's "not
    found" message names where a lab would put it)."""
    override = os.environ.get(DATA_ENV)
    if override and (Path(override) / name).exists():
        return Path(override) / name
    packaged = packaged_data_dir() / name
    if packaged.exists() or not override:
        return packaged
    return Path(override) / name


def data_write_path(name: str) -> Path:
    """Where the kit writes the data file `name`: in $ARMLAB_DATA when set, else in the packaged data folder."""
    return data_dir() / name
