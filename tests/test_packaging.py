"""`pip install .` gives a package that works from any folder: the wheel carries the data files (read through
importlib.resources), declares compatible version ranges for what it imports, and a lab's own data folder
($ARMLAB_DATA) overrides the packaged files one by one.
"""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

from armlab import _paths

tomllib = pytest.importorskip("tomllib")        # Python 3.11+

REPO = Path(__file__).resolve().parents[1]


def build_wheel(source: Path, out: Path) -> Path:
    """The wheel `pip wheel` builds from the project folder `source`, in `out`."""
    run = subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(out), str(source)],
                         capture_output=True, text=True, timeout=600)
    if run.returncode != 0:
        pytest.fail(f"pip wheel failed: {run.stderr[-2000:]}")
    (path,) = out.glob("armlab-*.whl")
    return path


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    return build_wheel(REPO, tmp_path_factory.mktemp("wheel"))


@pytest.fixture(scope="module")
def student_wheel(tmp_path_factory) -> Path:
    """The wheel to publish: built from the student release (make student), as docs/release.md says."""
    from armlab_course.exercises import make_student_release

    release = tmp_path_factory.mktemp("release") / "student"
    make_student_release(REPO, release)
    return build_wheel(release, tmp_path_factory.mktemp("student_wheel"))


def test_the_student_wheel_holds_no_hidden_checks_and_no_solution(student_wheel):
    """Every module of the published wheel is the instructor's with each exercise region stubbed (so no solution
    line is left, whatever it is), and the grader's hidden checks are not in it; data, licence and py.typed are."""
    from armlab_course.exercises.markers import find_regions, stub_regions

    wheel = zipfile.ZipFile(student_wheel)
    names = set(wheel.namelist())
    assert not any(n.startswith("armlab_course/grading/hidden") for n in names), \
        sorted(n for n in names if "hidden" in n)
    assert "armlab/py.typed" in names and "armlab/data/lab.json" in names
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names), "the licence travels with the wheel"
    modules = sorted(n for n in names if n.startswith("armlab/") and n.endswith(".py"))
    stubbed = []
    for name in modules:
        shipped = wheel.read(name).decode()
        instructors = (REPO / name).read_text()
        assert shipped == stub_regions(instructors, name), f"{name} in the student wheel is not the stubbed source"
        if find_regions(instructors, name):
            assert shipped != instructors
            stubbed.append(name)
    assert len(stubbed) >= 5, stubbed          # the package exercises (DH, IK, calibration, detection, tasks)
    assert "armlab/kinematics.py" in stubbed


