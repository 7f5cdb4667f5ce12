"""The Table I recipes describe what produced the committed numbers: each stage of each seed,
resolved from its recipe, equals the ``config.yaml`` of the committed run folder, key by key.

Exclusions (every other key of the committed file must match exactly):

- ``preset``: the runs name the moving ``cpu`` preset; a recipe names its frozen base file
  (``relmogen/configs/recipes/bases/``), which is that preset's content of 2026-12 (the equality of
  every other key is what shows it).
- ``episodes``, ``max_hours``, ``max_cpu_hours`` of a stage that is not the last of its run: a run
  continued in place (``continue``) keeps one ``config.yaml``, rewritten with the last stage's
  budget, so the earlier stages' budgets are not on disk. The last stage of each run is compared on
  ``episodes`` and ``max_cpu_hours`` too.
- ``max_hours`` everywhere: PointNav relmogen-r's runs had ``--max-hours 1.6`` (wall clock), which
  never bound (each stopped at its 1,200 episodes); recipes budget in episodes and CPU hours only.
- Keys absent from a committed file (added to ``TrainConfig`` after the run, e.g. ``env.reach_mask``,
  ``algo.qmap_head_kernel``): the recipe's value must equal the key's default, the behaviour the code
  had before the key existed.
- Other algorithms' keys in a committed file (written when one model held every algorithm's keys):
  each must be null or at its default, which ``read_config`` drops (``with_algorithms_keys_only``
  refuses any other value).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from relmogen.experiments.config import ALGOS, TrainConfig, with_algorithms_keys_only
from relmogen.experiments.recipes import (BASE_DIR, Recipe, available_recipes, content_sha256, dry_run_text,
                                          file_sha256, listing_rows, load_recipe, resolve_stages)
from relmogen.experiments.table1 import PAPER_METRIC, PAPER_VALUES

REPO = Path(__file__).resolve().parents[2]
CELLS = ("PointNav__relmogen-r", "PointNav__relmogen-d", "PushDoorNav__relmogen-r", "PushDoorNav__sac",
         "ButtonDoorNav__relmogen-d", "ArrangeKitchenMM__relmogen-d", "ArrangeChairMM__relmogen-d",
         "TabletopReachM__relmogen-r", "PointNav__sac")
ALWAYS_EXCLUDED = {"preset", "max_hours"}
BUDGET_KEYS = {"episodes", "max_cpu_hours"}


def flatten(tree: dict, prefix: str = "") -> dict:
    flat = {}
    for key, value in tree.items():
        if isinstance(value, dict):
            flat.update(flatten(value, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = value
    return flat


DEFAULTS = {algo: flatten(TrainConfig(task="PointNav", algo=algo).model_dump(mode="json")) for algo in ALGOS}


def committed_run(recipe: Recipe, stage: str, seed: int) -> Path:
    pattern = recipe.ours.runs[stage].format(seed=seed)
    found = sorted(path for path in REPO.glob(pattern) if (path / "config.yaml").is_file())
    assert len(found) == 1, f"{pattern}: expected one committed run folder, found {found}"
    return found[0]


def stage_cases():
    for cell in CELLS:
        recipe = load_recipe(cell)
        for stage in recipe.stages:
            for seed in recipe.seeds:
                yield pytest.param(cell, stage, seed, id=f"{cell}-{stage}-seed{seed}")


def test_every_cell_has_a_recipe_and_recipes_without_a_figure_have_no_cell_yet():
    recipes = [name for name in available_recipes() if name.startswith("table1/")]
    with_figure = sorted(name.split("/")[-1] for name in recipes if load_recipe(name).ours is not None)
    assert with_figure == sorted(CELLS)
    for name in set(recipes) - {f"table1/{cell}" for cell in CELLS}:
        assert not (REPO / "results" / name / "table.json").exists(), f"{name} has a figure: fill in its ours block"
        assert dry_run_text(load_recipe(name), seeds=[0])


@pytest.mark.parametrize("cell, stage, seed", list(stage_cases()))
def test_stage_equals_the_committed_run_config(cell, stage, seed):
    recipe = load_recipe(cell)
    resolved = flatten(resolve_stages(recipe, seed)[stage].model_dump(mode="json"))
    tree = yaml.safe_load((committed_run(recipe, stage, seed) / "config.yaml").read_text())
    committed, kept = flatten(tree), flatten(with_algorithms_keys_only(tree))
    excluded = ALWAYS_EXCLUDED | (set() if recipe.chain_end(stage) == stage else BUDGET_KEYS)
    differences = {}
    for key in sorted(set(resolved) - excluded):
        expected = committed[key] if key in committed else DEFAULTS[recipe.algo][key]
        if resolved[key] != expected:
            differences[key] = {"recipe": resolved[key], "committed" if key in committed else "default": expected}
    assert not differences, f"{cell} stage {stage} seed {seed}: {differences}"
    assert set(kept) - set(resolved) == set(), "the committed run has keys today's TrainConfig lacks"


@pytest.mark.parametrize("cell", CELLS)
def test_paper_value_and_metric_are_table1s(cell):
    recipe = load_recipe(cell)
    assert recipe.paper.metric == PAPER_METRIC[recipe.task][0]
    assert recipe.paper.value == PAPER_VALUES[recipe.task][recipe.algo]


@pytest.mark.parametrize("cell", CELLS)
def test_ours_is_the_committed_reference_row(cell):
    recipe = load_recipe(cell)
    table = json.loads((REPO / recipe.ours.folder / "table.json").read_text())
    row = next(row for row in table["rows"] if row["reference"])
    metric = row[recipe.paper.metric]
    assert (recipe.ours.mean, recipe.ours.std, recipe.ours.max) == tuple(
        round(metric[key], 2) for key in ("mean", "std", "max"))
    assert recipe.ours.cpu_hours_per_seed == round(row["cpu_hours"], 2)
    assert recipe.ours.episodes_per_seed == round(row["episodes"])
    assert row["checkpoint"] == recipe.evaluation.checkpoint
    assert row["eval_episodes"] == recipe.evaluation.episodes


def test_dry_run_prints_every_stage_of_every_seed_as_yaml():
    recipe = load_recipe("PushDoorNav__relmogen-r")
    documents = list(yaml.safe_load_all(dry_run_text(recipe, [0, 5])))
    assert [(doc["seed"], doc["episodes"]) for doc in documents] == [(0, 1000), (0, 100000), (5, 1000), (5, 100000)]
    assert documents[1]["run"]["eval_seed"] == 20000 and documents[0]["run"]["eval_seed"] is None


def test_list_shows_each_recipe_with_paper_ours_and_cpu_hours():
    rows = {row["recipe"]: row for row in listing_rows()}
    assert rows["table1/PushDoorNav__relmogen-r"]["paper"] == 0.97
    assert rows["table1/PushDoorNav__relmogen-r"]["ours"] == "0.91 / 0.01 / 0.93"
    assert rows["table1/ArrangeKitchenMM__relmogen-d"]["cpu_hours_per_seed"] == 6.0


# ------------------------------------------------------------------------ schema edges
def write_variant(tmp_path: Path, edit) -> Path:
    """A copy of the PushDoorNav relmogen-r recipe changed by ``edit(data)``."""
    data = yaml.safe_load((REPO / "relmogen/configs/recipes/table1/PushDoorNav__relmogen-r.yaml").read_text())
    edit(data)
    path = tmp_path / "variant.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def one_line_error(path: Path) -> str:
    with pytest.raises(ValueError) as error:
        load_recipe(path)
    message = str(error.value)
    assert "\n" not in message
    return message


def test_unknown_key_is_one_line_with_a_suggestion(tmp_path):
    path = write_variant(tmp_path, lambda data: data["stages"]["phase1"].update(budgte={"episodes": 5}))
    assert one_line_error(path).endswith("stages.phase1.budgte: unknown key; did you mean budget?")


def test_unknown_setting_is_one_line_with_a_suggestion(tmp_path):
    def edit(data):
        data["stages"]["phase1"]["set"]["env.noop_cots"] = 1.0
        data["stages"]["phase1"]["why"]["env.noop_cots"] = "a typo"

    message = one_line_error(write_variant(tmp_path, edit))
    assert message.endswith("stage phase1: unknown key env.noop_cots; did you mean env.noop_cost?")


def test_a_setting_of_another_algorithm_names_the_algorithms_that_have_it(tmp_path):
    def edit(data):
        data["stages"]["phase1"]["set"]["algo.qmap_widths"] = [8, 8, 8, 8]
        data["stages"]["phase1"]["why"]["algo.qmap_widths"] = "a relmogen-d key in a relmogen-r recipe"

    message = one_line_error(write_variant(tmp_path, edit))
    assert message.endswith("stage phase1: algo.qmap_widths: relmogen-d only, not relmogen-r")


def test_a_setting_without_a_reason_is_refused(tmp_path):
    path = write_variant(tmp_path, lambda data: data["stages"]["phase1"]["why"].pop("env.subgoal_feedback"))
    assert "missing for env.subgoal_feedback" in one_line_error(path)


def test_stages_refer_only_to_earlier_stages(tmp_path):
    path = write_variant(tmp_path, lambda data: data["stages"]["phase1"].update(init_from="phase2"))
    assert "init_from 'phase2' is not an earlier stage" in one_line_error(path)


def test_a_changed_base_is_refused(tmp_path):
    path = write_variant(tmp_path, lambda data: data.update(base_sha256="0" * 64))
    assert "bases are frozen" in one_line_error(path)


def test_the_recorded_sha256_is_of_the_data_not_the_bytes(tmp_path):
    base = BASE_DIR / "cpu-2026-12.yaml"
    edited = tmp_path / "comments.yaml"
    edited.write_text("# a new comment\n" + base.read_text().replace("#", "# edited:"))
    changed = tmp_path / "value.yaml"
    changed.write_text(base.read_text().replace("image_size: 64", "image_size: 96", 1))
    assert file_sha256(edited) != file_sha256(base)
    assert content_sha256(edited) == content_sha256(base)
    assert content_sha256(changed) != content_sha256(base)


def test_a_continue_stage_changes_only_what_a_resumed_run_can(tmp_path):
    def edit(data):
        data["stages"]["phase3"] = {"continue": "phase2", "budget": {"episodes": 200000},
                                    "set": {"env.image_size": 128}, "why": {"env.image_size": "bigger"}}

    recipe = load_recipe(write_variant(tmp_path, edit))
    with pytest.raises(ValueError, match="stage phase3: cannot change 'env.image_size' when resuming"):
        resolve_stages(recipe, 0)


# ------------------------------------------------------------------------------- CLI
def test_cli_list_and_dry_run(capsys):
    from relmogen.cli import main

    assert main(["reproduce", "--list"]) == 0
    rows = [line.strip("│ ").split("│") for line in capsys.readouterr().out.splitlines() if "table1/" in line]
    assert len(rows) == len(available_recipes())
    chair = next(row for row in rows if row[0].strip() == "table1/ArrangeChairMM__relmogen-d")
    assert [cell.strip() for cell in chair[1:4]] == ["closed_10", "0.36", "0.81 / 0.24 / 1.08"]
    assert "not run yet" in next(row for row in rows if row[0].strip() == "table1/ArrangeChairMM__sac")[3]
    assert main(["reproduce", "ArrangeKitchenMM__relmogen-d", "--dry-run", "--seeds", "2"]) == 0
    documents = list(yaml.safe_load_all(capsys.readouterr().out))
    assert [(doc["seed"], doc["episodes"]) for doc in documents] == [(2, 1500), (2, 4600), (2, 100000)]


def test_cli_refuses_an_unknown_recipe_in_one_line(capsys):
    from relmogen.cli import main

    assert main(["reproduce", "PointNav__relmogen-q", "--dry-run"]) == 2
    assert capsys.readouterr().err.strip() == ("relmogen: error: unknown recipe 'PointNav__relmogen-q'; did you mean "
                                               "PointNav__relmogen-r? (relmogen reproduce --list shows them)")
