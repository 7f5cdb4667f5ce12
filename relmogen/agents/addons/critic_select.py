"""Critic-selected actions (``relmogen eval --critic-select K``; ours, a test-time rule never used in training).

SAC's deterministic action is the mean of its actor's squashed Gaussian. With the temperature
held at a floor the actor stays wide (median pre-tanh std 0.65-0.95 on the PushDoorNav arm
dimensions, ``results/pushdoornav-table1-second/diagnosis/actor_spread.txt``): the critic
is trained on samples scattered around the mean, and the mean itself is a point it rarely
evaluated. This rule scores the mean and ``K - 1`` actions drawn from the actor's own
distribution, and takes the one with the highest ``min(Q1, Q2)``, the value SAC's actor
maximises. The noise vectors are drawn once from ``seed``, so the policy is a deterministic
function of the observation, like the plain mean; it uses the learned networks only (no
demonstrations, no oracle). It is the action-selection step of QT-Opt (Kalashnikov et al. 2018)
with the actor as its proposal distribution.

Evaluations report it as its own policy (``deterministic-critic-select-K``), never as the plain
deterministic figure. Measured on a Table I PushDoorNav policy (seed 2, best checkpoint, 20
episodes; ``results/pushdoornav-table1-second/COMMANDS.md``): SR 0.45 with K = 16 and 0.50
with K = 4, against 0.78 for the mean: the critics rate arm subgoals that change nothing almost
as highly as progress (a no-op costs 0.1 plus 1% of a value near 10), so maximising over them
picks no-ops. Not recommended for these policies; kept as the measurement's tool.
"""

from __future__ import annotations

import numpy as np
import torch as th


def critic_selected(model, candidates: int, seed: int = 0):
    """``obs -> action`` of an SB3 SAC-family ``model``: of the actor's mean and ``candidates - 1``
    fixed-noise samples around it, the action its critics value highest; ``reset`` is a no-op."""
    if candidates < 2:
        raise ValueError(f"critic selection compares the mean with at least one sample: candidates >= 2, got {candidates}")
    policy = model.policy
    policy.set_training_mode(False)
    dim = int(np.prod(model.action_space.shape))
    generator = th.Generator().manual_seed(int(seed))
    noise = th.cat([th.zeros(1, dim), th.randn(candidates - 1, dim, generator=generator)]).to(policy.device)

    def act(obs):
        with th.no_grad():
            obs_tensor, _ = policy.obs_to_tensor(obs)
            mean, log_std, _ = policy.actor.get_action_dist_params(obs_tensor)
            actions = th.tanh(mean + log_std.exp() * noise)  # (K, dim); row 0 is the deterministic action
            features = policy.critic.extract_features(obs_tensor, policy.critic.features_extractor)
            inputs = th.cat([features.expand(candidates, -1), actions], dim=1)
            value = th.min(th.cat([q_net(inputs) for q_net in policy.critic.q_networks], dim=1), dim=1).values
            best = actions[int(value.argmax())].cpu().numpy()
        return policy.unscale_action(best[None])[0]

    act.reset = lambda: None
    return act
