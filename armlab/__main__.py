"""Command line: `python -m armlab demo` runs the kit's main job headless on the simulator; `python -m armlab record
OUT.bag` records the lab's RealSense camera for replay with make_station("real", arm=False, playback=...)."""

from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="armlab", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="run the end-to-end demo headless on the simulator")
    demo.add_argument("--out", default="out", help="folder for the demo's images and replay (default: out/)")
    demo.add_argument("--seed", type=int, default=0)
    demo.add_argument("--event", default="sort_stack",
                      help="the competition event to run: sort_stack (default), line_up, sky, or any other registered "
                           "event (armlab.tasks.events.registry: a module defining EVENT, in the kit's events package "
                           "or named in $ARMLAB_EVENT_MODULES)")
    demo.add_argument("--level", type=int, default=None, help="the event's level (default: its highest)")
    demo.add_argument("--no-html", action="store_true", help="skip the meshcat replay page")
    sub.add_parser("exercises", help="list the exercises: id, points, notebook, where to write them")
    sub.add_parser("record", add_help=False,
                   help="record the RealSense camera to a .bag (replay: make_station('real', arm=False, playback=...))")
    args, rest = parser.parse_known_args(argv)
    if args.command == "record":
        from armlab.hardware.record import main as record_main

        return record_main(rest)
    if rest:
        parser.error(f"unrecognized arguments: {' '.join(rest)}")
    if args.command == "exercises":
        from armlab.exercises import exercises_table

        print(exercises_table())
        return 0
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
        return run_demo(out_dir=args.out, seed=args.seed, event=args.event, level=level, html=not args.no_html)
    return 2


if __name__ == "__main__":
    sys.exit(main())
