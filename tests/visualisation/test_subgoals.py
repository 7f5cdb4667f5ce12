"""``relmogen viz subgoals``: the figure, and a JSON with one point per subgoal the policy took."""

import json
from types import SimpleNamespace

import imageio.v2 as imageio
import numpy as np
import pytest

from relmogen.cli import main
from relmogen.scenes.geometry import Doorway
from relmogen.visualisation.scene_map import door_distances

EPISODES = 2
STEPS = 10  # the tiny preset's episode length


def run_viz(tmp_path, run_dir, *extra) -> tuple[dict, np.ndarray]:
    out = tmp_path / "figure" / "subgoals.png"
    assert main(["viz", "subgoals", str(run_dir), "--episodes", str(EPISODES), "--out", str(out), *extra]) == 0
    return json.loads(out.with_suffix(".json").read_text()), imageio.imread(out)


def test_relmogen_r_subgoals_are_all_recorded_with_their_door_distance(tiny_runs, tmp_path):
    result, image = run_viz(tmp_path, tiny_runs["relmogen-r"], "--stochastic")  # sampled: base and arm subgoals
    assert image.ndim == 3 and image.shape[1] > 2 * image.shape[0] and image[..., :3].std() > 10
    assert result["algo"] == "relmogen-r" and result["checkpoint_episode"] == 2 and result["policy"] == "stochastic"
    taken = sum(episode["steps"] for episode in result["episode_records"])
    assert len(result["episode_records"]) == EPISODES and taken <= EPISODES * STEPS
    assert result["base_subgoals"] == len(result["base"]) and result["arm_subgoals"] == len(result["arm"])
    assert len(result["base"]) + len(result["arm"]) == taken
    assert result["base"] and result["arm"]
    for record in result["base"]:
        assert {"episode", "step", "start", "goal", "end", "plan_found", "door_distance", "door_offset"} <= set(record)
        assert len(record["end"]) == 3 and record["door_distance"] >= 0.0
        if not record["plan_found"]:  # a base subgoal without a plan leaves the base where it was
            assert record["end"] == pytest.approx(record["start"])
    assert result["mean_door_distance"] == pytest.approx(np.mean([r["door_distance"] for r in result["base"]]))
    for record in result["arm"]:
        assert len(record["pixel"]) == 2 and (record["point"] is None or len(record["point"]) == 3)
    assert 0 <= result["camera_image_arm_subgoal"] < len(result["arm"])


def test_relmogen_d_runs_too(tiny_runs, tmp_path):
    result, _ = run_viz(tmp_path, tiny_runs["relmogen-d"])
    taken = sum(episode["steps"] for episode in result["episode_records"])
    assert result["algo"] == "relmogen-d" and len(result["base"]) + len(result["arm"]) == taken > 0


def test_another_robot_can_take_the_policy(tiny_runs, tmp_path):
    result, _ = run_viz(tmp_path, tiny_runs["relmogen-r"], "--robot", "movo")
    assert result["robot"] == "movo" and len(result["episode_records"]) == EPISODES
    assert all("door_distance" in record for record in result["base"])


def test_joint_velocity_runs_and_bad_outputs_are_refused(tiny_runs, tmp_path, capsys):
    assert main(["viz", "subgoals", str(tiny_runs["sac"]), "--out", str(tmp_path / "s.png")]) == 2
    assert "relmogen-r or relmogen-d" in capsys.readouterr().err
    assert main(["viz", "subgoals", str(tiny_runs["relmogen-r"]), "--out", str(tmp_path / "s.gif")]) == 2


def test_door_distance_is_measured_to_the_line_across_the_doorway():
    doorway = Doorway(center=(2.0, 1.0), yaw=0.0, width=1.0, regions=("corridor", "room"), wall_thickness=0.1,
                      height=2.1)  # normal +x, the opening along y from 0.5 to 1.5
    task = SimpleNamespace(door=SimpleNamespace(doorway=doorway))
    assert door_distances(task, (1.2, 1.3)) == pytest.approx({"door_distance": 0.8, "door_offset": -0.8})
    assert door_distances(task, (2.3, 2.5)) == pytest.approx({"door_distance": np.hypot(0.3, 1.0),
                                                              "door_offset": 0.3})
    assert door_distances(SimpleNamespace(), (0.0, 0.0)) == {}
