#!/usr/bin/env bash
# Gradescope runs this once, in /autograder/source, when it builds the autograder image: a Python the kit's pins can
# install on (pick-python: the newest python3.X >= 3.11 of the image, else Debian/Ubuntu's python3.11 or python3.12
# package), the kit's requirements in /autograder/venv, and bubblewrap (the grader's sandbox; where the container
# does not allow namespaces the grader runs student code as an unprivileged user instead).
set -euo pipefail
cd "$(dirname "$0")"
MIN=3.11
apt-get update -q
apt-get install -y -q bubblewrap util-linux python3 python3-venv || true
if ! PY=$(bash pick-python "$MIN" 2>/dev/null); then
    apt-get install -y -q python3.12 python3.12-venv || apt-get install -y -q python3.11 python3.11-venv || true
    PY=$(bash pick-python "$MIN")
fi
"$PY" -m venv /autograder/venv
/autograder/venv/bin/python -m pip install --quiet --upgrade pip
/autograder/venv/bin/python -m pip install --quiet -r requirements.txt
