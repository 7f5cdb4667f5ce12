"""The report aggregates final evaluations over seeds (mean / std / max) and plots curves."""

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from matplotlib.collections import PathCollection

from relmogen.experiments.budgets import scheduled_gradient_updates
from relmogen.experiments.config import resolve_config, save_config
from relmogen.cli import main
from relmogen.experiments.report import (CURVE_SMOOTHING, ROW_METRICS, _counts_items, checkpoint_evaluations,
                                         episodes_to_fraction_of_final, final_evaluation, headline_metric,
                                         read_curve, write_curves, write_report)
from relmogen.experiments.table1 import write_table1


def fake_run(root, algo, seed, success_rate, spl, overrides=()):
    run = root / f"PushDoorNav__{algo}__{seed}"
    (run / "eval").mkdir(parents=True)
    save_config(resolve_config("PushDoorNav", algo, seed=seed, preset="cpu", overrides=overrides), run / "config.yaml")
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
    assert "| 3 |" in row and "| 100 | - | 1.00 | 0.50 |" in row  # updates unknown; CPU h: mean of 0.25, 0.5, 0.75
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


def write_swap(run, success_rate):
    (run / "eval" / "swap.json").write_text(json.dumps(
        {"success_rate": success_rate, "spl": 0.1, "closed_10": 0.0, "episodes": 50, "scene": "office_A",
         "base_planner": "lazy_prm", "arm_planner": "lazy_prm", "arm_collision": True}))


def test_every_evaluation_setting_gets_a_row(tmp_path):
    runs = [fake_run(tmp_path, "relmogen-r", s, 0.5, 0.4) for s in (0, 1)]
    for run, rate in zip(runs, (0.2, 0.4)):
        write_swap(run, rate)
    table = write_report(runs, tmp_path / "report")["markdown"]
    swap = next(line for line in table.splitlines() if "lazy_prm" in line)
    assert "| 2 | 0.30 / 0.10 / 0.40 |" in swap
    on_movo = json.loads((runs[0] / "eval" / "swap.json").read_text()) | {"robot": "movo", "base_planner": "rrt_connect"}
    (runs[0] / "eval" / "movo.json").write_text(json.dumps(on_movo))
    rows = json.loads(Path(write_report(runs, tmp_path / "report")["json"]).read_text())["rows"]
    assert [row["robot"] for row in rows if row["base_planner"] == "rrt_connect" and row["eval_episodes"] == 50] == ["movo"]


def test_a_continued_run_is_reported_at_its_newest_checkpoint_its_earlier_evaluation_superseded(tmp_path):
    runs = [fake_run(tmp_path, "relmogen-r", s, 0.5, 0.4) for s in (0, 1)]
    setting = {"spl": 0.1, "closed_5": 0.0, "closed_10": 0.0, "scene": "office_A", "base_planner": "rrt_connect",
               "arm_planner": "rrt_connect", "arm_collision": True}
    for run, (early, late) in zip(runs, [(0.1, 0.6), (0.3, 0.8)]):
        for name, episode, rate in (("early", 2600, early), ("late", 4600, late)):
            (run / "eval" / f"{name}_collision-on.json").write_text(json.dumps(
                setting | {"success_rate": rate, "episodes": 50, "checkpoint": f"episode_{episode:07d}",
                           "checkpoint_episode": episode}))
    (runs[0] / "eval" / "early_collision-on.json").touch()  # the earlier checkpoint's file is the newer
    assert final_evaluation(runs[0])["success_rate"] == 0.6
    rows = json.loads(Path(write_report(runs, tmp_path / "report")["json"]).read_text())["rows"]
    row = next(row for row in rows if not row["reference"] and row["eval_episodes"] == 50)
    assert row["seeds"] == 2 and row["success_rate"]["mean"] == pytest.approx(0.7)


def test_curves_show_items_closed_for_tasks_that_count_them(tmp_path):
    navigation = fake_run(tmp_path, "relmogen-r", 0, 0.5, 0.4)
    assert not _counts_items([{"curve": read_curve(navigation / "episodes.csv")}])
    kitchen = tmp_path / "kitchen.csv"
    kitchen.write_text("episode,return,success,closed_10\n1,0.5,0,1\n2,0.7,0,3\n")
    curve = read_curve(kitchen)
    np.testing.assert_array_equal(curve["closed_10"], [1, 3])
    assert _counts_items([{"curve": curve}])


