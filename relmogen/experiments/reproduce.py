"""``relmogen reproduce RECIPE``: every stage of every seed of a recipe, then its evaluation and report.

It drives ``relmogen sweep``'s machinery: the backends (Ray tasks with retries, or serial child
processes that never import Ray), the manifest ``OUT/sweep.json`` (written by the driver only)
and its live table. One job per seed trains the seed's stages in order, each stage as ``relmogen
train`` would: a fresh or ``init_from`` stage in ``OUT/runs/<stage>/``, a ``continue`` stage by
resuming the run it continues with its raised budget. A retried or ``--resume``d job picks up
where the files say it stopped (finished stages are skipped, an unfinished one resumes from its
latest checkpoint). Then each seed's last run is evaluated as the recipe's ``evaluation`` says,
and ``OUT/<Task>__<algo>/`` gets the report (``relmogen report``'s) and ``OUT/README.md`` Table I.
``--publish DIR`` (``results/table1``) then copies the report and the run folders' small files (no
checkpoints, replay or TensorBoard events) into ``DIR/<Task>__<algo>/`` when the cell is new, or
into ``DIR/<Task>__<algo>/reruns/<commit>-<host kind>/`` beside the cell's own figure, and
rewrites ``DIR/README.md``.
"""

from __future__ import annotations

import json
import math
import shutil
import subprocess
from pathlib import Path

from relmogen.experiments.host import host_info
from relmogen.experiments.recipes import (ExtraEvaluation, Recipe, content_sha256, file_sha256, load_recipe,
                                          recipe_path, resolve_stages, setting_assignment)
from relmogen.experiments.sweep import (MANIFEST, RUNS, LiveTable, manifest_updates, make_backend, mark_started,
                                        read_manifest, run_key, write_manifest)

MANIFEST_KIND = "reproduce"


# ----------------------------------------------------------------------- one seed's stages
def execute_seed(out: str, recipe_file: str, seed: int) -> dict:
    """Train every stage of ``seed`` (in the worker process); returns the run folders, relative to ``out``."""
    out = Path(out)
    recipe = load_recipe(recipe_file)
    configs = resolve_stages(recipe, seed)
    place = mark_started(out, run_key(recipe.task, recipe.algo, seed))  # the manifest's state and placements
    run_dirs: dict[str, Path] = {}
    for name, stage in recipe.stages.items():
        if stage.continue_ is not None:
            run_dirs[name] = continue_stage(run_dirs[stage.continue_], configs[name], stage.set)
        else:
            source = run_dirs[stage.init_from] if stage.init_from else None
            run_dirs[name] = start_stage(out / RUNS / name, configs[name], source, stage.init_replay)
    stages = {name: str(path.relative_to(out)) for name, path in run_dirs.items()}
    return {"run_dir": stages[recipe.last_stage], "stages": stages, "placement": place}


def stage_run_dir(folder: Path, config) -> Path | None:
    """The newest run of ``config``'s (task, algo, seed) in ``folder`` that got as far as its config.yaml."""
    found = [path for path in sorted(folder.glob(f"{run_key(config.task, config.algo, config.seed)}__*"))
             if (path / "config.yaml").is_file()]
    return found[-1] if found else None


def start_stage(folder: Path, config, init_from: Path | None, init_replay: bool) -> Path:
    from relmogen.experiments.resume import resume
    from relmogen.experiments.train import train

    run_dir = stage_run_dir(folder, config)
    if run_dir is None:
        return train(config, folder, quiet=True, init_from=init_from, init_replay=init_replay)
    if not (run_dir / "done.json").is_file():
        return resume(run_dir, quiet=True)
    return run_dir


def budget_of(config) -> tuple[int, float]:
    return config.episodes, config.max_cpu_hours or math.inf


def continue_stage(run_dir: Path, config, settings: dict) -> Path:
    """Resume ``run_dir`` with ``config``'s budget, unless it already reached it (or a later stage's)."""
    from relmogen.experiments.config import read_config
    from relmogen.experiments.resume import resume

    recorded, done = read_config(run_dir / "config.yaml"), (run_dir / "done.json").is_file()
    if budget_of(recorded) > budget_of(config) or (budget_of(recorded) == budget_of(config) and done):
        return run_dir
    if budget_of(recorded) == budget_of(config):  # this stage was under way: carry on as it was
        return resume(run_dir, quiet=True)
    changes = [setting_assignment(key, value) for key, value in settings.items()]
    changes += [f"max_cpu_hours={config.max_cpu_hours}"] if config.max_cpu_hours else []
    return resume(run_dir, quiet=True, episodes=config.episodes, overrides=changes)


# ---------------------------------------------------------------------------- evaluation
def evaluation_settings(recipe: Recipe) -> list[dict]:
    """The reference evaluation first, then each ``also`` one with the reference's values where unset."""
    protocol = recipe.evaluation
    reference = {"episodes": protocol.episodes, "seed": protocol.seed, "checkpoint": protocol.checkpoint,
                 "arm_collision": protocol.arm_collision, "stochastic": False, "base_planner": None,
                 "arm_planner": None}
    settings = [reference]
    for extra in protocol.also:
        given = {key: value for key, value in extra.model_dump().items()
                 if value is not None and value != ExtraEvaluation.model_fields[key].default}
        settings.append({**reference, **given})
    return settings


