"""The report aggregates final evaluations over seeds (mean / std / max) and plots curves."""

import csv
import json

import numpy as np
import pytest

from relmogen.experiments.config import resolve_config, save_config
from relmogen.experiments.report import write_report


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
