"""Competition events on the simulator: score (from the world's truth) and simulated time per event and level, and
the tallest stable "to the sky" tower. One process run; wall time is the whole run (calibration included).

    .venv/bin/python benchmarks/events.py [--seeds 0 1 2]

`event_rows(seeds)` returns the rows (dicts) for other benchmark tables (e.g. benchmarks/manipulation.py).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from armlab.tasks import start_session
from armlab.tasks.events import event_station, run_event

CASES = [("sort_stack", 1), ("sort_stack", 2), ("sort_stack", 3), ("line_up", 1), ("line_up", 2), ("line_up", 3),
         ("sky", 1)]


def event_rows(seeds=(0,), cases=CASES) -> list[dict]:
    """One row per (event, level, seed): points, max, simulated s, limit, moves, failed picks, placement error,
    tower height (sky), why it stopped, wall s."""
    rows = []
    for event, level in cases:
        for seed in seeds:
            t = time.perf_counter()
            session = start_session(event_station(event, level, seed=seed))
            r = run_event(session, event, level, seed=seed, record=False)
            err = np.linalg.norm(r.placement_errors[:, :2], axis=1) if len(r.placement_errors) else np.zeros(1)
            rows.append({"event": event, "level": level, "seed": seed, "points": r.score.points,
                         "max": r.score.max_points, "sim_s": r.time_s, "limit_s": r.time_limit_s,
                         "moves": len(r.moves), "failed_picks": sum(not m.picked for m in r.moves),
                         "err_mean": float(err.mean()), "err_max": float(err.max()),
                         "tower": len(r.score.lines) if event == "sky" else None, "stopped": r.stopped,
                         "wall_s": time.perf_counter() - t})
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    args = parser.parse_args(argv)
    rows = event_rows(args.seeds)
    print(f"{'event':<11} {'lvl':>3} {'seed':>4} {'score':>11} {'sim s':>7} {'limit':>6} {'moves':>5} "
          f"{'fails':>5} {'place err mean/max mm':>21} {'wall s':>7}")
    for r in rows:
        print(f"{r['event']:<11} {r['level']:>3} {r['seed']:>4} {r['points']:>5g}/{r['max']:<5} {r['sim_s']:7.1f} "
              f"{r['limit_s']:6.0f} {r['moves']:>5} {r['failed_picks']:>5} "
              f"{r['err_mean']:10.2f} / {r['err_max']:<8.2f} {r['wall_s']:7.1f}")
    sky = [r for r in rows if r["event"] == "sky"]
    if sky:
        best = max(sky, key=lambda r: r["tower"])
        print(f"tallest stable 'to the sky' tower: {best['tower']} large blocks ({best['tower'] * 38} mm, "
              f"{best['points']:g} points); stopped: {best['stopped']}")
    full = sum(r["points"] >= r["max"] for r in rows if r["event"] != "sky")
    print(f"full marks in {full} of {sum(r['event'] != 'sky' for r in rows)} sort/line runs")


if __name__ == "__main__":
    main()
