"""Recipes: a Table I cell as data (``relmogen/configs/recipes/table1/<Task>__<algo>.yaml``).

A recipe names a frozen base (``relmogen/configs/recipes/bases/<name>.yaml``, a preset file that
never changes once a recipe cites it: the recipe records the sha256 of its data, so comments may change), the seeds, one or more
stages and the evaluation protocol. Each stage is a training run made from the base plus the
stage's own ``set`` (``section.key: value``, each with a one-line ``why``) and its budget. A stage
either starts fresh, starts from an earlier stage's model (``init_from``, with ``init_replay`` its
replay too), or continues an earlier stage's run with a raised budget (``continue``, as ``relmogen
train --resume RUN --episodes N``). The ``validation`` block of the evaluation sets the periodic
evaluations of the evaluated run (the last stage's). ``resolve_stages`` turns one seed of a
recipe into one ``TrainConfig`` per stage through ``relmogen.experiments.config``'s functions.
"""

from __future__ import annotations

import difflib
import hashlib
import json
from pathlib import Path
from typing import Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from relmogen.experiments.config import Algo, TrainConfig, override_config, resolve_config, unknown_setting

RECIPE_DIR = Path(__file__).resolve().parent.parent / "configs" / "recipes"
BASE_DIR = RECIPE_DIR / "bases"
UNBOUNDED_EPISODES = 10**9  # a stage budgeted in CPU hours only (as relmogen sweep --cpu-hours)
SET_SECTIONS = ("env", "algo", "run")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Budget(_Strict):
    """Episodes and/or CPU hours (trainer plus environment workers). In a ``continue`` stage both
    are totals of the run since its first stage, as ``relmogen train --resume`` counts them."""

    episodes: int | None = Field(None, ge=1)
    cpu_hours: float | None = Field(None, gt=0)

    @model_validator(mode="after")
    def _some_budget(self) -> Budget:
        if self.episodes is None and self.cpu_hours is None:
            raise ValueError("a budget needs episodes, cpu_hours or both")
        return self


class Stage(_Strict):
    budget: Budget
    set: dict[str, object] = Field(default_factory=dict)  # section.key: value, over the base
    why: dict[str, str] = Field(default_factory=dict)  # section.key: one-line reason, for every key of set
    init_from: str | None = None  # an earlier stage: start from its latest model
    init_replay: bool = False  # with init_from: and its replay buffer
    continue_: str | None = Field(None, alias="continue")  # an earlier stage: resume its run, budget raised

    model_config = ConfigDict(extra="forbid", populate_by_name=True)

    @model_validator(mode="after")
    def _consistent(self) -> Stage:
        if self.init_from and self.continue_:
            raise ValueError("init_from starts a new run and continue resumes one: give one of them")
        if self.init_replay and not self.init_from:
            raise ValueError("init_replay loads the replay of the init_from stage: give init_from too")
        unexplained, orphans = sorted(set(self.set) - set(self.why)), sorted(set(self.why) - set(self.set))
        if unexplained:
            raise ValueError(f"every setting needs a one-line reason under why: missing for {', '.join(unexplained)}")
        if orphans:
            raise ValueError(f"why names settings that set does not: {', '.join(orphans)}")
        return self


class Validation(_Strict):
    """The periodic evaluations during the evaluated run (``run.eval_*``); with ``checkpoint: best``
    they choose the model."""

    every_episodes: int = Field(ge=1)
    episodes: int = Field(ge=1)
    seed: int | None = Field(ge=0)  # None: a new block each time (10000 + the training episode)
    why: str | None = None  # why these depart from the base's, where they do


class ExtraEvaluation(_Strict):
    """One more evaluation of the evaluated model, beside the reference one (its unset fields are the reference's)."""

    episodes: int | None = Field(None, ge=1)
    seed: int | None = Field(None, ge=0)
    stochastic: bool = False
    base_planner: str | None = None
    arm_planner: str | None = None
    arm_collision: bool | None = None


class Evaluation(_Strict):
    episodes: int = Field(ge=1)
    seed: int = Field(ge=0)
    checkpoint: Literal["latest", "best"]
    arm_collision: bool = True
    validation: Validation
    also: list[ExtraEvaluation] = Field(default_factory=list)


class Paper(_Strict):
    metric: str  # the key in table.json (relmogen.experiments.table1.PAPER_METRIC)
    value: float


class Ours(_Strict):
    """The committed result this recipe reproduces (results/table1/<cell>/)."""

    mean: float
    std: float
    max: float
    cpu_hours_per_seed: float = Field(gt=0)
    episodes_per_seed: int = Field(ge=1)
    folder: str  # the cell's folder, relative to the repository
    runs: dict[str, str]  # stage -> its committed run folders, a glob with {seed}


