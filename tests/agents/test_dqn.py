"""SGP-D (``relmogen-d``): Q-map index layout, Double DQN targets, action masking, end to end."""

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from gymnasium import spaces
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.agents.dqn import (
    CellMaskTracker,
    QMapReplayBuffer,
    QMapReplaySamples,
    RelmogenDQN,
    DQFD_MARGIN,
    allowed_actions,
    env_policy,
    masked_argmax,
    masks_before,
    without_actions,
)
from relmogen.agents.qmap_network import NUM_MAPS, QMapNetwork
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import PUSH_BINS, YAW_BINS

SIZE = 64
Q = SIZE // 4
SMALL_NET = {"widths": (8, 16, 16, 32), "head_width": 32}


@pytest.fixture(scope="module", autouse=True)
def one_torch_thread():
    """Two OpenMP threads on a loaded 2-core machine run ~50x slower than one."""
    threads = th.get_num_threads()
    th.set_num_threads(1)
    yield
    th.set_num_threads(threads)


def make_env(audit=None):
    env = RelmogenEnv(task="PointNav", control="subgoal-d", image_size=SIZE, episode_steps=5)
    return env if audit is None else MaskAudit(env, audit)


@pytest.fixture(scope="module")
def model():
    dqn = RelmogenDQN(env=DummyVecEnv([make_env]), buffer_size=64, batch_size=4, learning_starts=0,
                      policy_kwargs=SMALL_NET, seed=0)
    yield dqn
    dqn.env.close()


def random_batch(space: spaces.Dict, n: int, seed: int = 0) -> dict[str, th.Tensor]:
    space.seed(seed)
    samples = [space.sample() for _ in range(n)]
    return {key: th.as_tensor(np.stack([s[key] for s in samples])) for key in space.spaces}


def few_free_cells(n: int, cells=((0, 0), (5, 9), (15, 15)), arm_cells=None) -> np.ndarray:
    """(n, 2, Q, Q) masks: base allowed only at ``cells``; arm at ``arm_cells`` (None: everywhere)."""
    masks = np.zeros((n, 2, Q, Q), dtype=bool)
    for i, j in cells:
        masks[:, 0, i, j] = True
    if arm_cells is None:
        masks[:, 1] = True
    for i, j in arm_cells or ():
        masks[:, 1, i, j] = True
    return masks


# ------------------------------------------------------------------ (a) index layout
def test_decode_encode_round_trip(model):
    control = model.env.unwrapped.envs[0].unwrapped.control
    assert control.q == Q and control.action_space.n == NUM_MAPS * Q * Q
    for index in np.random.default_rng(0).integers(0, control.action_space.n, 500):
        assert control.encode(*control.decode(int(index))) == index


@pytest.mark.parametrize("skip", [False, True])
def test_flat_q_values_follow_the_env_index_order(model, skip):
    control = model.env.unwrapped.envs[0].unwrapped.control
    net = QMapNetwork(model.observation_space, **SMALL_NET, skip=skip)
    last_layer = net.head[-1] if not skip else net.head["out"][-1]
    captured = {}
    handle = last_layer.register_forward_hook(lambda module, inputs, output: captured.update(maps=output))
    obs = random_batch(model.observation_space, 3)
    with th.no_grad():
        q_values = net(obs)
    handle.remove()
    maps = captured["maps"]
    assert maps.shape == (3, NUM_MAPS, Q, Q) and q_values.shape == (3, control.action_space.n)
    for index in np.random.default_rng(1).integers(0, control.action_space.n, 300):
        part, bin_, i, j = control.decode(int(index))
        channel = bin_ if part == "base" else YAW_BINS + bin_
        assert th.equal(q_values[:, index], maps[:, channel, i, j])


def test_skip_connections_survive_save_and_load(tmp_path):
    dqn = RelmogenDQN(env=DummyVecEnv([make_env]), buffer_size=64, learning_starts=0,
                      policy_kwargs=dict(SMALL_NET, skip=True), seed=0)
    dqn.save(tmp_path / "model.zip")
    loaded = RelmogenDQN.load(tmp_path / "model.zip")
    dqn.env.close()
    assert loaded.q_net.net.skip and loaded.q_net_target.net.skip
    obs = random_batch(dqn.observation_space, 2)
    with th.no_grad():
        assert th.equal(dqn.q_net(obs), loaded.q_net(obs))


