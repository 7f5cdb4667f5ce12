#!/usr/bin/env bash
# One seed of the ArrangeKitchenMM relmogen-d row, reward only: the sgpd-explore Boltzmann recipe
# (discount 0.95, exploratory actions from softmax(Q)) for 1,500 episodes (at most 6 CPU h), then
# its evaluations (../relmogen-d-seed.sh says what it does).  SEED
exec bash "$(dirname "$0")/../relmogen-d-seed.sh" boltzmann ArrangeKitchenMM "$1" 1500