def test_the_wheel_carries_every_data_file(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    shipped = sorted(p.relative_to(REPO).as_posix() for p in (REPO / "armlab" / "data").rglob("*") if p.is_file())
    assert len(shipped) >= 20
    missing = [n for n in shipped if n not in names]
    assert not missing, f"data files left out of the wheel: {missing}"
    assert not any(n.startswith(("tests/", "notebooks/", "benchmarks/")) for n in names)


def test_the_installed_wheel_works_from_another_folder(wheel, tmp_path):
    """Installed (no repository on the path) and run from an empty folder: station, frame, detection, FK, IK."""
    target = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--target", str(target),
                    str(wheel)], check=True, capture_output=True, timeout=600)
    deps = sysconfig.get_paths()["purelib"]          # the dependencies, from the test's own environment
    code = """
import numpy as np, armlab
from armlab import make_station, kinematics, detection, tasks
assert armlab.__file__.startswith(TARGET), armlab.__file__
station = make_station("sim", seed=0, scene="swap")
frame = station.camera.capture()                                # a frame
assert frame.rgb.shape == (720, 1280, 3)
session = tasks.start_session(station)                         # calibration from the packaged checkerboard set
blocks = detection.detect_blocks(frame.rgb, session.calibration.depth_correction.apply(frame.depth),
                                 session.calibration.camera, arm_q=station.arm.joint_positions())
q = kinematics.ik([100.0, 250.0, 19.0], np.pi / 2)[0]
print(sorted(b.color for b in blocks), kinematics.fk(q)[:3, 3].round(1).tolist())
""".replace("TARGET", repr(str(target)))
    work = tmp_path / "elsewhere"
    work.mkdir()
    env = {"PATH": os.environ.get("PATH", "/usr/bin:/bin"), "PYTHONPATH": os.pathsep.join([str(target), deps]),
           "MPLBACKEND": "Agg", "HOME": str(tmp_path)}
    base_python = Path(sys.base_prefix) / "bin" / "python3"
    run = subprocess.run([str(base_python), "-s", "-c", code], cwd=work, env=env, capture_output=True, text=True,
                         timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    assert run.stdout.strip() == "['blue', 'red'] [100.0, 250.0, 19.0]", run.stdout


def _by_name(specs: list[str]) -> dict[str, str]:
    return {re.split(r"[<>=!~; \[]", d, maxsplit=1)[0].lower(): d for d in specs}


def test_every_imported_package_has_a_declared_version_range():
    """What armlab imports is a dependency with a compatible range; what only a subpackage with an extra of its own
    imports (the grader: `pip install armlab[grading]`) may be declared in that extra instead."""
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    declared = _by_name(project["dependencies"])
    extras = {name: _by_name(specs) for name, specs in project["optional-dependencies"].items()}
    for spec in [*declared.values(), *(s for e in extras.values() for s in e.values())]:
        assert "<" in spec and ">=" in spec, f"{spec!r}: give a compatible range (>= tested, < next major)"
    extra_of = {"grading": "grading"}          # armlab_course/grading/ may import what [grading] declares
    imported_as = {"numpy": "numpy", "cv2": "opencv-python-headless", "pupil_apriltags": "pupil-apriltags",
                   "meshcat": "meshcat", "zmq": "pyzmq", "matplotlib": "matplotlib", "ipywidgets": "ipywidgets",
                   "ipyevents": "ipyevents", "IPython": "ipython", "scipy": "scipy", "jsonschema": "jsonschema",
                   "platformdirs": "platformdirs", "mujoco": "mujoco",
                   "anywidget": "anywidget", "traitlets": "traitlets", "umsgpack": "u-msgpack-python",
                   "pytest": "pytest"}
    third_party: dict[str, set] = {}            # module -> the extras of the files importing it (None: the core)
    for path in [*(REPO / "armlab").rglob("*.py"), *(REPO / "armlab_course").rglob("*.py")]:
        if "hardware" in path.parts:            # vendor modules, imported lazily (HardwareUnavailable if missing)
            continue
        extra = next((extra_of[p] for p in path.relative_to(REPO).parts[1:-1] if p in extra_of), None)
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                names = [node.module]
            else:
                continue
            for top in {n.split(".")[0] for n in names} - set(sys.stdlib_module_names) - {"armlab", "armlab_course"}:
                third_party.setdefault(top, set()).add(extra)
    unknown = set(third_party) - set(imported_as)
    assert not unknown, f"armlab imports {sorted(unknown)}: declare them in pyproject.toml and in this table"
    for module, users in third_party.items():
        for extra in users:
            allowed = declared if extra is None else {**declared, **extras[extra]}
            where = f"its dependencies or [{extra}]" if extra else "its dependencies"
            assert imported_as[module] in allowed, f"armlab imports {module}: declare {imported_as[module]} in {where}"
    assert "opencv-python-headless>=4.10,<6" in project["dependencies"]   # 5.x: armlab.camera's fallback


def test_a_lab_data_folder_overrides_packaged_files_one_by_one(tmp_path, monkeypatch):
    packaged = _paths.packaged_data_dir()
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "user"))
    assert (packaged / "lab.json").is_file() and packaged.parent.name == "armlab"
    monkeypatch.setenv(_paths.DATA_ENV, str(tmp_path))
    assert _paths.data_path("lab.json") == packaged / "lab.json"          # not in the lab's folder: the package's
    (tmp_path / "lab.json").write_text("{}")
    assert _paths.data_path("lab.json") == tmp_path / "lab.json"          # the lab's own wins
    assert _paths.data_path("checkerboard_real") == tmp_path / "checkerboard_real"   # missing: where to put it
    assert _paths.data_write_path("color_model.json") == tmp_path / "color_model.json"


def test_a_missing_colour_model_is_an_error_not_other_colours(tmp_path, monkeypatch):
    from armlab.detection import color

    monkeypatch.setattr(_paths, "packaged_data_dir", lambda: tmp_path)
    monkeypatch.delenv(_paths.DATA_ENV, raising=False)
    with pytest.raises(ValueError, match="color_model.json: colour model file not found"):
        color.default_color_model()


def test_the_users_data_folder_sits_between_the_lab_folder_and_the_package(tmp_path, monkeypatch):
    """Without ARMLAB_DATA the kit writes to the per-user folder (never into site-packages) and reads what it wrote
    there before the packaged file; a lab's folder still wins over both."""
    packaged = _paths.packaged_data_dir()
    monkeypatch.delenv(_paths.DATA_ENV, raising=False)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "user"))
    user = tmp_path / "user" / "armlab"
    assert _paths.user_data_dir() == user
    assert _paths.data_path("lab.json") == packaged / "lab.json"
    target = _paths.data_write_path("lab.json")
    assert target == user / "lab.json" and user.is_dir()          # the folder is made; nothing in the package
    target.write_text("{}")
    assert _paths.data_path("lab.json") == user / "lab.json"
    lab = tmp_path / "lab"
    (lab / "lab.json").parent.mkdir()
    (lab / "lab.json").write_text("{}")
    monkeypatch.setenv(_paths.DATA_ENV, str(lab))
    assert _paths.data_path("lab.json") == lab / "lab.json"


def test_the_version_is_the_same_everywhere():
    """pyproject.toml, armlab.__version__ and the CHANGELOG's newest section name the same version."""
    import armlab

    declared = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]
    newest = re.search(r"^## \[(\d+\.\d+\.\d+)\]", (REPO / "CHANGELOG.md").read_text(), re.MULTILINE)
    assert newest, "CHANGELOG.md has no '## [X.Y.Z]' section"
    assert declared == armlab.__version__ == newest[1], (declared, armlab.__version__, newest[1])