DEMONSTRATIONS = ["algo.demo_episodes=5"]


def markdown_rows(markdown):
    """The data lines of every markdown table, as lists of cells."""
    return [[cell.strip() for cell in line.strip("|").split("|")] for line in markdown.splitlines()
            if line.startswith("| ") and not line.startswith("| task |")]


def test_table_json_has_a_typed_row_per_table_md_row(tmp_path):
    runs = [fake_run(tmp_path, "relmogen-r", s, sr, 0.5) for s, sr in [(0, 0.9), (1, 1.0), (2, 0.8)]]
    runs.append(fake_run(tmp_path, "relmogen-d", 0, 0.4, 0.3, overrides=DEMONSTRATIONS))
    runs.append(fake_run(tmp_path, "sac", 0, 0.0, 0.0))
    write_swap(runs[0], 0.2)
    result = write_report(runs, tmp_path / "report")
    table = json.loads((tmp_path / "report" / "table.json").read_text())
    assert table["schema_version"] == 1 and result["json"].endswith("table.json")
    rows, md_rows = table["rows"], markdown_rows(result["markdown"])
    assert len(rows) == len(md_rows) == 3 + 4  # reference rows, then the settings (relmogen-r has a swap)
    for row, cells in zip(rows, md_rows):
        assert cells[:3] == [row["task"], row["algorithm"], "assisted" if row["assisted"] else "reward-only"]
        assert str(row["seeds"]) in cells
        assert isinstance(row["task"], str) and isinstance(row["algorithm"], str) and isinstance(row["policy"], str)
        assert isinstance(row["arm_collision"], bool) and isinstance(row["assisted"], bool)
        assert isinstance(row["seeds"], int) and isinstance(row["episodes"], float)
        assert isinstance(row["cpu_hours"], float)
        assert {"base_planner", "arm_planner", "scene"} <= row.keys()
        for metric in ROW_METRICS:
            assert row[metric] is None or set(row[metric]) == {"mean", "std", "max"}
    reference = {row["algorithm"]: row for row in rows if row["reference"]}
    assert reference["relmogen-d"]["assisted"] and not reference["relmogen-r"]["assisted"]
    assert reference["relmogen-r"]["seeds"] == 3 and reference["relmogen-r"]["episodes"] == 100
    assert reference["relmogen-r"]["cpu_hours"] == pytest.approx(0.5)  # mean of 0.25, 0.5, 0.75
    assert reference["relmogen-r"]["success_rate"] == pytest.approx({"mean": 0.9, "std": np.std([0.9, 1.0, 0.8]),
                                                                     "max": 1.0})
    assert reference["relmogen-r"]["policy"] == "deterministic" and reference["relmogen-r"]["arm_collision"] is True
    swap = next(row for row in rows if row["base_planner"] == "lazy_prm")
    assert (swap["seeds"], swap["closed_5"], swap["success_rate"]["mean"]) == (1, None, 0.2)


def test_a_fine_tuned_run_counts_the_budget_of_its_initial_weights(tmp_path):
    run = fake_run(tmp_path, "relmogen-r", 0, 0.9, 0.5)  # 100 episodes, 0.25 CPU h
    (run / "eval_during_training.jsonl").write_text(json.dumps({"episode": 40, "success_rate": 0.6}) + "\n")
    (run / "init_from.json").write_text(json.dumps({"initial_episodes": 1000.0, "initial_cpu_time_s": 1800.0,
                                                     "initial_wall_time_s": 3600.0}))
    rows = json.loads(Path(write_report([run], tmp_path / "report")["json"]).read_text())["rows"]
    reference = next(row for row in rows if row["reference"])
    assert reference["episodes"] == 1100 and reference["cpu_hours"] == pytest.approx(0.75)
    assert reference["initial_episodes"] == 1000 and reference["initial_cpu_hours"] == pytest.approx(0.5)
    assert reference["episodes_to_success_rate"]["0.5"] == [1040]


