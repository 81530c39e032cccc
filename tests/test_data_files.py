"""Every data file the kit loads is checked against its declared schema (armlab.schemas): a bad file is refused with
its path and the field at fault, never loaded, and never with a raw RecursionError, OSError or OverflowError.

The mutation test writes hundreds of absurd lab.json files into a lab folder ($ARMLAB_DATA, as a lab would) and
loads each through the kit's normal path (data_path -> load_lab): each must be refused naming the file and field;
sensible edits must still load."""

from __future__ import annotations

import copy
import json
import math
import os

import numpy as np
import pytest

from armlab import calibration as cal
from armlab._paths import DATA_ENV, packaged_data_dir
from armlab.detection.color import ColorModel
from armlab.detection.color_labels import LABELS_FILE, load_labelled_frames
from armlab.files import read_json
from armlab.lab import load_lab
from armlab.schemas import field_name
from armlab.sim.scenes import SceneError, load_scene
from armlab.tasks import TeachFileError, load_teach

GOOD_LAB = json.loads((packaged_data_dir() / "lab.json").read_text())
# A non-finite or wrongly typed value in place of any number: (label, JSON text of the value)
ABSURD_VALUES = [("NaN", "NaN"), ("Infinity", "Infinity"), ("-Infinity", "-Infinity"), ("1e400", "1e400"),
                 ("10**400", "1" + "0" * 400), ("string", '"12"'), ("null", "null"), ("true", "true"),
                 ("list", "[1]"), ("object", "{}")]
# Fields that are sizes (must be > 0): zero and negative are absurd
SIZE_FIELDS = [("board", "grid_mm"), ("tags", "size_mm"), ("blocks", "large_mm"), ("blocks", "small_mm"),
               ("robot_base", "half_extent_mm", 0), ("robot_base", "half_extent_mm", 1), ("camera", "width"),
               ("camera", "height"), ("camera", "factory_K", 0, 0), ("camera", "factory_K", 1, 1)]
BOUND_PAIRS = [(("board", "x_min_mm"), ("board", "x_max_mm")), (("board", "y_min_mm"), ("board", "y_max_mm")),
               (("board", "grid_x_mm", 0), ("board", "grid_x_mm", 1)),
               (("board", "grid_y_mm", 0), ("board", "grid_y_mm", 1))]


