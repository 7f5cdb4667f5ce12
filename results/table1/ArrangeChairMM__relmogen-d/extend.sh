#!/usr/bin/env bash
# Continue a finished 2,600-episode seed of the ArrangeChairMM relmogen-d row to 4,600 episodes, the
# most the issue's 6 CPU h per seed buys seeds 0 and 1 (their first 2,600 episodes ran on the slow
# AMD host), then evaluate it (../relmogen-d-extend.sh says how).  SEED
[[ $# -eq 1 ]] || { echo "usage: $0 SEED" >&2; exit 2; }
exec bash "$(dirname "$0")/../relmogen-d-extend.sh" gamma ArrangeChairMM "$1" 4600
