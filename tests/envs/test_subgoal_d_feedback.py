"""SGP-D's ``subgoal_feedback``: the previous subgoal's cell and outcome drawn into two more
``local_map`` channels (``relmogen/envs/subgoal_controls.py``)."""

import numpy as np
import pytest

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.envs.subgoal_controls import FEEDBACK_EXECUTED, FEEDBACK_NO_OP

SIZE = 64
BASE, ARM = 0, 1  # feedback channels, after the sensed ones


@pytest.fixture(scope="module")
def button_door():
    """ButtonDoorNav (base and arm subgoals) with feedback, 16 x 16 Q maps of 4 px cells."""
    env = RelmogenEnv(task="ButtonDoorNav", control="subgoal-d", image_size=SIZE, arm_collision=False,
                      subgoal_feedback=True)
    yield env
    env.close()


def feedback(obs) -> np.ndarray:
    return obs["local_map"][..., -2:]


def marked_cell(control, channel: int, i: int, j: int, value: int) -> np.ndarray:
    """The feedback channels with only cell (i, j)'s pixel square on ``channel`` set to ``value``."""
    c = control.cell_pixels
    expected = np.zeros((SIZE, SIZE, 2), dtype=np.uint8)
    expected[c * i:c * (i + 1), c * j:c * (j + 1), channel] = value
    return expected


def executed_nothing(info) -> bool:
    return not info["plan_found"] or info["sim_time_s"] <= 0.0


def cells_by_distance(mask: np.ndarray, centre: tuple[float, float]) -> list[tuple[int, int]]:
    cells = [(int(i), int(j)) for i, j in np.argwhere(mask)]
    return sorted(cells, key=lambda cell: np.hypot(cell[0] - centre[0], cell[1] - centre[1]))


def test_feedback_channels_join_the_local_map_only_when_enabled(button_door):
    assert button_door.observation_space["local_map"].shape == (SIZE, SIZE, 4)
    assert button_door.control.map_channels == 2 and button_door.control.feedback_channels == 2
    plain = RelmogenEnv(task="ButtonDoorNav", control="subgoal-d", image_size=SIZE)
    assert plain.observation_space["local_map"].shape == (SIZE, SIZE, 2)
    assert plain.reset(seed=1)[0]["local_map"].shape == (SIZE, SIZE, 2)
    plain.close()
    kitchen = RelmogenEnv(task="ArrangeKitchenMM", control="subgoal-d", image_size=SIZE, subgoal_feedback=True)
    assert kitchen.observation_space["local_map"].shape == (SIZE, SIZE, 3)  # occupancy, no marks, then feedback
    kitchen.close()


def test_an_arm_push_marks_its_image_cell_by_outcome(button_door):
    control = button_door.control
    obs, info = button_door.reset(seed=1)
    np.testing.assert_array_equal(feedback(obs), 0)
    outcomes = set()
    for i, j in cells_by_distance(info["arm_mask"], (control.q / 2, control.q / 2))[:8]:
        obs, _, terminated, truncated, step_info = button_door.step(control.encode("arm", 3, i, j))
        no_op = executed_nothing(step_info)
        value = FEEDBACK_NO_OP if no_op else FEEDBACK_EXECUTED
        np.testing.assert_array_equal(feedback(obs), marked_cell(control, ARM, i, j, value))
        assert button_door.observation_space.contains(obs)
        outcomes.add(no_op)
        if terminated or truncated:
            break
    assert outcomes == {True, False}, "expected both pushes that executed and pushes without a plan"


def test_an_arm_cell_beyond_reach_is_marked_as_a_no_op(button_door):
    control = button_door.control
    _, info = button_door.reset(seed=1)
    frame, c = button_door.last_frame, control.cell_pixels
    far = [(i, j) for i, j in np.argwhere(~info["arm_mask"]) if frame.has_point(c * i + c // 2, c * j + c // 2)]
    i, j = (int(v) for v in far[0])
    obs, _, _, _, step_info = button_door.step(control.encode("arm", 0, i, j))
    assert not step_info["plan_found"] and "beyond its reach" in step_info["reason"]
    np.testing.assert_array_equal(feedback(obs), marked_cell(control, ARM, i, j, FEEDBACK_NO_OP))


def test_a_base_subgoal_marks_its_local_map_cell_by_outcome_and_reset_clears_it():
    env = RelmogenEnv(task="PointNav", control="subgoal-d", image_size=SIZE, subgoal_feedback=True)
    control = env.control
    _, info = env.reset(seed=0)
    blocked = cells_by_distance(~info["base_mask"], (control.q / 2, control.q / 2))[0]
    obs, _, _, _, step_info = env.step(control.encode("base", 0, *blocked))
    assert executed_nothing(step_info)
    np.testing.assert_array_equal(feedback(obs), marked_cell(control, BASE, *blocked, FEEDBACK_NO_OP))
    executed = None
    for i, j in cells_by_distance(step_info["base_mask"], (control.q / 2 + 4, control.q / 2))[:10]:
        obs, _, _, _, step_info = env.step(control.encode("base", 6, i, j))
        value = FEEDBACK_NO_OP if executed_nothing(step_info) else FEEDBACK_EXECUTED
        np.testing.assert_array_equal(feedback(obs), marked_cell(control, BASE, i, j, value))
        if value == FEEDBACK_EXECUTED:
            executed = (i, j)
            break
    assert executed is not None, "expected a base subgoal ~1.25 m ahead to execute"
    obs, _, _, _, step_info = env.step(control.encode("arm", 0, 5, 7))  # PointNav has no arm subgoals
    assert step_info["reason"] == "arm subgoals are not used by PointNav"
    np.testing.assert_array_equal(feedback(obs), marked_cell(control, ARM, 5, 7, FEEDBACK_NO_OP))
    obs, _ = env.reset(seed=1)
    np.testing.assert_array_equal(feedback(obs), 0)
    env.close()


def test_feedback_leaves_the_sensed_observation_and_rewards_as_they_were_without_it():
    with_feedback = RelmogenEnv(task="PointNav", control="subgoal-d", image_size=SIZE, subgoal_feedback=True)
    without = RelmogenEnv(task="PointNav", control="subgoal-d", image_size=SIZE)
    obs_a, info = with_feedback.reset(seed=2)
    obs_b, _ = without.reset(seed=2)
    control = with_feedback.control
    free = cells_by_distance(info["base_mask"], (control.q / 2 + 3, control.q / 2))
    actions = [control.encode("base", 6, *free[0]), control.encode("base", 0, *free[1]), control.encode("arm", 0, 1, 1)]
    first_view = obs_a["rgb"]
    for action in [None, *actions]:
        if action is not None:
            obs_a, reward_a, *_ = with_feedback.step(action)
            obs_b, reward_b, *_ = without.step(action)
            assert reward_a == reward_b
        for key in ("rgb", "depth", "scan", "task_obs"):
            np.testing.assert_array_equal(obs_a[key], obs_b[key])
        np.testing.assert_array_equal(obs_a["local_map"][..., :2], obs_b["local_map"])
    assert not np.array_equal(obs_a["rgb"], first_view), "expected the base subgoals to move the robot"
    assert feedback(obs_a).any()
    with_feedback.close()
    without.close()
