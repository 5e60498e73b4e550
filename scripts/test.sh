#!/usr/bin/env bash
# Set up the environment and run the test suite: bash scripts/test.sh [pytest args]
# Real-data tests read ../shared/data (or $GRAPHNAV_DATA) and skip with a reason when it is absent.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
# One pytest worker per core, at most 4 (pytest-xdist; a test module stays on one worker, so its fixtures are
# made once); PYTEST_WORKERS=0 runs everything in this process.
WORKERS=${PYTEST_WORKERS:-$(nproc 2>/dev/null || echo 2)}
if [ "$WORKERS" -gt 4 ]; then WORKERS=4; fi
exec .venv/bin/python -m pytest -q -rs -n "$WORKERS" --dist loadscope "$@"
