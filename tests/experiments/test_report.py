"""The report aggregates final evaluations over seeds (mean / std / max) and plots curves."""

import csv
import json

import numpy as np
import pytest

from relmogen.experiments.config import resolve_config, save_config
from relmogen.experiments.report import _counts_items, final_evaluation, read_curve, write_report


def fake_run(root, algo, seed, success_rate, spl):
    run = root / f"PushDoorNav__{algo}__{seed}"
    (run / "eval").mkdir(parents=True)
    save_config(resolve_config("PushDoorNav", algo, seed=seed, preset="cpu"), run / "config.yaml")
    (run / "eval" / "eval_collision-on.json").write_text(json.dumps(
        {"success_rate": success_rate, "spl": spl, "closed_5": 0.0, "closed_10": 0.0}))
    with open(run / "episodes.csv", "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["episode", "timesteps", "wall_time_s", "return", "length", "success"])
        for episode in range(1, 101):
            writer.writerow([episode, episode * 25, episode * 10.0, episode / 10, 25, float(episode > 50)])
    (run / "done.json").write_text(json.dumps({"episodes": 100, "wall_time_s": 3600.0,
                                               "cpu_time_s": 900.0 * (seed + 1)}))
    return run


def test_table_has_mean_std_max_over_seeds(tmp_path):
    runs = [fake_run(tmp_path, "relmogen-r", s, sr, spl) for s, sr, spl in [(0, 0.9, 0.5), (1, 1.0, 0.7), (2, 0.8, 0.6)]]
    runs.append(fake_run(tmp_path, "sac", 0, 0.0, 0.0))
    result = write_report(runs, tmp_path / "report")
    table = (tmp_path / "report" / "table.md").read_text()
    row = next(line for line in table.splitlines() if "relmogen-r" in line)
    mean, std = np.mean([0.9, 1.0, 0.8]), np.std([0.9, 1.0, 0.8])
    assert f"{mean:.2f} / {std:.2f} / 1.00" in row
    assert f"{np.mean([0.5, 0.7, 0.6]):.2f} / {np.std([0.5, 0.7, 0.6]):.2f} / 0.70" in row
    assert "| 3 |" in row and "| 100 | 1.00 | 0.50 |" in row  # CPU h: mean of 0.25, 0.5, 0.75
    assert "0.00 / 0.00 / 0.00" in next(line for line in table.splitlines() if "| sac |" in line)
    assert (tmp_path / "report" / "curves.png").stat().st_size > 10_000
    assert result["table"].endswith("table.md")


def test_report_without_runs_is_an_error(tmp_path):
    with pytest.raises(ValueError, match="no run"):
        write_report([], tmp_path)


def test_reference_evaluation_uses_the_training_planners_and_the_most_episodes(tmp_path):
    run = fake_run(tmp_path, "relmogen-r", 0, 0.5, 0.4)
    def write(name, planner, episodes, success_rate):
        (run / "eval" / name).write_text(json.dumps(
            {"success_rate": success_rate, "spl": 0.0, "closed_5": 0.0, "closed_10": 0.0, "episodes": episodes,
             "base_planner": planner, "arm_planner": planner, "scene": "office_A"}))
    write("eval_office_A_rrt_connect_rrt_connect_collision-on_100ep.json", "rrt_connect", 100, 0.7)
    write("eval_office_A_lazy_prm_lazy_prm_collision-on_50ep.json", "lazy_prm", 50, 0.1)  # newest: a swap
    write("eval_office_A_rrt_connect_rrt_connect_collision-on_20ep.json", "rrt_connect", 20, 0.2)
    assert final_evaluation(run)["success_rate"] == 0.7
    stochastic = json.loads((run / "eval" / "eval_office_A_rrt_connect_rrt_connect_collision-on_100ep.json").read_text())
    (run / "eval" / "eval_office_A_rrt_connect_rrt_connect_collision-on_200ep_stochastic.json").write_text(
        json.dumps(dict(stochastic, episodes=200, success_rate=0.9, policy="stochastic")))
    assert final_evaluation(run)["success_rate"] == 0.7  # the reference is the deterministic policy


def test_every_evaluation_setting_gets_a_row(tmp_path):
    runs = [fake_run(tmp_path, "relmogen-r", s, 0.5, 0.4) for s in (0, 1)]
    for run, rate in zip(runs, (0.2, 0.4)):
        (run / "eval" / "swap.json").write_text(json.dumps(
            {"success_rate": rate, "spl": 0.1, "closed_10": 0.0, "episodes": 50, "scene": "office_A",
             "base_planner": "lazy_prm", "arm_planner": "lazy_prm", "arm_collision": True}))
    table = write_report(runs, tmp_path / "report")["markdown"]
    swap = next(line for line in table.splitlines() if "lazy_prm" in line)
    assert "| 2 | 0.30 / 0.10 / 0.40 |" in swap


def test_curves_show_items_closed_for_tasks_that_count_them(tmp_path):
    navigation = fake_run(tmp_path, "relmogen-r", 0, 0.5, 0.4)
    assert not _counts_items([{"curve": read_curve(navigation / "episodes.csv")}])
    kitchen = tmp_path / "kitchen.csv"
    kitchen.write_text("episode,return,success,closed_10\n1,0.5,0,1\n2,0.7,0,3\n")
    curve = read_curve(kitchen)
    np.testing.assert_array_equal(curve["closed_10"], [1, 3])
    assert _counts_items([{"curve": curve}])
