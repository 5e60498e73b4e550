#!/usr/bin/env bash
# Retrain the shipped missing-beam networks and print their evaluation tables.
# Usage: scripts/train_beams.sh [OUT_DIR]   (default: the package's nets/weights; needs ../shared/data or
# GRAPHNAV_DATA). The beam-only networks (BeamsNet data) take about 4 min of CPU time (paper schedule,
# patience 30, 1 thread); the IMU-aware networks (A-KIT, split by trajectory) about 1 min of CPU each.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-.venv/bin/python}
OUT=${1:-nets/weights}
$PY -m graphnav train-beams --out "$OUT"
$PY -m graphnav eval-beams --weights "$OUT"
nice -n 10 $PY -m graphnav train-beams --imu --no-progress --out "$OUT"
$PY -m graphnav eval-beams --imu --weights "$OUT"
