"""The command line's option checks, shared by `python -m armlab` and its subcommands (armlab.__main__,
armlab.hardware.record): a bad option or path is reported in one line ("armlab demo: error: ...") with exit code 2,
before any work starts, never as a traceback."""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

__all__ = ["MAX_SEED", "CommandError", "OneLineParser", "int_at_least", "positive_seconds", "output_folder",
           "output_file", "input_folder"]

MAX_SEED = 2**63 - 1          # numpy's generators take any non-negative integer; a 64-bit one is plenty


class CommandError(Exception):
    """A subcommand's refusal: main prints "armlab <command>: error: <message>" and returns 2."""

    def __init__(self, command: str, message: str):
        super().__init__(message)
        self.command = command


class OneLineParser(argparse.ArgumentParser):
    """argparse that reports a bad option in one line ("armlab demo: error: ...") and exits 2, without the usage
    block (`--help` still shows it). Its subparsers are of the same class."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message}\n")


def int_at_least(low: int, high: int | None = None):
    """An argparse type: a whole number in [low, high]."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
        if value < low or (high is not None and value > high):
            raise argparse.ArgumentTypeError(f"{value} is out of range: must be {low} or more"
                                             + ("" if high is None else f" and at most {high}"))
        return value
    return parse


def positive_seconds(text: str) -> float:
    """An argparse type: a positive, finite number of seconds (nan, inf, 0 and negatives refused)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of seconds") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive, finite number of seconds")
    return value


def output_folder(text: str, option: str = "--out") -> Path:
    """An output folder option: not empty, not a file, creatable and writable (created here, before any work, so
    that a bad one is refused at once). ValueError saying why otherwise."""
    out = _named(text, option, "folder")
    if out.exists() and not out.is_dir():
        raise ValueError(f"{option} {text}: is a file, not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise ValueError(f"{option} {text}: cannot create the folder ({e.strerror or e})") from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise ValueError(f"{option} {text}: the folder is not writable")
    return out


def output_file(text: str, option: str) -> Path:
    """An output file option: not empty, not a folder, in a folder that exists. ValueError saying why otherwise."""
    path = _named(text, option, "file")
    problem = ("is a folder, not a file" if path.is_dir()
               else f"folder {path.parent} does not exist" if not path.parent.is_dir() else None)
    if problem:
        raise ValueError(f"{option} {text}: {problem}")
    return path


def input_folder(text: str, option: str) -> Path:
    """An input folder option: it exists and is a folder. ValueError saying why otherwise."""
    path = _named(text, option, "folder")
    problem = "no such folder" if not path.exists() else "is a file, not a folder" if not path.is_dir() else None
    if problem:
        raise ValueError(f"{option} {text}: {problem}")
    return path


def _named(text: str, option: str, what: str) -> Path:
    """The path an option names; ValueError when it names nothing (an empty or blank option)."""
    if not text.strip():
        raise ValueError(f"{option} is empty: name a {what}" + (f" (e.g. {option} out)" if what == "folder" else ""))
    return Path(text)
