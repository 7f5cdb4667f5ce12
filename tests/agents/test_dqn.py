"""SGP-D (``relmogen-d``): Q-map index layout, Double DQN targets, action masking, replay, end to end.

The add-ons have their own files: ``test_dqn_conservative.py``, ``test_dqn_demonstration_margin.py``,
``test_dqn_kept_demonstrations.py``, ``test_dqn_n_step.py`` and ``test_dqn_skip_no_ops.py``
(oracle labels: ``test_demonstrations.py``).
"""

import numpy as np
import pytest
import torch as th
from dqn_helpers import (Q, SIZE, SMALL_NET, assert_base_actions_free, few_free_cells, make_env, random_batch,
                         transposed_observation_space)
from gymnasium import spaces
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.agents.dqn import (
    CellMaskTracker,
    QMapReplayBuffer,
    QMapReplaySamples,
    RelmogenDQN,
    allowed_actions,
    env_policy,
    masks_before,
    without_actions,
)
from relmogen.agents.qmap_network import NUM_MAPS, QMapNetwork
from relmogen.envs.subgoal_controls import PUSH_BINS, YAW_BINS

pytestmark = pytest.mark.usefixtures("one_torch_thread")


# ------------------------------------------------------------------ (a) index layout
def test_decode_encode_round_trip(model):
    control = model.env.unwrapped.envs[0].unwrapped.control
    assert control.q == Q and control.action_space.n == NUM_MAPS * Q * Q
    for index in np.random.default_rng(0).integers(0, control.action_space.n, 500):
        assert control.encode(*control.decode(int(index))) == index


HEADS = {"deconv": {}, "skip": {"skip": True}, "unet": {"unet": True}, "deconv-k2": {"head_kernel": 2},
         "skip-k2": {"skip": True, "head_kernel": 2}, "unet-k2": {"unet": True, "head_kernel": 2}}


@pytest.mark.parametrize("head", HEADS)
def test_flat_q_values_follow_the_env_index_order(model, head):
    control = model.env.unwrapped.envs[0].unwrapped.control
    net = QMapNetwork(model.observation_space, **SMALL_NET, **HEADS[head])
    last_layer = net.last_layer
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


@pytest.mark.parametrize("setting", ["skip", "bf16", "unet"])
def test_network_settings_survive_save_and_load(tmp_path, setting):
    dqn = RelmogenDQN(env=DummyVecEnv([make_env]), buffer_size=64, learning_starts=0,
                      policy_kwargs=dict(SMALL_NET, **{setting: True}), seed=0)
    dqn.save(tmp_path / "model.zip")
    loaded = RelmogenDQN.load(tmp_path / "model.zip")
    dqn.env.close()
    assert getattr(loaded.q_net.net, setting) and getattr(loaded.q_net_target.net, setting)
    obs = random_batch(dqn.observation_space, 2)
    with th.no_grad():
        assert th.equal(dqn.q_net(obs), loaded.q_net(obs))


def test_head_kernel_survives_save_and_load_and_sets_the_last_upsampling(tmp_path):
    dqn = RelmogenDQN(env=DummyVecEnv([make_env]), buffer_size=64, learning_starts=0,
                      policy_kwargs=dict(SMALL_NET, head_kernel=2), seed=0)
    dqn.save(tmp_path / "model.zip")
    loaded = RelmogenDQN.load(tmp_path / "model.zip")
    dqn.env.close()
    for net in (loaded.q_net.net, loaded.q_net_target.net):
        upsamplings = [layer for layer in net.modules() if isinstance(layer, th.nn.ConvTranspose2d)]
        assert [layer.kernel_size for layer in upsamplings] == [(4, 4)] * (len(upsamplings) - 1) + [(2, 2)]
    obs = random_batch(dqn.observation_space, 2)
    with th.no_grad():
        assert th.equal(dqn.q_net(obs), loaded.q_net(obs))


def test_an_unknown_head_kernel_is_refused(model):
    with pytest.raises(ValueError, match="last kernel"):
        QMapNetwork(model.observation_space, **SMALL_NET, head_kernel=3)


def test_channels_last_layout_gives_the_q_values_of_the_plain_layout(model):
    net = QMapNetwork(model.observation_space, **SMALL_NET, skip=True)
    obs = random_batch(model.observation_space, 3)
    with th.no_grad():
        channels_last = net(obs)
        net.to(memory_format=th.contiguous_format)
        net.image_tensor = lambda batch: QMapNetwork.image_tensor(net, batch).contiguous()
        net.map_tensor = lambda batch: QMapNetwork.map_tensor(net, batch).contiguous()
        plain = net(obs)
    assert next(p for p in QMapNetwork(model.observation_space, **SMALL_NET).parameters()
                if p.dim() == 4).is_contiguous(memory_format=th.channels_last)
    assert th.allclose(channels_last, plain, atol=1e-5)


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


