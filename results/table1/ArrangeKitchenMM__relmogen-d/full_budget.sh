#!/usr/bin/env bash
# Continue a 4,600-episode seed of the ArrangeKitchenMM relmogen-d row until the issue's 6 CPU h
# per seed is spent (max_cpu_hours in the run's config stops it; the episode cap is never reached):
# every seed was still rising at 4,600 episodes (2.2-2.4 items closed per training episode). Then
# evaluate it (../relmogen-d-extend.sh says how).  SEED
[[ $# -eq 1 ]] || { echo "usage: $0 SEED" >&2; exit 2; }
exec bash "$(dirname "$0")/../relmogen-d-extend.sh" boltzmann ArrangeKitchenMM "$1" 100000
