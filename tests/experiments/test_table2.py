"""Tables II / A.4 / A.2: planner swap and arm collision checking of each ReLMoGen report."""

import json

import numpy as np
import pytest
from test_report import fake_run, markdown_rows

from relmogen.cli import main
from relmogen.experiments.report import write_report
from relmogen.experiments.table2 import write_table2

RATES = {0: 0.9, 1: 1.0, 2: 0.8}


def add_evaluation(run, rate: float, base: str, arm: str, collision: bool, **extra) -> None:
    name = f"eval_{base}_{arm}{''.join(f'_{v}' for v in extra.values())}_collision-{'on' if collision else 'off'}.json"
    (run / "eval" / name).write_text(json.dumps({"success_rate": rate, "spl": 0.5, "closed_5": 0.0, "closed_10": 0.0,
                                                 "base_planner": base, "arm_planner": arm, "arm_collision": collision,
                                                 "episodes": 50, **extra}))


def table1_folder(tmp_path):
    runs = []
    for seed, rate in RATES.items():
        run = fake_run(tmp_path / "runs", "relmogen-r", seed, rate, 0.5)
        add_evaluation(run, rate - 0.1, "lazy_prm", "lazy_prm", True)
        add_evaluation(run, rate - 0.2, "rrt_connect", "rrt_connect", False)
        runs.append(run)
    write_report(runs, tmp_path / "table1" / "PushDoorNav__relmogen-r")
    return tmp_path / "table1"


def test_planner_swap_and_collision_rows_carry_the_change_and_the_papers_values(tmp_path):
    result = write_table2(table1_folder(tmp_path), tmp_path / "table2")
    rows = {(r["table"], r["base_planner"], r["arm_planner"], r["arm_collision"]): r for r in result["rows"]}
    assert len(rows) == 6 and json.loads((tmp_path / "table2" / "table.json").read_text()) == result
    mean = np.mean(list(RATES.values()))
    training = rows[("planner_swap", "rrt_connect", "rrt_connect", True)]
    assert training["ours"]["mean"] == pytest.approx(mean) and training["change"] is None
    assert training["paper"] == 0.99 and training["seeds"] == 3
    lazy = rows[("planner_swap", "lazy_prm", "lazy_prm", True)]
    assert lazy["change"] == pytest.approx(-0.1) and lazy["paper"] == 1.0 and lazy["paper_change"] == pytest.approx(0.01)
    assert rows[("planner_swap", "rrt_connect", "lazy_prm", True)]["ours"] is None
    on = rows[("arm_collision", "rrt_connect", "rrt_connect", True)]
    assert on["change"] == pytest.approx(0.2) and on["paper"] == 0.99
    table = (tmp_path / "table2" / "table.md").read_text()
    swap = markdown_rows(table.split("## Planner swap")[1].split("## Arm collision")[0])
    assert [line[5:7] for line in swap] == [["RRT-Connect", "RRT-Connect"], ["RRT-Connect", "Lazy PRM"],
                                           ["Lazy PRM", "RRT-Connect"], ["Lazy PRM", "Lazy PRM"]]
    assert swap[1][7] == "not run" and swap[3][7].endswith("(-0.10), 50 eps")


def test_evaluations_with_another_base_goal_rule_stay_out_of_the_planner_tables(tmp_path):
    folder = table1_folder(tmp_path)
    for run in sorted((tmp_path / "runs").iterdir()):
        add_evaluation(run, 0.0, "rrt_connect", "rrt_connect", True, base_goal="nearest_reachable")
    write_report(sorted((tmp_path / "runs").iterdir()), folder / "PushDoorNav__relmogen-r")
    result = write_table2(folder, tmp_path / "table2")
    training = [r for r in result["rows"] if (r["table"], r["base_planner"], r["arm_planner"], r["arm_collision"])
                == ("planner_swap", "rrt_connect", "rrt_connect", True)]
    assert len(training) == 1 and training[0]["ours"]["mean"] == pytest.approx(np.mean(list(RATES.values())))


def test_table2_needs_an_output_folder(tmp_path, capsys):
    assert main(["report", "--table2", str(table1_folder(tmp_path))]) == 2
    assert "--out" in capsys.readouterr().err


def test_a_best_checkpoint_reference_compares_best_checkpoint_swaps_only(tmp_path):
    runs = []
    for seed, rate in RATES.items():
        run = fake_run(tmp_path / "runs", "relmogen-r", seed, rate - 0.5, 0.5)  # the latest checkpoint
        add_evaluation(run, rate, "rrt_connect", "rrt_connect", True, checkpoint="best_0000100")
        add_evaluation(run, rate - 0.1, "lazy_prm", "lazy_prm", True, checkpoint="best_0000100")
        runs.append(run)
    write_report(runs, tmp_path / "table1" / "PushDoorNav__relmogen-r", checkpoint="best")
    result = write_table2(tmp_path / "table1", tmp_path / "table2")
    rows = {(r["table"], r["base_planner"], r["arm_planner"], r["arm_collision"]): r for r in result["rows"]}
    training = rows[("planner_swap", "rrt_connect", "rrt_connect", True)]
    assert training["ours"]["mean"] == pytest.approx(np.mean(list(RATES.values())))
    assert rows[("planner_swap", "lazy_prm", "lazy_prm", True)]["change"] == pytest.approx(-0.1)
