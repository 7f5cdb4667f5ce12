"""``relmogen viz exploration`` (paper Fig. 6): embeddings, positions and lasting interactions of runs."""

import json

import imageio.v2 as imageio
import numpy as np
import pybullet as p
import pytest

from relmogen.cli import main
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.rollout import run_episode
from relmogen.visualisation.exploration import ExplorationLog, InteractionTracker, coverage_m2, pca_2d, relative_steps

EPISODES = 2


def test_figure_and_json_for_subgoal_and_joint_velocity_runs(tiny_runs, tmp_path):
    runs = [tiny_runs["relmogen-r"], tiny_runs["sac"], tiny_runs["relmogen-d"]]
    out = tmp_path / "exploration"
    assert main(["viz", "exploration", *map(str, runs), "--episodes", str(EPISODES), "--pca-episodes", "1",
                 "--out-dir", str(out)]) == 0
    image = imageio.imread(out / "exploration.png")
    assert image.shape[0] > 2.5 * 300 and image[..., :3].std() > 10  # three rows of panels
    result = json.loads((out / "exploration.json").read_text())
    assert result["interaction_min_s"] == 1.0 and len(result["runs"]) == 3
    assert [run["algo"] for run in result["runs"]] == ["relmogen-r", "sac", "relmogen-d"]
    for run in result["runs"]:
        assert run["policy"] == "stochastic" and run["episodes"] == EPISODES
        pca = run["pca"]
        assert pca["episodes"] == 1 and len(pca["points"]) == 1 and len(pca["points"][0]) == pca["states"]
        assert 2 <= pca["states"] <= 11  # the reset and up to 10 steps (tiny preset)
        assert pca["embedding_size"] > 2 and sum(pca["explained_variance_ratio"]) <= 1.0 + 1e-9
        assert len(run["positions"]) == EPISODES and all(len(path) >= 1 for path in run["positions"])
        assert run["coverage_m2"] >= 0.0625 and run["interaction_count"] == len(run["interactions"])
        for interaction in run["interactions"]:
            assert interaction["duration_s"] >= 1.0 and interaction["episode"] in range(EPISODES)
            assert {"body", "start_s", "position"} <= set(interaction)


def test_a_contact_lasting_a_second_is_one_interaction_shorter_ones_none():
    tracker = InteractionTracker(min_duration_s=1.0)
    ended = []
    for step in range(15):  # body 7 touched from 0.0 s to 1.2 s; body 8 from 0.3 s to 0.8 s
        time = 0.1 * step
        touches = {}
        if time <= 1.2 + 1e-9:
            touches[7] = (1.0, 2.0, 0.5) if step % 2 else (1.2, 2.0, 0.5)
        if 0.3 - 1e-9 <= time <= 0.8 + 1e-9:
            touches[8] = (0.0, 0.0, 0.0)
        ended += tracker.update(time, touches)
    ended += tracker.close_all()
    assert len(ended) == 1
    body, start, duration, position = ended[0]
    assert body == 7 and start == 0.0 and duration == pytest.approx(1.2)
    assert position == pytest.approx([1.1, 2.0, 0.5], abs=0.01)
    tracker.update(0.0, {9: (0, 0, 0)})
    tracker.update(1.0, {9: (0, 0, 0)})
    assert [body for body, *_ in tracker.close_all()] == [9]  # still touching when the episode ends


def test_the_gripper_resting_on_a_box_is_an_interaction():
    env = RelmogenEnv(task="PointNav", control="joint", image_size=32, episode_steps=15)  # 1.5 s
    boxes = []

    def place_box():  # a static box around the gripper link, which joint control may touch things with
        client = env.world.client
        gripper = p.getLinkState(env.robot.robot_id, env.robot.gripper_link_indices[0], physicsClientId=client)[0]
        shape = p.createCollisionShape(p.GEOM_BOX, halfExtents=[0.03] * 3, physicsClientId=client)
        boxes.append(p.createMultiBody(0, shape, basePosition=list(gripper), physicsClientId=client))

    try:
        log = ExplorationLog(lambda obs: np.zeros(3))
        record = run_episode(env, lambda obs: np.zeros(env.action_space.shape), seed=0, on_reset=place_box,
                             recorder=log)
    finally:
        env.close()
    assert record.termination is None and record.steps == 15
    assert len(log.interactions) == 1 and log.interactions[0]["body"] == f"body {boxes[0]}"
    assert 1.0 <= log.interactions[0]["duration_s"] <= 1.5 + 1e-6
    assert len(log.embeddings) == 1 and len(log.embeddings[0]) == 16  # the reset and every step


def test_pca_steps_and_coverage():
    rng = np.random.default_rng(0)
    walk = np.cumsum(0.01 * rng.normal(size=(200, 8)), axis=0)  # small steps
    jumps = rng.normal(size=(200, 8))  # independent states
    assert relative_steps([walk])["median_relative_step"] < 0.2 < 1.0 < relative_steps([jumps])["median_relative_step"]
    repeated = relative_steps([np.repeat(jumps[:5], 2, axis=0)])
    assert repeated["unchanged_steps"] == 5 and repeated["median_relative_step"] > 0.5
    line = np.outer(np.arange(10.0), [1.0, 2.0, 0.0])
    projected, ratios = pca_2d(line)
    assert ratios[0] == pytest.approx(1.0) and np.ptp(projected[:, 0]) == pytest.approx(9 * np.sqrt(5))
    assert coverage_m2([[(0.1, 0.1), (0.2, 0.2)], [(0.3, 0.1)]]) == pytest.approx(2 * 0.0625)