def test_gradient_updates_are_the_counted_ones_or_marked_as_derived_from_the_schedule(tmp_path):
    runs = [fake_run(tmp_path, "relmogen-r", seed, 0.9, 0.5) for seed in (0, 1)]
    for run, updates in zip(runs, (1000, 1200)):
        done = json.loads((run / "done.json").read_text())
        (run / "done.json").write_text(json.dumps(dict(done, timesteps=2500, gradient_updates=updates)))
    row = reference_row(write_report(runs, tmp_path / "counted"))
    assert (row["gradient_updates"], row["gradient_updates_counted"]) == (1100, True)
    older = json.loads((runs[1] / "done.json").read_text())
    del older["gradient_updates"]
    (runs[1] / "done.json").write_text(json.dumps(older))
    config = resolve_config("PushDoorNav", "relmogen-r", seed=1, preset="cpu")
    scheduled = scheduled_gradient_updates(config, 2500)
    assert scheduled == 2500 // 4 - 500 // 4  # cpu preset: one update per 2 steps of its 2 environments past 500
    row = reference_row(write_report(runs, tmp_path / "derived"))
    assert (row["gradient_updates"], row["gradient_updates_counted"]) == ((1000 + scheduled) / 2, False)
    line = next(line for line in (tmp_path / "derived" / "table.md").read_text().splitlines() if "relmogen-r" in line)
    assert f"| ~{(1000 + scheduled) / 2:,.0f} |" in line


def reference_row(report: dict) -> dict:
    return next(row for row in json.loads(Path(report["json"]).read_text())["rows"] if row["reference"])


def fake_report(folder, algo, overrides=()):
    runs = [fake_run(folder / "runs", algo, seed, rate, 0.5, overrides)
            for seed, rate in [(0, 0.9), (1, 1.0), (2, 0.8)]]
    write_report(runs, folder)


def test_table1_sets_reward_only_runs_beside_the_paper_and_assisted_runs_apart(tmp_path):
    fake_report(tmp_path / "PushDoorNav__relmogen-r", "relmogen-r")
    fake_report(tmp_path / "PushDoorNav__relmogen-d", "relmogen-d", DEMONSTRATIONS)
    readme = write_table1(tmp_path).read_text()
    main_table, assisted, budget = readme.split("\n## ")
    lines = {cells[0]: cells for cells in markdown_rows(main_table)}
    assert list(lines) == ["PointNav", "TabletopReachM", "PushDoorNav", "ButtonDoorNav", "InteractiveObstaclesNav",
                           "ArrangeKitchenMM", "ArrangeChairMM"]
    assert lines["PointNav"] == ["PointNav", "SR", "-", "0.72", "-", "0.68", "-", "0.60", "-", "0.46", "-", "0.33"]
    assert lines["ArrangeKitchenMM"][3::2] == ["4.91", "6.10", "4.95", "3.55", "4.67"]
    assert lines["ArrangeChairMM"][3::2] == ["0.11", "0.36", "0.00", "0.00", "0.00"]
    std = np.std([0.9, 1.0, 0.8])
    assert lines["PushDoorNav"][2:6] == [f"0.90 / {std:.2f} / 1.00 (3)", "0.97", "-", "0.41"]  # relmogen-d: assisted
    assert assisted.startswith("Assisted runs: demonstrations or oracle labels; not comparable")
    assert markdown_rows(assisted) == [["PushDoorNav", "relmogen-d", "PushDoorNav__relmogen-d", "SR",
                                        f"0.90 / {std:.2f} / 1.00 (3)", "0.41"]]
    assert [cells[:3] for cells in markdown_rows(budget)] == [["PushDoorNav", "relmogen-r", "reward-only"],
                                                              ["PushDoorNav", "relmogen-d", "assisted"]]


def test_table1_without_reports_is_a_one_line_error(tmp_path, capsys):
    assert main(["report", "--table1", str(tmp_path)]) == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_a_run_without_any_evaluation_gets_a_hint_on_how_to_make_one(tmp_path):
    run = fake_run(tmp_path, "relmogen-r", 0, 0.5, 0.4)
    (run / "eval" / "eval_collision-on.json").unlink()
    markdown = write_report([run], tmp_path / "report")["markdown"]
    assert f"{run} has no evaluation yet: run `relmogen eval {run}`" in markdown


