"""SAC with one shared image encoder (SGP-R and the joint-velocity baseline) and OAC.

SB3's SAC gives the actor, the critic and the target critic their own features extractor
and runs the image encoder five times per gradient step (actor on s and s', target critic
on s', critic on s twice). ``SharedEncoderSAC`` keeps one encoder, trained by the critic
loss, that the actor reads with gradients stopped (as in SAC-AE and DrQ), plus its Polyak
target: three encoder forward passes and one backward pass per step. ``relmogen bench
train`` measures the difference.

OAC (Ciosek et al. 2019, "Better Exploration with Optimistic Actor-Critic"): exploration
actions come from a Gaussian whose mean is shifted, by at most ``sqrt(2 * delta)`` in the
policy covariance's norm, along the gradient of the critics' upper bound
``Q_UB = mean(Q1, Q2) + beta_ub * |Q1 - Q2| / 2`` taken at the policy mean (pre-tanh).
Training is plain SAC.

``ent_coef_min`` puts a floor under the learned temperature. In the first PushDoorNav runs it
fell from 0.1 to 0.006 while the critic's Q for the policy's own actions rose to about 3x the
observed returns; the policy then collapsed onto a few subgoals, some of which found no plan.
0 (the default) is SB3's behaviour.

Before the first gradient step the encoder's input scaling is fitted on the replay (see
``relmogen.agents.networks``), and the target critic's encoder gets the same statistics.

The gradient step's arithmetic is SB3's as above; what issue 58 took out of its cost (each
change checked bit for bit against the step before it, tests/agents/test_sac_update_equivalence.py;
``relmogen.bench.train_bench.bench_sac_update_variants`` times them): glibc's page faults on the
step's freshly allocated activations (``relmogen.agents.allocator``: about 12 ms of system time per
batch-64 update), the observations of s' prepared once for the encoder and its target (uint8
straight from the replay, no float copy by SB3's ``preprocess_obs``), the actor loss
back-propagated to the actor's parameters only (not to the critic's weights, whose gradients the
next critic step discards), and the Polyak update as two multi-tensor calls.
"""

from __future__ import annotations

import contextlib
from typing import Any, Iterator

import numpy as np
import torch as th
from stable_baselines3 import SAC
from stable_baselines3.common.preprocessing import preprocess_obs
from stable_baselines3.sac.policies import MultiInputPolicy
from torch.nn import functional as F

from relmogen.agents.addons.critic_layer_norm import layer_normalise
from relmogen.agents.allocator import keep_freed_memory_once
from relmogen.agents.networks import SGPREncoder
from relmogen.agents.replay import stored_rows


class SharedEncoderSACPolicy(MultiInputPolicy):
    """One features extractor for actor and critic; the critic's optimizer trains it.
    ``critic_layer_norm``: the critics' Q networks with LayerNorm (``addons.critic_layer_norm``)."""

    def __init__(self, *args: Any, critic_layer_norm: bool = False, **kwargs: Any):
        kwargs["share_features_extractor"] = True
        self.critic_layer_norm = critic_layer_norm  # read by make_critic, which super().__init__ calls
        super().__init__(*args, **kwargs)

    def make_critic(self, features_extractor=None):
        critic = super().make_critic(features_extractor)
        if self.critic_layer_norm:
            layer_normalise(critic)
        return critic

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return dict(super()._get_constructor_parameters(), critic_layer_norm=self.critic_layer_norm)

    def _build(self, lr_schedule) -> None:
        super()._build(lr_schedule)
        encoder = list(self.actor.features_extractor.parameters())
        encoder_ids = {id(p) for p in encoder}
        actor_params = [p for p in self.actor.parameters() if id(p) not in encoder_ids]
        critic_params = [p for name, p in self.critic.named_parameters() if "features_extractor" not in name]
        self.actor.optimizer = self.optimizer_class(actor_params, lr=lr_schedule(1), **self.optimizer_kwargs)
        self.critic.optimizer = self.optimizer_class(critic_params + encoder, lr=lr_schedule(1),
                                                     **self.optimizer_kwargs)