class Recipe(_Strict):
    title: str
    task: str
    algo: Algo
    base: str  # a file of relmogen/configs/recipes/bases, without .yaml
    base_sha256: str  # the base's content when this recipe first cited it
    seeds: list[int] = Field(min_length=1)
    stages: dict[str, Stage] = Field(min_length=1)
    evaluation: Evaluation
    paper: Paper
    ours: Ours | None = None  # None: a cell not yet run (relmogen reproduce makes its first figure)

    @model_validator(mode="after")
    def _stages_refer_backwards(self) -> Recipe:
        seen: list[str] = []
        for name, stage in self.stages.items():
            for field, target in (("init_from", stage.init_from), ("continue", stage.continue_)):
                if target is not None and target not in seen:
                    raise ValueError(f"stage {name}: {field} {target!r} is not an earlier stage "
                                     f"(earlier: {', '.join(seen) or 'none'})")
            seen.append(name)
            for key in stage.set:
                check_setting_key(key, self.algo, name)
        unknown = sorted(set(self.ours.runs if self.ours else ()) - set(self.stages))
        if unknown:
            raise ValueError(f"ours.runs names unknown stages {', '.join(unknown)}; stages: {', '.join(self.stages)}")
        return self

    @property
    def name(self) -> str:
        return f"{self.task}__{self.algo}"

    @property
    def last_stage(self) -> str:
        return list(self.stages)[-1]

    def run_root(self, stage: str) -> str:
        """The stage whose run ``stage`` trains in: itself, or the first stage of its ``continue`` chain."""
        while self.stages[stage].continue_ is not None:
            stage = self.stages[stage].continue_
        return stage

    def chain_end(self, stage: str) -> str:
        """The last stage that trains in ``stage``'s run (its config.yaml is that stage's)."""
        root, end = self.run_root(stage), stage
        for name in self.stages:
            if self.run_root(name) == root:
                end = name
        return end


def check_setting_key(key: str, algo: str, stage: str) -> None:
    """``section.key`` of env, run or ``algo``'s settings, with a did-you-mean for a misspelt one."""
    section, _, name = key.partition(".")
    if section not in SET_SECTIONS or not name or "." in name:
        raise ValueError(f"stage {stage}: setting {key!r} must be env.KEY, algo.KEY or run.KEY "
                         "(budgets go under budget:)")
    problem = unknown_setting(section, name, algo)
    if problem:
        raise ValueError(f"stage {stage}: {problem}")


# ----------------------------------------------------------------------------- loading
def available_recipes() -> list[str]:
    """Recipe names relative to the recipes folder, e.g. ``table1/PointNav__relmogen-r``."""
    return sorted(str(path.relative_to(RECIPE_DIR).with_suffix("")) for path in RECIPE_DIR.glob("*/*.yaml")
                  if path.parent != BASE_DIR)


def recipe_path(recipe: str) -> Path:
    """A recipe file path, a name (``table1/PointNav__relmogen-r``) or a cell (``PointNav__relmogen-r``)."""
    path = Path(recipe).expanduser()
    if path.suffix in (".yaml", ".yml"):
        if not path.is_file():
            raise ValueError(f"recipe file {recipe} does not exist")
        return path.resolve()
    for candidate in (RECIPE_DIR / f"{recipe}.yaml", *RECIPE_DIR.glob(f"*/{recipe}.yaml")):
        if candidate.is_file() and candidate.parent != BASE_DIR:
            return candidate
    close = difflib.get_close_matches(recipe, available_recipes() + [name.split("/")[-1] for name in
                                                                     available_recipes()], n=1)
    hint = f"; did you mean {close[0]}?" if close else ""
    raise ValueError(f"unknown recipe {recipe!r}{hint} (relmogen reproduce --list shows them)")


def load_recipe(recipe: str | Path) -> Recipe:
    path = recipe_path(str(recipe))
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as error:
        raise ValueError(f"recipe {path} is not valid YAML: {error}") from error
    try:
        loaded = Recipe.model_validate(data)
    except ValidationError as error:
        raise ValueError(f"recipe {path}: {one_line(error)}") from None
    check_base(loaded)
    return loaded


def one_line(error: ValidationError) -> str:
    """The first problem of a pydantic error as ``where: what``, with a did-you-mean for an unknown key."""
    first = error.errors()[0]
    where = ".".join(str(part) for part in first["loc"])
    if first["type"] == "extra_forbidden":
        close = difflib.get_close_matches(str(first["loc"][-1]), _schema_keys(), n=1)
        return f"{where}: unknown key" + (f"; did you mean {close[0]}?" if close else "")
    message = first["msg"].removeprefix("Value error, ")
    return f"{where}: {message}" if where else message


def _schema_keys() -> set[str]:
    models = (Recipe, Stage, Budget, Evaluation, Validation, ExtraEvaluation, Paper, Ours)
    return {field.alias or name for model in models for name, field in model.model_fields.items()}