def test_tables_show_only_the_metrics_of_their_tasks(tmp_path):
    navigation = fake_run(tmp_path, "relmogen-r", 0, 0.5, 0.4)
    header = write_report([navigation], tmp_path / "nav")["markdown"].splitlines()[0]
    assert "success_rate" in header and "spl" in header and "closed" not in header
    kitchen = tmp_path / "ArrangeKitchenMM__relmogen-d__0"
    (kitchen / "eval").mkdir(parents=True)
    save_config(resolve_config("ArrangeKitchenMM", "relmogen-d", preset="cpu"), kitchen / "config.yaml")
    (kitchen / "eval" / "eval_collision-on.json").write_text(json.dumps(
        {"success_rate": 0.0, "spl": 0.0, "closed_5": 1.0, "closed_10": 2.0, "episodes": 5}))
    result = write_report([navigation, kitchen], tmp_path / "both")
    rows = {cells[0]: cells for cells in markdown_rows(result["markdown"].split("\n## ")[0])}
    header = result["markdown"].splitlines()[0]
    assert "spl" in header and "closed_10" in header
    assert rows["ArrangeKitchenMM"][5] == "n/a" and rows["PushDoorNav"][6:8] == ["n/a", "n/a"]
    reference = {row["task"]: row for row in json.loads((tmp_path / "both" / "table.json").read_text())["rows"]
                 if row["reference"]}
    assert reference["ArrangeKitchenMM"]["spl"] is None and reference["ArrangeKitchenMM"]["closed_10"]["mean"] == 2.0
    assert reference["PushDoorNav"]["closed_10"] is None


def test_curves_of_short_runs_leave_no_panel_empty(tmp_path):
    from relmogen.experiments.report import collect, curve_figure

    run = fake_run(tmp_path, "sac", 0, 0.0, 0.0)  # joint velocities: no subgoal shares logged
    (run / "episodes.csv").write_text("episode,timesteps,wall_time_s,return,length,success\n1,750,30.0,0.5,750,0\n"
                                      "2,1500,60.0,0.7,750,0\n")
    figure = curve_figure(collect([run]))
    for axis in figure.axes:
        drawn = any(np.isfinite(line.get_ydata()).sum() >= 2 for line in axis.get_lines())
        assert drawn or [text.get_text() for text in axis.texts], axis.get_ylabel()
    assert len(figure.axes) == 3  # no base-share row: joint velocities choose no subgoals


def test_an_evaluation_of_the_best_checkpoint_is_a_setting_of_its_own_not_the_reference(tmp_path):
    run = fake_run(tmp_path, "relmogen-r", 0, 0.5, 0.4)
    new = {"success_rate": 0.2, "spl": 0.1, "closed_5": 0.0, "closed_10": 0.0, "episodes": 100, "scene": "office_A",
           "base_planner": "rrt_connect", "arm_planner": "rrt_connect", "eval_seed": 100_000}
    name = "eval_office_A_rrt_connect_rrt_connect_collision-on_100ep_{}_seed100000.json"
    (run / "eval" / name.format("best_0000080")).write_text(json.dumps(dict(new, checkpoint="best_0000080",
                                                                           success_rate=0.9)))
    (run / "eval" / name.format("episode_0000100")).write_text(json.dumps(dict(new, checkpoint="episode_0000100")))
    kept = name.format("evaluated_0000060").replace("100ep", "200ep")  # run.keep_evaluated: never the latest
    (run / "eval" / kept).write_text(json.dumps(dict(new, checkpoint="evaluated_0000060", episodes=200, success_rate=0.7)))
    assert final_evaluation(run)["success_rate"] == 0.2  # the latest checkpoint's, newer names and older alike
    write_report([run], tmp_path / "report")
    rows = json.loads((tmp_path / "report" / "table.json").read_text())["rows"]
    best = [row for row in rows if row["checkpoint"] == "best"]
    assert len(best) == 1 and best[0]["success_rate"]["mean"] == 0.9 and not best[0]["reference"]
    evaluated = [row for row in rows if row["checkpoint"] == "evaluated"]
    assert len(evaluated) == 1 and evaluated[0]["success_rate"]["mean"] == 0.7 and not evaluated[0]["reference"]