def test_channels_last_and_channels_first_observations_agree():
    first = spaces.Dict({"rgb": spaces.Box(0, 255, (3, SIZE, SIZE), np.uint8),
                         "depth": spaces.Box(0.0, 3.0, (SIZE, SIZE, 1), np.float32),
                         "local_map": spaces.Box(0, 255, (2, SIZE, SIZE), np.uint8)})
    last = spaces.Dict({"rgb": spaces.Box(0, 255, (SIZE, SIZE, 3), np.uint8), "depth": first["depth"],
                        "local_map": spaces.Box(0, 255, (SIZE, SIZE, 2), np.uint8)})
    net_first, net_last = QMapNetwork(first, **SMALL_NET), QMapNetwork(last, **SMALL_NET)
    net_last.load_state_dict(net_first.state_dict())
    obs = random_batch(first, 2)
    obs_last = dict(obs, rgb=obs["rgb"].permute(0, 2, 3, 1), local_map=obs["local_map"].permute(0, 2, 3, 1))
    with th.no_grad():
        assert th.allclose(net_first(obs), net_last(obs_last))


# --------------------------------------------------------------- (b) Double DQN target
def test_double_dqn_target_uses_online_argmax_and_target_value(model):
    th.manual_seed(1)
    for parameter in model.q_net_target.parameters():  # make the two nets differ
        parameter.data.normal_(0.0, 0.1)
    n = 6
    masks = th.ones((n, 2, Q, Q), dtype=th.bool)
    masks[:3] = th.as_tensor(few_free_cells(3, arm_cells=((2, 3), (9, 9))))
    data = QMapReplaySamples(observations=random_batch(model.observation_space, n, seed=1), actions=th.zeros(n, 1),
                             next_observations=random_batch(model.observation_space, n, seed=2),
                             dones=th.tensor([[0.0], [1.0], [0.0], [0.0], [1.0], [0.0]]),
                             rewards=th.arange(n, dtype=th.float32).reshape(-1, 1), next_masks=masks)
    with th.no_grad():
        online = model.q_net(data.next_observations)
        target_values = model.q_net_target(data.next_observations)
    allowed = allowed_actions(masks, model.subgoal_parts)
    expected = []
    for b in range(n):
        best = int(th.where(allowed[b], online[b], -th.inf).argmax())
        not_done = 1 - float(data.dones[b])
        expected.append(float(data.rewards[b]) + model.gamma * not_done * float(target_values[b, best]))
    targets = model.double_dqn_targets(data)
    np.testing.assert_allclose(targets.numpy().ravel(), expected, rtol=1e-5, atol=1e-6)
    vanilla = data.rewards + (1 - data.dones) * model.gamma * target_values.max(dim=1, keepdim=True).values
    assert not th.allclose(targets, vanilla)  # the test tells Double DQN from plain DQN
    discounts = th.linspace(0.1, 0.6, n).reshape(-1, 1)  # n-step samples carry their own gamma^k
    n_step = model.double_dqn_targets(data._replace(discounts=discounts))
    expected = data.rewards + (1 - data.dones) * discounts * (targets - data.rewards) / model.gamma
    np.testing.assert_allclose(n_step.numpy(), expected.numpy(), rtol=1e-5, atol=1e-6)


def conservative_batch(model, n: int = 6) -> QMapReplaySamples:
    """Transitions whose taken actions are allowed (different ones), ending with reward 0."""
    masks = th.as_tensor(few_free_cells(n, arm_cells=((2, 3), (9, 9))))
    allowed = allowed_actions(masks, model.subgoal_parts)
    actions = th.stack([allowed[b].nonzero().ravel()[7 * b] for b in range(n)]).reshape(-1, 1)
    return QMapReplaySamples(observations=random_batch(model.observation_space, n, seed=3), actions=actions,
                             next_observations=random_batch(model.observation_space, n, seed=4),
                             dones=th.ones(n, 1), rewards=th.zeros(n, 1), next_masks=masks, masks=masks)


