"""relmogen-d's test-time rule ``--skip-no-ops`` (``relmogen/agents/addons/skip_no_ops.py``) through ``env_policy``."""

import pytest

from relmogen.agents.dqn import env_policy

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def test_skip_no_ops_excludes_a_subgoal_whose_view_did_not_change_until_it_does(model):
    env = model.env.envs[0]
    obs, _ = env.reset(seed=3)
    greedy, skipping = env_policy(model, env), env_policy(model, env, skip_no_ops=True)
    first = skipping(obs)
    assert first == greedy(obs)
    second, third = skipping(obs), skipping(obs)  # the same view again: the earlier choices are excluded
    assert len({int(first), int(second), int(third)}) == 3
    changed = dict(obs, rgb=obs["rgb"].copy())
    changed["rgb"][0, 0] ^= 255
    assert skipping(changed) == greedy(changed)  # a new view: nothing excluded
    skipping.reset()
    assert skipping(obs) == first and skipping(changed) == greedy(changed)