def base_path(base: str) -> Path:
    path = BASE_DIR / f"{base}.yaml"
    if not path.is_file():
        bases = sorted(found.stem for found in BASE_DIR.glob("*.yaml"))
        raise ValueError(f"unknown base {base!r}; bases in {BASE_DIR}: {', '.join(bases)}")
    return path


def file_sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def content_sha256(path: Path) -> str:
    """sha256 of a YAML file's data (canonical JSON), not of its bytes: editing a comment or the
    layout keeps it, changing a value does not."""
    data = yaml.safe_load(Path(path).read_text())
    return hashlib.sha256(json.dumps(data, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def check_base(recipe: Recipe) -> None:
    digest = content_sha256(base_path(recipe.base))
    if digest != recipe.base_sha256:
        raise ValueError(f"base {recipe.base} changed since recipe {recipe.name} cited it (sha256 {digest[:12]}, "
                         f"recorded {recipe.base_sha256[:12]}): bases are frozen; put new settings in a new base")


# ---------------------------------------------------------------------------- resolving
def setting_assignment(key: str, value: object) -> str:
    return f"{key}={json.dumps(value)}"  # JSON is YAML: config's overrides parse it back exactly


def validation_settings(validation: Validation) -> dict[str, object]:
    return {"run.eval_every_episodes": validation.every_episodes, "run.eval_episodes": validation.episodes,
            "run.eval_seed": validation.seed}


def stage_settings(recipe: Recipe, stage: str) -> dict[str, object]:
    """The stage's ``set``, plus the validation block on the run that is evaluated."""
    settings = dict(recipe.stages[stage].set)
    if stage == recipe.run_root(recipe.last_stage):
        clashes = sorted(set(settings) & set(validation_settings(recipe.evaluation.validation)))
        if clashes:
            raise ValueError(f"stage {stage}: {', '.join(clashes)} belong in evaluation.validation")
        settings.update(validation_settings(recipe.evaluation.validation))
    return settings


def resolve_stages(recipe: Recipe, seed: int, device: str = "auto") -> dict[str, TrainConfig]:
    """Each stage's ``TrainConfig`` for ``seed``, in order: fresh and ``init_from`` stages from the
    base and their settings, ``continue`` stages from the run they continue with the new budget."""
    configs: dict[str, TrainConfig] = {}
    for name, stage in recipe.stages.items():
        try:
            configs[name] = _resolve_stage(recipe, name, stage, seed, device, configs)
        except ValueError as error:
            raise ValueError(f"recipe {recipe.name}, stage {name}: {str(error).strip()}") from None
    return configs


def _resolve_stage(recipe: Recipe, name: str, stage: Stage, seed: int, device: str,
                   earlier: dict[str, TrainConfig]) -> TrainConfig:
    budget = stage.budget
    if stage.continue_ is not None:
        changes = [setting_assignment(key, value) for key, value in stage.set.items()]
        changes += [f"episodes={budget.episodes}"] if budget.episodes else []
        changes += [f"max_cpu_hours={budget.cpu_hours}"] if budget.cpu_hours else []
        return override_config(earlier[stage.continue_], changes)[0]
    overrides = [setting_assignment(key, value) for key, value in stage_settings(recipe, name).items()]
    overrides += [f"max_cpu_hours={budget.cpu_hours}"] if budget.cpu_hours else []
    return resolve_config(recipe.task, recipe.algo, seed, str(base_path(recipe.base)),
                          budget.episodes or UNBOUNDED_EPISODES, device, overrides)


def dry_run_text(recipe: Recipe, seeds: list[int] | None = None) -> str:
    """Every stage of every seed as YAML: how it starts and its resolved configuration."""
    documents = []
    for seed in seeds or recipe.seeds:
        for name, config in resolve_stages(recipe, seed).items():
            stage = recipe.stages[name]
            start = (f"continue: {stage.continue_}" if stage.continue_ else
                     f"init_from: {stage.init_from}" + (" (with its replay)" if stage.init_replay else "")
                     if stage.init_from else "fresh")
            header = f"# {recipe.name}, seed {seed}, stage {name} ({start})\n"
            documents.append(header + yaml.safe_dump(config.model_dump(mode="json"), sort_keys=False))
    return "---\n".join(documents)


def listing_rows() -> list[dict]:
    """One row per recipe: its name, the paper's value and ours, the CPU hours per seed."""
    rows = []
    for name in available_recipes():
        recipe = load_recipe(name)
        ours = recipe.ours
        rows.append({"recipe": name, "title": recipe.title, "metric": recipe.paper.metric,
                     "paper": recipe.paper.value,
                     "ours": f"{ours.mean:.2f} / {ours.std:.2f} / {ours.max:.2f}" if ours else "not run yet",
                     "seeds": len(recipe.seeds), "stages": len(recipe.stages),
                     "episodes_per_seed": ours.episodes_per_seed if ours else "-",
                     "cpu_hours_per_seed": ours.cpu_hours_per_seed if ours else "-"})
    return rows
