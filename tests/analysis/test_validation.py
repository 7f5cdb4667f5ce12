"""``relmogen analyse choose``: the model chosen on periodic plus extra validation episodes."""

import json
from pathlib import Path

import pytest

from relmogen.analysis.validation import choose, validation_rows
from relmogen.cli import main

REPO = Path(__file__).resolve().parents[2]


def make_run(folder, periodic, extra):
    """periodic / extra: {episode: (success_rate, mean_return)} over 20 / 30 episodes."""
    (folder / "validation").mkdir(parents=True)
    (folder / "eval_during_training.jsonl").write_text("".join(
        json.dumps({"episode": e, "episodes": 20, "success_rate": sr, "mean_return": r}) + "\n"
        for e, (sr, r) in periodic.items()))
    for e, (sr, r) in extra.items():
        (folder / "validation" / f"eval_30ep_evaluated_{e:07d}_seed20020.json").write_text(json.dumps(
            {"episodes": 30, "success_rate": sr, "mean_return": r, "checkpoint": f"evaluated_{e:07d}",
             "checkpoint_episode": e}))
    return folder


def test_models_are_ranked_on_the_pooled_block_then_the_return(tmp_path):
    run = make_run(tmp_path / "run", {100: (0.9, 5.0), 200: (0.6, 9.0), 300: (0.8, 7.0)},
                   {100: (0.5, 4.0), 200: (0.8, 9.0), 300: (0.6, 6.0)})
    rows = validation_rows(run)
    assert [r["episode"] for r in rows] == [100, 200, 300]
    assert rows[0]["success_rate"] == pytest.approx((20 * 0.9 + 30 * 0.5) / 50)  # 0.66
    assert rows[1]["success_rate"] == pytest.approx(0.72) and rows[2]["success_rate"] == pytest.approx(0.68)
    chosen = choose(run)
    assert chosen["chosen_episode"] == 200 and chosen["checkpoint"] == "evaluated_0000200"
    tie = make_run(tmp_path / "tie", {100: (0.5, 1.0), 200: (0.5, 2.0)}, {100: (0.5, 1.0), 200: (0.5, 2.0)})
    assert choose(tie)["chosen_episode"] == 200  # equal success: the higher return


def test_the_committed_table1_third_runs_choose_phase2_episode_400(capsys, tmp_path):
    runs = sorted((REPO / "results" / "pushdoornav-table1-third").glob("PushDoorNav__relmogen-r__*"))
    assert len(runs) == 3
    assert main(["analyse", "choose", *map(str, runs), "--out", str(tmp_path / "choice.json"), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    chosen = {r["run"].split("__")[2]: (r["episode"], round(r["success_rate"], 2)) for r in rows if r["chosen"]}
    assert chosen == {"0": (400, 0.9), "1": (400, 0.88), "2": (400, 0.88)}  # docs/experiments.md
    assert [c["chosen_episode"] for c in json.loads((tmp_path / "choice.json").read_text())] == [400, 400, 400]


def test_a_run_without_extra_validation_is_a_clear_error(tmp_path):
    run = make_run(tmp_path / "run", {100: (0.5, 1.0)}, {})
    with pytest.raises(ValueError, match="no validation"):
        choose(run)