def test_the_best_checkpoint_can_be_the_reference_and_table1_says_so(tmp_path):
    run = fake_run(tmp_path / "runs", "relmogen-r", 0, 0.5, 0.4)
    evaluation = {"success_rate": 0.9, "spl": 0.1, "closed_5": 0.0, "closed_10": 0.0, "episodes": 100,
                  "scene": "office_A", "base_planner": "rrt_connect", "arm_planner": "rrt_connect",
                  "eval_seed": 100_000, "checkpoint": "best_0000080"}
    (run / "eval" / "eval_office_A_rrt_connect_rrt_connect_collision-on_100ep_best_seed100000.json").write_text(
        json.dumps(evaluation))
    assert final_evaluation(run, "best")["success_rate"] == 0.9
    assert final_evaluation(run, "latest")["success_rate"] == 0.5
    write_report([run], tmp_path / "PushDoorNav__relmogen-r", checkpoint="best")
    rows = json.loads((tmp_path / "PushDoorNav__relmogen-r" / "table.json").read_text())["rows"]
    reference = next(row for row in rows if row["reference"])
    assert reference["checkpoint"] == "best" and reference["success_rate"]["mean"] == 0.9
    readme = write_table1(tmp_path).read_text()
    assert "0.90 / 0.00 / 0.90 (1, best checkpoint)" in readme
    with pytest.raises(ValueError, match="latest, best"):
        final_evaluation(run, "newest")


def test_reference_rows_give_the_episodes_at_which_periodic_evaluation_first_reached_05_and_09(tmp_path):
    runs = [fake_run(tmp_path, "relmogen-r", s, 0.9, 0.5) for s in (0, 1)]
    for run, rates in zip(runs, [(0.1, 0.6, 0.4, 0.9), (0.0, 0.2, 0.5, 0.8)]):
        (run / "eval_during_training.jsonl").write_text("".join(
            json.dumps({"episode": 100 * (i + 1), "success_rate": rate}) + "\n" for i, rate in enumerate(rates)))
    result = write_report(runs, tmp_path / "report")
    reference = next(row for row in json.loads((tmp_path / "report" / "table.json").read_text())["rows"]
                     if row["reference"])
    assert reference["episodes_to_success_rate"] == {"0.5": [200, 300], "0.9": [400, None]}
    assert "200, 300" in result["markdown"] and "400, -" in result["markdown"]


def test_reference_rows_give_the_episodes_at_which_periodic_evaluation_reached_half_and_90_percent_of_final(tmp_path):
    runs = [fake_run(tmp_path, "relmogen-r", seed, final, 0.5) for seed, final in ((0, 0.8), (1, 0.4), (2, 0.0))]
    for run, rates in zip(runs, [(0.1, 0.4, 0.7, 0.8), (0.3, 0.1, 0.2, 0.4), (0.0, 0.1, 0.0, 0.0)]):
        (run / "eval_during_training.jsonl").write_text("".join(
            json.dumps({"episode": 100 * (i + 1), "success_rate": rate}) + "\n" for i, rate in enumerate(rates)))
    cell = tmp_path / "table1" / "PushDoorNav__relmogen-r"
    result = write_report(runs, cell)
    reference = next(row for row in json.loads((cell / "table.json").read_text())["rows"] if row["reference"])
    # seed 0: 0.4 >= 0.5 x 0.8 at 200, 0.8 >= 0.9 x 0.8 at 400 (0.7 < 0.72); seed 1: 0.3 >= 0.2 at 100,
    # 0.4 >= 0.36 at 400; seed 2 ends at 0: no milestone
    assert reference["episodes_to_final_fraction"] == {"0.5": [200, 100, None], "0.9": [400, 400, None]}
    assert "200, 100, -" in result["markdown"] and "episodes to 90% of final" in result["markdown"]
    budget_line = next(line for line in write_table1(cell.parent).read_text().splitlines()
                       if line.startswith("| PushDoorNav | relmogen-r | reward-only"))
    assert budget_line.endswith("| 200, 100, - | 400, 400, - |")


def test_the_arrangement_tasks_are_judged_by_items_closed_and_the_others_by_success():
    assert headline_metric("ArrangeKitchenMM") == headline_metric("ArrangeChairMM") == "closed_10"
    assert headline_metric("PushDoorNav") == headline_metric("TabletopReachM") == "success_rate"
    assert episodes_to_fraction_of_final([{"episode": 500, "closed_10": 2.0}], "closed_10", 4.0, 0.5) == 500
    assert episodes_to_fraction_of_final([{"episode": 500, "closed_10": 1.9}], "closed_10", 4.0, 0.5) is None


