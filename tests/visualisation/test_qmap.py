"""``relmogen viz qmap``: the state it draws, the greedy choice it marks, the files it writes."""

import json

import imageio.v2 as imageio
import matplotlib.pyplot as plt
import numpy as np
import pytest
import torch as th
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.agents.dqn import RelmogenDQN
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.agents.oracles.base import world_to_pixel
from relmogen.envs.subgoal_controls import PUSH_BINS, Q_DOWNSAMPLE, YAW_BINS
from relmogen.experiments.config import resolve_config
from relmogen.simulation.occupancy import OCCUPIED, UNKNOWN
from relmogen.visualisation.qmap import (QMapState, figure_title, legend_handles, q_map_figure, q_map_figures,
                                         q_map_state)

SIZE = 64


@pytest.fixture(scope="module")
def model_and_env():
    threads = th.get_num_threads()
    th.set_num_threads(1)
    env = RelmogenEnv(task="ButtonDoorNav", control="subgoal-d", image_size=SIZE, episode_steps=4)
    model = RelmogenDQN(env=DummyVecEnv([lambda: RelmogenEnv(task="ButtonDoorNav", control="subgoal-d",
                                                             image_size=SIZE, episode_steps=4)]),
                        buffer_size=16, batch_size=4, learning_starts=0, seed=0,
                        policy_kwargs={"widths": (8, 16, 16, 32), "head_width": 32})
    yield model, env
    env.close()
    model.env.close()
    th.set_num_threads(threads)


def test_marked_choice_is_the_best_allowed_q_value(model_and_env):
    model, env = model_and_env
    obs, _ = env.reset(seed=1)
    state = q_map_state(model, env, obs, step=0)
    part, bin_, i, j = state.choice
    base = np.where(state.masks[0][None], state.q_maps[:YAW_BINS], -np.inf)
    arm = np.where(state.masks[1][None], state.q_maps[YAW_BINS:], -np.inf)
    best = max(base.max(), arm.max())
    chosen = state.q_maps[bin_ if part == "base" else YAW_BINS + bin_, i, j]
    assert chosen == pytest.approx(best, abs=1e-5)
    assert state.masks[0 if part == "base" else 1, i, j]
    assert state.rgb.shape == (SIZE, SIZE, 3) and state.local_map.shape[:2] == (SIZE, SIZE)


def test_figures_are_written_every_stride_steps(model_and_env, tmp_path):
    model, env = model_and_env
    paths = q_map_figures(model, env, tmp_path, states=3, seed=0, stride=2)
    assert len(paths) == 3 and all(p.is_file() for p in paths)
    assert "step00" in paths[0].name and "step02" in paths[1].name
    image = imageio.imread(paths[0])
    assert image.ndim == 3 and image.shape[1] > image.shape[0] > 300  # three panels side by side
    assert image[..., :3].std() > 10  # not a blank canvas


def test_bad_arguments_are_refused(model_and_env, tmp_path):
    model, env = model_and_env
    with pytest.raises(ValueError, match="positive"):
        q_map_figures(model, env, tmp_path, states=0)


