#!/usr/bin/env bash
# Gradescope runs this once, in /autograder/source, when it builds the autograder image: Python and the kit's
# requirements (the same ones the instructor's checkout grades with).
set -euo pipefail
cd "$(dirname "$0")"
apt-get update -q
apt-get install -y -q python3 python3-pip python3-venv
python3 -m venv /autograder/venv
/autograder/venv/bin/python -m pip install --quiet --upgrade pip
/autograder/venv/bin/python -m pip install --quiet -r requirements.txt