def save_evaluation(run, name: str, checkpoint: str, episodes: int, success_rate: float) -> None:
    (run / "eval" / name).write_text(json.dumps({"checkpoint": checkpoint, "episodes": episodes,
                                                 "success_rate": success_rate}))


def test_only_the_checkpoints_own_evaluations_most_episodes_first(tmp_path):
    (tmp_path / "eval").mkdir()
    save_evaluation(tmp_path, "a.json", "best_0000500", 50, 0.70)
    save_evaluation(tmp_path, "b.json", "best_0000500", 100, 0.78)
    save_evaluation(tmp_path, "c.json", "episode_0001000", 100, 0.18)
    found = checkpoint_evaluations(tmp_path, "best_0000500")
    assert [(e["episodes"], e["success_rate"]) for e in found] == [(100, 0.78), (50, 0.70)]


def test_a_run_never_evaluated_has_none(tmp_path):
    assert checkpoint_evaluations(tmp_path, "episode_0000020") == []


def write_base_shares(run, shares) -> None:
    """Rewrite ``run``'s episodes.csv with one row per share in ``shares``."""
    with open(run / "episodes.csv", "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["episode", "timesteps", "wall_time_s", "return", "length", "success", "base_fraction"])
        for episode, share in enumerate(shares, start=1):
            writer.writerow([episode, episode * 25, episode * 36.0, episode / 10, 25, float(episode > 50), share])


def write_periodic(run, rows) -> None:
    """``eval_during_training.jsonl`` with (episode, success_rate, mean_return) rows of 10 episodes each."""
    (run / "eval_during_training.jsonl").write_text("".join(json.dumps(
        {"episode": e, "wall_time_s": e * 36.0, "episodes": 10, "success_rate": sr, "mean_return": ret}) + "\n"
        for e, sr, ret in rows))


def legend_texts(figure) -> list[str]:
    return [text.get_text() for axis in figure.axes if axis.get_legend() for text in axis.get_legend().get_texts()]


def scatter_points(axis) -> list[tuple[float, float]]:
    """The (x, y) of every point scattered on ``axis`` (not the std bands), sorted."""
    points = [c.get_offsets() for c in axis.collections if isinstance(c, PathCollection)]
    return sorted(tuple(p) for p in np.concatenate(points).tolist()) if points else []


def curves_of(runs):
    from relmogen.experiments.report import collect, curve_figure

    return curve_figure(collect(runs))


def axis_named(figure, ylabel_start: str, xlabel: str = "training episodes"):
    return next(a for a in figure.axes if a.get_ylabel().startswith(ylabel_start) and a.get_xlabel() == xlabel)


def test_the_legend_counts_seeds_in_the_singular_for_one_seed(tmp_path):
    one = curves_of([fake_run(tmp_path / "one", "relmogen-r", 0, 0.9, 0.5)])
    assert "relmogen-r, training (1 seed)" in legend_texts(one)
    three = curves_of([fake_run(tmp_path / "three", "relmogen-r", s, 0.9, 0.5) for s in range(3)])
    assert "relmogen-r, training (mean and std of 3 seeds)" in legend_texts(three)
    assert not any("1 seeds" in text for text in legend_texts(one) + legend_texts(three))


def test_the_success_panel_says_it_is_a_rolling_mean_of_training_episodes(tmp_path):
    figure = curves_of([fake_run(tmp_path, "relmogen-r", 0, 0.9, 0.5)])
    label = figure.axes[0].get_ylabel()
    assert label.startswith("success rate of training episodes")
    assert f"rolling mean of {CURVE_SMOOTHING} episodes" in label


def test_periodic_evaluations_are_drawn_as_points_per_seed(tmp_path):
    runs = [fake_run(tmp_path, "relmogen-r", s, 0.9, 0.5) for s in (0, 1)]
    write_periodic(runs[0], [(50, 0.2, 3.0), (100, 0.6, 9.0)])
    write_periodic(runs[1], [(50, 0.4, 5.0)])
    figure = curves_of(runs)
    success = axis_named(figure, "success rate")
    assert scatter_points(success) == [(50, 0.2), (50, 0.4), (100, 0.6)]
    by_hours = scatter_points(axis_named(figure, "episode return", "wall-clock hours"))
    assert by_hours == [(0.5, 3.0), (0.5, 5.0), (1.0, 9.0)]  # 50 episodes x 36 s = 0.5 h
    assert "relmogen-r, periodic evaluations of 10 episodes (greedy, one point per seed)" in legend_texts(figure)


def test_a_run_without_periodic_evaluations_draws_no_points(tmp_path):
    figure = curves_of([fake_run(tmp_path, "relmogen-r", 0, 0.9, 0.5)])
    assert scatter_points(axis_named(figure, "success rate")) == []
    assert not any("periodic" in text for text in legend_texts(figure))


def test_a_constant_base_share_is_not_drawn(tmp_path):
    runs = [fake_run(tmp_path, "relmogen-r", s, 0.9, 0.5) for s in (0, 1)]
    for run in runs:
        write_base_shares(run, [1.0] * 100)
    figure = curves_of(runs)
    assert len(figure.axes) == 3
    assert not any(axis.get_ylabel().startswith("base share") for axis in figure.axes)


def test_a_varying_base_share_is_drawn(tmp_path):
    run = fake_run(tmp_path, "relmogen-r", 0, 0.9, 0.5)
    write_base_shares(run, np.linspace(1.0, 0.5, 100))
    figure = curves_of([run])
    line = axis_named(figure, "base share").get_lines()[0]
    assert np.nanmax(line.get_ydata()) == pytest.approx(1.0) and np.nanmin(line.get_ydata()) < 0.6


def test_beside_a_task_that_needs_it_a_constant_share_says_why_it_is_left_out(tmp_path):
    varying = fake_run(tmp_path, "relmogen-r", 0, 0.9, 0.5)
    write_base_shares(varying, np.linspace(1.0, 0.5, 100))
    constant = tmp_path / "PointNav__relmogen-r__0"
    (constant / "eval").mkdir(parents=True)
    save_config(resolve_config("PointNav", "relmogen-r", seed=0, preset="cpu"), constant / "config.yaml")
    write_base_shares(constant, [1.0] * 100)
    figure = curves_of([varying, constant])
    assert [a.get_title() for a in figure.axes[:2]] == ["PointNav", "PushDoorNav"] or \
        {a.get_title() for a in figure.axes} >= {"PointNav", "PushDoorNav"}
    left_out = [a for a in figure.axes if not a.axison]
    assert len(left_out) == 1 and "always 1 (not plotted)" in left_out[0].texts[0].get_text().replace("\n", " ")
    assert sum(a.get_ylabel().startswith("base share") for a in figure.axes) == 1


def test_curves_only_redraws_curves_png_and_leaves_the_tables_byte_identical(tmp_path, capsys):
    import imageio.v2 as imageio

    runs = [fake_run(tmp_path, "relmogen-r", s, 0.9, 0.5) for s in (0, 1)]
    out = tmp_path / "report"
    assert main(["report", *map(str, runs), "--out", str(out)]) == 0
    tables = {name: (out / name).read_bytes() for name in ("table.md", "table.json")}
    first = imageio.imread(out / "curves.png")
    for run in runs:  # new evaluations (a full report would change its tables) and points on the curves
        (run / "eval" / "eval_collision-on.json").write_text(json.dumps(
            {"success_rate": 0.1, "spl": 0.1, "closed_5": 0.0, "closed_10": 0.0}))
        write_periodic(run, [(50, 0.2, 3.0), (100, 0.6, 9.0)])
    capsys.readouterr()
    assert main(["report", *map(str, runs), "--out", str(out), "--curves-only"]) == 0
    assert capsys.readouterr().out == f"{out / 'curves.png'}\n"
    assert {name: (out / name).read_bytes() for name in tables} == tables
    redrawn = imageio.imread(out / "curves.png")
    expected = imageio.imread(write_report(runs, tmp_path / "full")["curves"])
    assert not np.array_equal(redrawn, first) and np.array_equal(redrawn, expected)
    assert (tmp_path / "full" / "table.md").read_bytes() != tables["table.md"]


def test_curves_only_writes_nothing_else_and_needs_runs(tmp_path):
    out = write_curves([fake_run(tmp_path, "sac", 0, 0.0, 0.0)], tmp_path / "new" / "report")
    assert sorted(p.name for p in out.parent.iterdir()) == ["curves.png"] and out.stat().st_size > 10_000
    with pytest.raises(ValueError, match="no run"):
        write_curves([], tmp_path / "empty")
