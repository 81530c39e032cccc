"""Command line: `python -m armlab demo` runs the kit's main job headless on the simulator."""

from __future__ import annotations

import argparse
import sys


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="armlab", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="run the end-to-end demo headless on the simulator")
    demo.add_argument("--out", default="out", help="folder for the demo's images and replay (default: out/)")
    demo.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    if args.command == "demo":
        from armlab.demo import run_demo

        return run_demo(out_dir=args.out, seed=args.seed)
    return 2


if __name__ == "__main__":
    sys.exit(main())
