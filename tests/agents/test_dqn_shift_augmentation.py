"""relmogen-d's shift augmentation of arm pushes (``relmogen/agents/addons/shift_augmentation.py``)."""

import pytest
import torch as th
from dqn_helpers import SIZE, SMALL_NET, make_env, random_batch, transposed_observation_space
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.agents.dqn import QMapReplaySamples, RelmogenDQN
from relmogen.agents.addons.shift_augmentation import random_cell_shifts, shift_arm_pushes, translate_images
from relmogen.envs.subgoal_controls import YAW_BINS, decode_indices

pytestmark = pytest.mark.usefixtures("one_torch_thread")
Q = 32  # the paper's maps from 64 px: 2 px a cell
PIXELS = SIZE // Q


def arm_index(push_bin: int, i: int, j: int) -> int:
    return YAW_BINS * Q * Q + push_bin * Q * Q + i * Q + j


def marked_batch(actions: list[int], channels_last_rgb: bool = False) -> dict[str, th.Tensor]:
    """Black images with a bright cell (rgb 255, depth 2.5 m) under each action's cell."""
    n = len(actions)
    rgb, depth = th.zeros(n, 3, SIZE, SIZE, dtype=th.uint8), th.zeros(n, SIZE, SIZE, 1)
    for b, action in enumerate(actions):
        _, _, i, j = (int(v) for v in decode_indices(action, Q))
        rgb[b, :, i * PIXELS:(i + 1) * PIXELS, j * PIXELS:(j + 1) * PIXELS] = 255
        depth[b, i * PIXELS:(i + 1) * PIXELS, j * PIXELS:(j + 1) * PIXELS] = 2.5
    obs = random_batch(transposed_observation_space(SIZE), n)
    obs["rgb"] = rgb.permute(0, 2, 3, 1).contiguous() if channels_last_rgb else rgb
    obs["depth"] = depth
    return obs


def bright_cell(image_chw: th.Tensor) -> tuple[int, int]:
    rows, cols = th.nonzero(image_chw[0] > 0, as_tuple=True)
    return int(rows.min()) // PIXELS, int(cols.min()) // PIXELS


def test_translation_moves_content_and_repeats_the_edges():
    image = th.arange(16.0).reshape(1, 1, 4, 4)
    moved = translate_images(image, th.tensor([1]), th.tensor([-2]))
    assert moved[0, 0, 1:, :2].tolist() == image[0, 0, :3, 2:].tolist()  # down 1, left 2
    assert moved[0, 0, 0].tolist() == moved[0, 0, 1].tolist()  # the top row repeats the first moved row
    assert moved[0, 0, :, 3].tolist() == moved[0, 0, :, 1].tolist() == moved[0, 0, :, 2].tolist()


@pytest.mark.parametrize("channels_last_rgb", [False, True])
def test_the_pushed_cell_moves_with_the_image(channels_last_rgb):
    th.manual_seed(0)
    actions = [arm_index(k % 12, i, j) for k, (i, j) in enumerate([(0, 0), (31, 31), (5, 20), (16, 3)] * 25)]
    obs = marked_batch(actions, channels_last_rgb)
    shifted, moved = shift_arm_pushes(obs, th.tensor(actions).reshape(-1, 1), Q, 3, not channels_last_rgb)
    assert moved.shape == (len(actions), 1)
    is_arm, push_bin, i, j = decode_indices(moved.numpy().ravel(), Q)
    assert is_arm.all() and (push_bin == [k % 12 for k in range(len(actions))]).all()  # the bin is kept
    assert ((i >= 0) & (i < Q) & (j >= 0) & (j < Q)).all()
    old = decode_indices(actions, Q)
    assert (abs(i - old[2]) <= 3).all() and (abs(j - old[3]) <= 3).all()
    assert (i != old[2]).any() and (j != old[3]).any()
    rgb = shifted["rgb"].permute(0, 3, 1, 2) if channels_last_rgb else shifted["rgb"]
    for b in range(len(actions)):
        cell = (slice(None), slice(i[b] * PIXELS, (i[b] + 1) * PIXELS), slice(j[b] * PIXELS, (j[b] + 1) * PIXELS))
        assert (rgb[b][cell] == 255).all() and (shifted["depth"][b].permute(2, 0, 1)[cell] == 2.5).all()
        if 0 < old[2][b] < Q - 1 and 0 < old[3][b] < Q - 1:  # away from the edges, nothing else is bright
            assert bright_cell(rgb[b]) == (i[b], j[b]) and int((rgb[b][0] > 0).sum()) == PIXELS ** 2
    assert th.equal(shifted["local_map"], obs["local_map"])  # the local map is not an image of the pushes


def test_base_actions_and_their_images_stay_as_they_were():
    actions = [0, 7, YAW_BINS * Q * Q - 1]
    obs = marked_batch([arm_index(0, 10, 10)] * 3)
    shifted, moved = shift_arm_pushes(obs, th.tensor(actions).reshape(-1, 1), Q, 4, True)
    assert moved.ravel().tolist() == actions
    assert th.equal(shifted["rgb"], obs["rgb"]) and th.equal(shifted["depth"], obs["depth"])


def test_shifts_stay_inside_the_map_and_cover_the_range():
    th.manual_seed(1)
    cells = th.tensor([0, 31, 15] * 2000)
    shifts = random_cell_shifts(cells, Q, 2, th.ones_like(cells, dtype=th.bool))
    assert set(shifts[cells == 0].tolist()) == {0, 1, 2}
    assert set(shifts[cells == 31].tolist()) == {-2, -1, 0}
    assert set(shifts[cells == 15].tolist()) == {-2, -1, 0, 1, 2}
    assert (random_cell_shifts(cells, Q, 2, th.zeros_like(cells, dtype=th.bool)) == 0).all()


def test_an_update_with_shifts_fits_the_moved_push_in_the_moved_image():
    dqn = RelmogenDQN(env=DummyVecEnv([make_env]), buffer_size=64, batch_size=4, learning_starts=0,
                      policy_kwargs=SMALL_NET, seed=0, shift_cells=2)  # its own model: the update changes it
    q, n = dqn.q, 8
    actions = th.tensor([[YAW_BINS * q * q + 3 * q * q + 5 * q + 6]] * n)
    data = QMapReplaySamples(observations=random_batch(dqn.observation_space, n, seed=5), actions=actions,
                             next_observations=random_batch(dqn.observation_space, n, seed=6),
                             dones=th.zeros(n, 1), rewards=th.ones(n, 1))
    th.manual_seed(3)
    shifted, moved = shift_arm_pushes(data.observations, actions, q, 2, dqn.q_net.net.rgb_channels_first)
    assert not th.equal(moved, actions)
    with th.no_grad():
        taken = dqn.q_net(shifted).gather(1, moved)
        unshifted = dqn.q_net(data.observations).gather(1, actions)
    dqn.policy.set_training_mode(True)
    th.manual_seed(3)
    step = dqn._gradient_step(data)
    dqn.env.close()
    assert step["q_taken"] == pytest.approx(float(taken.mean()), rel=1e-5)
    assert step["q_taken"] != pytest.approx(float(unshifted.mean()), rel=1e-5)