def test_conservative_gap_is_logsumexp_over_allowed_actions_minus_the_taken_one(model):
    data = conservative_batch(model)
    with th.no_grad():
        q_values = model.q_net(data.observations)
        taken = q_values.gather(1, data.actions)
        gap = model.conservative_gap(q_values, taken, data.masks)
    allowed = allowed_actions(data.masks, model.subgoal_parts)
    expected = np.mean([float(th.logsumexp(q_values[b][allowed[b]], 0) - taken[b]) for b in range(len(taken))])
    assert float(gap) == pytest.approx(expected, rel=1e-5)
    everything = model.conservative_gap(q_values, taken, th.ones_like(data.masks))
    assert float(everything) > float(gap)  # masked cells are left out of the logsumexp


def updated_on_one_batch(make_batch, updates: int, **weights) -> tuple[np.ndarray, th.Tensor, QMapReplaySamples]:
    """A fresh small model updated ``updates`` times on one batch: the (TD, conservative, margin)
    losses of every update, the final Q values on the batch, and the batch."""
    dqn = RelmogenDQN(env=DummyVecEnv([make_env]), buffer_size=64, batch_size=4, learning_starts=0,
                      policy_kwargs=SMALL_NET, seed=0, learning_rate=3e-3, **weights)
    dqn.policy.set_training_mode(True)
    data = make_batch(dqn)
    losses = np.array([dqn._gradient_step(data) for _ in range(updates)])
    with th.no_grad():
        q_values = dqn.q_net(data.observations)
    dqn.env.close()
    return losses, q_values, data


def test_conservative_updates_lower_untried_actions_below_the_taken_ones():
    losses, q_values, data = updated_on_one_batch(conservative_batch, 30, conservative_weight=5.0)
    gaps = losses[:, 1]
    allowed = allowed_actions(data.masks)
    assert min(gaps) >= 0 and gaps[-1] < gaps[0] - 1.0  # from about log(60 allowed actions) = 4.1
    for b, action in enumerate(data.actions.ravel()):
        others = allowed[b].clone()
        others[action] = False
        assert q_values[b, action] > q_values[b][others].mean() + 1.0


# ------------------------------------------------------------- (c) masked exploration
def assert_base_actions_free(actions: np.ndarray, masks: np.ndarray) -> int:
    """Every base action lies on an allowed base cell and every arm action on an allowed arm
    cell of its row's (2, Q, Q) masks; returns the number of base actions."""
    base = actions < YAW_BINS * Q * Q
    part = (~base).astype(int)
    cells = np.where(base, actions, actions - YAW_BINS * Q * Q) % (Q * Q)
    assert masks.reshape(len(actions), 2, -1)[np.arange(len(actions)), part, cells].all()
    return int(base.sum())


def test_random_exploration_never_picks_an_occupied_cell(model):
    n = 500
    obs = {key: value.numpy() for key, value in random_batch(model.observation_space, n).items()}
    masks = few_free_cells(n)
    model.exploration_rate = 1.0
    actions = np.concatenate([model.predict(obs, deterministic=False, masks=masks)[0] for _ in range(8)])
    base_count = assert_base_actions_free(actions, np.concatenate([masks] * 8))
    assert 0 < base_count < len(actions)  # both parts are explored (base: 36 of 3,108 allowed actions)
    model.env.reset()  # the tracker now holds the reset infos' masks
    warmup = np.concatenate([model._sample_action(learning_starts=10**9, n_envs=1)[0] for _ in range(300)])
    assert_base_actions_free(warmup, np.repeat(model.env.masks, 300, axis=0))


def test_random_exploration_never_picks_an_unreachable_arm_cell(model):
    n = 400
    obs = {key: value.numpy() for key, value in random_batch(model.observation_space, n).items()}
    masks = few_free_cells(n, cells=((4, 4),), arm_cells=((1, 2), (8, 8)))
    model.exploration_rate = 1.0
    actions, _ = model.predict(obs, deterministic=False, masks=masks)
    base_count = assert_base_actions_free(actions, masks)
    assert 0 < base_count < n  # 12 base and 24 arm actions allowed: both are drawn
    model.mask_arm = False
    try:
        unmasked, _ = model.predict(obs, deterministic=False, masks=masks)
    finally:
        model.mask_arm = True
    arm_cells = (unmasked[unmasked >= YAW_BINS * Q * Q] - YAW_BINS * Q * Q) % (Q * Q)
    assert len(set(arm_cells.tolist())) > 2  # without arm masking every arm cell is allowed


