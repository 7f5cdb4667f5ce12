#!/usr/bin/env bash
# README command 2: set everything up and run the test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_venv.sh
exec .venv/bin/python -m pytest -n 2 --dist loadgroup --durations=15 "$@"