def test_oracle_drive_draws_its_pushes_at_the_button(model_and_env, tmp_path):
    model, env = model_and_env
    own_control = env.control
    paths = q_map_figures(model, env, tmp_path, states=2, seed=0, drive="oracle")
    assert env.control is own_control  # the policy's control is back after the oracle's steps
    summary = json.loads((tmp_path / "oracle_cells.json").read_text())
    assert len(paths) == 2 and summary["pushes"] == 2 and all(p.is_file() for p in paths)
    # The oracle pushed from where it stood at the last figure: the cell it reached for sees the button.
    row, col = world_to_pixel(env, env.task.button.face_centre())
    last = summary["states"][-1]
    assert last["oracle_cell"] == [row // Q_DOWNSAMPLE, col // Q_DOWNSAMPLE]
    assert last["oracle_cell_allowed"] and 0.0 <= last["oracle_cell_percentile"] <= 100.0


def test_arm_percentile_ranks_among_allowed_cells_only():
    q = np.zeros((YAW_BINS + 12, 2, 2))
    q[YAW_BINS:, 0, 0], q[YAW_BINS + 3, 0, 1], q[YAW_BINS + 5, 1, 0] = 1.0, 2.0, 9.0
    masks = np.ones((2, 2, 2), dtype=bool)
    masks[1, 1, 0] = False  # the 9.0 cell is masked: it must not count
    state = QMapState(np.zeros((8, 8, 3), np.uint8), np.zeros((8, 8, 1), np.uint8), q, masks, ("base", "arm"),
                      ("arm", 3, 0, 1), step=0)
    assert state.arm_percentile((0, 1)) == pytest.approx(100.0 * 2 / 3)  # above (0,0) and (1,1)
    assert state.arm_percentile((1, 1)) == 0.0
    assert state.arm_percentile((1, 0)) is None


def test_area_percentile_ranks_the_surroundings_of_a_cell():
    q = np.zeros((YAW_BINS + 12, 5, 5))
    q[YAW_BINS:, 1:4, 1:4] = 5.0  # a high ring around a low centre
    q[YAW_BINS:, 2, 2] = -1.0
    masks = np.ones((2, 5, 5), dtype=bool)
    masks[1, 0, 0] = False
    state = QMapState(np.zeros((20, 20, 3), np.uint8), np.zeros((20, 20, 1), np.uint8), q, masks,
                      ("base", "arm"), ("arm", 0, 2, 2), step=0)
    assert state.arm_percentile((2, 2)) == 0.0  # the lowest cell of the map
    assert state.arm_area_percentile((2, 2)) > 90.0  # 8 of its 9 cells are the highest
    assert state.arm_area_percentile((4, 4)) == 0.0  # a corner square: 1 high cell of 4
    assert state.arm_area_percentile((0, 0)) is None


def test_unknown_driver_is_refused(model_and_env, tmp_path):
    model, env = model_and_env
    with pytest.raises(ValueError, match="unknown drive"):
        q_map_figures(model, env, tmp_path, drive="teleop")


def synthetic_state(map_channels: int = 2, choice=("arm", 3, 1, 2), marked_cell=None) -> QMapState:
    """A 4 x 4 Q map over a 16-pixel image: arm values 0..15 on allowed cells, base values 100 + 0..15."""
    q = np.zeros((YAW_BINS + PUSH_BINS, 4, 4))
    q[YAW_BINS:] = np.arange(16.0).reshape(4, 4)
    q[:YAW_BINS] = 100.0 + np.arange(16.0).reshape(4, 4)
    masks = np.ones((2, 4, 4), dtype=bool)
    masks[1, 3, 3] = False  # the arm's highest cell (15) is masked: the colour bar must stop at 14
    local_map = np.zeros((16, 16, map_channels), np.uint8)
    local_map[:4, :, 0] = OCCUPIED
    local_map[4:8, :, 0] = UNKNOWN
    return QMapState(np.full((16, 16, 3), 90, np.uint8), local_map, q, masks, ("base", "arm"), choice, step=5,
                     choice_heading=0.3 if choice[0] == "arm" else None, marked_cell=marked_cell)


def colour_bars(figure) -> dict[str, tuple[float, float]]:
    """Label -> value limits of each colour bar axis of ``figure``."""
    return {axis.get_ylabel(): axis.get_ylim() for axis in figure.axes if axis.get_label() == "<colorbar>"}


def test_each_q_map_has_a_colour_bar_of_its_allowed_q_values():
    figure = q_map_figure(synthetic_state(), "ButtonDoorNav: Q maps of relmogen-d (seed 0) after 10 training episodes")
    bars = colour_bars(figure)
    assert set(bars) == {"arm Q value", "base Q value"}
    assert bars["arm Q value"] == pytest.approx((0.0, 14.0))
    assert bars["base Q value"] == pytest.approx((100.0, 115.0))
    plt.close(figure)


def test_the_legend_names_the_map_colours_the_robot_and_the_choice():
    figure = q_map_figure(synthetic_state(), "t")
    labels = [text.get_text() for text in figure.legends[0].get_texts()]
    for expected in ("local map: free", "local map: not seen yet", "local map: occupied", "goal and path to it",
                     "robot (map centre, facing up)"):
        assert expected in labels
    assert any(label.startswith("the policy's choice") for label in labels)
    assert not any("oracle" in label for label in labels)  # no oracle cell outlined, none explained
    plt.close(figure)


def test_the_legend_explains_only_what_is_drawn():
    figure = q_map_figure(synthetic_state(map_channels=1, marked_cell=(1, 1)), "t")
    labels = [text.get_text() for text in figure.legends[0].get_texts()]
    assert "goal and path to it" not in labels  # no goal channel on this map
    assert "cell the scripted oracle pushes" in labels
    assert "driven by the scripted oracle" in figure.get_suptitle()
    plt.close(figure)


def test_the_title_says_task_training_and_choice_in_words_not_bins_and_cells():
    figure = q_map_figure(synthetic_state(choice=("base", 2, 0, 3)), "PointNav: Q maps of relmogen-d (seed 1)")
    title = figure.get_suptitle()
    assert title.startswith("PointNav: Q maps of relmogen-d (seed 1)\nstep 5 of an episode driven by the policy")
    assert "drive the base" in title
    assert "bin" not in title and "cell" not in title
    plt.close(figure)


def test_the_figure_title_names_task_seed_and_training_episodes():
    config = resolve_config("ButtonDoorNav", "relmogen-d", seed=2, preset="tiny")
    assert figure_title(config, 2019, "ButtonDoorNav") == \
        "ButtonDoorNav: Q maps of relmogen-d (seed 2) after 2,019 training episodes"
    other = config.model_copy(update={"task": "PushDoorNav"})
    assert figure_title(other, None, "ButtonDoorNav") == "PushDoorNav: Q maps of relmogen-d (seed 2) on ButtonDoorNav"


def test_the_drawn_local_map_leaves_out_the_subgoal_feedback_channels():
    """ArrangeKitchenMM has no goal marks: its base feedback channel must not be drawn as them."""
    def kitchen():
        return RelmogenEnv(task="ArrangeKitchenMM", control="subgoal-d", image_size=SIZE, episode_steps=4,
                           subgoal_feedback=True)
    threads = th.get_num_threads()
    th.set_num_threads(1)
    env, model = kitchen(), RelmogenDQN(env=DummyVecEnv([kitchen]), buffer_size=16, batch_size=4, learning_starts=0,
                                        seed=0, policy_kwargs={"widths": (8, 16, 16, 32), "head_width": 32})
    obs, _ = env.reset(seed=1)
    obs, *_ = env.step(env.control.encode("base", 0, 0, 0))  # a no-op at the map's corner, drawn in feedback
    assert obs["local_map"].shape == (SIZE, SIZE, 3) and obs["local_map"][..., 1].any()
    state = q_map_state(model, env, obs, step=1)
    np.testing.assert_array_equal(state.local_map, obs["local_map"][..., :1])
    assert "goal and path to it" not in [handle.get_label() for handle in legend_handles(state)]
    env.close()
    model.env.close()
    th.set_num_threads(threads)