def test_greedy_choice_never_picks_an_occupied_cell(model):
    head = model.q_net.net.head[-1]
    saved = head.bias.detach().clone()
    with th.no_grad():
        head.bias[:YAW_BINS] += 1e3  # unmasked argmax: a base action, almost surely on an occupied cell
    n = 50
    obs = {key: value.numpy() for key, value in random_batch(model.observation_space, n).items()}
    masks = few_free_cells(n)
    model.exploration_rate = 0.0
    try:
        actions, _ = model.predict(obs, deterministic=False, masks=masks)
        assert assert_base_actions_free(actions, masks) == n
        unmasked, _ = model.predict(obs, deterministic=True)
        assert not (masks[:, 0].reshape(n, -1)[np.arange(n), unmasked % (Q * Q)]).all()
    finally:
        with th.no_grad():
            head.bias.copy_(saved)


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


def test_excluding_every_allowed_action_leaves_the_row_as_it_was():
    allowed = th.tensor([[True, False, True], [True, True, False]])
    narrowed = without_actions(allowed, [0, 2])
    assert narrowed.tolist() == [[True, False, True], [False, True, False]]


def test_a_part_the_task_does_not_use_is_never_chosen(model):
    masks = th.as_tensor(few_free_cells(2, arm_cells=((3, 3),)))
    base_only = allowed_actions(masks, ("base",))
    assert base_only.sum(dim=1).tolist() == [YAW_BINS * 3] * 2
    arm_only = allowed_actions(masks, ("arm",))
    assert not arm_only[:, : YAW_BINS * Q * Q].any() and arm_only.sum(dim=1).tolist() == [PUSH_BINS] * 2
    no_free = allowed_actions(th.zeros((1, 2, Q, Q), dtype=th.bool), ("base",))
    assert no_free[0, : YAW_BINS * Q * Q].all()  # nothing free: fall back to every base action
    no_reach = allowed_actions(th.zeros((1, 2, Q, Q), dtype=th.bool), ("arm",))
    assert no_reach[0, YAW_BINS * Q * Q:].all() and not no_reach[0, : YAW_BINS * Q * Q].any()


# ------------------------------------------------------------------ replay memory
def test_replay_buffer_stores_depth_as_float16_and_fits_the_paper_buffer():
    size = 128
    space = spaces.Dict({"rgb": spaces.Box(0, 255, (3, size, size), np.uint8),
                         "depth": spaces.Box(0.0, 3.0, (size, size, 1), np.float32),
                         "local_map": spaces.Box(0, 255, (2, size, size), np.uint8),
                         "scan": spaces.Box(0.0, 1.0, (220,), np.float32),
                         "task_obs": spaces.Box(-np.inf, np.inf, (55,), np.float32)})
    buffer = QMapReplayBuffer(10_000, space, spaces.Discrete(NUM_MAPS * 32 * 32), device="cpu")
    assert buffer.observations["depth"].dtype == np.float16
    assert buffer.nbytes() < 2.5e9  # about 2.33 GB for 1e4 transitions at 128 px


def test_masks_of_an_older_buffer_are_rebuilt_from_the_previous_next_masks():
    rows, q = 5, 2
    next_masks = np.zeros((rows, 1, 2, q, q), dtype=bool)
    for row in range(rows):
        next_masks[row, 0, 0, 0, row % q] = True  # a different mask per row
    dones = np.array([[0], [1], [0], [0], [0]], dtype=np.float32)
    masks = masks_before(next_masks, dones, pos=2, full=True)  # row 2 is the oldest
    np.testing.assert_array_equal(masks[1], next_masks[0])
    np.testing.assert_array_equal(masks[4], next_masks[3])
    np.testing.assert_array_equal(masks[0], next_masks[4])  # the ring wraps
    assert masks[2].all()  # the oldest row: nothing before it
    np.testing.assert_array_equal(masks[3], next_masks[2])
    assert masks_before(next_masks, dones, pos=2, full=False)[0].all()  # not full: row 0 is the oldest
    dones[2] = 1
    assert masks_before(next_masks, dones, pos=0, full=True)[3].all()  # after an episode end: every cell