@pytest.mark.parametrize("head", HEADS)
def test_bfloat16_body_gives_float32_q_values_close_to_the_float32_network(head):
    space = transposed_observation_space(SIZE)
    exact = QMapNetwork(space, **SMALL_NET, **HEADS[head])
    reduced = QMapNetwork(space, **SMALL_NET, **HEADS[head], bf16=True)
    reduced.load_state_dict(exact.state_dict())
    obs = random_batch(space, 4)
    q_reduced = reduced(obs)
    assert q_reduced.dtype == th.float32
    with th.no_grad():
        q_exact = exact(obs)
    assert not th.equal(q_reduced, q_exact)  # the body did run in bfloat16
    assert th.allclose(q_reduced, q_exact, atol=0.05 * q_exact.abs().max().item())
    q_reduced.sum().backward()
    assert all(p.grad is not None and p.grad.dtype == th.float32 for p in reduced.parameters())


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


def test_an_update_reports_the_q_of_the_taken_actions_and_of_their_targets():
    dqn = RelmogenDQN(env=DummyVecEnv([make_env]), buffer_size=64, batch_size=4, learning_starts=0,
                      policy_kwargs=SMALL_NET, seed=0)  # its own model: the update changes the weights
    n = 4
    data = QMapReplaySamples(observations=random_batch(dqn.observation_space, n, seed=5),
                             actions=th.tensor([[0], [7], [300], [1000]]),
                             next_observations=random_batch(dqn.observation_space, n, seed=6),
                             dones=th.tensor([[1.0], [0.0], [1.0], [0.0]]), rewards=th.tensor([[1.0], [2.0], [3.0], [4.0]]))
    with th.no_grad():
        taken = dqn.q_net(data.observations).gather(1, data.actions)
        targets = dqn.double_dqn_targets(data)
    dqn.policy.set_training_mode(True)
    step = dqn._gradient_step(data)
    dqn.env.close()
    assert step["q_taken"] == pytest.approx(float(taken.mean()), rel=1e-5)
    assert step["target"] == pytest.approx(float(targets.mean()), rel=1e-5)
    assert step["loss"] > 0


# ------------------------------------------------------------- (c) masked exploration
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
    space = transposed_observation_space(128)
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


# ------------------------------------------------------------------- (d) end to end
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
    filled = slice(0, 200)  # a buffer that is not full pickles only its filled rows
    np.testing.assert_array_equal(loaded.replay_buffer.next_masks[filled], model.replay_buffer.next_masks[filled])
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


# ------------------------------------------------- (f) Q maps finer than the input's quarter
@pytest.mark.parametrize("head", HEADS)
def test_32_by_32_q_maps_from_64_px_follow_the_env_index_order(head):
    """The paper's 32 x 32 maps (24,576 actions) from 64 px inputs: one more upsampling stage,
    and the flat Q values still in the environment's index order."""
    env = make_env(qmap_size=32)
    space, control = env.observation_space, env.unwrapped.control
    net = QMapNetwork(space, **SMALL_NET, **HEADS[head], q=32)
    assert net.n_actions == control.action_space.n == NUM_MAPS * 32 * 32
    last_layer = net.last_layer
    captured = {}
    handle = last_layer.register_forward_hook(lambda module, inputs, output: captured.update(maps=output))
    with th.no_grad():
        q_values = net(random_batch(space, 2))
    handle.remove()
    assert captured["maps"].shape == (2, NUM_MAPS, 32, 32)
    for index in np.random.default_rng(2).integers(0, control.action_space.n, 300):
        part, bin_, i, j = control.decode(int(index))
        channel = bin_ if part == "base" else YAW_BINS + bin_
        assert th.equal(q_values[:, index], captured["maps"][:, channel, i, j])
    env.close()


@pytest.mark.parametrize("q", [16, 32])
def test_unet_head_fuses_both_branches_at_every_scale_down_to_q(q):
    """At 64 px: 16 x 16 maps take the S/8 and S/4 features, 32 x 32 maps also the S/2 ones."""
    net = QMapNetwork(transposed_observation_space(64), **SMALL_NET, unet=True, q=q)
    widths = SMALL_NET["widths"]
    expected = [2, 1] if q == 16 else [2, 1, 0]
    assert net.unet_skips == expected and len(net.head["up"]) == len(expected)
    for fuse, index in zip(net.head["fuse"], expected):
        assert fuse[0].in_channels == SMALL_NET["head_width"] + 2 * widths[index]
    with pytest.raises(ValueError, match="choose one Q-map head"):
        QMapNetwork(transposed_observation_space(64), **SMALL_NET, unet=True, skip=True, q=q)


def test_q_map_sides_the_network_cannot_reach_are_refused():
    env = make_env()
    with pytest.raises(ValueError, match="2, 4 or 8 times"):
        QMapNetwork(env.observation_space, **SMALL_NET, q=48)
    env.close()


def test_replay_at_32_by_32_maps_stores_its_masks_at_that_resolution():
    """At 64 px and 32 x 32 maps a 1e4 replay costs about 0.59 GiB (a 1.6e5 one, 9.4 GiB)."""
    space = transposed_observation_space(64)
    buffer = QMapReplayBuffer(10_000, space, spaces.Discrete(NUM_MAPS * 32 * 32), device="cpu")
    assert buffer.next_masks.shape[-2:] == buffer.masks.shape[-2:] == (32, 32)
    per_1e4 = buffer.nbytes() / 2**30
    print(f"replay GiB per 1e4 transitions at 64 px, 32 x 32 maps: {per_1e4:.3f}")
    assert 0.3 < per_1e4 < 0.8
