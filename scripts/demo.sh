#!/usr/bin/env bash
# README command 1: set everything up and run the main job.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_venv.sh
exec .venv/bin/relmogen demo "$@"
