"""armlab.files: atomic writes leave the old file or the new one, never a half-written one; JSON reads fail clearly."""

from __future__ import annotations

import json

import pytest

from armlab.files import atomic_path, read_json, write_json_atomic, write_text_atomic


def test_atomic_write_replaces_the_file_and_leaves_no_temporary(tmp_path):
    target = tmp_path / "cal.json"
    write_json_atomic(target, {"a": 1})
    write_json_atomic(target, {"a": 2})
    assert json.loads(target.read_text()) == {"a": 2}
    assert [p.name for p in tmp_path.iterdir()] == ["cal.json"]


def test_a_failed_write_leaves_the_old_file_untouched(tmp_path):
    target = write_text_atomic(tmp_path / "notes.txt", "old")
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("half of the new")
        raise RuntimeError("the writer crashed")
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["notes.txt"]
    with pytest.raises(ValueError, match="not JSON compliant"):
        write_json_atomic(target, {"x": float("nan")})
    assert target.read_text() == "old"


def test_writing_into_a_missing_folder_names_it(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        write_text_atomic(tmp_path / "nowhere" / "f.txt", "x")
    assert write_text_atomic(tmp_path / "made" / "f.txt", "x", make_parents=True).read_text() == "x"


class SceneTrouble(Exception):
    pass


def test_read_json_names_the_file_and_the_problem(tmp_path):
    good = write_json_atomic(tmp_path / "ok.json", [1, 2])
    assert read_json(good, "scene") == [1, 2]
    with pytest.raises(SceneTrouble, match=r"missing\.json: scene file not found"):
        read_json(tmp_path / "missing.json", "scene", SceneTrouble)
    (tmp_path / "bad.json").write_text('{"blocks": [1, 2')
    with pytest.raises(ValueError, match=r"bad\.json: not valid JSON, a corrupt teach file"):
        read_json(tmp_path / "bad.json", "teach")
    (tmp_path / "binary.json").write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ValueError, match="not valid JSON"):
        read_json(tmp_path / "binary.json", "teach")
    with pytest.raises(ValueError, match="is a folder"):
        read_json(tmp_path, "scene")
