"""``relmogen viz subgoals``: the figure, and a JSON with one point per subgoal the policy took."""

import json
from types import SimpleNamespace

import imageio.v2 as imageio
import matplotlib.pyplot as plt
import numpy as np
import pytest

from relmogen.experiments.shipped import shipped_policy_dir
from relmogen.cli import main
from relmogen.experiments.demo import DEMO_POLICY
from relmogen.scenes.geometry import Doorway
from relmogen.visualisation.scene_map import door_distances
from relmogen.visualisation.subgoals import SubgoalLog, subgoals_figure

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


def test_the_shipped_policy_folder_is_drawn_as_relmogen_demo_loads_it(tmp_path):
    folder = shipped_policy_dir(DEMO_POLICY)  # relmogen/policies/PushDoorNav-relmogen-r: an exported actor
    provenance = json.loads((folder / "provenance.json").read_text())
    result, image = run_viz(tmp_path, folder, "--episodes", "1")  # the last --episodes wins
    assert image.ndim == 3 and image.shape[1] > 2 * image.shape[0] and image[..., :3].std() > 10
    assert result["run"] == str(folder) and result["algo"] == "relmogen-r" and result["policy"] == "deterministic"
    assert result["checkpoint"] == provenance["checkpoint"] and result["checkpoint_episode"] == provenance["episodes"]
    assert result["exported_from"] == provenance["run"] and len(result["episode_records"]) == 1
    taken = result["episode_records"][0]["steps"]
    assert result["base_subgoals"] + result["arm_subgoals"] == taken > 0 and result["base"]


@pytest.mark.parametrize("option", [["--stochastic"], ["--robot", "movo"], ["--checkpoint", "best"]])
def test_options_an_exported_actor_cannot_honour_are_refused(option, tmp_path, capsys):
    out = tmp_path / "s.png"
    assert main(["viz", "subgoals", str(shipped_policy_dir(DEMO_POLICY)), "--out", str(out), *option]) == 2
    error = capsys.readouterr().err
    assert "exported actor" in error and option[0] in error and not out.exists()


def test_door_distance_is_measured_to_the_line_across_the_doorway():
    doorway = Doorway(center=(2.0, 1.0), yaw=0.0, width=1.0, regions=("corridor", "room"), wall_thickness=0.1,
                      height=2.1)  # normal +x, the opening along y from 0.5 to 1.5
    task = SimpleNamespace(door=SimpleNamespace(doorway=doorway))
    assert door_distances(task, (1.2, 1.3)) == pytest.approx({"door_distance": 0.8, "door_offset": -0.8})
    assert door_distances(task, (2.3, 2.5)) == pytest.approx({"door_distance": np.hypot(0.3, 1.0),
                                                              "door_offset": 0.3})
    assert door_distances(SimpleNamespace(), (0.0, 0.0)) == {}


@pytest.fixture(scope="module")
def door_env():
    from relmogen.envs.relmogen_env import RelmogenEnv

    env = RelmogenEnv(task="PushDoorNav", control="subgoal-r", image_size=64)
    env.reset(seed=0)
    yield env
    env.close()


def door_log(env) -> SubgoalLog:
    """Base and arm subgoals around PushDoorNav's door, as ``SubgoalLog`` records them."""
    log = SubgoalLog()
    # Starts and goals spread over both rooms, as in ten episodes: the base panel zooms out wide.
    log.episodes = [{"episode": 0, "start": [9.0, 5.5, 0.0], "goal": [17.5, 0.7], "success": True},
                    {"episode": 1, "start": [17.0, 6.5, 0.0], "goal": [13.0, 3.5], "success": False}]
    for k in range(4):
        start, end = [13.0, 6.0 - k * 0.2, 0.0], [13.1, 5.5 - k * 0.2, -1.5]
        log.base.append({"episode": 0, "step": k, "plan_found": k != 2, "start": start, "goal": end[:2], "end": end})
        log.arm.append({"episode": 0, "step": 4 + k, "plan_found": k % 2 == 0, "pixel": [20 + k, 30],
                        "point": [13.0 + 0.1 * k, 5.0, 0.8 + 0.1 * k], "push_end_pixel": [25 + k, 35],
                        "base_pose": end})
        log.arm_images.append(np.full((64, 64, 3), 120, np.uint8))
    return log


def test_every_axis_label_of_the_three_panels_is_inside_the_figure(door_env):
    run = SimpleNamespace(env=door_env, config=SimpleNamespace(task="PushDoorNav"))
    title = "PushDoorNav__relmogen-r__0\nrelmogen-r on PushDoorNav, fetch (episode 400)\n10 episodes, success 0.90"
    figure = subgoals_figure(run, door_log(door_env), title)
    figure.canvas.draw()
    bounds = figure.bbox
    labels = [axis.xaxis.label for axis in figure.axes if axis.get_xlabel()] + \
             [axis.yaxis.label for axis in figure.axes if axis.get_ylabel()]
    assert len(labels) >= 5  # x and y of both map panels, the colour bar's height label
    for label in labels:
        box = label.get_window_extent()
        assert bounds.x0 <= box.x0 and box.x1 <= bounds.x1 and bounds.y0 <= box.y0 and box.y1 <= bounds.y1, \
            label.get_text()
    plt.close(figure)
