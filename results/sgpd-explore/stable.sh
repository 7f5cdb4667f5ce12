#!/usr/bin/env bash
# The sgpd-explore recipe (train.sh, surface push frame, skip connections, evaluation every 200
# episodes) with one stabiliser against the Q divergence measured in ButtonDoorNav seed 0
# (COMMANDS.md, seventh session): VARIANT = cql (algo.conservative_weight=1), slow (learning
# rate 1e-4, target copy every 4,096 transitions instead of 1,024) or gamma (discount 0.95
# instead of 0.99: a 20-subgoal horizon for 25-subgoal episodes); boltzmann is gamma with exploratory
# actions drawn from softmax(Q / 1) instead of uniformly (algo.exploration_temperature=1, eighth
# session); prioritized is boltzmann with proportional prioritized replay (algo.priority_alpha=0.6,
# beta 0.4 -> 1 over the exploration steps; ninth session); unet is boltzmann with the U-Net Q-map
# head instead of the skip head (algo.qmap_unet, tenth session); myopic is boltzmann with discount 0.5, so
# the bootstrapped max over 24,576 actions no longer swamps the rare closing rewards; shift is boltzmann
# with arm pushes shifted up to 3 cells with their images (algo.shift_cells=3), so a place alone no
# longer predicts a push's reward, and myopic-shift is both (eleventh session).
# VARIANT TASK SEED CPU_HOURS
set -euo pipefail
VARIANT=$1; TASK=$2; SEED=$3; HOURS=$4; shift 4
case $VARIANT in
  cql) extra=(--set algo.conservative_weight=1.0) ;;
  slow) extra=(--set algo.learning_rate=0.0001 --set algo.target_update_interval=4096) ;;
  gamma) extra=(--set algo.gamma=0.95) ;;
  boltzmann) extra=(--set algo.gamma=0.95 --set algo.exploration_temperature=1.0) ;;
  prioritized) extra=(--set algo.gamma=0.95 --set algo.exploration_temperature=1.0 --set algo.priority_alpha=0.6
                      --set algo.priority_beta=0.4) ;;
  unet) extra=(--set algo.gamma=0.95 --set algo.exploration_temperature=1.0 --set algo.qmap_skip=false
               --set algo.qmap_unet=true) ;;
  myopic) extra=(--set algo.gamma=0.5 --set algo.exploration_temperature=1.0) ;;
  shift) extra=(--set algo.gamma=0.95 --set algo.exploration_temperature=1.0 --set algo.shift_cells=3) ;;
  myopic-shift) extra=(--set algo.gamma=0.5 --set algo.exploration_temperature=1.0 --set algo.shift_cells=3) ;;
  *) echo "unknown variant $VARIANT (cql, slow, gamma, boltzmann, prioritized, unet, myopic, shift or myopic-shift)" >&2; exit 2 ;;
esac
bash "$(dirname "$0")/train.sh" $TASK $SEED $HOURS --set env.push_frame=surface --set algo.qmap_skip=true \
  --set run.eval_every_episodes=200 "${extra[@]}" --out runs/sgpd-stable-$VARIANT "$@"
