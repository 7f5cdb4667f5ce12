"""``relmogen report --figure4``: the paper's Fig. 4 from a Table I folder's reward-only cells."""

import csv
import json

import numpy as np

from relmogen.cli import main
from relmogen.experiments.config import resolve_config, save_config
from relmogen.experiments.figure4 import read_cells, task_figure, write_figure4
from relmogen.experiments.report import TABLE_JSON_SCHEMA_VERSION

TASK = "PushDoorNav"


def fake_run(folder, algo, seed, episodes, stamp="20261203-120000", init_from=None):
    run = folder / f"{TASK}__{algo}__{seed}__{stamp}"
    run.mkdir(parents=True)
    save_config(resolve_config(TASK, algo, seed=seed, preset="cpu"), run / "config.yaml")
    with open(run / "episodes.csv", "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["episode", "timesteps", "wall_time_s", "return", "length", "success", "closed_10"])
        for episode in range(1, episodes + 1):
            writer.writerow([episode, episode * 25, episode * 10.0, episode / 10, 25, float(episode % 2), ""])
    if init_from is not None:  # as train --init-from writes it: the path on the machine that trained it
        (run / "init_from.json").write_text(json.dumps({"run": f"/elsewhere/runs/p1/{init_from.name}",
                                                        "initial_episodes": float(episodes_of(init_from))}))
    return run


def episodes_of(run) -> int:
    return len((run / "episodes.csv").read_text().splitlines()) - 1


def fake_cell(folder, algo, assisted=False):
    cell = folder / f"{TASK}__{algo}"
    cell.mkdir(parents=True)
    row = {"task": TASK, "algorithm": algo, "reference": True, "assisted": assisted, "seeds": 2}
    (cell / "table.json").write_text(json.dumps({"schema_version": TABLE_JSON_SCHEMA_VERSION, "rows": [row]}))
    return cell


def fake_table1(folder):
    """relmogen-r in two stages (stage1/ 30 episodes, then 20 from its model), sac in one (25 and 27
    episodes), an assisted cell, and reruns/ holding decoys: a run of another seed and a copy of a
    first stage's run with other episodes."""
    two_stage = fake_cell(folder, "relmogen-r")
    for seed in (0, 1):
        first = fake_run(two_stage / "stage1", "relmogen-r", seed, 30, "20261203-100000")
        fake_run(two_stage, "relmogen-r", seed, 20, "20261203-110000", init_from=first)
        fake_run(two_stage / "reruns", "relmogen-r", seed, 99, "20261203-100000")  # the first stage's name
    fake_run(two_stage / "reruns" / "abc1234-avx2", "relmogen-r", 7, 40)
    one_stage = fake_cell(folder, "sac")
    for seed, episodes in ((0, 25), (1, 27)):
        fake_run(one_stage, "sac", seed, episodes)
    fake_run(fake_cell(folder, "relmogen-d", assisted=True), "relmogen-d", 0, 30)


def markdown_rows(markdown):
    return {line.split(" | ")[0].strip("| "): line.split(" | ") for line in markdown.splitlines()
            if line.startswith("| ") and not line.startswith("| algorithm")}


def test_figure4_draws_reward_only_cells_with_their_stages_end_to_end(tmp_path):
    fake_table1(tmp_path / "table1")
    paths = write_figure4(tmp_path / "table1", tmp_path / "out")
    assert set(paths) == {TASK, "markdown"}
    assert paths[TASK] == tmp_path / "out" / f"figure4_{TASK}.png" and paths[TASK].stat().st_size > 20_000
    markdown = paths["markdown"].read_text()
    rows = markdown_rows(markdown)
    assert list(rows) == ["relmogen-r", "sac"]  # the assisted relmogen-d cell is left out
    assert rows["relmogen-r"][2:4] == ["0, 1", "50 (30 + 20), 50 (30 + 20)"]  # reruns/ not read
    assert rows["sac"][2:4] == ["0, 1", "25, 27"]
    assert f"](figure4_{TASK}.png)" in markdown


def test_a_seeds_stages_follow_one_another_on_the_episode_axis(tmp_path):
    fake_table1(tmp_path)
    cells = {cell.algorithm: cell for cell in read_cells(tmp_path)}
    seed = cells["relmogen-r"].seeds[0]
    assert [run.parent.name for run in seed.runs] == ["stage1", tmp_path.joinpath("PushDoorNav__relmogen-r").name]
    assert seed.stage_starts == [30] and seed.episodes == 50
    np.testing.assert_array_equal(seed.curve["episode"], np.arange(1, 51))
    np.testing.assert_allclose(seed.curve["return"][30:32], [0.1, 0.2])  # the second stage's first episodes
    figure = task_figure(TASK, list(cells.values()))
    return_axis = figure.axes[0]
    lines = {line.get_label(): line for line in return_axis.get_lines()}
    assert max(lines["relmogen-r (2 seeds)"].get_xdata()) == 50 and max(lines["sac (2 seeds)"].get_xdata()) == 27
    dotted = [line for line in return_axis.get_lines() if line.get_linestyle() == ":"]
    assert [line.get_xdata()[0] for line in dotted] == [30]
    assert figure._suptitle.get_text() == f"{TASK}: training curves (reward only)"


def test_a_stage_not_in_the_folder_still_counts_its_episodes(tmp_path):
    cell = fake_cell(tmp_path, "relmogen-r")
    elsewhere = fake_run(tmp_path / "not-committed", "relmogen-r", 0, 30)
    fake_run(cell, "relmogen-r", 0, 20, init_from=elsewhere)
    seed = read_cells(tmp_path)[0].seeds[0]
    assert seed.stage_episodes == [30, 20] and seed.curve["episode"][0] == 31


def test_the_command_writes_to_dir_figure4_by_default(tmp_path, capsys):
    fake_table1(tmp_path)
    assert main(["report", "--figure4", str(tmp_path)]) == 0
    assert (tmp_path / "figure4" / f"figure4_{TASK}.png").is_file()
    assert "| sac | PushDoorNav__sac |" in capsys.readouterr().out
    assert main(["report", "--figure4", str(tmp_path), "--table1", str(tmp_path)]) == 2
