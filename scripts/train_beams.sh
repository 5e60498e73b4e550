#!/usr/bin/env bash
# Retrain the shipped missing-beam networks and print their evaluation table.
# Usage: scripts/train_beams.sh [OUT_DIR]   (default: the package's nets/weights; needs ../shared/data or
# GRAPHNAV_DATA). Both scenarios take about 4 min of CPU time (paper schedule, patience 30, 1 thread).
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-.venv/bin/python}
OUT=${1:-nets/weights}
$PY -m graphnav train-beams --out "$OUT"
$PY -m graphnav eval-beams --weights "$OUT"
