#!/usr/bin/env bash
# One seed of the ButtonDoorNav relmogen-d row, reward only: the sgpd-explore gamma recipe
# (discount 0.95, which keeps its TD loss from diverging; uniform exploratory actions) for 2,600
# episodes (at most 6 CPU h), the ArrangeChairMM row's budget, then its evaluations
# (../relmogen-d-seed.sh says what it does).  SEED
exec bash "$(dirname "$0")/../relmogen-d-seed.sh" gamma ButtonDoorNav "$1" 2600
