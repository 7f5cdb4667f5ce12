"""Issue 58: SharedEncoderSAC's cheaper gradient step computes what the step before it computed.

``reference_gradient_step`` (``relmogen.bench.train_bench.sac_step_before_issue_58``) is the step
as it was (SB3's ``extract_features`` for each of the three encoder passes, the actor loss
back-propagated through the critic's weights too, SB3's ``polyak_update``); the losses, every
parameter, the temperature and the optimizers' moments after the same steps on the same batches,
with the same random numbers, must be equal bit for bit."""

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.utils import polyak_update

from relmogen.agents import sac as sac_module
from relmogen.agents.networks import EncoderInputs
from relmogen.agents.sac import SharedEncoderSAC
from relmogen.bench.train_bench import sac_step_before_issue_58 as reference_gradient_step
from relmogen.experiments.config import resolve_config
from relmogen.experiments.environments import make_training_env
from relmogen.experiments.models import build_model


def tiny_model(*overrides: str) -> SharedEncoderSAC:
    config = resolve_config("PointNav", "relmogen-r", preset="tiny", episodes=1, seed=3, overrides=list(overrides))
    model = build_model(config, make_training_env(config))
    model._setup_learn(total_timesteps=1)
    return model


def fill_replay(model: SharedEncoderSAC, transitions: int) -> None:
    env = model.get_env()
    obs = env.reset()
    for _ in range(transitions):
        action = np.array([env.action_space.sample()])
        next_obs, reward, done, infos = env.step(action)
        model.replay_buffer.add(obs, next_obs, action, reward, done, infos)
        obs = next_obs


def trained_state(model: SharedEncoderSAC) -> dict[str, th.Tensor]:
    state = {f"policy.{key}": value.clone() for key, value in model.policy.state_dict().items()}
    state["log_ent_coef"] = model.log_ent_coef.detach().clone()
    for name, optimizer in (("actor", model.actor.optimizer), ("critic", model.critic.optimizer),
                            ("ent_coef", model.ent_coef_optimizer)):
        for index, moments in optimizer.state_dict()["state"].items():
            for key, value in moments.items():
                state[f"{name}.{index}.{key}"] = th.as_tensor(value).clone()
    return state


def run_steps(model: SharedEncoderSAC, step, batches, seed: int) -> tuple[dict, dict]:
    model._fit_input_scaling_once()
    model.policy.set_training_mode(True)
    logs = {"ent_coef": [], "actor_loss": [], "critic_loss": [], "ent_coef_loss": []}
    th.manual_seed(seed)
    for data in batches:
        step(model, data, logs)
    return logs, trained_state(model)


@pytest.fixture(scope="module")
def models_and_batches():
    """Two relmogen-r models built alike (tiny preset, DrQ's shift on so that its random numbers
    count too), one replay for both, and three fixed batches."""
    th.set_num_threads(1)
    old, new = tiny_model("algo.image_shift=2"), tiny_model("algo.image_shift=2")
    fill_replay(old, 12)
    new.replay_buffer = old.replay_buffer
    batches = [old.replay_buffer.sample(8) for _ in range(3)]
    yield old, new, batches
    for model in (old, new):
        model.get_env().close()


def test_the_cheaper_step_gives_the_same_losses_parameters_and_moments_bit_for_bit(models_and_batches):
    old, new, batches = models_and_batches
    assert all(th.equal(a, b) for a, b in zip(old.policy.state_dict().values(), new.policy.state_dict().values()))
    old_logs, old_state = run_steps(old, reference_gradient_step, batches, seed=7)
    new_logs, new_state = run_steps(new, SharedEncoderSAC._gradient_step, batches, seed=7)
    assert old_logs == new_logs and len(new_logs["critic_loss"]) == 3
    assert old_state.keys() == new_state.keys()
    changed = [key for key, value in old_state.items() if not th.equal(value, new_state[key])]
    assert not changed
    # the step did train: the critic, the actor and the target moved
    initial = tiny_model("algo.image_shift=2")
    moved = {key: not th.equal(value, new_state[f"policy.{key}"]) for key, value in initial.policy.state_dict().items()}
    initial.get_env().close()
    assert moved["critic.qf0.0.weight"] and moved["actor.mu.weight"] and moved["critic_target.qf0.0.weight"]
    assert moved["critic.features_extractor.image_conv.0.weight"]


def test_prepared_inputs_give_the_encoders_forward_and_are_left_unchanged(models_and_batches):
    old, _, batches = models_and_batches
    encoder, target = old.critic.features_extractor, old.critic_target.features_extractor
    observations = batches[0].next_observations
    rgb = observations["rgb"].clone()
    prepared = encoder.prepare(observations)
    assert isinstance(prepared, EncoderInputs) and encoder.prepare(prepared) is prepared
    assert prepared["images"].is_contiguous(memory_format=th.channels_last)
    kept = {key: value.clone() for key, value in prepared.items()}
    with th.no_grad():
        for module in (encoder, target, encoder):
            via_sb3 = old.critic.extract_features(observations, module)
            assert th.equal(module(prepared), via_sb3)
    assert all(th.equal(prepared[key], kept[key]) for key in kept)
    assert th.equal(observations["rgb"], rgb)
    preprocessed = {key: value.float() for key, value in observations.items()}  # float RGB, as SB3 hands it
    encoder(preprocessed)
    assert th.equal(preprocessed["rgb"], rgb.float())  # not scaled in place


def test_the_polyak_update_matches_sb3s_bit_for_bit():
    th.manual_seed(0)
    params = [th.randn(37, 5), th.randn(300), th.randn(2, 3, 4, 4)]
    targets = [th.randn_like(p) for p in params]
    expected = [t.clone() for t in targets]
    polyak_update(params, expected, 0.005)
    sac_module.polyak_update_all(params, targets, 0.005)
    assert all(th.equal(a, b) for a, b in zip(targets, expected))


def test_the_update_variants_bench_times_each_variant_in_forked_children():
    from relmogen.agents import allocator
    from relmogen.bench import train_bench

    kept = allocator._kept_freed_memory
    rows = train_bench.bench_sac_update_variants("PointNav", updates=1, rounds=1, preset="tiny")
    assert [row["variant"] for row in rows] == list(train_bench.SAC_UPDATE_VARIANTS)
    assert all(row["update_cpu_s"] > 0 and row["page_faults_per_update"] >= 0 for row in rows)
    assert rows[0]["speedup_vs_before"] == 1.0
    assert allocator._kept_freed_memory == kept  # put back
