#!/usr/bin/env bash
# One seed of the ArrangeChairMM relmogen-d row, reward only: the sgpd-explore gamma recipe
# (discount 0.95, uniform exploratory actions) for 2,600 episodes (at most 6 CPU h: the budget
# bought about 2,600 episodes on the AVX2-only AMD host and 3x as many on the AVX-512 Intel one, so
# the row fixes the episodes to keep its seeds comparable across hosts), then its evaluations
# (../relmogen-d-seed.sh says what it does).  SEED
exec bash "$(dirname "$0")/../relmogen-d-seed.sh" gamma ArrangeChairMM "$1" 2600
