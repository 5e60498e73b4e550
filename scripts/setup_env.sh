#!/usr/bin/env bash
# Create (or reuse) the project virtual environment .venv and install graphnav into it, editable.
# torch is installed first and pinned to 2.13.0 so that pip never pulls a multi-GB CUDA build as a
# dependency (on the project machines a CPU build of 2.13.0 is on disk). Set GRAPHNAV_TORCH to override
# (any version in the range pyproject.toml allows).
# The rest is installed with uv when it can be had (it downloads in parallel: a new venv with empty caches
# takes 66 s in all, against 144 s with pip alone), else with pip; GRAPHNAV_INSTALLER=pip forces pip. With
# torch already in the venv and inside the project's range, neither installer touches it.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}
VENV=${GRAPHNAV_VENV:-.venv}
if [ ! -x "$VENV/bin/python" ]; then
    "$PYTHON" -m venv "$VENV"
fi
PIP=("$VENV/bin/python" -m pip --disable-pip-version-check -q)
# setuptools and wheel in the venv itself: the packaging tests build a wheel without build isolation (installed
# when missing or too old, not upgraded on every run)
"${PIP[@]}" install "pip>=23" "setuptools>=68" wheel
"$VENV/bin/python" -c "import torch" 2>/dev/null || "${PIP[@]}" install "torch==${GRAPHNAV_TORCH:-2.13.0}"
# The optional readers/writers (ROS bags, PD0, evo, Dask) are installed too: the tests exercise them.
PROJECT=".[test,ros,pd0,eval,dask]"
INSTALLER=${GRAPHNAV_INSTALLER:-uv}
if [ "$INSTALLER" != uv ] && [ "$INSTALLER" != pip ]; then
    echo "setup_env.sh: GRAPHNAV_INSTALLER must be uv or pip, got '$INSTALLER'" >&2
    exit 2
fi
if [ "$INSTALLER" = pip ] || ! { "${PIP[@]}" install "uv>=0.4,<1" \
        && "$VENV/bin/uv" pip install --quiet --python "$VENV/bin/python" -e "$PROJECT"; }; then
    echo "setup_env.sh: installing with pip" >&2
    "${PIP[@]}" install -e "$PROJECT"
fi
echo "graphnav installed in $VENV ($("$VENV/bin/python" -c 'import graphnav; print(graphnav.__version__)'))"
