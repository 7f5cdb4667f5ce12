#!/usr/bin/env bash
# Create .venv in the checkout and install relmogen into it. Idempotent: a second run
# only checks a stamp and returns in about a second.
#
# RELMOGEN_TORCH_INDEX_URL (optional): an extra package index for the torch install, passed
# to pip as --extra-index-url, e.g. https://download.pytorch.org/whl/cpu for the CPU build
# on a machine without a GPU (a plain index resolves the pin to the CUDA build).
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3.11}
command -v "$PYTHON" >/dev/null 2>&1 || PYTHON=python3
torch_index=${RELMOGEN_TORCH_INDEX_URL:-}
if [ ! -x .venv/bin/python ]; then
  echo "[setup] creating .venv with $($PYTHON --version)"
  "$PYTHON" -m venv .venv
fi
stamp=.venv/.relmogen-installed
# The stamp covers what decides the install: the dependencies, this script and the torch index.
want=$({ cat pyproject.toml scripts/setup_venv.sh; printf 'torch index: %s\n' "$torch_index"; } \
  | sha256sum | cut -d' ' -f1)
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
  exit 0
fi
echo "[setup] installing dependencies into .venv (first run takes a few minutes)"
.venv/bin/python -m pip install -q --upgrade pip
# torch first and pinned: an unpinned torch pulls a multi-GB CUDA build.
torch_args=()
if [ -n "$torch_index" ]; then
  echo "[setup] torch: extra index $torch_index"
  torch_args=(--extra-index-url "$torch_index")
fi
.venv/bin/python -m pip install -q ${torch_args[@]+"${torch_args[@]}"} "torch==2.13.0"
.venv/bin/python -m pip install -q -e ".[test]"
echo "$want" > "$stamp"
echo "[setup] done"