def evaluate_setting(run_dir: str, setting: dict) -> dict:
    """One evaluation of a finished run (in a worker process), saved in ``RUN/eval/`` as ``relmogen eval`` does."""
    from relmogen.experiments.evaluate import evaluate_path

    result = evaluate_path(Path(run_dir), setting["episodes"], setting["seed"], setting["base_planner"],
                           setting["arm_planner"], setting["arm_collision"], quiet=True,
                           stochastic=setting["stochastic"], checkpoint=setting["checkpoint"])
    return {"success_rate": result["success_rate"]}


def evaluate_runs(out: Path, manifest: dict, recipe: Recipe, executor, quiet: bool) -> None:
    """Runs every evaluation not yet recorded in the manifest (``evaluations``: indices done)."""
    settings = evaluation_settings(recipe)
    jobs = []
    for key, entry in manifest["runs"].items():
        if entry["state"] != "done":
            continue
        for index, setting in enumerate(settings):
            if index not in entry.setdefault("evaluations", []):
                jobs.append((f"{key}#{index}", evaluate_setting, (str(out / entry["run_dir"]), setting)))

    def record(job: str, result: dict | None, error: str | None) -> None:
        key, index = job.split("#")
        entry = manifest["runs"][key]
        if error is None:
            entry["evaluations"] = sorted(set(entry["evaluations"]) | {int(index)})
        else:
            entry["eval_error"] = error
            if not quiet:
                print(f"relmogen reproduce: evaluation {index} of {key} failed: {error}")
        write_manifest(out, manifest)

    if jobs:
        executor.run(jobs, lambda job: None, record)


# --------------------------------------------------------------------------------- report
def write_cell_report(out: Path, manifest: dict, recipe: Recipe) -> Path | None:
    """``OUT/<Task>__<algo>/`` (table.md, table.json, curves.png, COMMANDS.md) and ``OUT/README.md``
    from the seeds whose reference evaluation exists; None when there is none yet."""
    from relmogen.experiments.report import write_report
    from relmogen.experiments.table1 import write_table1

    run_dirs = [out / entry["run_dir"] for entry in manifest["runs"].values()
                if entry["state"] == "done" and 0 in entry.get("evaluations", [])]
    if not run_dirs:
        return None
    folder = out / recipe.name
    write_report(run_dirs, folder, checkpoint=recipe.evaluation.checkpoint)
    (folder / "COMMANDS.md").write_text(commands_text(manifest, run_dirs, out))
    return write_table1(out)


def commands_text(manifest: dict, run_dirs: list[Path], out: Path) -> str:
    recipe = manifest["recipe"]
    seeds = " ".join(str(seed) for seed in manifest["seeds"])
    lines = ["# Commands", "", f"Made by `relmogen reproduce` from the recipe `{recipe['name']}` (sha256 "
             f"{recipe['sha256'][:12]}) at commit {recipe['commit'] or 'unknown'}:", "", "```bash",
             f"relmogen reproduce {recipe['name']} --seeds {seeds} --out {out.name}", "```", "",
             "Run folders (each seed's last stage):", ""]
    lines += [f"- `{run_dir.relative_to(out)}`" for run_dir in sorted(run_dirs)]
    return "\n".join(lines + [""])


# -------------------------------------------------------------------------------- publish
RUN_FILES_LEFT_OUT = ("checkpoints", "tb", "*.log", "events.out.tfevents*", "*.pkl", "*.zip")


def publish_report(out: Path, manifest: dict, folder: Path) -> Path:
    """Copies ``OUT/<cell>/`` and the seeds' run folders (results only) into ``folder/<cell>/``, or
    into ``folder/<cell>/reruns/<commit>-<host kind>/`` when the cell already holds a figure, and
    rewrites ``folder/README.md``; returns where the report went."""
    from relmogen.experiments.table1 import write_table1

    name = manifest["recipe"]["name"].split("/")[-1]
    cell = Path(folder) / name
    target = cell / "reruns" / rerun_label(manifest) if (cell / "table.json").is_file() else cell
    shutil.copytree(out / name, target, dirs_exist_ok=True)
    for entry in manifest["runs"].values():
        first_stage = {run_dir: stage for stage, run_dir in reversed(entry.get("stages", {}).items())}
        for run_dir, stage in first_stage.items():  # a continued stage trained on in its first stage's folder
            shutil.copytree(out / run_dir, target / "runs" / stage / Path(run_dir).name, dirs_exist_ok=True,
                            ignore=shutil.ignore_patterns(*RUN_FILES_LEFT_OUT))
    recipe = {key: value for key, value in manifest["recipe"].items() if key != "path"}  # no machine's paths
    (target / "rerun.json").write_text(json.dumps({"recipe": recipe, "host": manifest.get("host"),
                                                   "seeds": manifest["seeds"]}, indent=1) + "\n")
    write_table1(Path(folder))
    return target


