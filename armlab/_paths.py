"""Where the kit's data files live: inside the package (armlab/data, read through importlib.resources, so an
installed wheel finds them from any folder), overridable file by file by a lab's own folder and by the user's.

Reading `name` looks, in order, in $ARMLAB_DATA (a lab's folder: its own lab.json, colour model or
checkerboard_real/), in the per-user data folder (`user_data_dir()`: what the kit wrote for this user, e.g. a colour
model refitted by `python -m armlab colors fit`), and in the package. Files the kit writes go to $ARMLAB_DATA when it
is set, else to the per-user data folder: never into the installed package (site-packages may be read-only, shared by
other users, and is replaced by the next install). A maintainer refreshing the packaged files passes the path
explicitly (`colors fit --out armlab/data/color_model.json`).
"""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

import platformdirs

__all__ = ["DATA_ENV", "packaged_data_dir", "user_data_dir", "data_dir", "data_path", "data_write_path"]

DATA_ENV = "ARMLAB_DATA"


def packaged_data_dir() -> Path:
    """The data folder shipped inside the armlab package (read only: the kit never writes there by itself)."""
    return Path(str(resources.files("armlab") / "data"))


def user_data_dir() -> Path:
    """The per-user data folder (platformdirs: $XDG_DATA_HOME/armlab, by default ~/.local/share/armlab on Linux;
    the platform's own place on macOS and Windows). Created by data_write_path when the kit first writes there."""
    return Path(platformdirs.user_data_dir("armlab", appauthor=False))


def data_dir() -> Path:
    """The folder the kit writes data to: $ARMLAB_DATA when set, else the per-user data folder."""
    override = os.environ.get(DATA_ENV)
    return Path(override) if override else user_data_dir()


def data_path(name: str) -> Path:
    """The data file or folder `name` (e.g. "lab.json", "checkerboard"): the first of $ARMLAB_DATA/name, the
    per-user folder's and the packaged one that exists. When none exists, the path looked at first (so that a
    caller's "not found" message names where a lab would put it)."""
    override = os.environ.get(DATA_ENV)
    if override and (Path(override) / name).exists():
        return Path(override) / name
    user = user_data_dir() / name
    if user.exists():
        return user
    packaged = packaged_data_dir() / name
    if packaged.exists() or not override:
        return packaged
    return Path(override) / name


def data_write_path(name: str) -> Path:
    """Where the kit writes the data file `name`: in $ARMLAB_DATA when set, else in the per-user data folder, which
    is created when missing."""
    folder = data_dir()
    folder.mkdir(parents=True, exist_ok=True)
    return folder / name
