"""`python -m armlab colors fit --frames FOLDER`: the colour model refitted from a folder of labelled RGB-D frames
(the format real frames are labelled in), here written from simulated frames labelled at their blocks' true
top-face centres."""

import json
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from armlab import make_station
from armlab.calibration import Calibration, fit_depth_correction, save_calibration
from armlab.detection.color import ColorModel
from armlab.detection.color_labels import LABELS_FORMAT, labelled_colours, load_labelled_frames
from armlab.detection.masks import arm_mask

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def labelled_folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("labelled")
    station = make_station("sim", seed=0, scene="line_up_2")        # 12 blocks: every colour, both sizes
    cam, q = station.camera.truth, station.arm.joint_positions()
    frames, calibration = [], None
    for seed in (0, 1):                                               # two exposures: the sensor's noise differs
        frame = station.camera.capture()
        correction = fit_depth_correction(frame.depth, cam, exclude=arm_mask(cam, q))
        calibration = calibration or Calibration(cam, correction, "simulated: the true camera")
        blocks = [o for o in station.world.objects if o.is_block]
        tops = cam.project(np.array([o.position + [0.0, 0.0, o.edge / 2] for o in blocks]))
        cv2.imwrite(str(folder / f"frame_{seed}.png"), cv2.cvtColor(frame.rgb, cv2.COLOR_RGB2BGR))
        np.save(folder / f"frame_{seed}.npy", frame.depth)
        frames.append({"rgb": f"frame_{seed}.png", "depth": f"frame_{seed}.npy", "arm_q": q.tolist(),
                       "blocks": [{"pixel": uv.tolist(), "color": o.color}
                                  for uv, o in zip(tops, blocks, strict=True)]})
    save_calibration(calibration, folder / "calibration.json")
    (folder / "labels.json").write_text(json.dumps({"format": LABELS_FORMAT, "calibration": "calibration.json",
                                                    "frames": frames}))
    return folder


def run_cli(*args, cwd):
    env = {**os.environ, "PYTHONPATH": str(REPO), "MPLBACKEND": "Agg"}
    return subprocess.run([sys.executable, "-m", "armlab", "colors", "fit", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


@pytest.mark.exercise("detect.classify")           # the fitted model classifies its faces back
def test_colors_fit_refits_the_model_from_labelled_frames(labelled_folder, tmp_path):
    frames, calibration = load_labelled_frames(labelled_folder)
    colours, labels = labelled_colours(frames, calibration)
    assert len(labels) == 24 and set(labels) == {"red", "orange", "yellow", "green", "blue", "violet"}
    out = tmp_path / "model.json"
    run = run_cli("--frames", str(labelled_folder), "--out", str(out), cwd=tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    assert f"wrote {out} from 24 faces" in run.stdout
    model = ColorModel.load(out)
    assert set(model.names) == set(labels)
    assert model.classify(colours)[0] == labels               # the fitted model names its own training faces
    raw = json.loads(out.read_text())
    assert "24 labelled block faces of 2 frames" in raw["note"]


def test_a_label_no_face_holds_is_an_error_and_writes_nothing(labelled_folder, tmp_path):
    bad = tmp_path / "bad"
    bad.mkdir()
    for f in labelled_folder.iterdir():
        (bad / f.name).write_bytes(f.read_bytes())
    labels = json.loads((bad / "labels.json").read_text())
    labels["frames"][0]["blocks"].append({"pixel": [5, 5], "color": "red"})      # the image corner: no block there
    (bad / "labels.json").write_text(json.dumps(labels))
    out = tmp_path / "model.json"
    run = run_cli("--frames", str(bad), "--out", str(out), cwd=tmp_path)
    assert run.returncode == 2 and "frame_0.png: no detected block face holds the labelled pixel (5, 5)" in run.stderr
    assert not out.exists()
    labels["frames"][0]["blocks"][-1] = {"pixel": [5, 5], "color": "purple"}
    (bad / "labels.json").write_text(json.dumps(labels))
    with pytest.raises(ValueError, match=r"frames\[0\]\.blocks\[\d+\]\.color: must be one of \('red', .*got 'purple'"):
        load_labelled_frames(bad)
    with pytest.raises(ValueError, match="colour labels file not found"):
        load_labelled_frames(tmp_path)


def test_colors_fit_without_out_writes_the_users_data_folder_not_the_package(labelled_folder, tmp_path):
    """Without --out (and without ARMLAB_DATA) the model goes to the per-user data folder ($XDG_DATA_HOME/armlab),
    which the kit then reads before the packaged model; the installed package is left as it was."""
    from armlab import _paths

    packaged = _paths.packaged_data_dir() / "color_model.json"
    before = packaged.read_bytes()
    xdg = tmp_path / "xdg"
    env = {k: v for k, v in os.environ.items() if k != _paths.DATA_ENV}
    env.update(PYTHONPATH=str(REPO), MPLBACKEND="Agg", XDG_DATA_HOME=str(xdg))
    run = subprocess.run([sys.executable, "-m", "armlab", "colors", "fit", "--frames", str(labelled_folder)],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    written = xdg / "armlab" / "color_model.json"
    assert f"wrote {written} from 24 faces" in run.stdout
    assert packaged.read_bytes() == before
    code = "from armlab import _paths; print(_paths.data_path('color_model.json'))"
    read = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=120)
    assert read.stdout.strip() == str(written), read.stderr[-2000:]
