#!/usr/bin/env bash
# One seed of the ArrangeChairMM relmogen-d row, reward only: the sgpd-explore gamma recipe
# (discount 0.95, uniform exploratory actions) for the issue's whole budget of 6 CPU h, then its
# evaluations (../relmogen-d-seed.sh says what it does).  SEED
exec bash "$(dirname "$0")/../relmogen-d-seed.sh" gamma ArrangeChairMM "$1"
