#!/usr/bin/env bash
# Continue a finished 2,600-episode seed of the ButtonDoorNav relmogen-d row to 4,600 episodes, as
# the ArrangeChairMM row was (its greedy figure tripled between 2,600 and 4,600 episodes): after
# epsilon's floor (episode 2,000) the seeds press the button in 3-5% of training episodes (11-19 per
# 400), against 1.6% at epsilon near 1 (episodes 1-400), and succeed 1-3 times per 400 episodes.
# Then evaluate it (../relmogen-d-extend.sh says how).  SEED
[[ $# -eq 1 ]] || { echo "usage: $0 SEED" >&2; exit 2; }
exec bash "$(dirname "$0")/../relmogen-d-extend.sh" gamma ButtonDoorNav "$1" 4600