def rerun_label(manifest: dict) -> str:
    host = manifest.get("host") or {}
    return f"{manifest['recipe']['commit'] or 'unknown'}-{host.get('host_kind', 'unknown')}"


def current_commit() -> str | None:
    try:
        found = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=Path(__file__).parent, text=True,
                               capture_output=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return found.stdout.strip() or None


# ------------------------------------------------------------------------------- driver
def new_manifest(recipe: Recipe, path: Path, seeds: list[int]) -> dict:
    runs = {run_key(recipe.task, recipe.algo, seed): {"state": "pending", "run_dir": None, "error": None}
            for seed in seeds}
    return {"version": 1, "kind": MANIFEST_KIND, "seeds": seeds, "runs": runs,
            "recipe": {"name": recipe.name, "path": str(path), "sha256": content_sha256(path),
                       "commit": current_commit()},
            "host": current_host()}


def current_host() -> dict:
    host = host_info()
    return {"cpu_model": host["cpu_model"], "host_kind": host["host_kind"]}


def open_manifest(out: Path, recipe_arg: str, seeds: list[int] | None, resume: bool) -> dict:
    path = recipe_path(recipe_arg)
    if not resume:
        if (out / MANIFEST).is_file():
            raise ValueError(f"{out} already holds a run; continue it with relmogen reproduce {recipe_arg} --resume "
                             f"--out {out}")
        recipe = load_recipe(path)
        return new_manifest(recipe, path, seeds or recipe.seeds)
    manifest = read_manifest(out)
    if manifest.get("kind") != MANIFEST_KIND:
        raise ValueError(f"{out}/{MANIFEST} is a relmogen sweep's, not a reproduction; use relmogen sweep --resume")
    recorded = manifest["recipe"]["sha256"]  # of the recipe's data; of its bytes in manifests before 2026-12-08
    if recorded not in (content_sha256(path), file_sha256(path)) or (seeds and seeds != manifest["seeds"]):
        raise ValueError(f"{out} reproduces {manifest['recipe']['name']} (seeds {manifest['seeds']}) as it was "
                         "then; the recipe or the seeds differ now: start it in a new --out")
    manifest.setdefault("host", current_host())  # manifests written before hosts were recorded
    return manifest


def follow_stages(out: Path, manifest: dict, recipe: Recipe, poll):
    """The live table's poll: a running seed shows its newest stage's run."""
    def poll_stages() -> None:
        poll()
        for key, entry in manifest["runs"].items():
            if entry["state"] != "running":
                continue
            for name in reversed(list(recipe.stages)):
                found = sorted((out / RUNS / recipe.run_root(name)).glob(f"{key}__*"))
                if found:
                    entry["run_dir"] = str(found[-1].relative_to(out))
                    break
    return poll_stages


def record_stages(manifest: dict, on_finish):
    def finished(key: str, result: dict | None, error: str | None) -> None:
        if result is not None:
            manifest["runs"][key]["stages"] = result["stages"]
        on_finish(key, result, error)
    return finished


def run_reproduce(recipe_arg: str, out: Path, seeds: list[int] | None = None, resume: bool = False,
                  backend: str = "ray", address: str | None = None, cpus_per_run: float = 1,
                  quiet: bool = False, publish: Path | None = None) -> dict:
    """Train, evaluate and report a recipe in ``out`` (and publish it in ``publish``); returns the
    manifest (its ``report``: OUT/README.md or None; ``published``: where the copy went)."""
    out = Path(out).resolve()
    manifest = open_manifest(out, recipe_arg, seeds, resume)
    recipe = load_recipe(manifest["recipe"]["path"])
    from relmogen.experiments.train import check_trainable

    for seed in manifest["seeds"]:  # every name and value checked before anything runs
        check_trainable(next(iter(resolve_stages(recipe, seed).values())))
    (out / RUNS).mkdir(parents=True, exist_ok=True)
    write_manifest(out, manifest)
    executor = make_backend(backend, cpus_per_run, address)
    try:
        todo = [key for key, entry in manifest["runs"].items() if entry["state"] != "done"]
        jobs = [(key, execute_seed, (str(out), manifest["recipe"]["path"], int(key.rsplit("__", 1)[1])))
                for key in todo]
        on_start, on_finish, poll = manifest_updates(out, manifest, serial=executor.name == "serial")
        with LiveTable(out, manifest, quiet):
            executor.run(jobs, on_start, record_stages(manifest, on_finish),
                         follow_stages(out, manifest, recipe, poll))
        evaluate_runs(out, manifest, recipe, executor, quiet)
    finally:
        executor.close()
    report = write_cell_report(out, manifest, recipe)
    manifest["report"] = str(report) if report else None
    if report and publish is not None:
        manifest["published"] = str(publish_report(out, manifest, publish))
    write_manifest(out, manifest)
    return manifest
