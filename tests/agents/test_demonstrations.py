"""Oracle demonstrations in the replay buffer (``algo.demo_episodes``)."""

import numpy as np
import pytest
from dqn_helpers import SMALL_NET
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.agents.demonstrations import OracleAgreement, OracleLabels, add_demonstrations, oracle_choice
from relmogen.agents.oracles import make_policy
from relmogen.agents.dqn import RelmogenDQN
from relmogen.agents.sac import SharedEncoderSAC
from relmogen.envs.relmogen_env import RelmogenEnv

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def make_env(task: str, control: str):
    return lambda: RelmogenEnv(task=task, control=control, image_size=64, episode_steps=6, arm_collision=False)


def test_discrete_demonstrations_fill_the_replay_without_counting_as_policy_steps():
    make = make_env("ButtonDoorNav", "subgoal-d")
    model = RelmogenDQN(env=DummyVecEnv([make, make]), buffer_size=200, batch_size=4, policy_kwargs=SMALL_NET,
                        seed=0)
    result = add_demonstrations(model, make, episodes=3, seed=5, quiet=True)
    buffer = model.replay_buffer
    assert result["episodes"] >= 3 and result["transitions"] == buffer.pos * buffer.n_envs
    assert buffer.dones[: buffer.pos].sum() == result["episodes"]
    assert model.num_timesteps == 0 and model._last_obs is None  # the policy's own bookkeeping untouched
    actions = buffer.actions[: buffer.pos, :, 0].astype(int)
    assert ((actions >= 0) & (actions < model.action_space.n)).all()
    parts = actions >= 12 * model.q * model.q
    assert parts.any() and (~parts).any()  # the oracle drives and presses
    continuing = np.flatnonzero(buffer.dones[: buffer.pos - 1, 0] == 0) + 1  # each row keeps its own masks
    np.testing.assert_array_equal(buffer.masks[continuing, 0], buffer.next_masks[continuing - 1, 0])
    assert buffer.demo[: buffer.pos].all() and not buffer.adding_demonstrations  # rows marked, then off
    model.env.close()


def test_oracle_labels_go_with_the_policys_own_transitions():
    make = make_env("ButtonDoorNav", "subgoal-d")
    model = RelmogenDQN(env=DummyVecEnv([lambda: OracleLabels(make())] * 2), buffer_size=200, batch_size=4,
                        learning_starts=1000, policy_kwargs=SMALL_NET, oracle_labels=True, seed=0)
    probe = OracleLabels(make())
    probe.reset(seed=3)
    first = probe.oracle_label()
    assert 0 <= first < model.action_space.n and probe.oracle.attempt == 0
    model.learn(total_timesteps=16)
    buffer = model.replay_buffer
    labels, actions = buffer.labels[: buffer.pos], buffer.actions[: buffer.pos, :, 0]
    assert ((labels >= 0) & (labels < model.action_space.n)).all() and not buffer.demo.any()
    assert (labels != actions).any()  # random policy actions, oracle labels
    agreement = model._oracle_labeller.agreement
    assert len(agreement) == buffer.pos * 2
    assert np.mean(agreement) == pytest.approx(np.mean(labels == actions))
    add_demonstrations(model, make, episodes=1, seed=5, quiet=True)  # demonstrations: labelled by themselves
    demo = buffer.demo[: buffer.pos]
    np.testing.assert_array_equal(buffer.labels[: buffer.pos][demo], buffer.actions[: buffer.pos, :, 0][demo])
    model.env.close()


def test_oracle_agreement_counts_the_oracles_choices_without_touching_the_episode():
    env = make_env("ButtonDoorNav", "subgoal-d")()
    twin = make_policy("oracle", env)  # a policy that is the oracle itself agrees every time

    def act(obs):
        return oracle_choice(twin, obs)

    act.reset = twin.reset
    agreement = OracleAgreement(act, env)
    obs, _ = env.reset(seed=2)
    agreement.reset()
    for _ in range(3):
        stream = env.np_random.bit_generator.state
        action = agreement(obs)
        assert env.np_random.bit_generator.state == stream  # asking the oracle draws nothing
        obs, *_ = env.step(action)
    assert agreement.matches == [True] * 3
    other = OracleAgreement(lambda obs: (oracle_choice(twin, obs) + 1) % env.action_space.n, env)
    other.oracle.reset()
    other(obs)
    assert other.matches == [False]
    env.close()


def test_oracle_labels_need_discrete_subgoals():
    with pytest.raises(ValueError, match="discrete subgoal actions"):
        OracleLabels(make_env("ButtonDoorNav", "subgoal-r")())


def test_continuous_demonstrations_store_the_oracle_actions():
    make = make_env("PointNav", "subgoal-r")
    model = SharedEncoderSAC(env=DummyVecEnv([make]), buffer_size=100, batch_size=4, seed=0,
                             policy_kwargs={"net_arch": [16]})
    result = add_demonstrations(model, make, episodes=2, seed=5, quiet=True)
    actions = model.replay_buffer.actions[: model.replay_buffer.pos, 0]
    assert result["episodes"] == 2 and len(actions) == result["transitions"]
    assert (actions[:, 0] > 0).all()  # PointNav's oracle only drives: a0 > 0 selects the base
    assert np.abs(actions).max() <= 1.0 and model.num_timesteps == 0
    model.env.close()


def test_joint_control_has_no_demonstrations():
    make = lambda: RelmogenEnv(task="PointNav", control="joint", image_size=64)  # noqa: E731
    model = SharedEncoderSAC(env=DummyVecEnv([make]), buffer_size=100, seed=0, policy_kwargs={"net_arch": [16]})
    with pytest.raises(ValueError, match="subgoal controls, not 'joint'"):
        add_demonstrations(model, make, episodes=1, seed=0, quiet=True)
    model.env.close()