# ------------------------------------------------------------ kept demonstrations
def tiny_buffer(rows: int, keep: bool) -> QMapReplayBuffer:
    space = spaces.Dict({"depth": spaces.Box(0.0, 3.0, (2, 2, 1), np.float32)})
    return QMapReplayBuffer(rows, space, spaces.Discrete(NUM_MAPS), device="cpu", keep_demonstrations=keep)


def add_step(buffer: QMapReplayBuffer, row_id: int, reward: float = 0.0, done=False, timeout=False,
             demo=False) -> None:
    """One transition with action ``row_id`` whose next observation's depth is ``row_id`` too (to see
    which row a target bootstraps from)."""
    buffer.adding_demonstrations = demo
    obs, next_obs = {"depth": np.zeros((1, 2, 2, 1), np.float32)}, {"depth": np.full((1, 2, 2, 1), row_id, np.float32)}
    buffer.add(obs, next_obs, np.array([[row_id]]), np.array([reward]), np.array([done or timeout]),
               [{"TimeLimit.truncated": timeout}])
    buffer.adding_demonstrations = False


def add_rows(buffer: QMapReplayBuffer, actions, demonstrations: bool) -> None:
    for action in actions:
        add_step(buffer, action, demo=demonstrations)


@pytest.mark.parametrize("keep", [True, False])
def test_the_ring_skips_kept_demonstration_rows(keep):
    buffer = tiny_buffer(8, keep)
    add_rows(buffer, [20, 21, 22], demonstrations=True)
    add_rows(buffer, range(10), demonstrations=False)  # 10 policy rows wrap the 8-row ring
    stored = buffer.actions[:, 0, 0].astype(int).tolist()
    if keep:
        assert stored == [20, 21, 22, 5, 6, 7, 8, 9] and buffer.demo.tolist() == [True] * 3 + [False] * 5
        add_rows(buffer, [10], demonstrations=False)
        assert buffer.full and buffer.actions[3, 0, 0] == 10  # the next row goes after the demonstrations
    else:
        assert stored == [5, 6, 7, 8, 9, 2, 3, 4] and not buffer.demo.any()
    add_rows(buffer, [23], demonstrations=True)  # a resume's extra demonstrations are kept as well
    assert buffer.demo.sum() == (4 if keep else 1)


def test_demonstrations_filling_the_whole_ring_are_refused():
    buffer = tiny_buffer(4, keep=True)
    add_rows(buffer, range(4), demonstrations=True)
    with pytest.raises(ValueError, match="demonstrations fill all 4 rows"):
        add_rows(buffer, [5], demonstrations=False)


def test_a_buffer_saved_before_demonstration_rows_loads_with_none():
    buffer = tiny_buffer(4, keep=False)
    state = buffer.__getstate__() if hasattr(buffer, "__getstate__") else dict(vars(buffer))
    for key in ("demo", "keep_demonstrations", "adding_demonstrations", "acting_masks", "labels", "acting_labels"):
        state.pop(key)
    old = QMapReplayBuffer.__new__(QMapReplayBuffer)
    old.__setstate__(dict(state))
    assert old.demo.shape == (4,) and not old.demo.any() and not old.keep_demonstrations
    assert (old.labels == -1).all()
    add_rows(old, [1], demonstrations=False)


def test_rows_carry_expert_labels_into_their_samples():
    buffer = tiny_buffer(8, keep=False)
    add_rows(buffer, [20, 21], demonstrations=True)  # a demonstration is labelled by its own action
    buffer.acting_labels = np.array([3])
    add_step(buffer, 9)  # a policy step with the oracle's label
    add_step(buffer, 10)  # and one without
    assert buffer.labels[:4, 0].tolist() == [20, 21, 3, -1] and buffer.acting_labels is None
    assert buffer._get_samples(np.array([0, 2, 3])).labels.tolist() == [20, 3, -1]
    state = dict(vars(buffer))
    del state["labels"]  # a buffer saved before labels: its demonstrations get their own actions
    old = QMapReplayBuffer.__new__(QMapReplayBuffer)
    old.__setstate__(state)
    assert old.labels[:4, 0].tolist() == [20, 21, -1, -1]


