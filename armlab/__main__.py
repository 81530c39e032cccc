"""Command line: `python -m armlab demo` runs the kit's main job headless on the simulator; `python -m armlab record
OUT.bag` records the lab's RealSense camera for replay with make_station("real", arm=False, playback=...);
`python -m armlab colors fit [--frames FOLDER]` refits the block colour model from labelled frames."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from armlab._command_line import (
    MAX_SEED,
    CommandError,
    OneLineParser,
    input_folder,
    int_at_least,
    output_file,
    output_folder,
)


def main(argv: list[str] | None = None) -> int:
    """The command line; returns the exit code. A bad option or path prints one line on stderr and returns 2."""
    parser = OneLineParser(prog="armlab", description=__doc__)
    try:
        return _run(parser, argv)
    except CommandError as e:
        print(f"armlab {e.command}: error: {e}", file=sys.stderr)
        return 2


def _run(parser: argparse.ArgumentParser, argv: list[str] | None) -> int:
    from armlab import __version__

    parser.add_argument("--version", action="version", version=f"armlab {__version__}",
                        help="print the kit's version and exit")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="run the end-to-end demo headless on the simulator")
    demo.add_argument("--out", default="out", help="folder for the demo's images and replay (default: out/)")
    demo.add_argument("--seed", type=int_at_least(0, MAX_SEED), default=0,
                      help="the scene's and the camera noise's seed (a whole number, 0 or more)")
    demo.add_argument("--event", default="sort_stack",
                      help="the competition event to run: sort_stack (default), line_up, sky, or any other registered "
                           "event (armlab.tasks.events.registry: a module defining EVENT, in the kit's events package "
                           "or named in $ARMLAB_EVENT_MODULES)")
    demo.add_argument("--level", type=int_at_least(0), default=None, help="the event's level (default: its highest)")
    demo.add_argument("--no-html", action="store_true", help="skip the meshcat replay page")
    listing = sub.add_parser("exercises", help="list the exercises: id, points, kind, notebook, where to write them")
    listing.add_argument("--json", action="store_true",
                         help="as JSON: id, title, points, notebook, kind, where, functions, hidden, solution_lines")
    colors = sub.add_parser("colors", help="the block colour model (data/color_model.json)")
    colors_fit = colors.add_subparsers(dest="colors_command", required=True).add_parser(
        "fit", help="refit the colour model from labelled frames (real or simulated)")
    colors_fit.add_argument("--frames", default=None,
                            help="a folder of labelled RGB-D frames with labels.json (format: "
                                 "armlab.detection.color_labels); default: the kit's simulated training frames")
    colors_fit.add_argument("--out", default=None,
                            help="where to write the model (default: color_model.json in $ARMLAB_DATA when set, "
                                 "else the package's data folder)")
    from armlab_course.grading.cli import add_parsers as add_grading_parsers

    add_grading_parsers(sub)
    sub.add_parser("record", add_help=False,
                   help="record the RealSense camera to a .bag (replay: make_station('real', arm=False, playback=...))")
    args, rest = parser.parse_known_args(argv)
    if args.command == "record":
        from armlab.hardware.record import main as record_main

        return record_main(rest)
    if rest:
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    if args.command == "exercises":
        from armlab_course.exercises import exercises_json, exercises_table

        print(json.dumps(exercises_json(), indent=1) if args.json else exercises_table())
        return 0
    if args.command == "colors":
        try:
            frames = None if args.frames is None else input_folder(args.frames, "--frames")
            out = None if args.out is None else output_file(args.out, "--out")
        except ValueError as e:
            raise CommandError("colors fit", str(e)) from None
        return _fit_colors(frames, out)
    if args.command in ("grade", "check"):
        from armlab_course.grading.cli import main as grading_main

        return grading_main(args)
    if args.command == "demo":
        from armlab.demo import run_demo
        from armlab.tasks.events.registry import events

        specs = events()               # read only here: the other commands do not import the task layer
        if args.event not in specs:
            parser.error(f"unknown event {args.event!r}: the registered events are {', '.join(sorted(specs))}")
        spec = specs[args.event]
        level = max(spec.levels) if args.level is None else args.level
        if level not in spec.levels:
            parser.error(f"{args.event} has levels {spec.levels}, got --level {level}")
        try:
            out = output_folder(args.out)
        except ValueError as e:
            raise CommandError("demo", str(e)) from None
        return run_demo(out_dir=str(out), seed=args.seed, event=args.event, level=level, html=not args.no_html)
    return 2


def _fit_colors(frames_folder: Path | None, out: Path | None) -> int:
    """`armlab colors fit`: fit ColorModel on labelled faces and write it atomically; 2 and nothing written on
    bad input."""
    from armlab._paths import data_write_path
    from armlab.detection.color import COLOR_MODEL_FILE, ColorModel

    try:
        if frames_folder is not None:
            from armlab.detection.color_labels import labelled_colours, load_labelled_frames

            frames, calibration = load_labelled_frames(frames_folder)
            colours, labels = labelled_colours(frames, calibration)
            model, n = ColorModel.fit(colours, labels), len(labels)
            note = f"fitted on {n} labelled block faces of {len(frames)} frames in {frames_folder}"
        else:
            from armlab.sim.detection_eval import TRAIN_SEEDS, fit_color_model

            model, n = fit_color_model()
            note = f"fitted on {n} simulated block faces, seeds {TRAIN_SEEDS.start}-{TRAIN_SEEDS.stop - 1}"
    except ValueError as e:
        raise CommandError("colors fit", str(e)) from None
    path = out if out is not None else data_write_path(COLOR_MODEL_FILE)
    try:
        model.save(path, note=note)
    except OSError as e:
        raise CommandError("colors fit", f"cannot write {path} ({e.strerror or e})") from None
    print(f"wrote {path} from {n} faces ({', '.join(model.names)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
