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
    demo.add_argument("--event", default="sort_stack", choices=["sort_stack", "line_up", "sky"],
                      help="the competition event to run (default: sort_stack)")
    demo.add_argument("--level", type=int, default=3, help="the event's level, 1-3 (default: 3; sky: 1)")
    demo.add_argument("--no-html", action="store_true", help="skip the meshcat replay page")
    sub.add_parser("exercises", help="list the exercises: id, points, notebook, where to write them")
    grade = sub.add_parser("grade", help="grade a folder of submissions (one folder per student) into OUT")
    grade.add_argument("submissions")
    grade.add_argument("--out", required=True, help="folder for grades.csv and <student>/results.json, feedback.md")
    grade.add_argument("--jobs", type=int, default=1, help="submissions graded in parallel (default: 1)")
    grade.add_argument("--timeout", type=float, default=300.0, help="wall-clock seconds per notebook run")
    grade.add_argument("--reference", default=".", help="the instructor's checkout (default: .)")
    sub.add_parser("check", help="run the public checks of each exercise in this checkout (students)")
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
    if args.command in ("grade", "check"):
        from armlab.grading.cli import main as grading_main

        return grading_main(args)
    if args.command == "demo":
        from armlab.demo import run_demo

        level = 1 if args.event == "sky" else args.level
        return run_demo(out_dir=args.out, seed=args.seed, event=args.event, level=level, html=not args.no_html)
    return 2


if __name__ == "__main__":
    sys.exit(main())
