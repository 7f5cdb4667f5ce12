import multiprocessing as mp

import gymnasium as gym
import numpy as np
import pytest

import relmogen  # noqa: F401  (registers the ids)
from relmogen.envs.relmogen_env import RelmogenEnv

IDS = ["relmogen/PointNav-v0", "relmogen/TabletopReachM-v0"]


@pytest.mark.parametrize("env_id", IDS)
def test_same_seed_same_first_observation(env_id):
    a, b = (gym.make(env_id, control="joint", image_size=64) for _ in range(2))
    obs_a, _ = a.reset(seed=7)
    a.step(a.action_space.sample())
    obs_a2, _ = a.reset(seed=7)  # also after an episode, in the same world
    obs_b, _ = b.reset(seed=7)
    for key in obs_a:
        np.testing.assert_array_equal(obs_a[key], obs_b[key])
        np.testing.assert_array_equal(obs_a[key], obs_a2[key])
    obs_c, _ = b.reset(seed=8)
    assert not np.array_equal(obs_a["task_obs"], obs_c["task_obs"])
    a.close(), b.close()


def test_observation_layout(pointnav):
    obs, _ = pointnav.reset(seed=0)
    assert obs["rgb"].shape == (64, 64, 3) and obs["rgb"].dtype == np.uint8
    assert obs["depth"].shape == (64, 64, 1) and obs["depth"].dtype == np.float32
    assert obs["scan"].shape == (220,) and 0.0 <= obs["scan"].min() <= obs["scan"].max() <= 1.0
    assert obs["task_obs"].shape == (55,)
    depth = obs["depth"]
    assert ((depth == 0.0) | ((depth >= 0.35) & (depth <= 3.0))).all()
    # the last waypoint is at most 10 x 0.2 m along the path, and waypoints are 0.2 m apart
    waypoints = obs["task_obs"][:20].reshape(10, 2)
    steps = np.linalg.norm(np.diff(waypoints, axis=0), axis=1)
    assert np.all(steps <= 0.2 + 1e-3)


@pytest.mark.parametrize(
    "action,message",
    [
        (np.full(10, np.nan), "NaN"),
        (np.array([np.inf] + [0.0] * 9), "infinite"),
        (np.zeros(3), "shape"),
        ("left", "numeric"),
    ],
)
def test_bad_actions_raise_value_errors_that_name_the_problem(pointnav, action, message):
    pointnav.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        pointnav.step(action)


@pytest.mark.parametrize(
    "kwargs,message",
    [
        (dict(task="FlyToMars"), "valid tasks: .*PointNav"),
        (dict(task="PointNav", robot="r2d2"), "fetch"),
        (dict(task="PointNav", scene="moon_A"), "office_A"),
        (dict(task="PointNav", control="telepathy"), "joint"),
        (dict(task="PointNav", scene="house_A"), "office"),
    ],
)
def test_unknown_names_list_the_valid_ones(kwargs, message):
    with pytest.raises(ValueError, match=message):
        RelmogenEnv(**kwargs)


def test_driving_into_a_wall_terminates_with_the_cause(pointnav):
    obs, _ = pointnav.reset(seed=3)
    action = np.zeros(10, dtype=np.float32)
    action[:2] = 1.0  # full speed ahead until something is hit
    for _ in range(pointnav.control.episode_steps):
        obs, reward, terminated, truncated, info = pointnav.step(action)
        if terminated or truncated:
            break
    assert terminated and info["termination"] == "collision"
    assert info["collisions"] and "robot link" in info["collisions"][0]
    assert info["metrics"]["success"] == 0.0


def test_render_gives_a_third_person_image():
    env = gym.make("relmogen/PointNav-v0", render_mode="rgb_array", image_size=32)
    env.reset(seed=0)
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3 and frame.dtype == np.uint8
    assert frame.std() > 5  # not a blank image
    env.close()


def _child_episode(queue):
    env = RelmogenEnv(task="PointNav", image_size=32)
    obs, _ = env.reset(seed=1)
    env.step(np.zeros(10))
    queue.put(obs["task_obs"].tolist())
    env.close()


@pytest.mark.parametrize("method", ["fork", "spawn"])
def test_environments_in_a_parent_and_a_child_process_at_once(method):
    parent = RelmogenEnv(task="PointNav", image_size=32)
    parent_obs, _ = parent.reset(seed=1)
    ctx = mp.get_context(method)
    queue = ctx.Queue()
    child = ctx.Process(target=_child_episode, args=(queue,))
    child.start()
    child_obs = queue.get(timeout=120)
    child.join(timeout=60)
    parent.step(np.zeros(10))  # the parent's world still works
    assert child.exitcode == 0
    np.testing.assert_allclose(child_obs, parent_obs["task_obs"], rtol=1e-5, atol=1e-5)
    parent.close()