def _actor_from_features(actor, features: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
    latent = actor.latent_pi(features)
    mean, log_std = actor.mu(latent), th.clamp(actor.log_std(latent), -20, 2)
    return actor.action_dist.log_prob_from_params(mean, log_std)


def _q_from_features(critic, features: th.Tensor, actions: th.Tensor) -> list[th.Tensor]:
    inputs = th.cat([features, actions], dim=1)
    return [q_net(inputs) for q_net in critic.q_networks]


def _encoder_inputs(policy_part, observations):
    """What ``policy_part.extract_features`` hands its features extractor, computed once per batch:
    ``SGPREncoder.prepare`` for our encoder, SB3's ``preprocess_obs`` for any other."""
    encoder = policy_part.features_extractor
    if isinstance(encoder, SGPREncoder):
        return encoder.prepare(observations)
    return preprocess_obs(observations, policy_part.observation_space, normalize_images=policy_part.normalize_images)


def polyak_update_all(params: list[th.Tensor], target_params: list[th.Tensor], tau: float) -> None:
    """SB3's ``polyak_update`` (``target * (1 - tau)``, then ``+ tau * param``: the same values bit
    for bit) in two multi-tensor calls instead of two calls per tensor."""
    with th.no_grad():
        th._foreach_mul_(target_params, 1 - tau)
        th._foreach_add_(target_params, params, alpha=tau)


INPUT_SCALING_SAMPLE = 5000  # the newest stored transitions the input statistics are fitted on


@contextlib.contextmanager
def augmented(encoders) -> Iterator[None]:
    """Image augmentation on (``SGPREncoder.image_shift``) for the encoders inside the block."""
    for encoder in encoders:
        encoder.augmenting = True
    try:
        yield
    finally:
        for encoder in encoders:
            encoder.augmenting = False


class SharedEncoderSAC(SAC):
    """SB3 SAC whose gradient step encodes each observation batch once (see module doc)."""

    def __init__(self, policy=SharedEncoderSACPolicy, *args: Any, ent_coef_min: float = 0.0, **kwargs: Any):
        if ent_coef_min < 0:
            raise ValueError(f"ent_coef_min must be >= 0, got {ent_coef_min}")
        self.ent_coef_min = ent_coef_min
        super().__init__(policy, *args, **kwargs)

    def train(self, gradient_steps: int, batch_size: int = 64) -> None:
        keep_freed_memory_once()
        self._fit_input_scaling_once()
        self.policy.set_training_mode(True)
        optimizers = [self.actor.optimizer, self.critic.optimizer]
        if self.ent_coef_optimizer is not None:
            optimizers.append(self.ent_coef_optimizer)
        self._update_learning_rate(optimizers)
        logs: dict[str, list[float]] = {"ent_coef": [], "actor_loss": [], "critic_loss": [], "ent_coef_loss": []}
        for _ in range(gradient_steps):
            self._gradient_step(self.replay_buffer.sample(batch_size, env=self._vec_normalize_env), logs)
        self._n_updates += gradient_steps
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        for key, values in logs.items():
            if values:
                self.logger.record(f"train/{key}", float(np.mean(values)))

    def _fit_input_scaling_once(self) -> None:
        encoders = [self.critic.features_extractor, self.critic_target.features_extractor]
        if not hasattr(encoders[0], "fit_input_scaling") or encoders[0].input_scaling_fitted:
            return
        buffer = self.replay_buffer
        rows = stored_rows(buffer)[-max(INPUT_SCALING_SAMPLE // buffer.n_envs, 1):]
        stored = {key: th.as_tensor(buffer.observations[key][rows].reshape(len(rows) * buffer.n_envs, -1))
                  for key in ("scan", *encoders[0].task_keys)}
        for encoder in encoders:
            encoder.fit_input_scaling(stored)

    def _gradient_step(self, data, logs: dict[str, list[float]]) -> None:
        critic, target = self.critic, self.critic_target
        observations = _encoder_inputs(critic, data.observations)
        next_observations = _encoder_inputs(critic, data.next_observations)  # for both encoders
        with augmented([critic.features_extractor, target.features_extractor]):
            features = critic.features_extractor(observations)
            with th.no_grad():
                next_features = critic.features_extractor(next_observations)
                next_target_features = target.features_extractor(next_observations)
        actions_pi, log_prob, ent_coef = self._critic_update(data, features, next_features, next_target_features, logs)
        actor_loss = self._actor_loss(features, actions_pi, log_prob, ent_coef, logs)
        self.actor.optimizer.zero_grad()
        # the actor's parameters only: the critic's weight gradients would be discarded unused
        actor_loss.backward(inputs=self._actor_parameters())
        self.actor.optimizer.step()
        polyak_update_all(*self._polyak_parameters(), self.tau)

    def _critic_update(self, data, features: th.Tensor, next_features: th.Tensor, next_target_features: th.Tensor,
                       logs: dict[str, list[float]]) -> tuple[th.Tensor, th.Tensor, th.Tensor]:
        """The temperature's and the critics' steps of one gradient step; returns the actor's
        actions, their log-probabilities and the temperature, for the actor's step."""
        actions_pi, log_prob = _actor_from_features(self.actor, features.detach())
        log_prob = log_prob.reshape(-1, 1)
        ent_coef = self._entropy_step(log_prob, logs)
        target_q = self._td_target(data, next_features, next_target_features, ent_coef)
        current_q = _q_from_features(self.critic, features, data.actions)
        critic_loss = 0.5 * sum(F.mse_loss(q, target_q) for q in current_q)
        self.critic.optimizer.zero_grad()
        critic_loss.backward()
        self.critic.optimizer.step()
        logs["critic_loss"].append(critic_loss.item())
        return actions_pi, log_prob, ent_coef

    def _actor_loss(self, features: th.Tensor, actions_pi: th.Tensor, log_prob: th.Tensor, ent_coef: th.Tensor,
                    logs: dict[str, list[float]]) -> th.Tensor:
        q_pi = th.cat(_q_from_features(self.critic, features.detach(), actions_pi), dim=1)
        actor_loss = (ent_coef * log_prob - th.min(q_pi, dim=1, keepdim=True)[0]).mean()
        logs["actor_loss"].append(actor_loss.item())
        return actor_loss

    @th.no_grad()
    def _td_target(self, data, next_features: th.Tensor, next_target_features: th.Tensor,
                   ent_coef: th.Tensor) -> th.Tensor:
        """SAC's soft TD target: the target critics' smaller Q at the actor's next action, less the
        entropy term (per-transition discounts where the replay gives them)."""
        next_actions, next_log_prob = _actor_from_features(self.actor, next_features)
        next_q = th.cat(_q_from_features(self.critic_target, next_target_features, next_actions), dim=1)
        next_q = th.min(next_q, dim=1, keepdim=True)[0] - ent_coef * next_log_prob.reshape(-1, 1)
        discounts = data.discounts if data.discounts is not None else self.gamma
        return data.rewards + (1 - data.dones) * discounts * next_q

    def _actor_parameters(self) -> list[th.Tensor]:
        return [p for group in self.actor.optimizer.param_groups for p in group["params"] if p.requires_grad]

    def _polyak_parameters(self) -> tuple[list[th.Tensor], list[th.Tensor]]:
        return list(self.critic.parameters()), list(self.critic_target.parameters())

    def _entropy_step(self, log_prob: th.Tensor, logs: dict[str, list[float]]) -> th.Tensor:
        if self.ent_coef_optimizer is None:
            logs["ent_coef"].append(self.ent_coef_tensor.item())
            return self.ent_coef_tensor
        ent_coef = th.exp(self.log_ent_coef.detach())
        loss = -(self.log_ent_coef * (log_prob + self.target_entropy).detach()).mean()
        self.ent_coef_optimizer.zero_grad()
        loss.backward()
        self.ent_coef_optimizer.step()
        if self.ent_coef_min > 0:
            with th.no_grad():  # clamp the parameter too, so it can rise again at once
                self.log_ent_coef.clamp_(min=float(np.log(self.ent_coef_min)))
            ent_coef = ent_coef.clamp(min=self.ent_coef_min)
        logs["ent_coef"].append(ent_coef.item())
        logs["ent_coef_loss"].append(loss.item())
        return ent_coef


def optimistic_action(policy, observation: dict[str, np.ndarray], beta_ub: float, delta: float,
                      rng: np.random.Generator) -> np.ndarray:
    """OAC exploration actions in [-1, 1] for a batch of observations."""
    obs, _ = policy.obs_to_tensor(observation)
    with th.no_grad():
        features = policy.actor.extract_features(obs, policy.actor.features_extractor)
        latent = policy.actor.latent_pi(features)
        mean, log_std = policy.actor.mu(latent), th.clamp(policy.actor.log_std(latent), -20, 2)
        critic_features = policy.critic.extract_features(obs, policy.critic.features_extractor)
    pre_tanh = mean.detach().clone().requires_grad_(True)
    q1, q2 = _q_from_features(policy.critic, critic_features, th.tanh(pre_tanh))[:2]
    q_upper = (q1 + q2) / 2.0 + beta_ub * th.abs(q1 - q2) / 2.0
    (grad,) = th.autograd.grad(q_upper.sum(), pre_tanh)
    variance = th.exp(2.0 * log_std)
    norm = th.sqrt(th.sum(grad * grad * variance, dim=1, keepdim=True)).clamp_min(1e-8)
    shifted_mean = mean + np.sqrt(2.0 * delta) * variance * grad / norm
    noise = th.as_tensor(rng.standard_normal(mean.shape), dtype=mean.dtype, device=mean.device)
    return th.tanh(shifted_mean + th.exp(log_std) * noise).detach().cpu().numpy()


class OAC(SharedEncoderSAC):
    """SAC trained as usual, exploring with the optimistic shift of Ciosek et al. (2019)."""

    def __init__(self, *args: Any, beta_ub: float = 4.66, delta: float = 23.53, **kwargs: Any):
        self.beta_ub, self.delta = float(beta_ub), float(delta)
        super().__init__(*args, **kwargs)
        self._oac_rng = np.random.default_rng(self.seed)

    def _sample_action(self, learning_starts: int, action_noise=None, n_envs: int = 1):
        if self.num_timesteps < learning_starts:
            return super()._sample_action(learning_starts, action_noise, n_envs)
        scaled = optimistic_action(self.policy, self._last_obs, self.beta_ub, self.delta, self._oac_rng)
        return self.policy.unscale_action(scaled), scaled
