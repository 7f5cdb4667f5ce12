"""``relmogen analyse training`` / ``curves``: windows of episodes.csv and TensorBoard, rolling curves."""

import csv
import json

import imageio.v2 as imageio
import numpy as np
import pytest
from torch.utils.tensorboard import SummaryWriter

from relmogen.analysis.training import phase_starts, plot_curves, rolling_success, scalar_series, windows
from relmogen.cli import main

SUCCESS = [0, 0, 1, 0, 1, 1, 1, 0]


def make_run(folder, resumed=False):
    """An 8-episode run: episodes.csv, done.json, two TensorBoard files (the second a resume's)."""
    folder.mkdir(parents=True)
    with open(folder / "episodes.csv", "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["episode", "timesteps", "wall_time_s", "return", "length", "success", "base_fraction",
                         "closed_10"])
        for k, success in enumerate(SUCCESS):
            writer.writerow([k + 1, 10 * (k + 1), 360.0 * (k + 1), float(k), 10 + k, float(success), 0.25, ""])
    (folder / "done.json").write_text(json.dumps({"episodes": 8, "cpu_time_s": 5760.0, "wall_time_s": 2880.0}))
    first = SummaryWriter(str(folder / "tb" / "a"))
    for episode in range(1, 9):
        first.add_scalar("losses/actor_loss", -float(episode), episode)
        first.add_scalar("losses/ent_coef", 0.1, episode)
        first.add_scalar("reward_terms/button", 5.0 if episode in (2, 7) else 0.0, episode)
    first.close()
    if resumed:  # a resume rewrote episode 8's value
        second = SummaryWriter(str(folder / "tb" / "b"))
        second.add_scalar("losses/actor_loss", -100.0, 8)
        second.close()
        (folder / "resumes.jsonl").write_text(json.dumps({"from_episode": 5, "set": ["algo.gamma=0.9"]}) + "\n")
    return folder


def test_windows_average_the_log_and_the_scalars_per_block_of_episodes(tmp_path):
    run = make_run(tmp_path / "set" / "run0")
    rows = windows(run, window=4)
    assert [r["episodes"] for r in rows] == ["1-4", "5-8"]
    assert rows[0]["train_success"] == 0.25 and rows[1]["train_success"] == 0.75 and rows[1]["successes"] == 3
    assert rows[0]["mean_return"] == 1.5 and rows[0]["length"] == 11.5 and rows[0]["arm_share"] == 0.75
    assert rows[1]["hours"] == pytest.approx(0.8)
    assert rows[0]["value_estimate"] == 2.5 and rows[1]["value_estimate"] == 6.5  # minus the actor loss
    assert rows[0]["temperature"] == pytest.approx(0.1)
    assert [r["presses"] for r in rows] == [1, 1]
    assert "closed_10_per_episode" not in rows[0] and "td_loss" not in rows[0]  # columns the run lacks


def test_a_resume_s_values_win_and_phases_split_where_settings_changed(tmp_path):
    run = make_run(tmp_path / "run", resumed=True)
    steps, values = scalar_series(run, "losses/actor_loss")
    assert list(steps) == list(range(1, 9)) and values[-1] == -100.0
    assert phase_starts(run) == [0, 5]
    rows = windows(run, window=None)
    assert [r["episodes"] for r in rows] == ["1-5", "6-8"]
    assert rows[1]["value_estimate"] == pytest.approx((6 + 7 + 100) / 3, abs=1e-3)


def test_rolling_success_against_episodes_and_cpu_hours_starts_after_the_initial_budget(tmp_path):
    run = make_run(tmp_path / "run")
    (run / "init_from.json").write_text(json.dumps({"initial_episodes": 1000, "initial_cpu_time_s": 3600.0}))
    curve = rolling_success(run, window=4)
    assert list(curve["episode"]) == [1004, 1005, 1006, 1007, 1008]
    assert list(curve["success"]) == [0.25, 0.5, 0.75, 0.75, 0.75]
    assert curve["cpu_hours"][0] == pytest.approx(1.0 + 4 * 360.0 * 2 / 3600)  # CPU / wall = 2


def test_curves_are_drawn_per_group_and_the_cli_prints_the_windows(tmp_path, capsys):
    runs = [make_run(tmp_path / "off" / "run0"), make_run(tmp_path / "on" / "run1")]
    out = plot_curves({"off": runs[:1], "on": runs[1:]}, tmp_path / "curves.png", window=2, cpu_hours=True,
                      tags=("losses/actor_loss",))
    image = imageio.imread(out)
    assert image.shape[1] > 2.5 * image.shape[0] and image[..., :3].std() > 10  # three panels
    assert main(["analyse", "curves", str(runs[0]), "--group", "on", str(runs[1]), "--window", "2",
                 "--out", str(tmp_path / "cli.png")]) == 0
    assert (tmp_path / "cli.png").is_file()
    capsys.readouterr()
    assert main(["analyse", "training", str(runs[0]), "--window", "8", "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)["rows"]
    assert row["run"] == "run0" and row["successes"] == int(np.sum(SUCCESS)) and row["presses"] == 2
