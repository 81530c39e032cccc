"""`python -m armlab record OUT.bag`: record the lab's RealSense L515 (the streams make_station("real") uses) to a
file that `make_station("real", arm=False, playback="OUT.bag")` replays anywhere, camera or not.

The recording holds the raw colour (1280x720 BGR8) and depth (1024x768 z16) streams at 30 fps with the device's
intrinsics, extrinsics and depth units; alignment happens at playback, through the same rs.align as live. Size:
roughly 60-80 MB per second uncompressed; keep recordings to a few seconds of the scenes a notebook needs.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from pathlib import Path

from armlab.arguments import finite_float, int_in_range
from armlab.command_line import OneLineParser, int_at_least, positive_seconds
from armlab.hardware import HardwareUnavailable
from armlab.hardware.realsense import configure_streams, import_realsense

__all__ = ["record", "main"]


def record(out: str | Path, seconds: float = 5.0, serial: str | None = None, warmup_frames: int = 30,
           overwrite: bool = False, clock: Callable[[], float] = time.monotonic) -> int:
    """Record the live camera to `out` (a .bag): `warmup_frames` framesets while auto-exposure settles (they are in
    the file too: librealsense records from the start; playback skips none), then `seconds` s more.
    Returns the number of framesets recorded after the warm-up. Refuses to overwrite a file unless overwrite=True."""
    out = Path(out)
    if out.suffix != ".bag":
        raise ValueError(f"the recording must be a .bag file, got {out.name!r}")
    if out.exists() and not overwrite:
        raise FileExistsError(f"{out} exists: choose another name or pass --overwrite")
    seconds = finite_float(seconds, "seconds", positive=True, what="s")
    warmup_frames = int_in_range(warmup_frames, "warmup_frames", 0, 100_000)
    if not out.parent.is_dir():
        raise FileNotFoundError(f"cannot record to {out}: folder {out.parent} does not exist")
    rs = import_realsense()
    pipeline, config = rs.pipeline(), rs.config()
    configure_streams(rs, config, serial)
    config.enable_record_to_file(str(out))
    pipeline.start(config)
    frames = 0
    try:
        for _ in range(max(0, int(warmup_frames))):
            pipeline.wait_for_frames(5000)
        end = clock() + float(seconds)
        while clock() < end:
            pipeline.wait_for_frames(5000)
            frames += 1
    finally:
        pipeline.stop()
    return frames


def main(argv: list[str] | None = None) -> int:
    """Command line entry: `python -m armlab record OUT.bag [--seconds S] [--serial N] [--overwrite]`."""
    parser = OneLineParser(prog="armlab record", description=__doc__.split("\n\n")[0])
    parser.add_argument("out", help="the recording to write (.bag)")
    parser.add_argument("--seconds", type=positive_seconds, default=5.0, help="how long to record (default 5 s)")
    parser.add_argument("--serial", default=None, help="the camera's serial number when several are connected")
    parser.add_argument("--warmup-frames", type=int_at_least(0, 100_000), default=30,
                        help="frames before the timed part (default 30)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing file")
    args = parser.parse_args(argv)
    try:
        frames = record(args.out, args.seconds, args.serial, args.warmup_frames, args.overwrite)
    except (ValueError, OSError, HardwareUnavailable) as e:     # HardwareUnavailable: no pyrealsense2 or camera
        print(f"armlab record: error: {e}", file=sys.stderr)
        return 2
    print(f"recorded {frames} framesets ({args.seconds:g} s) to {args.out}; replay with "
          f"make_station('real', arm=False, playback={str(args.out)!r})")
    return 0