def demonstration_batch(model, n: int = 6) -> QMapReplaySamples:
    data = conservative_batch(model, n)
    demo = th.tensor([True, False] * (n // 2))
    return data._replace(labels=th.where(demo, data.actions.reshape(-1), -1))


def test_demonstration_margin_is_dqfds_large_margin_loss_on_demonstration_rows(model):
    data = demonstration_batch(model)
    with th.no_grad():
        q_values = model.q_net(data.observations)
        margin = model.demonstration_margin(q_values, data)
    allowed = allowed_actions(data.masks, model.subgoal_parts)
    expected = []
    for b in np.flatnonzero(data.labels.numpy() >= 0):
        action = int(data.labels[b])
        others = allowed[b].clone()
        others[action] = False
        best_other = float(q_values[b][others].max()) + DQFD_MARGIN
        expected.append(max(best_other, float(q_values[b, action])) - float(q_values[b, action]))
    assert float(margin) == pytest.approx(np.mean(expected), rel=1e-5)
    assert float(model.demonstration_margin(q_values, data._replace(labels=th.full((6,), -1)))) == 0.0
    relabelled = data._replace(labels=th.where(data.labels >= 0, (data.labels + 1) % model.action_space.n, -1))
    # the margin follows the labels, not the stored actions
    assert float(model.demonstration_margin(q_values, relabelled)) != pytest.approx(float(margin))


def test_margin_updates_make_each_demonstrated_action_the_greedy_one():
    losses, q_values, data = updated_on_one_batch(demonstration_batch, 40, demo_margin_weight=5.0)
    margins = losses[:, 2]
    greedy = masked_argmax(q_values, allowed_actions(data.masks))
    assert margins[0] > DQFD_MARGIN and margins[-1] < 0.1 * margins[0]
    demo = data.labels.numpy() >= 0
    np.testing.assert_array_equal(greedy.numpy()[demo], data.labels.numpy()[demo])


# ----------------------------------------------------------------- n-step returns
def n_step_samples(buffer: QMapReplayBuffer, rows) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, np.ndarray]:
    data = buffer._get_samples(np.array(rows))
    discounts = None if data.discounts is None else data.discounts.numpy().ravel()
    return (data.rewards.numpy().ravel(), discounts, data.dones.numpy().ravel(),
            data.next_observations["depth"][:, 0, 0, 0].numpy())


def test_n_step_targets_sum_rewards_up_to_the_episode_end_and_bootstrap_from_the_last_state():
    buffer = tiny_buffer(8, keep=False)
    buffer.n_step_returns, buffer.gamma = 3, 0.5
    for row, reward in enumerate([1, 2, 3, 4, 5, 6]):  # terminal at row 2, time limit at row 4; row 5 is the newest
        add_step(buffer, row, reward, done=row == 2, timeout=row == 4)
    rewards, discounts, dones, bootstrap_rows = n_step_samples(buffer, range(6))
    np.testing.assert_allclose(rewards, [1 + 0.5 * 2 + 0.25 * 3, 2 + 0.5 * 3, 3, 4 + 0.5 * 5, 5, 6])
    np.testing.assert_allclose(discounts, [0.125, 0.25, 0.5, 0.25, 0.5, 0.5])
    np.testing.assert_array_equal(dones, [1, 1, 1, 0, 0, 0])  # a time limit still bootstraps
    np.testing.assert_array_equal(bootstrap_rows, [2, 2, 2, 4, 4, 5])
    buffer.n_step_returns = 1
    rewards, discounts, _, bootstrap_rows = n_step_samples(buffer, range(6))
    assert discounts is None  # one-step samples as before: the algorithm's gamma applies
    np.testing.assert_array_equal(rewards, [1, 2, 3, 4, 5, 6])
    np.testing.assert_array_equal(bootstrap_rows, range(6))


def test_n_step_windows_stop_where_kept_demonstrations_border_policy_rows():
    buffer = tiny_buffer(6, keep=True)
    buffer.n_step_returns, buffer.gamma = 3, 0.5
    add_step(buffer, 0, 1.0, demo=True)
    add_step(buffer, 1, 1.0, demo=True)  # the demonstration block ends without an episode end
    for row in range(10, 15):  # 5 policy rows in 4 free rows: the newest, 14, goes to row 2
        add_step(buffer, row, 1.0)
    assert buffer.actions[:, 0, 0].astype(int).tolist() == [0, 1, 14, 11, 12, 13]
    rewards, discounts, _, bootstrap_rows = n_step_samples(buffer, [5, 1, 2, 3, 0])
    np.testing.assert_array_equal(bootstrap_rows, [13, 1, 14, 13, 1])
    np.testing.assert_allclose(discounts, [0.5, 0.5, 0.5, 0.125, 0.25])
    np.testing.assert_allclose(rewards, [1, 1, 1, 1.75, 1.5])


# ------------------------------------------------------------------- (d) end to end
class MaskAudit(gym.Wrapper):
    """Counts actions sent to a masked cell according to the latest ``info["base_mask"]`` and
    ``info["arm_mask"]``."""

    def __init__(self, env, record: dict):
        super().__init__(env)
        self.record, self.masks = record, None

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        self.masks = info
        return obs, info

    def step(self, action):
        part, _, i, j = self.env.unwrapped.control.decode(int(action))
        self.record["steps"] = self.record.get("steps", 0) + 1
        self.record["violations"] = self.record.get("violations", 0) + int(not self.masks[f"{part}_mask"][i, j])
        obs, reward, terminated, truncated, info = self.env.step(action)
        self.masks = info
        return obs, reward, terminated, truncated, info


def test_learns_on_pointnav_and_round_trips_with_its_replay_buffer(tmp_path):
    record: dict = {}
    venv = DummyVecEnv([lambda: make_env(record)])
    model = RelmogenDQN(env=venv, buffer_size=300, batch_size=8, learning_starts=40, train_freq=4,
                        gradient_steps=1, target_update_interval=64, exploration_steps=100,
                        policy_kwargs=SMALL_NET, seed=0)
    model.learn(200)
    assert record == {"steps": 200, "violations": 0}
    assert model._n_updates == len(range(44, 201, 4)) and np.isfinite(model.logger.name_to_value["train/loss"])
    assert isinstance(model.env, CellMaskTracker) and model.replay_buffer.pos == 200
    assert model.exploration_rate == pytest.approx(0.04)  # decayed over exploration_steps=100
    model.save(tmp_path / "model.zip")
    model.save_replay_buffer(tmp_path / "replay.pkl")
    loaded = RelmogenDQN.load(tmp_path / "model.zip", env=venv)
    loaded.load_replay_buffer(tmp_path / "replay.pkl")
    for key, value in model.q_net.state_dict().items():
        assert th.equal(value, loaded.q_net.state_dict()[key])
    assert loaded.subgoal_parts == model.subgoal_parts and loaded.replay_buffer.pos == 200
    assert loaded.replay_buffer.observations["depth"].dtype == np.float16
    np.testing.assert_array_equal(loaded.replay_buffer.next_masks, model.replay_buffer.next_masks)
    assert not model.replay_buffer.next_masks[:200, :, 1].all()  # arm masks were recorded
    buffer = model.replay_buffer  # each transition keeps the masks its action was chosen under
    assert_base_actions_free(buffer.actions[:200, 0, 0], buffer.masks[:200, 0])
    continuing = np.flatnonzero(buffer.dones[:199, 0] == 0) + 1  # rows whose previous step did not end an episode
    np.testing.assert_array_equal(buffer.masks[continuing], buffer.next_masks[continuing - 1])
    obs = venv.reset()
    np.testing.assert_array_equal(model.predict(obs, deterministic=True)[0], loaded.predict(obs, deterministic=True)[0])
    loaded.learn(20, reset_num_timesteps=False)
    assert loaded.num_timesteps == 220 and record["violations"] == 0
    venv.close()
    evaluation: dict = {}
    env = make_env(evaluation)
    act, (obs, _) = env_policy(loaded, env), env.reset(seed=3)
    for _ in range(5):
        obs = env.step(act(obs))[0]
    assert evaluation == {"steps": 5, "violations": 0}
    env.close()
