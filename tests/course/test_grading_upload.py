"""The Gradescope bundle finds a submission's files wherever the upload puts them (issue 34): flat (the files dragged
in), in one folder, in the release's layout; two files of one name are refused with the reason; an upload with none
of the release's files scores 0 with a visible "no release files found: upload ...". One end-to-end run of
armlab_course.grading.autograder.run in a simulated /autograder tree grades a flat upload's solved notebook."""

from __future__ import annotations

import json
import shutil
from pathlib import Path, PurePosixPath

import pytest

from armlab_course.exercises.registry import exercise
from armlab_course.grading.upload import find_release_files, refusal, release_names, stage

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOK = "notebooks/02_forward_kinematics.ipynb"
PACKAGE = "armlab/kinematics.py"


def _put(folder: Path, rel: str, text: str = "x") -> None:
    (folder / rel).parent.mkdir(parents=True, exist_ok=True)
    (folder / rel).write_text(text)


def _found(upload: Path) -> dict[str, str]:
    found = find_release_files(upload)
    assert refusal(found) is None, refusal(found)
    return {name: str(rel) for name, rel in found.files.items()}


@pytest.mark.parametrize("prefix", ["", "my work/", "dist/student/"])
def test_the_release_layout_is_found_under_any_folder(tmp_path, prefix):
    for name in (NOTEBOOK, PACKAGE, "benchmarks/kinematics.py", "armlab/__init__.py"):
        _put(tmp_path, prefix + name)
    _put(tmp_path, prefix + "notebooks/.ipynb_checkpoints/02_forward_kinematics.ipynb")   # JupyterLab's copy
    assert _found(tmp_path) == {NOTEBOOK: prefix + NOTEBOOK, PACKAGE: prefix + PACKAGE}


@pytest.mark.parametrize("prefix", ["", "hw2/"])
def test_flat_files_are_found_by_their_names(tmp_path, prefix):
    _put(tmp_path, prefix + "02_forward_kinematics.ipynb")
    _put(tmp_path, prefix + "kinematics.py")
    _put(tmp_path, prefix + "notes.txt")
    _put(tmp_path, "__MACOSX/" + prefix + "02_forward_kinematics.ipynb")              # a Mac zip's shadow copy
    assert _found(tmp_path) == {NOTEBOOK: prefix + "02_forward_kinematics.ipynb", PACKAGE: prefix + "kinematics.py"}


def test_two_files_of_one_name_are_refused_naming_both(tmp_path):
    _put(tmp_path, "a/02_forward_kinematics.ipynb")
    _put(tmp_path, "b/02_forward_kinematics.ipynb")
    _put(tmp_path, "kinematics.py")
    found = find_release_files(tmp_path)
    assert found.ambiguous == {NOTEBOOK: [PurePosixPath("a/02_forward_kinematics.ipynb"),
                                          PurePosixPath("b/02_forward_kinematics.ipynb")]}
    why = refusal(found)
    assert why.startswith("refused:") and "a/02_forward_kinematics.ipynb and b/02_forward_kinematics.ipynb" in why


def test_an_upload_without_release_files_is_refused_saying_what_to_upload(tmp_path):
    _put(tmp_path, "homework.pdf")
    _put(tmp_path, "forward_kinematics.ipynb")           # not the release's name
    why = refusal(find_release_files(tmp_path))
    assert why.startswith("no release files found: upload ")
    assert all(PurePosixPath(n).name in why for n in release_names())


def test_staging_puts_the_files_in_the_release_layout_and_keeps_links_links(tmp_path):
    upload = tmp_path / "upload"
    _put(upload, "hw/02_forward_kinematics.ipynb", "the notebook")
    (upload / "armlab").mkdir()
    (upload / "elsewhere").mkdir()
    _put(upload, "elsewhere/armlab/kinematics.py", "instructor's")
    shutil.rmtree(upload / "armlab")
    (upload / "armlab").symlink_to(upload / "elsewhere/armlab", target_is_directory=True)
    found = find_release_files(upload, [NOTEBOOK, PACKAGE])
    staged = stage(upload, found, tmp_path / "staged")
    assert (staged / NOTEBOOK).read_text() == "the notebook" and not (staged / NOTEBOOK).is_symlink()
    assert (staged / "armlab").is_symlink()           # the reader refuses it, as it refuses the upload's own link


def _gradescope_root(tmp_path: Path) -> Path:
    from armlab_course.grading.autograder import build_bundle

    root = tmp_path / "autograder"
    root.mkdir()
    build_bundle(ROOT, root / "source")
    (root / "source.zip").unlink()
    (root / "submission").mkdir()
    return root


def test_an_upload_without_release_files_or_with_two_of_one_name_scores_0_visibly(tmp_path, capsys):
    from armlab_course.grading.autograder import run

    root = _gradescope_root(tmp_path)
    _put(root / "submission", "homework.pdf")
    results = json.loads(run(root).read_text())
    assert results["score"] == 0 and results["output"].startswith("no release files found: upload ")
    assert "no release files found" in capsys.readouterr().out
    _put(root / "submission", "a/02_forward_kinematics.ipynb")
    _put(root / "submission", "b/02_forward_kinematics.ipynb")
    results = json.loads(run(root).read_text())
    assert results["score"] == 0 and results["output"].startswith("refused: the upload holds more than one file")


def test_a_flat_upload_of_a_solved_notebook_scores_full(tmp_path, monkeypatch, capsys):
    from armlab_course.grading.autograder import run

    root = _gradescope_root(tmp_path)
    shutil.copy(ROOT / NOTEBOOK, root / "submission" / Path(NOTEBOOK).name)      # the instructor's: solved
    monkeypatch.setenv("ARMLAB_GRADE_EXERCISES", "fk.euler")
    results = json.loads(run(root).read_text())
    tests = {t["name"].split(":")[0]: t for t in results["tests"]}
    assert tests["fk.euler"]["score"] == exercise("fk.euler").points > 0, tests["fk.euler"]
    out = capsys.readouterr().out
    assert f"{NOTEBOOK} <- 02_forward_kinematics.ipynb" in out
    assert not [p for p in root.iterdir() if p.name.startswith("found-")]        # the staged copy is gone
