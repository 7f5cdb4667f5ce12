#!/usr/bin/env bash
# Continue a finished 1,500-episode seed of the ArrangeKitchenMM relmogen-d row to 4,600 episodes,
# as the ArrangeChairMM row was: at 1,500 episodes epsilon was still 0.29 (it reaches its floor of
# 0.05 at episode 2,000), and ArrangeChairMM's greedy figure tripled between 2,600 and 4,600
# episodes. Then evaluate it (../relmogen-d-extend.sh says how).  SEED
[[ $# -eq 1 ]] || { echo "usage: $0 SEED" >&2; exit 2; }
exec bash "$(dirname "$0")/../relmogen-d-extend.sh" boltzmann ArrangeKitchenMM "$1" 4600
