#!/usr/bin/env bash
# Create (or reuse) the project virtual environment .venv and install graphnav into it, editable.
# torch is installed first and pinned to 2.13.0 so that pip never pulls a multi-GB CUDA build as a
# dependency (on the project machines a CPU build of 2.13.0 is on disk). Set GRAPHNAV_TORCH to override
# (any version in the range pyproject.toml allows).
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}
VENV=${GRAPHNAV_VENV:-.venv}
if [ ! -x "$VENV/bin/python" ]; then
    "$PYTHON" -m venv "$VENV"
fi
PIP=("$VENV/bin/python" -m pip --disable-pip-version-check -q)
"${PIP[@]}" install --upgrade "pip>=23" "setuptools>=68" wheel
"$VENV/bin/python" -c "import torch" 2>/dev/null || "${PIP[@]}" install "torch==${GRAPHNAV_TORCH:-2.13.0}"
# The optional readers/writers (ROS bags, PD0, evo, Dask) are installed too: the tests exercise them.
"${PIP[@]}" install -e ".[test,ros,pd0,eval,dask]"
echo "graphnav installed in $VENV ($("$VENV/bin/python" -c 'import graphnav; print(graphnav.__version__)'))"
