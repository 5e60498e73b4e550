#!/usr/bin/env bash
# Retrain the shipped missing-beam networks with the recipes chosen out of fold, install them over the shipped
# weights, and print the beam-only networks' table (V_test is the only data they were not trained on).
# Usage: scripts/train_beams.sh [OUT_DIR]   (default out/train-beams; needs ../shared/data or GRAPHNAV_DATA).
# Beam-only (akit-residual-aug-ens5-fade: five seeds averaged, fading to the average through an outage): its
# out-of-fold rows first, for the model card (about 20 min per scenario), then about 8 min of training; IMU-aware
# (graded-fade, all ten A-KIT trajectories, fading to the average through an outage): about 2 min of training per scenario, 5-8 min for both with loading. One
# thread each, seeded: a rerun gives the same weights.
set -euo pipefail
cd "$(dirname "$0")/.."
PY=${PYTHON:-.venv/bin/python}
OUT=${1:-out/train-beams}
DATA=${GRAPHNAV_DATA:-../shared/data}
RECIPE=akit-residual-aug-ens5-fade
mkdir -p "$OUT"
for s in 2-missing 3-missing; do
  nice -n 10 $PY -m graphnav eval-beams --folds --variant "$RECIPE" --scenario "$s" --akit "$DATA/snapir-2022-akit" \
    --beamsnet "$DATA/snapir-2021-beamsnet" --json "$OUT/cv-$s.json"
done
$PY -m graphnav train-beams --recipe "$RECIPE" --data "$DATA" --out "$OUT/beams" --force --no-progress \
  --out-of-fold "$OUT/cv-2-missing.json" "$OUT/cv-3-missing.json" --install-weights
$PY -m graphnav eval-beams --weights "$OUT/beams" --akit "$DATA/snapir-2022-akit" --beamsnet "$DATA/snapir-2021-beamsnet"
nice -n 10 $PY -m graphnav train-beams --imu --recipe graded-fade --data "$DATA/snapir-2022-akit" --out "$OUT/imu" \
  --force --no-progress --install-weights
