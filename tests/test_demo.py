"""`python -m armlab demo`: the end-to-end demo runs headless and writes its tables and files."""

from __future__ import annotations

import re

import cv2
import numpy as np
import pytest

from armlab.__main__ import main
from armlab.tasks.events import Replay


@pytest.mark.exercise("calib.tag_extrinsics", "calib.depth_plane", "detect.classify")
def test_demo_runs_end_to_end(tmp_path, capsys):
    code = main(["demo", "--out", str(tmp_path), "--seed", "0"])
    out = capsys.readouterr().out
    assert code == 0, out
    total = re.search(r"total\s+(\d+)\s+of (\d+)", out)
    assert total and total.group(1) == total.group(2) == "180"                 # full marks, level 3
    assert re.search(r"simulated \(limit 180 s\)", out)
    found = re.search(r"detection: (\d+) of (\d+) visible block tops found", out)
    assert found and int(found.group(1)) >= int(found.group(2)) - 1 > 0
    for row in ("detection x-y error", "detection z error", "placement x-y error"):
        mean, worst = (float(v) for v in re.search(rf"{row}\s+([\d.]+)\s+([\d.]+)", out).groups())
        assert 0 <= mean <= worst < 5.0, row                                   # mm
    image = cv2.imread(str(tmp_path / "detections.png"))
    assert image.shape == (720, 1280, 3)
    html = (tmp_path / "replay.html").read_text()
    assert "<html" in html.lower() and len(html) > 100_000
    replay = Replay.load(tmp_path / "replay.npz")
    assert replay.q.shape[1] == 5 and np.isfinite(replay.q).all() and replay.duration > 30
    assert not list(tmp_path.glob(".*"))                                       # no temporary files left behind