def _leaves(node, path=()):
    """Paths to every number in a JSON tree (comments left out)."""
    if isinstance(node, dict):
        for k, v in node.items():
            if not k.startswith("_"):
                yield from _leaves(v, path + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _leaves(v, path + (i,))
    elif isinstance(node, (int, float)) and not isinstance(node, bool):
        yield path


def _containers(node, path=()):
    if isinstance(node, dict):
        yield path, node
        for k, v in node.items():
            yield from _containers(v, path + (k,))


def _get(tree, path):
    for p in path:
        tree = tree[p]
    return tree


def _set(tree, path, value):
    _get(tree, path[:-1])[path[-1]] = value


_MARK = "__MUTATED_VALUE__"


def _with_text(path, text) -> str:
    """lab.json with the value at `path` replaced by raw JSON text (NaN, 1e400, huge integers written as such)."""
    data = copy.deepcopy(GOOD_LAB)
    _set(data, path, _MARK)
    return json.dumps(data).replace(f'"{_MARK}"', text)


def _mutations() -> list[tuple[str, str, set[str]]]:
    """(label, file text, fields any of which the refusal may name) for every absurd lab.json."""
    out = []
    for path in _leaves(GOOD_LAB):
        for label, text in ABSURD_VALUES:
            out.append((f"{field_name(path)} = {label}", _with_text(path, text), {field_name(path)}))
    for path in SIZE_FIELDS:
        for value in ("0", "-1", "-50.5"):
            out.append((f"{field_name(path)} = {value}", _with_text(path, value), {field_name(path)}))
    for a, b in BOUND_PAIRS:
        lo, hi = _get(GOOD_LAB, a), _get(GOOD_LAB, b)
        for new_lo, new_hi, how in ((hi, lo, "inverted"), (hi + 10, hi, "crossed")):
            data = copy.deepcopy(GOOD_LAB)
            _set(data, a, new_lo)
            _set(data, b, new_hi)
            fields = {field_name(a), field_name(b), field_name(a[:-1])}
            out.append((f"{field_name(a)} / {field_name(b)} {how}", json.dumps(data), fields))
    for path, node in _containers(GOOD_LAB):
        for key in node:
            if key.startswith("_") or path + (key,) == ("robot_base",) or path == ("tags", "centres_mm"):
                continue
            data = copy.deepcopy(GOOD_LAB)
            del _get(data, path)[key]
            out.append((f"{field_name(path + (key,))} missing", json.dumps(data), {field_name(path + (key,))}))
        data = copy.deepcopy(GOOD_LAB)
        _get(data, path)["grid_size_typo"] = 1.0
        out.append((f"unknown key in {field_name(path)}", json.dumps(data), {field_name(path)}))
    for path in (("board",), ("tags",), ("camera",), ("blocks",), ("tags", "centres_mm"), ("camera", "factory_K")):
        for text in ("[]", '"x"', "3"):
            out.append((f"{field_name(path)} = {text}", _with_text(path, text), {field_name(path)}))
    geometry = [(("tags", "centres_mm", "3"), "[2000, 0]", "tags.centres_mm.3"),      # a tag off the board
                (("camera", "position_mm", 2), "-100", "camera.position_mm"),        # camera below the board
                (("camera", "look_at_mm"), "[0, 337, 991]", "camera.look_at_mm"),   # looking at itself
                (("camera", "factory_K", 2), "[0, 0, 5]", "camera.factory_K"),      # not a camera matrix
                (("blocks", "small_mm"), "50", "blocks.small_mm"),                  # small larger than large
                (("board", "grid_x_mm"), "[-900, 900]", "board.grid_x_mm"),         # grid beyond the board
                (("board", "grid_mm"), "0.001", "board.grid_mm"),                   # a million grid lines
                (("tags", "family"), '"tag99h99"', "tags.family"),
                (("camera", "factory_dist"), "[0, 0, 0]", "camera.factory_dist"),
                (("camera", "width"), "1e300", "camera.width"),
                (("camera", "width"), "1280.5", "camera.width")]
    for path, text, field in geometry:
        out.append((f"{field} = {text}", _with_text(path, text), {field}))
    return out


MUTATIONS = _mutations()


def test_hundreds_of_absurd_lab_files_are_each_refused_naming_the_file_and_field(tmp_path, monkeypatch):
    monkeypatch.setenv(DATA_ENV, str(tmp_path))
    lab_file = tmp_path / "lab.json"
    refused, wrong = 0, []
    for label, text, fields in MUTATIONS:
        lab_file.write_text(text)
        try:
            load_lab()
        except ValueError as e:
            msg = str(e)
            if str(lab_file) in msg and any(f"{f}:" in msg or f"{f}." in msg or f"{f}[" in msg for f in fields):
                refused += 1
            else:
                wrong.append(f"{label}: refused without naming {sorted(fields)}: {msg}")
        except Exception as e:                                            # noqa: BLE001 - that is the failure
            wrong.append(f"{label}: {type(e).__name__}: {e}")
        else:
            wrong.append(f"{label}: loaded")
    print(f"\n{len(MUTATIONS)} absurd lab.json files: {refused} refused naming file and field, {len(wrong)} not")
    assert not wrong, "\n".join(wrong[:20])
    assert refused == len(MUTATIONS) > 500


@pytest.mark.parametrize("edit", [
    (("camera", "position_mm"), [10.0, 330.0, 1000.0]), (("tags", "size_mm"), 30), (("blocks", "large_mm"), 40),
    (("board", "grid_mm"), 25.0), (("camera", "factory_dist"), [0.1, -0.2, 0.001, 0.0, 0.05]),
    (("camera", "width"), 1280.0), (("robot_base", "half_extent_mm"), [60, 70]),
    (("tags", "centres_mm"), {"0": [0, 400], "7": [-300, 100]}),
])
def test_sensible_lab_edits_still_load(tmp_path, monkeypatch, edit):
    path, value = edit
    data = copy.deepcopy(GOOD_LAB)
    _set(data, path, value)
    monkeypatch.setenv(DATA_ENV, str(tmp_path))
    (tmp_path / "lab.json").write_text(json.dumps(data))
    cfg = load_lab()
    assert cfg.grid_points().shape[1] == 3


def _deep(n: int) -> str:
    return "[" * n + "]" * n


@pytest.mark.parametrize("loader, kind, error", [
    (load_lab, "lab config", ValueError), (cal.load_calibration, "calibration", cal.CalibrationFileError),
    (ColorModel.load, "colour model", ValueError), (load_teach, "teach", TeachFileError),
    (load_scene, "scene", SceneError)])
def test_pathological_files_are_refused_naming_the_file(tmp_path, loader, kind, error):
    cases = {
        "deep.json": _deep(100_000),                          # json's parser recurses: RecursionError inside
        "deep_object.json": '{"a": ' * 50_000 + "1" + "}" * 50_000,
        "digits.json": '{"x": ' + "9" * 10_000 + "}",           # more digits than int() converts
        "huge.json": '{"x": 1e999999}',
        "top_list.json": "[1, 2, 3]",
        "empty.json": "",
        "binary.json": "\udcff",
    }
    for name, text in cases.items():
        p = tmp_path / name
        p.write_bytes(text.encode("utf-8", "surrogateescape"))
        with pytest.raises(error) as err:
            loader(p)
        assert str(p) in str(err.value), (name, str(err.value))
    loop = tmp_path / "loop.json"
    os.symlink(loop, loop)                                    # a symlink to itself: ELOOP
    with pytest.raises(error, match="loop.json") as err:
        loader(loop)
    assert "Errno" not in str(err.value) or kind in str(err.value)


@pytest.mark.parametrize("loader, file", [(cal.load_checkerboard_set, "checkerboard.json"),
                                          (load_labelled_frames, LABELS_FILE)])
def test_a_folders_pathological_json_is_refused_naming_the_file(tmp_path, loader, file):
    """The folders' own JSON (a checkerboard set's metadata, a colour-label set's labels) go through the same reader:
    deep nesting, a 10,000-digit number and a symlink loop are each a ValueError naming the file."""
    for name, text in {"deep": _deep(100_000), "digits": '{"x": ' + "9" * 10_000 + "}", "loop": None}.items():
        folder = tmp_path / name
        folder.mkdir()
        p = folder / file
        if text is None:
            os.symlink(p, p)
        else:
            p.write_text(text)
        with pytest.raises(ValueError) as err:
            loader(folder)
        assert str(p) in str(err.value), (name, str(err.value))


def test_read_json_refuses_an_oversized_file_without_reading_it(tmp_path, monkeypatch):
    import armlab.files as files

    p = tmp_path / "big.json"
    p.write_text("[" + "0," * 1000 + "0]")
    monkeypatch.setattr(files, "MAX_JSON_BYTES", 1000)
    with pytest.raises(ValueError, match=r"big\.json: .*too large"):
        read_json(p, "scene")


def _calibration_dict(station_camera) -> dict:
    return cal.Calibration(station_camera).to_dict()


CAMERA = {"K": [[900.0, 0.0, 640.0], [0.0, 900.0, 360.0], [0.0, 0.0, 1.0]], "dist": [0.0] * 5,
          "T_cam_world": [[1.0, 0, 0, 0], [0, -1.0, 0, 300.0], [0, 0, -1.0, 1000.0], [0, 0, 0, 1.0]]}


@pytest.mark.parametrize("change, field", [
    ({"depth_correction": {"a": 0, "b": 0, "c": 0, "residual_mm": "NaN", "inliers": 10}},
     "depth_correction.residual_mm"),
    ({"depth_correction": {"a": 0, "b": 0, "c": 0, "residual_mm": 1.0, "inliers": -1}}, "depth_correction.inliers"),
    ({"width": 1e300}, "width"), ({"height": 0}, "height"), ({"width": 640.5}, "width"),
    ({"K": [[900.0, 0.0, 640.0], [0.0, "Infinity", 360.0], [0.0, 0.0, 1.0]]}, "K[1][1]"),
    ({"dist": [0.1, 0.2]}, "dist"), ({"T_cam_world": [[1, 0, 0], [0, 1, 0]]}, "T_cam_world"),
    ({"T_cam_world": (2 * np.eye(4)).tolist()}, "T_cam_world"), ({"surprise": 1}, "(top level)"),
    ({"notes": ["a"]}, "notes"),
])
def test_a_calibration_file_with_an_absurd_field_is_refused_naming_it(tmp_path, change, field):
    data = {"format": "armlab-calibration/1", "width": 1280, "height": 720, **CAMERA,
            "depth_correction": {"a": 0.0, "b": 0.0, "c": 0.0, "residual_mm": 0.5, "inliers": 100}, "notes": ""}
    data.update(change)
    p = tmp_path / "cal.json"
    p.write_text(json.dumps(data).replace('"NaN"', "NaN").replace('"Infinity"', "Infinity"))
    with pytest.raises(cal.CalibrationFileError) as err:
        cal.load_calibration(p)
    assert f"{p}: {field}" in str(err.value), str(err.value)
    data.update({"format": "armlab-calibration/1"})


@pytest.mark.parametrize("change, field", [
    ({"stds": [[1.0, 1.0, 1.0], [0.0, 1.0, 1.0]]}, "stds[1][0]"),
    ({"means": [[1.0, 1.0, "NaN"], [2.0, 2.0, 2.0]]}, "means[0][2]"),
    ({"names": ["red", "pink"]}, "names[1]"), ({"names": ["red", "red"]}, "names"),
    ({"means": [[1.0, 1.0], [2.0, 2.0, 2.0]]}, "means[0]"),
])
def test_a_colour_model_with_an_absurd_field_is_refused_naming_it(tmp_path, change, field):
    data = {"format": "armlab-color-model/1", "note": "", "names": ["red", "blue"],
            "means": [[1.0, 1.0, 1.0], [2.0, 2.0, 2.0]], "stds": [[1.0, 1.0, 1.0], [1.0, 1.0, 1.0]]}
    data.update(change)
    p = tmp_path / "color_model.json"
    p.write_text(json.dumps(data).replace('"NaN"', "NaN"))
    with pytest.raises(ValueError) as err:
        ColorModel.load(p)
    assert f"{p}: {field}" in str(err.value), str(err.value)


@pytest.mark.parametrize("waypoint, field", [
    ({"q": [0, 0, 0, 0, 10**400], "gripper": "open"}, "waypoints[0].q[4]"),
    ({"q": [0, 0, 0, 0], "gripper": "open"}, "waypoints[0].q"),
    ({"q": [0, 0, 0, 0, 0], "gripper": "half"}, "waypoints[0].gripper"),
    ({"q": [0, 0, 0, 0, True], "gripper": "open"}, "waypoints[0].q[4]"),
    ({"q": [0, 0, 0, 0, 0]}, "waypoints[0].gripper"),
])
def test_a_teach_file_with_an_absurd_field_is_refused_naming_it(tmp_path, waypoint, field):
    p = tmp_path / "teach.json"
    p.write_text(json.dumps({"format": "armlab-teach/1", "name": "x", "waypoints": [waypoint]}))
    with pytest.raises(TeachFileError) as err:
        load_teach(p)
    assert f"{p}: {field}" in str(err.value), str(err.value)


@pytest.mark.parametrize("obj, field", [
    ({"color": "red", "size": "large", "position_mm": [0, 300, 10**400]}, "objects[0].position_mm[2]"),
    ({"color": "red", "size": "large", "position_mm": [0, 300], "edge_mm": 0}, "objects[0].edge_mm"),
    ({"color": "red", "size": "large", "position_mm": [0, 300], "yaw_rad": "Infinity"}, "objects[0].yaw_rad"),
    ({"color": "red", "size": "large", "position_mm": [0, 300], "id": 1.5}, "objects[0].id"),
])
def test_a_scene_file_with_an_absurd_field_is_refused_naming_it(tmp_path, obj, field):
    p = tmp_path / "scene.json"
    p.write_text(json.dumps({"format": "armlab-scene", "version": 1, "objects": [obj]})
                 .replace('"Infinity"', "Infinity"))
    with pytest.raises(SceneError) as err:
        load_scene(p)
    assert f"{p}: {field}" in str(err.value), str(err.value)


def test_the_packaged_files_pass_their_schemas():
    data = packaged_data_dir()
    assert load_lab(data / "lab.json").grid_mm == 50.0
    assert len(ColorModel.load(data / "color_model.json").names) == 6
    for teach_file in sorted((data / "teach").glob("*.json")):
        assert len(load_teach(teach_file).q) >= 1
    assert math.isfinite(GOOD_LAB["board"]["grid_mm"])
