#!/usr/bin/env bash
# Set up the environment and run the main job on the built-in simulated mission (no download):
# the comparison benchmark of every method through 30 s partial-beam outages. Extra args go to
# `graphnav bench`; results land in out/bench (report.md, results.json, plots).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
exec .venv/bin/graphnav bench --out out/bench "$@"
