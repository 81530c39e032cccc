"""binder/ as repo2docker reads it (Binder, BinderHub and zero-to-jupyterhub build a class's image with it).

The test makes a fresh venv, installs jupyter-repo2docker there (from the package index, like an instructor would) and
asks it for the Dockerfile it would build from a clean copy of this checkout (`--no-build --debug`: no Docker needed).
It then checks what matters for the kit: the Python of the pins, the kit's pinned requirements installed after the
repository is copied in (binder/requirements.txt refers to ../requirements.txt), postBuild run (it installs the
package and checks the widget extensions), and that pip resolves binder/requirements.txt to the kit's pins with the
widgets the 3D view and the panel need. docs/hub.md is the instructors' page.
"""

from __future__ import annotations

import json
import re
import subprocess
import venv
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent
BINDER = REPO / "binder"


def pins(path: Path) -> dict[str, str]:
    """name -> version of the `name==version` lines of a requirements file whose environment marker holds for this
    Python (the binder venv is made from it), following `-r other` lines."""
    from packaging.markers import Marker

    out: dict[str, str] = {}
    for line in path.read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line.startswith("-r "):
            out.update(pins((path.parent / line[3:].strip()).resolve()))
        elif "==" in line:
            requirement, _, marker = line.partition(";")
            if marker.strip() and not Marker(marker.strip()).evaluate():
                continue
            name, version = requirement.split("==", 1)
            out[name.strip().lower()] = version.strip()
    return out


def canonical(name: str) -> str:
    """A distribution name as pip compares them (PEP 503)."""
    return re.sub(r"[-_.]+", "-", name).lower()


@pytest.fixture(scope="module")
def repo2docker(tmp_path_factory):
    """(python of a fresh venv with jupyter-repo2docker, a clean clone of this checkout with the working binder/)."""
    root = tmp_path_factory.mktemp("r2d")
    venv.EnvBuilder(with_pip=True).create(root / "venv")
    python = root / "venv" / "bin" / "python"
    install = subprocess.run([str(python), "-m", "pip", "install", "--quiet", "jupyter-repo2docker"],
                             capture_output=True, text=True, timeout=900)
    if install.returncode != 0:
        pytest.skip(f"jupyter-repo2docker cannot be installed here (no package index?): {install.stderr[-500:]}")
    clone = root / "repo"
    subprocess.run(["git", "clone", "--quiet", str(REPO), str(clone)], check=True, timeout=300)
    subprocess.run(["cp", "-r", str(BINDER), str(clone)], check=True)     # the binder/ being tested, committed or not
    return python, clone


def test_the_files_repo2docker_reads_are_there():
    assert (BINDER / "requirements.txt").is_file() and (BINDER / "runtime.txt").is_file()
    post = BINDER / "postBuild"
    assert post.is_file() and post.stat().st_mode & 0o111, "binder/postBuild must be executable"
    assert pins(BINDER / "requirements.txt") == pins(REPO / "requirements.txt")       # the kit's pins, nothing else
    assert {"anywidget", "ipywidgets", "ipyevents", "jupyterlab", "meshcat"} <= set(pins(BINDER / "requirements.txt"))
    text = post.read_text()
    assert "pip install --no-cache-dir --no-deps -e ." in text and "set -euo pipefail" in text


def test_repo2docker_builds_the_kits_image(repo2docker):
    python, clone = repo2docker
    run = subprocess.run([str(python), "-m", "repo2docker", "--no-build", "--no-run", "--debug", str(clone)],
                         capture_output=True, text=True, timeout=600)
    out = run.stdout + run.stderr
    assert run.returncode == 0, out[-3000:]
    assert "Building conda environment for python=3.11" in out, out[:2000]     # numpy 2.4.6 needs 3.11
    copy_all = out.index("COPY --chown=0:0 src/ ${REPO_DIR}/")
    install = out.index('pip install --no-cache-dir -r "binder/requirements.txt"')
    assert install > copy_all, "the requirements refer to ../requirements.txt: they must install after the copy"
    assert out.index("RUN ./binder/postBuild") > install
    assert not re.search(r"apt-get .*chromium", out)                          # students need no browser in the image


def test_pip_resolves_binder_requirements_to_the_kits_pins(repo2docker, tmp_path):
    python, clone = repo2docker
    report = tmp_path / "report.json"
    run = subprocess.run([str(python), "-m", "pip", "install", "--quiet", "--dry-run", "--ignore-installed",
                          "--report", str(report), "-r", str(clone / "binder" / "requirements.txt")],
                         capture_output=True, text=True, timeout=900, cwd=clone)
    assert run.returncode == 0, run.stderr[-3000:]
    resolved = {canonical(i["metadata"]["name"]): i["metadata"]["version"]
                for i in json.loads(report.read_text())["install"]}
    for name, version in pins(REPO / "requirements.txt").items():
        assert resolved.get(canonical(name)) == version, (name, version, resolved.get(canonical(name)))
