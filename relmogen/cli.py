"""The ``relmogen`` command line.

    relmogen --version
    relmogen tasks [--json]
    relmogen demo  [--episodes N] [--seed S] [--out DIR] [--video PATH.gif|mp4] [--json]
    relmogen oracle --task T [--episodes N] [--policy oracle|random] [--control subgoal-r|subgoal-d]
                    [--image-size PX] [--push-frame base|surface] [--scene S] [--base-planner X]
                    [--arm-planner Y] [--arm-collision on|off] [--video PATH.gif|mp4] [--json]
    relmogen bench env [--task T] [--samples N] [--image-size PX] [--subgoal-samples N] [--json]
    relmogen bench planner [--problems N] [--seed S] [--json]
    relmogen bench train [--task T] [--updates N] [--subgoals N] [--probes] [--json]
    relmogen bench sweep [--task T] [--preset NAME] [--episodes N] [--json]
    relmogen train --task T --algo A [--seed S] [--preset NAME|FILE.yaml] [--episodes N] [--max-hours H]
                   [--device auto] [--out runs/] [--set section.key=value ...] [--resume RUN_DIR] [--quiet] [--json]
    relmogen sweep --tasks T... --algos A... --seeds S... [--preset NAME|FILE.yaml] [--set key=value ...]
                   [--episodes N | --cpu-hours H] --out DIR [--backend ray|serial] [--address ADDR]
                   [--cpus-per-run C] [--eval-episodes N] [--resume] [--quiet]
    relmogen sweep --report DIR [--eval-episodes N] [--backend ray|serial]
    relmogen eval RUN_DIR_OR_CHECKPOINT_OR_POLICY [--checkpoint latest|best|PATH] [--episodes N] [--seed S]
                  [--base-planner X] [--arm-planner Y] [--arm-collision on|off] [--scene A|B] [--robot R]
                  [--base-goal RULE] [--base-goal-clearance M] [--stochastic] [--skip-no-ops]
                  [--critic-select K] [--video PATH.gif|mp4] [--json]
    relmogen export RUN_DIR_OR_CHECKPOINT [--checkpoint latest|best|PATH] --out DIR
    relmogen report RUN_DIRS... --out DIR [--checkpoint latest|best] [--curves-only]
    relmogen report --table1 DIR
    relmogen report --table2 DIR --out OUT
    relmogen report --figure4 DIR [--out OUT]
    relmogen viz qmap RUN_DIR_OR_CHECKPOINT [--task T] [--out DIR] [--states N] [--seed S] [--drive oracle]
    relmogen viz subgoals RUN_DIR_OR_CHECKPOINT|POLICY_DIR [--checkpoint latest|best|PATH] [--episodes N] [--seed S]
                          [--stochastic] [--robot NAME] [--out PNG]
    relmogen viz exploration RUN_DIR... [--checkpoint latest|best|PATH] [--episodes N] [--pca-episodes N]
                             [--seed S] [--deterministic] [--out-dir DIR]
    relmogen analyse TOPIC ...   (relmogen analyse --help: the analyses behind README's and docs' figures)
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np

from relmogen import __version__
from relmogen.motion_generation.base_planner import GOAL_MODES

CHECKPOINT_METAVAR = "latest|best|PATH"  # relmogen.experiments.evaluate.resolve_checkpoint
PLANNER_PROBLEMS_DEFAULT = 8  # the whole `bench planner` run stays under ~3 minutes on 2 cores


def _print_metrics(metrics: dict, as_json: bool, title: str) -> None:
    if as_json:
        print(json.dumps(metrics, sort_keys=True))
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=title)
    table.add_column("metric")
    table.add_column("value", justify="right")
    for key, value in metrics.items():
        table.add_row(key, _metric_text(value))
    Console().print(table)


def _metric_text(value) -> str:
    if isinstance(value, float):
        return f"{value:.3f}"
    if isinstance(value, dict):
        return ", ".join(f"{key} {_metric_text(item)}" for key, item in value.items())
    return str(value)


def cmd_tasks(args: argparse.Namespace) -> int:
    from relmogen.experiments.task_catalogue import task_catalogue

    rows = task_catalogue()
    if args.json:
        print(json.dumps(rows))
        return 0
    from rich.console import Console
    from rich.table import Table

    controls = ("joint", "subgoal-r", "subgoal-d")
    table = Table(title="tasks", caption="Gymnasium id relmogen/<task>-v0; episode length in 0.1 s steps "
                                         "(joint) or subgoals (r: subgoal-r, d: subgoal-d)")
    table.add_column("task", no_wrap=True)
    table.add_column("scene")
    table.add_column("episode length\njoint / r / d", justify="center")
    table.add_column("metrics", overflow="fold")
    for row in rows:
        lengths = " / ".join(str(row["episode_steps"][control]) for control in controls)
        table.add_row(row["task"], row["scene"], lengths, ", ".join(row["metrics"]))
    Console().print(table)
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    from relmogen.experiments.demo import run_demo

    metrics = run_demo(episodes=args.episodes, seed=args.seed, out_dir=Path(args.out), quiet=args.json,
                       video=Path(args.video) if args.video else None)
    _print_metrics(metrics, args.json, f"{metrics['task']} demo (shipped {metrics['policy']} policy)")
    return 0


def cmd_oracle(args: argparse.Namespace) -> int:
    from relmogen.experiments.oracle import run_oracle

    result = run_oracle(args.task, args.episodes, args.policy, args.control, args.seed, args.scene,
                        args.base_planner, args.arm_planner, args.arm_collision == "on", quiet=args.json,
                        video=Path(args.video) if args.video else None, image_size=args.image_size,
                        push_frame=args.push_frame, qmap_size=args.qmap_size, robot=args.robot,
                        arm_collision_backend=args.arm_collision_backend)
    _print_metrics(result, args.json, f"{args.task}: {args.policy} subgoals")
    return 0


def cmd_train(args: argparse.Namespace) -> int:
    from relmogen.experiments.config import resolve_config
    from relmogen.experiments.env_workers import EnvWorkerError
    from relmogen.experiments.budgets import stop_reason
    from relmogen.experiments.checkpoints import run_config_file
    from relmogen.experiments.resume import resume, resume_budget_note
    from relmogen.experiments.session import TrainingStopped
    from relmogen.experiments.train import train

    overrides = args.set + ([f"env.robot={args.robot}"] if args.robot else [])
    try:
        if args.resume:
            if args.init_from or args.init_replay:
                raise ValueError("--init-from / --init-replay start a new run; --resume continues one: give one of them")
            run_config_file(Path(args.resume))
            note = resume_budget_note(Path(args.resume), args.episodes, args.max_hours, overrides)
            run_dir = resume(Path(args.resume), quiet=args.quiet, episodes=args.episodes, max_hours=args.max_hours,
                             overrides=overrides)
            if note is not None:  # nothing trained: which budget is spent and how to raise it, not the old stop line
                return _print_run(run_dir, args.json, note)
        else:
            task, algo = args.task, args.algo
            if args.init_from and not (task and algo):  # the source run's, unless given
                from relmogen.experiments.config import read_config
                from relmogen.experiments.evaluate import resolve_checkpoint

                source = read_config(resolve_checkpoint(Path(args.init_from))[1] / "config.yaml")
                task, algo = task or source.task, algo or source.algo
            if not task or not algo:
                raise ValueError("--task and --algo are required unless --resume (or --init-from) is given")
            config = resolve_config(task, algo, args.seed, args.preset, args.episodes or 1000, args.device,
                                    overrides, args.max_hours)
            run_dir = train(config, Path(args.out), quiet=args.quiet,
                            init_from=Path(args.init_from) if args.init_from else None, init_replay=args.init_replay)
    except EnvWorkerError as error:  # checkpoint written; one line that says how to continue
        print(f"relmogen: error: {error}", file=sys.stderr)
        return 1
    except TrainingStopped as stopped:
        print(f"relmogen: {stopped}", file=sys.stderr)
        return STOPPED_EXIT_CODE
    return _print_run(run_dir, args.json, stop_reason(run_dir))


def _print_run(run_dir: Path, as_json: bool, line: str) -> int:
    """The end of ``relmogen train``: ``line`` on stderr; on stdout only the run directory (or, with
    ``--json``, one object of it and ``done.json``), so ``RUN=$(relmogen train ...)`` is one directory."""
    print(f"relmogen: {line}", file=sys.stderr)
    if as_json:
        done = json.loads((run_dir / "done.json").read_text())
        print(json.dumps({"run_dir": str(run_dir), **done}, sort_keys=True))
    else:
        print(run_dir)
    return 0


STOPPED_EXIT_CODE = 130  # the shell's code for a process ended by SIGINT


def cmd_sweep(args: argparse.Namespace) -> int:
    from relmogen.experiments.sweep import SweepSpec, evaluate_and_report, failed_runs, make_backend, run_sweep

    if args.report is not None:
        if args.out is not None or args.resume or args.tasks or args.algos or args.seeds:
            raise ValueError("sweep --report DIR takes neither --out, --resume nor --tasks/--algos/--seeds")
        executor = make_backend(args.backend, args.cpus_per_run, args.address)
        try:
            readme = evaluate_and_report(Path(args.report), executor=executor, eval_episodes=args.eval_episodes,
                                         quiet=args.quiet)
        finally:
            executor.close()
        if readme is None:
            raise ValueError(f"no finished run in {args.report} to report")
        print(readme)
        return 0
    if args.out is None:
        raise ValueError("sweep needs --out DIR (or --report DIR)")
    spec = None
    given = [name for name in ("tasks", "algos", "seeds") if getattr(args, name)]
    if given or not args.resume:
        if len(given) < 3:
            raise ValueError("a sweep needs --tasks, --algos and --seeds (or --resume --out DIR)")
        from relmogen.experiments.config import recorded_preset

        spec = SweepSpec(tasks=args.tasks, algos=args.algos, seeds=args.seeds, preset=recorded_preset(args.preset),
                         overrides=args.set, episodes=args.episodes, cpu_hours=args.cpu_hours, device=args.device)
    manifest = run_sweep(Path(args.out), spec, resume=args.resume, backend=args.backend, address=args.address,
                         cpus_per_run=args.cpus_per_run, eval_episodes=args.eval_episodes, quiet=args.quiet)
    errors = failed_runs(manifest, "run", f"relmogen sweep --resume --out {args.out}")
    if errors:
        print("\n".join(errors), file=sys.stderr)
        return 1
    print(Path(args.out) / "README.md")
    return 0


def cmd_reproduce(args: argparse.Namespace) -> int:
    from relmogen.experiments.recipes import dry_run_text, listing_rows, load_recipe

    if args.list:
        if args.recipe or args.dry_run:
            raise ValueError("reproduce --list takes no RECIPE and no --dry-run")
        _print_recipe_listing(listing_rows())
        return 0
    if args.recipe is None:
        raise ValueError("reproduce needs a RECIPE (relmogen reproduce --list shows them)")
    recipe = load_recipe(args.recipe)
    if args.dry_run:
        print(dry_run_text(recipe, args.seeds), end="")
        return 0
    from relmogen.experiments.reproduce import run_reproduce
    from relmogen.experiments.sweep import failed_runs

    out = Path(args.out or Path("runs") / "reproduce" / recipe.name)
    manifest = run_reproduce(args.recipe, out, args.seeds, resume=args.resume, backend=args.backend,
                             address=args.address, cpus_per_run=args.cpus_per_run, quiet=args.quiet,
                             publish=args.publish)
    errors = failed_runs(manifest, "seed run", f"relmogen reproduce {args.recipe} --resume --out {out}")
    if errors:
        print("\n".join(errors), file=sys.stderr)
        return 1
    if manifest.get("published"):
        print(f"relmogen reproduce: published in {manifest['published']}", file=sys.stderr)
    print(manifest["report"])
    return 0


def _print_recipe_listing(rows: list[dict]) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title="recipes (relmogen/configs/recipes)")
    for column in ("recipe", "metric", "paper", "ours (mean / std / max)", "seeds", "stages", "episodes/seed",
                   "CPU h/seed"):
        table.add_column(column, no_wrap=column == "recipe")
    for row in rows:
        table.add_row(row["recipe"], row["metric"], f"{row['paper']:.2f}", row["ours"], str(row["seeds"]),
                      str(row["stages"]), str(row["episodes_per_seed"]), str(row["cpu_hours_per_seed"]))
    Console(width=160).print(table)


def cmd_eval(args: argparse.Namespace) -> int:
    from relmogen.experiments.evaluate import evaluate_path

    result = evaluate_path(Path(args.path), args.episodes, args.seed, args.base_planner, args.arm_planner,
                           args.arm_collision == "on", args.scene, args.device,
                           stochastic=args.stochastic, skip_no_ops=args.skip_no_ops, checkpoint=args.checkpoint,
                           video=Path(args.video) if args.video else None, robot=args.robot,
                           base_goal=args.base_goal, base_goal_clearance=args.base_goal_clearance,
                           critic_select=args.critic_select)
    _print_metrics(result, args.json, f"evaluation of {args.path}")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    from relmogen.experiments.shipped import export_actor
    from relmogen.experiments.evaluate import load_checkpoint, resolve_checkpoint
    from relmogen.experiments.report import checkpoint_evaluations

    checkpoint, run_dir = resolve_checkpoint(Path(args.run), args.checkpoint)
    model, config = load_checkpoint(checkpoint, run_dir, device="cpu")
    state = json.loads((checkpoint / "state.json").read_text())
    provenance = {"run": run_dir.name, "command": " ".join(sys.argv), "checkpoint": checkpoint.name, **state,
                  "evaluations": checkpoint_evaluations(run_dir, checkpoint.name)}
    if args.note:
        provenance["note"] = args.note
    out = export_actor(model, config, Path(args.out), provenance)
    print(f"wrote {out}")
    return 0


def cmd_viz_qmap(args: argparse.Namespace) -> int:
    from relmogen.visualisation.qmap import q_map_figures_for_checkpoint

    paths = q_map_figures_for_checkpoint(Path(args.checkpoint), Path(args.out), args.task, args.states, args.seed,
                                         args.stride, args.device, args.drive)
    for path in paths:
        print(path)
    if args.drive == "oracle":
        fields = json.loads((Path(args.out) / "oracle_cells.json").read_text())
        print(json.dumps({key: value for key, value in fields.items() if key != "states"}))
    return 0


def cmd_viz_subgoals(args: argparse.Namespace) -> int:
    from relmogen.visualisation.subgoals import subgoal_figure

    result = subgoal_figure(Path(args.run), Path(args.out), args.episodes, args.seed, args.checkpoint, args.device,
                            args.stochastic, args.robot)
    print(result["figure"])
    print(json.dumps({key: value for key, value in result.items() if key not in ("episode_records", "base", "arm")}))
    return 0


def cmd_viz_exploration(args: argparse.Namespace) -> int:
    from relmogen.visualisation.exploration import exploration_figure

    result = exploration_figure([Path(run) for run in args.runs], Path(args.out_dir), args.episodes, args.seed,
                                args.pca_episodes, args.checkpoint, args.device, stochastic=not args.deterministic)
    print(result["figure"])
    for run in result["runs"]:
        print(json.dumps({"run": run["run"], "algo": run["algo"], "checkpoint_episode": run["checkpoint_episode"],
                          "median_relative_step": run["pca"]["median_relative_step"],
                          "coverage_m2": run["coverage_m2"], "interactions": run["interaction_count"]}))
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from relmogen.experiments.report import write_curves, write_report
    from relmogen.experiments.table1 import write_table1
    from relmogen.experiments.table2 import write_table2

    if args.curves_only and (args.table1 is not None or args.table2 is not None or args.figure4 is not None):
        raise ValueError("--curves-only redraws the curves.png of RUN_DIR... --out DIR; not with --table1/--table2/"
                         "--figure4")
    if args.figure4 is not None:
        from relmogen.experiments.figure4 import write_figure4

        if args.runs or args.table1 is not None or args.table2 is not None:
            raise ValueError("report --figure4 DIR [--out OUT] takes neither RUN_DIRs, --table1 nor --table2")
        paths = write_figure4(Path(args.figure4), Path(args.out) if args.out is not None else None)
        print(paths.pop("markdown").read_text())
        print(json.dumps({task: str(path) for task, path in paths.items()}))
        return 0
    if args.table1 is not None:
        if args.runs or args.out is not None or args.table2 is not None:
            raise ValueError("report --table1 DIR takes neither RUN_DIRs, --table2 nor --out")
        print(write_table1(Path(args.table1)).read_text())
        return 0
    if args.table2 is not None:
        if args.runs or args.out is None:
            raise ValueError("report --table2 DIR needs --out OUT and no RUN_DIRs")
        write_table2(Path(args.table2), Path(args.out))
        print((Path(args.out) / "table.md").read_text())
        return 0
    if not args.runs or args.out is None:
        raise ValueError("report needs RUN_DIR... --out DIR, --table1 DIR, or --table2 DIR --out OUT")
    if args.curves_only:  # the figure alone: table.md and table.json stay as written
        print(write_curves([Path(p) for p in args.runs], Path(args.out)))
        return 0
    result = write_report([Path(p) for p in args.runs], Path(args.out), args.checkpoint)
    print(result.pop("markdown"))
    print(json.dumps(result))
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    from relmogen.experiments.host import host_info

    if args.what == "env":
        from relmogen.bench.env_bench import bench_env

        result = bench_env(task=args.task or "PointNav", samples=args.samples, image_size=args.image_size, seed=args.seed,
                           subgoal_samples=args.subgoal_samples)
    elif args.what == "planner":
        return _bench_planner(args)
    elif args.what == "sweep":
        from relmogen.bench.sweep_bench import bench_sweep

        result = {**bench_sweep(task=args.task or "PointNav", preset=args.preset, episodes=args.episodes),
                  "host": host_info()}
        print(json.dumps(result, sort_keys=True) if args.json else json.dumps(result, indent=1))
        return 0
    elif args.what == "train":
        from relmogen.bench.train_bench import bench_train

        result = {**bench_train(task=args.task or "PushDoorNav", updates=args.updates, subgoals=args.subgoals,
                                probes=args.probes), "host": host_info()}
        print(json.dumps(result, sort_keys=True) if args.json else json.dumps(result, indent=1))
        return 0
    else:  # argparse restricts the choices
        raise AssertionError(args.what)
    _print_metrics({**result, "host": host_info()}, args.json, f"bench {args.what}")
    return 0


def _bench_planner(args: argparse.Namespace) -> int:
    from relmogen.experiments.host import host_info
    from relmogen.bench.planner_bench import bench_planner, planning_runs, print_planner_table

    if args.json:
        result = bench_planner(problems=args.problems, seed=args.seed, robot=args.robot)
        print(json.dumps({**result, "host": host_info()}, sort_keys=True))
        return 0
    from rich.console import Console
    from rich.progress import Progress

    with Progress(console=Console(stderr=True), transient=True) as progress:
        task = progress.add_task("planning", total=planning_runs(args.problems))
        result = bench_planner(problems=args.problems, seed=args.seed, advance=lambda: progress.advance(task),
                               robot=args.robot)
    print_planner_table(result)
    return 0


class _OneLineErrors(argparse.ArgumentParser):
    """argparse's usage errors as the CLI's other errors: one line, exit code 2, with the help to read."""

    def error(self, message: str):
        self.exit(2, f"relmogen: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _OneLineErrors(prog="relmogen", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}",
                        help="print the package version and exit")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND", help="what to do")
    for add in (_add_tasks, _add_demo, _add_oracle, _add_train, _add_sweep, _add_reproduce, _add_eval, _add_export,
                _add_viz, _add_report, _add_bench, _add_analyse):
        add(sub)
    return parser


def _add_tasks(sub) -> None:
    tasks = sub.add_parser("tasks", help="list the tasks: scene kind, metrics, episode length per control")
    tasks.add_argument("--json", action="store_true", help="print the list as one JSON array")
    tasks.set_defaults(func=cmd_tasks)


def _add_demo(sub) -> None:
    demo = sub.add_parser("demo", help="run the shipped policy, print its metrics and write a GIF")
    demo.add_argument("--episodes", type=_positive_int, default=1, help="episodes to run (default 1)")
    demo.add_argument("--seed", type=int, default=0, help="seed of the first episode (default 0)")
    demo.add_argument("--out", default="out/demo", help="folder for the GIF (default out/demo)")
    demo.add_argument("--video", metavar="PATH", default=None,
                      help="write the first episode annotated (subgoals, rewards, plans) to this .gif or .mp4 "
                           "instead of the plain GIF")
    demo.add_argument("--json", action="store_true", help="print the metrics as one JSON object")
    demo.set_defaults(func=cmd_demo)


def _add_oracle(sub) -> None:
    oracle = sub.add_parser("oracle", help="run the scripted (or random) subgoal policy of a task")
    oracle.add_argument("--task", required=True, help="task name (relmogen tasks lists them)")
    oracle.add_argument("--episodes", type=_positive_int, default=10, help="episodes to run (default 10)")
    oracle.add_argument("--policy", choices=["oracle", "random"], default="oracle",
                        help="the task's scripted oracle or uniformly random subgoals (default oracle)")
    oracle.add_argument("--control", choices=["subgoal-r", "subgoal-d"], default="subgoal-r",
                        help="subgoal-d: each oracle action executed as the nearest discrete SGP-D action")
    oracle.add_argument("--image-size", type=_positive_int, default=128, help="camera resolution (default 128)")
    oracle.add_argument("--push-frame", choices=["base", "surface"], default="base", help="subgoal-d's push bins")
    oracle.add_argument("--qmap-size", type=_positive_int, default=None,
                        help="subgoal-d's Q-map side (default: image size / 4, the paper's)")
    oracle.add_argument("--seed", type=int, default=0, help="seed of the first episode (default 0)")
    oracle.add_argument("--scene", default=None, help="scene name, e.g. office_B (default: the task's, layout A)")
    oracle.add_argument("--robot", default="fetch", metavar="NAME", help="robot: fetch (default) or movo")
    _add_planner_options(oracle, default="rrt_connect")
    oracle.add_argument("--arm-collision-backend", choices=["pybullet", "coal"], default=None,
                        help="who answers the arm's collision queries in IK solves and plans (default: "
                             "ArmConfig.collision_backend)")
    oracle.add_argument("--video", "--gif", dest="video", default=None, metavar="PATH",
                        help="also record one episode, annotated, to this .gif or .mp4")
    oracle.add_argument("--json", action="store_true", help="print the metrics as one JSON object")
    oracle.set_defaults(func=cmd_oracle)


def _add_planner_options(parser: argparse.ArgumentParser, default: str | None) -> None:
    """--base-planner, --arm-planner and --arm-collision, shared by oracle and eval."""
    shown = default or "the run's"
    parser.add_argument("--base-planner", default=default,
                        help=f"base planner: rrt_connect, lazy_prm, ompl_rrtconnect or ompl_prm (default {shown})")
    parser.add_argument("--arm-planner", default=default, help=f"arm planner, same choices (default {shown})")
    parser.add_argument("--arm-collision", choices=["on", "off"], default="on",
                        help="collision checking of arm plans (default on)")


def _add_train(sub) -> None:
    train = sub.add_parser("train", help="train a policy (SB3), with checkpoints and resume")
    train.add_argument("--task", help="task name (relmogen tasks lists them)")
    train.add_argument("--algo", help="relmogen-r, relmogen-d, sac, oac or hrl4in")
    train.add_argument("--seed", type=int, default=0, help="training seed (default 0)")
    train.add_argument("--preset", default="cpu",
                       help="a preset of relmogen/configs/presets (cpu, paper, tiny; default cpu) or the path of a "
                            "YAML file with the same sections")
    train.add_argument("--episodes", type=_positive_int, default=None, help="episode budget (default 1000)")
    train.add_argument("--max-hours", type=float, default=None, help="stop after this much wall-clock time")
    train.add_argument("--device", default="auto", help="torch device: auto (CUDA if present), cpu or cuda")
    train.add_argument("--out", default="runs", help="folder the run directory is made in (default runs)")
    train.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                       help="override a preset value, e.g. --set algo.batch_size=32 --set env.n_envs=4; with --resume, "
                            "learning parameters only (e.g. algo.exploration_final_eps=0.2, algo.buffer_size=50000)")
    train.add_argument("--resume", default=None, metavar="RUN_DIR",
                       help="continue this run from its latest checkpoint instead of starting one")
    train.add_argument("--robot", default=None, metavar="NAME",
                       help="the embodiment, a folder of relmogen/robots/assets (fetch, movo): --set env.robot=NAME")
    train.add_argument("--init-from", default=None, metavar="RUN_OR_CHECKPOINT",
                       help="fine-tune: a new run starting from the weights of this run's latest checkpoint (or of "
                            "this checkpoint folder); same algorithm and spaces; --task/--algo default to its own")
    train.add_argument("--init-replay", action="store_true",
                       help="with --init-from: start with that run's latest replay buffer too")
    train.add_argument("--quiet", action="store_true", help="no progress bar (progress and logs go to stderr)")
    train.add_argument("--json", action="store_true",
                       help="print one JSON object (run_dir, episodes, timesteps, wall and CPU seconds, stop_reason) "
                            "instead of the run directory")
    train.set_defaults(func=cmd_train)


def _add_backend_arguments(parser: argparse.ArgumentParser, unit: str) -> None:
    """Where the runs go: Ray (here or on a cluster) or one after another in this process."""
    parser.add_argument("--backend", choices=["ray", "serial"], default="ray",
                        help=f"ray: each {unit} a Ray task (default); serial: one after another, without Ray")
    parser.add_argument("--address", default=None, metavar="ADDR",
                        help="an existing Ray cluster (e.g. HEAD:6379) instead of a local Ray started here")
    parser.add_argument("--cpus-per-run", type=_positive_float, default=1,
                        help=f"Ray CPUs reserved per {unit} (default 1; 0.5 runs two per core)")


def _add_reproduce(sub) -> None:
    reproduce = sub.add_parser("reproduce", help="train, evaluate and report a recipe (a Table I cell as data) "
                                                 "on Ray or one by one")
    reproduce.add_argument("recipe", nargs="?", default=None, metavar="RECIPE",
                           help="a recipe name (PointNav__relmogen-r or table1/PointNav__relmogen-r) or YAML file")
    reproduce.add_argument("--list", action="store_true",
                           help="list the recipes with the paper's value, ours and the CPU hours per seed")
    reproduce.add_argument("--seeds", nargs="+", type=int, default=None, metavar="S",
                           help="training seeds (default: the recipe's)")
    reproduce.add_argument("--dry-run", action="store_true",
                           help="print each stage's resolved configuration (YAML) of each seed; train nothing")
    reproduce.add_argument("--out", default=None, metavar="DIR",
                           help="folder of the runs, sweep.json and the report (default runs/reproduce/<Task>__<algo>)")
    _add_backend_arguments(reproduce, "seed")
    reproduce.add_argument("--resume", action="store_true",
                           help="continue the reproduction in --out: finished stages are skipped, the others resume")
    reproduce.add_argument("--quiet", action="store_true", help="no live table")
    reproduce.add_argument("--publish", nargs="?", const=Path("results/table1"), default=None, type=Path,
                           metavar="DIR", help="copy the report and the runs' results (no checkpoints) into "
                           "DIR/<Task>__<algo>/ (its reruns/ when the cell exists) and rewrite DIR/README.md "
                           "(default DIR: results/table1)")
    reproduce.set_defaults(func=cmd_reproduce)


def _add_sweep(sub) -> None:
    sweep = sub.add_parser("sweep", help="train every (task, algorithm, seed) on Ray or one by one, then report "
                                         "Table I")
    sweep.add_argument("--tasks", nargs="+", default=[], metavar="T", help="tasks (relmogen tasks lists them)")
    sweep.add_argument("--algos", nargs="+", default=[], metavar="A", help="relmogen-r, relmogen-d, sac, oac, hrl4in")
    sweep.add_argument("--seeds", nargs="+", type=int, default=[], metavar="S", help="training seeds")
    sweep.add_argument("--preset", default="cpu", help="preset name or YAML file, as for train (default cpu)")
    sweep.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                       help="override a preset value in every run, as for train")
    budget = sweep.add_mutually_exclusive_group()
    budget.add_argument("--episodes", type=_positive_int, default=None, help="episode budget per run (default 1000)")
    budget.add_argument("--cpu-hours", type=float, default=None,
                        help="CPU-time budget per run (trainer plus environment workers) instead of episodes")
    sweep.add_argument("--device", default="auto", help="torch device of every run (default auto)")
    sweep.add_argument("--out", default=None, metavar="DIR",
                       help="sweep folder: sweep.json, runs/, a report per task and algorithm, README.md")
    _add_backend_arguments(sweep, "run")
    sweep.add_argument("--eval-episodes", type=_positive_int, default=100,
                       help="episodes of each finished run's final evaluation (default 100, seed 100000, arm "
                            "collision on)")
    sweep.add_argument("--resume", action="store_true",
                       help="continue the sweep in --out: skip finished runs, resume the others from their checkpoint")
    sweep.add_argument("--report", default=None, metavar="DIR",
                       help="only evaluate the finished runs of the sweep in DIR and write its reports and README.md")
    sweep.add_argument("--quiet", action="store_true", help="no live table")
    sweep.set_defaults(func=cmd_sweep)


def _add_eval(sub) -> None:
    evaluate = sub.add_parser("eval", help="evaluate a trained policy")
    evaluate.add_argument("path", metavar="RUN_DIR_OR_CHECKPOINT_OR_POLICY",
                          help="a run directory, a checkpoint folder or an exported policy folder "
                               "(e.g. relmogen/policies/PushDoorNav-relmogen-r)")
    evaluate.add_argument("--checkpoint", default="latest", metavar=CHECKPOINT_METAVAR,
                          help="which model of the run: its latest checkpoint (default), the best periodic "
                               "evaluation during training, or a checkpoint folder")
    evaluate.add_argument("--episodes", type=_positive_int, default=100, help="episodes (default 100)")
    evaluate.add_argument("--seed", type=int, default=100_000,
                          help="seed of the first episode; the others follow (default 100000)")
    _add_planner_options(evaluate, default=None)
    evaluate.add_argument("--scene", default=None, help="A or B (or a full scene name)")
    evaluate.add_argument("--robot", default=None, metavar="NAME",
                          help="evaluate on this robot instead of the run's (fetch, movo; the spaces must match)")
    evaluate.add_argument("--base-goal", default=None, choices=list(GOAL_MODES),
                          help="a base goal the robot cannot reach: strict (no-op, the paper's), nearest_free or "
                               "nearest_reachable (drive toward it); default the run's")
    evaluate.add_argument("--base-goal-clearance", type=_non_negative_float, default=None, metavar="M",
                          help="metres a base goal must keep from obstacles beyond the footprint (0: the paper's); "
                               "default the run's")
    evaluate.add_argument("--device", default="auto", help="torch device: auto (CUDA if present), cpu or cuda")
    evaluate.add_argument("--stochastic", action="store_true",
                          help="sample SGP-R/SAC actions instead of the deterministic mean; "
                               "SGP-D acts epsilon-greedy at its final training epsilon")
    evaluate.add_argument("--skip-no-ops", action="store_true",
                          help="a test-time rule reported as its own policy, after a subgoal that left the camera "
                               "image and local map unchanged: SGP-D does not choose it again until they change, "
                               "SGP-R samples its next subgoal instead of taking the mean")
    evaluate.add_argument("--critic-select", type=_non_negative_int, default=0, metavar="K",
                          help="ours, a test-time rule reported as its own policy: of the actor's mean and K-1 fixed "
                               "samples around it, take the action the critics value highest (SGP-R, SAC, OAC)")
    evaluate.add_argument("--video", metavar="PATH", default=None,
                          help="record the first episode, annotated, to this .gif or .mp4")
    evaluate.add_argument("--json", action="store_true", help="print the metrics as one JSON object")
    evaluate.set_defaults(func=cmd_eval)


def _add_export(sub) -> None:
    export = sub.add_parser("export", help="write a run's trained SGP-R/SAC actor as a small shipped policy")
    export.add_argument("run", metavar="RUN_DIR_OR_CHECKPOINT", help="a run directory or a checkpoint folder")
    export.add_argument("--checkpoint", default="latest", metavar=CHECKPOINT_METAVAR,
                        help="which model of the run (default latest)")
    export.add_argument("--out", required=True, help="folder to write config.yaml, actor.pt, provenance.json")
    export.add_argument("--note", default=None, help="a line for provenance.json (where the run's story is told)")
    export.set_defaults(func=cmd_export)


def _add_viz(sub) -> None:
    viz = sub.add_parser("viz", help="figures of trained policies")
    viz_sub = viz.add_subparsers(dest="figure", required=True, metavar="FIGURE", help="which figure")
    qmap = viz_sub.add_parser("qmap", help="SGP-D Q maps over the RGB frame and the local map (paper Fig. A.2)")
    qmap.add_argument("checkpoint", metavar="RUN_DIR_OR_CHECKPOINT", help="a relmogen-d run or checkpoint folder")
    qmap.add_argument("--task", default=None, help="task to show (default: the one it was trained on)")
    qmap.add_argument("--out", default="out/qmap", help="folder for the PNGs (default out/qmap)")
    qmap.add_argument("--states", type=_positive_int, default=4, help="figures to draw (default 4)")
    qmap.add_argument("--stride", type=_positive_int, default=3, help="draw every N-th step (default 3)")
    qmap.add_argument("--seed", type=int, default=0, help="first evaluation episode seed")
    qmap.add_argument("--drive", choices=("greedy", "oracle"), default="greedy",
                      help="who acts: the policy (every --stride-th state drawn) or the task's oracle "
                           "(the state before each of its pushes drawn, its cell outlined and ranked)")
    qmap.add_argument("--device", default="auto", help="torch device: auto (CUDA if present), cpu or cuda")
    qmap.set_defaults(func=cmd_viz_qmap)
    subgoals = viz_sub.add_parser("subgoals", help="where a ReLMoGen policy's base subgoals end and its arm subgoals "
                                                   "land, top-down and on the camera, with a JSON of the points")
    subgoals.add_argument("run", metavar="RUN_DIR_OR_CHECKPOINT|POLICY_DIR",
                          help="a relmogen-r or relmogen-d run or checkpoint, or an exported actor's folder (relmogen "
                               "export; e.g. relmogen/policies/PushDoorNav-relmogen-r: greedy, on its own robot)")
    subgoals.add_argument("--checkpoint", default="latest", metavar=CHECKPOINT_METAVAR,
                          help="which model of the run (default latest)")
    subgoals.add_argument("--episodes", type=_positive_int, default=10, help="evaluation episodes (default 10)")
    subgoals.add_argument("--seed", type=int, default=100_000, help="seed of the first episode (default 100000)")
    subgoals.add_argument("--stochastic", action="store_true", help="sample actions instead of the greedy policy")
    subgoals.add_argument("--robot", default=None, metavar="NAME",
                          help="run the policy on this robot instead of the run's (fetch, movo; the spaces must match)")
    subgoals.add_argument("--out", default="out/subgoals.png", help="the PNG; its points go beside it as .json "
                                                                   "(default out/subgoals.png)")
    subgoals.add_argument("--device", default="auto", help="torch device: auto (CUDA if present), cpu or cuda")
    subgoals.set_defaults(func=cmd_viz_subgoals)
    exploration = viz_sub.add_parser("exploration", help="exploration of runs (paper Fig. 6): PCA of state "
                                                         "embeddings, base positions, interactions >= 1 s")
    exploration.add_argument("runs", nargs="+", metavar="RUN_DIR", help="run directories or checkpoints, any algorithm")
    exploration.add_argument("--checkpoint", default="latest", metavar=CHECKPOINT_METAVAR,
                             help="which model of each run (default latest)")
    exploration.add_argument("--episodes", type=_positive_int, default=10,
                             help="episodes per run for positions and interactions (default 10)")
    exploration.add_argument("--pca-episodes", type=_positive_int, default=10,
                             help="of those, the first N drawn in the PCA panel (default 10)")
    exploration.add_argument("--seed", type=int, default=0, help="seed of the first episode (default 0)")
    exploration.add_argument("--deterministic", action="store_true",
                             help="the greedy policy instead of sampled actions (as during training)")
    exploration.add_argument("--out-dir", default="out/exploration",
                             help="folder for exploration.png and exploration.json (default out/exploration)")
    exploration.add_argument("--device", default="auto", help="torch device: auto (CUDA if present), cpu or cuda")
    exploration.set_defaults(func=cmd_viz_exploration)


def _add_report(sub) -> None:
    report = sub.add_parser("report", help="table (mean/std/max over seeds) and curves of runs")
    report.add_argument("runs", nargs="*", metavar="RUN_DIR", help="run directories, one or more seeds per algorithm")
    report.add_argument("--out", help="where table.md, table.json and curves.png go (with --figure4: the figures)")
    report.add_argument("--table1", metavar="DIR", help="write DIR/README.md, the paper's Table I beside ours, "
                                                        "from DIR/*/table.json (one report per task and algorithm)")
    report.add_argument("--table2", metavar="DIR", help="with --out OUT: the paper's Tables II / A.4 (planner swap) and "
                                                        "A.2 (arm collision checking) beside ours, from DIR/*/table.json")
    report.add_argument("--figure4", metavar="DIR", help="the paper's Fig. 4 for the reward-only cells of the Table I "
                                                         "folder DIR: training return and Table I metric against "
                                                         "training episodes, OUT/figure4_<Task>.png and OUT/figure4.md "
                                                         "(--out OUT, default DIR/figure4)")
    report.add_argument("--checkpoint", choices=["latest", "best"], default="latest",
                        help="the reference table evaluates each run's latest checkpoint (default) or the best one "
                             "its periodic evaluations chose (an early-stopping protocol, shown as such in Table I)")
    report.add_argument("--curves-only", action="store_true",
                        help="with RUN_DIR... --out DIR: redraw only DIR/curves.png; table.md and table.json stay as "
                             "written")
    report.set_defaults(func=cmd_report)


def _add_bench(sub) -> None:
    bench = sub.add_parser("bench", help="speed benchmarks")
    bench.add_argument("what", choices=["env", "planner", "train", "sweep"], help="what to time")
    bench.add_argument("--task", default=None,
                       help="env: task of the joint-velocity steps (PointNav); train: task (PushDoorNav); "
                            "sweep: task of the relmogen-r runs (PointNav)")
    bench.add_argument("--preset", default="tiny", help="sweep: preset of the runs (default tiny)")
    bench.add_argument("--episodes", type=_positive_int, default=10, help="sweep: episodes per run (default 10)")
    bench.add_argument("--updates", type=_positive_int, default=10, help="train: gradient steps timed per run")
    bench.add_argument("--probes", action="store_true",
                       help="train: also the paper preset (128 px), the Q-map resolutions and bfloat16 (slow on "
                            "CPUs without native bfloat16)")
    bench.add_argument("--subgoals", type=_positive_int, default=1000,
                       help="train: subgoals of the real relmogen-r cpu training run, counted from its first update")
    bench.add_argument("--samples", type=_positive_int, default=200, help="env: joint-velocity steps")
    bench.add_argument("--image-size", type=_positive_int, default=128, help="env: camera resolution")
    bench.add_argument("--subgoal-samples", type=_non_negative_int, default=40,
                       help="env: lifted steps of each kind, base and arm (0 skips them)")
    bench.add_argument("--problems", type=_positive_int, default=PLANNER_PROBLEMS_DEFAULT,
                       help=f"planner: problems per category (default {PLANNER_PROBLEMS_DEFAULT})")
    bench.add_argument("--seed", type=int, default=0, help="seed of the problems or samples (default 0)")
    bench.add_argument("--robot", default="fetch", metavar="NAME", help="planner: the robot planned for (default fetch)")
    bench.add_argument("--json", action="store_true", help="print the results as one JSON object")
    bench.set_defaults(func=cmd_bench)


def _add_analyse(sub) -> None:
    from relmogen.analysis.cli import add_analyse_parser  # the analyses behind README's and docs' figures

    add_analyse_parser(sub)


def _positive_int(text: str) -> int:
    value = int(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def _positive_float(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text}")
    return value


def _non_negative_int(text: str) -> int:
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {text}")
    return value


def _non_negative_float(text: str) -> float:
    value = float(text)
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"must be a finite number >= 0, got {text}")
    return value


# argparse names a type in its errors ("invalid positive integer value: 'x'")
for _type, _name in ((_positive_int, "positive integer"), (_positive_float, "positive number"),
                     (_non_negative_int, "non-negative integer"), (_non_negative_float, "non-negative number")):
    _type.__name__ = _name


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except ValueError as exc:  # bad names and inputs: one clear line, no traceback
        print(f"relmogen: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    np.set_printoptions(precision=3)
    sys.exit(main())
