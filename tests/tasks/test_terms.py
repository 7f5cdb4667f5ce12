import numpy as np
import pytest

from relmogen.tasks.terms import EventReward, PotentialReward, StateReward, spl


def test_spl_on_a_hand_made_trajectory():
    # shortest path 4 m; the robot drove a 1 m detour: SPL = 4 / 5
    trajectory = np.array([[0, 0], [2, 0], [2, 1], [2, 0], [4, 0]], dtype=float)
    driven = np.linalg.norm(np.diff(trajectory, axis=0), axis=1).sum()
    assert driven == pytest.approx(6.0)
    assert spl(True, 4.0, driven) == pytest.approx(4.0 / 6.0)
    assert spl(False, 4.0, driven) == 0.0
    assert spl(True, 4.0, 3.9) == 1.0  # never above 1
    assert spl(True, 0.0, 0.0) == 1.0


def test_potential_reward_pays_progress_and_charges_regress():
    values = iter([5.0, 4.0, 4.5, 0.0])
    current = {"v": next(values)}
    term = PotentialReward("geodesic", lambda: current["v"], weight=1.0)
    term.reset()
    rewards = []
    for v in values:
        current["v"] = v
        rewards.append(term())
    assert rewards == pytest.approx([1.0, -0.5, 4.5])


def test_event_reward_is_paid_once():
    state = {"done": False}
    term = EventReward("success", lambda: state["done"], 10.0)
    term.reset()
    assert term() == 0.0
    state["done"] = True
    assert [term(), term()] == [10.0, 0.0]


def test_state_reward_scales_the_value():
    term = StateReward("reach", lambda: 0.25, -1.0)
    assert term() == -0.25


def test_success_is_paid_only_where_a_subgoal_ends_not_while_it_passes_the_goal():
    """A base subgoal whose path crosses the goal region but ends outside it earns no success
    reward; a later subgoal ending inside it earns the +10 (and ends the episode)."""
    from relmogen.envs.relmogen_env import RelmogenEnv

    env = RelmogenEnv(task="PointNav", control="subgoal-r", image_size=16)
    env.reset(seed=0)
    task, robot = env.task, env.robot
    start = robot.base_pose()
    robot.set_base_pose(*task.goal_xy, 0.0)  # mid-subgoal: inside the goal region
    assert task.is_success()
    _, terms = task.reward(decision=False)
    assert terms.get("success", 0.0) == 0.0
    robot.set_base_pose(*start)  # the subgoal ends outside it
    _, terms = task.reward(decision=True)
    assert terms["success"] == 0.0
    robot.set_base_pose(*task.goal_xy, 0.0)  # the next subgoal ends inside it
    _, terms = task.reward(decision=True)
    assert terms["success"] == 10.0
    env.close()
