"""``relmogen analyse TOPIC ...``: the analyses of ``relmogen.analysis`` on the command line.

Each prints a Markdown table (rows, then a summary line where there is one) or, with ``--json``,
one JSON object. Imports are lazy, so ``relmogen --help`` stays quick.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path


def markdown_table(rows: list[dict]) -> str:
    """Rows as a Markdown table, columns in first-seen order; floats to 3 decimals, lists and
    dicts as JSON."""
    columns: list[str] = []
    for row in rows:
        columns += [key for key in row if key not in columns]

    def cell(value) -> str:
        if isinstance(value, float):
            return f"{value:.3f}" if math.isfinite(value) else str(value)
        if isinstance(value, (list, tuple, dict)):
            return json.dumps(value, default=str)
        return "-" if value is None else str(value)

    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    lines += ["| " + " | ".join(cell(row.get(key)) for key in columns) + " |" for row in rows]
    return "\n".join(lines)


def emit(args: argparse.Namespace, rows: list[dict], summary: dict | None = None, key: str = "rows") -> int:
    if args.json:
        print(json.dumps({key: rows, **({"summary": summary} if summary is not None else {})}, default=str))
        return 0
    if rows:
        print(markdown_table(rows))
    if summary is not None:
        print(json.dumps(summary, default=str))
    return 0


def write_json(path: str | None, data) -> None:
    if path:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(json.dumps(data, indent=1, default=str) + "\n")


def _positive(text: str) -> int:
    value = int(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def _json_flag(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of a Markdown table")


# ---------------------------------------------------------------------------------------- handlers
def cmd_training(args) -> int:
    from relmogen.analysis.training import windows

    rows = [{"run": Path(run).name, **row} for run in args.runs for row in windows(run, None if args.phases else args.window)]
    return emit(args, rows)


def cmd_curves(args) -> int:
    from relmogen.analysis.training import plot_curves

    groups: dict[str, list[Path]] = {}
    for run in args.runs:
        groups.setdefault(Path(run).resolve().parent.name, []).append(Path(run))
    for label, *runs in args.group or []:
        groups.setdefault(label, []).extend(map(Path, runs))
    if not groups:
        raise ValueError("name runs, or --group LABEL RUN...")
    print(plot_curves(groups, Path(args.out), args.window, args.cpu_hours, tuple(args.tags)))
    return 0


def cmd_choose(args) -> int:
    from relmogen.analysis.validation import choose

    chosen = [choose(run) for run in args.runs]
    write_json(args.out, chosen)
    rows = [{"run": c["run"], **model, "chosen": model["episode"] == c["chosen_episode"]}
            for c in chosen for model in c["models"]]
    return emit(args, rows)


def cmd_door_distance(args) -> int:
    from relmogen.analysis.subgoals import door_distance_row

    return emit(args, [door_distance_row(path) for path in args.figures])


def cmd_oracle_table(args) -> int:
    from relmogen.analysis.oracles import oracle_rows

    return emit(args, oracle_rows(args.folder))


def cmd_random_sgpd(args) -> int:
    from relmogen.analysis.oracles import random_sgpd

    result = random_sgpd(args.task, args.episodes, args.sampler, args.push_frame, args.mask_arm, args.image_size,
                         args.qmap_size, args.seed)
    return emit(args, [result])


def cmd_episodes(args) -> int:
    from relmogen.analysis.episodes import episode_traces, parse_assignments, summarise_traces, write_jsonl

    rows = episode_traces(args.policy, args.checkpoint, args.episodes, args.seed, parse_assignments(args.set),
                          parse_assignments(args.arm), deterministic=not args.stochastic)
    if args.out:
        write_jsonl(rows, args.out)
    shown = [{**row, "trace": " ".join(row["trace"])} for row in rows]
    return emit(args, shown, summarise_traces(rows))


def cmd_arm_settings(args) -> int:
    from relmogen.analysis.arm import oracle_figures, parse_setting, random_step_costs
    from relmogen.analysis.episodes import parse_assignments

    settings = dict(map(parse_setting, args.settings))
    if args.mode == "random":
        rows = [row for task in args.tasks for row in
                random_step_costs(task, settings, args.episodes or 20, args.image_size,
                                  env_options=parse_assignments(args.set))]
    else:
        rows = [{"setting": name, **oracle_figures(task, overrides, args.episodes or 50)}
                for task in args.tasks for name, overrides in settings.items()]
    return emit(args, rows)


def cmd_collision_backends(args) -> int:
    from relmogen.analysis.collision_backends import ARM_TASKS, agreement_rows

    rows, summary = agreement_rows(args.tasks or list(ARM_TASKS), args.configurations, args.seeds)
    return emit(args, rows, summary)


def cmd_door_front(args) -> int:
    from relmogen.analysis.arm import door_front_plan_rates, parse_setting

    return emit(args, door_front_plan_rates(dict(map(parse_setting, args.settings)), args.trials))


def cmd_ik_contacts(args) -> int:
    from relmogen.analysis.arm import ik_collisions

    result = ik_collisions(args.policy, args.seeds, args.checkpoint)
    summary = {"episodes": result["episodes"], "success_rate": result["success_rate"], "cases": len(result["cases"])}
    if args.json:
        print(json.dumps(result, default=str))
        return 0
    print(markdown_table(result["cases"]) if result["cases"] else "no arm subgoal with every IK solution in collision")
    if result["counts"]:
        print(markdown_table(result["counts"]))
    print(json.dumps(summary))
    return 0


def cmd_reach(args) -> int:
    from relmogen.analysis.reach import by_band, reach_samples

    samples = [row for task in args.tasks for row in
               reach_samples(args.robot, task, args.episodes, args.per_state, args.seed, args.image_size,
                             args.arm_collision == "on", args.base_moves)]
    table = by_band(samples)
    write_json(args.out, {"robot": args.robot, "tasks": args.tasks, "by_distance": table, "samples": samples})
    return emit(args, table)


def cmd_reach_mask(args) -> int:
    from relmogen.analysis.reach import reach_mask_cells, reach_mask_summary

    rows = reach_mask_cells(args.task, args.episodes, args.cells)
    summary = reach_mask_summary(rows)
    bands = [{"distance_m": band, **values} for band, values in summary.pop("by_distance").items()]
    return emit(args, bands, summary)


def cmd_button_presses(args) -> int:
    from relmogen.analysis.reach import button_presses

    rows = button_presses(args.episodes, args.stand_off, args.radius)
    summary = {"states": len({r["episode"] for r in rows}), "actions_tried": sum(r["bins_tried"] for r in rows),
               "actions_pressing": sum(len(r["bins_pressing"]) for r in rows)}
    return emit(args, rows, summary)


def cmd_goal_pixels(args) -> int:
    from relmogen.analysis.goal_pixels import goal_pixels

    result = goal_pixels(args.run, args.checkpoint, args.episodes, args.seed)
    if args.json:
        print(json.dumps(result))
        return 0
    print(markdown_table([{"axis": axis, **result[axis]} for axis in ("column", "row")]))
    print(json.dumps({key: value for key, value in result.items() if key not in ("column", "row")}))
    return 0


def cmd_qvalues(args) -> int:
    from relmogen.analysis import qvalues

    if args.mode == "oracle":
        rows = qvalues.oracle_states(args.run, args.checkpoint, args.states, args.seed, args.button_only)
        summary = qvalues.oracle_states_summary(rows)
    else:
        rows = qvalues.greedy_values(args.run, args.checkpoint, args.episodes, args.seed)
        summary = qvalues.greedy_summary(rows)
        rows = [{k: v for k, v in row.items() if k != "per_step"} for row in rows]
    write_json(args.out, {"summary": summary, "rows": rows})
    return emit(args, rows, summary)


def cmd_oracle_cells(args) -> int:
    from relmogen.analysis.qvalues import oracle_cell_table

    return emit(args, oracle_cell_table(args.stages))


def cmd_replay(args) -> int:
    from relmogen.analysis.replay import action_rewards, button_pushes, load_replay

    if args.mode == "pushes":
        return emit(args, [{"run": Path(run).name, **button_pushes(*load_replay(run))} for run in args.runs])
    actions = [tuple(int(v) for v in text.split(",")) for text in args.action]
    if any(len(a) != 3 for a in actions):
        raise ValueError("--action takes BIN,I,J")
    rows = []
    for run in args.runs:
        result = action_rewards(*load_replay(run), actions)
        rows += [{"run": Path(run).name, **row} for row in result.pop("given") + result.pop("most_frequent")]
        if not args.json:
            print(json.dumps({"run": Path(run).name, **result}))
    return emit(args, rows)


def cmd_offline_updates(args) -> int:
    from relmogen.analysis.replay import offline_updates

    summary = offline_updates(args.run, args.out, args.updates, args.conservative_weight, args.from_scratch, args.set)
    print(json.dumps(summary))
    return 0


def cmd_average_checkpoints(args) -> int:
    from relmogen.analysis.checkpoints import average_checkpoints

    print(average_checkpoints(args.run, args.checkpoints, args.name))
    return 0


# ---------------------------------------------------------------------------------------- parsers
def add_analyse_parser(sub) -> None:
    analyse = sub.add_parser("analyse", help="analyses behind figures of README.md and docs/ (relmogen.analysis)")
    topics = analyse.add_subparsers(dest="topic", required=True, metavar="TOPIC", help="what to analyse")

    p = topics.add_parser("training", help="runs' episodes.csv and TensorBoard scalars per window of episodes")
    p.add_argument("runs", nargs="+", metavar="RUN_DIR", help="run directories")
    p.add_argument("--window", type=_positive, default=100, help="episodes per row (default 100)")
    p.add_argument("--phases", action="store_true", help="one row per settings phase (resumes with --set) instead")
    _json_flag(p)
    p.set_defaults(func=cmd_training)

    p = topics.add_parser("curves", help="rolling training success against episodes (and CPU hours), TensorBoard scalars")
    p.add_argument("runs", nargs="*", metavar="RUN_DIR", help="run directories, one colour per parent folder")
    p.add_argument("--group", nargs="+", action="append", metavar="LABEL_THEN_RUNS",
                   help="a labelled group of runs: LABEL RUN_DIR... (repeatable)")
    p.add_argument("--window", type=_positive, default=100, help="episodes per rolling mean (default 100)")
    p.add_argument("--cpu-hours", action="store_true", help="add a panel against CPU hours")
    p.add_argument("--tags", nargs="*", default=[], help="TensorBoard scalars to add a panel each (losses/loss ...)")
    p.add_argument("--out", required=True, help="the PNG to write")
    p.set_defaults(func=cmd_curves)

    p = topics.add_parser("choose", help="choose each run's kept model on periodic plus RUN/validation/ evaluations")
    p.add_argument("runs", nargs="+", metavar="RUN_DIR", help="run directories")
    p.add_argument("--out", default=None, help="also write the choices to this JSON file")
    _json_flag(p)
    p.set_defaults(func=cmd_choose)

    p = topics.add_parser("door-distance", help="where the base stood at arm subgoals (viz subgoals JSONs)")
    p.add_argument("figures", nargs="+", metavar="SUBGOALS_JSON", help="JSONs written by relmogen viz subgoals")
    _json_flag(p)
    p.set_defaults(func=cmd_door_distance)

    p = topics.add_parser("oracle-table", help="the relmogen oracle JSONs of a folder as one table")
    p.add_argument("folder", help="folder of relmogen oracle --json outputs (e.g. results/oracles)")
    _json_flag(p)
    p.set_defaults(func=cmd_oracle_table)

    p = topics.add_parser("random-sgpd", help="SGP-D's random exploration (epsilon = 1): the task metrics")
    p.add_argument("--task", required=True, help="task name")
    p.add_argument("--episodes", type=_positive, default=30, help="episodes (default 30)")
    p.add_argument("--sampler", choices=("uniform", "part-coin"), default="uniform",
                   help="uniform over allowed actions (training's) or a coin for the part first")
    p.add_argument("--push-frame", choices=("base", "surface"), default="base", help="env.push_frame (default base)")
    p.add_argument("--no-mask-arm", dest="mask_arm", action="store_false",
                   help="sample arm cells beyond the arm's reach too")
    p.add_argument("--image-size", type=_positive, default=64, help="camera resolution (default 64)")
    p.add_argument("--qmap-size", type=_positive, default=None, help="Q-map side (default image size / 4)")
    p.add_argument("--seed", type=int, default=100_000, help="seed of the first episode (default 100000)")
    _json_flag(p)
    p.set_defaults(func=cmd_random_sgpd)

    p = topics.add_parser("episodes", help="a policy's episodes one by one: outcome and subgoal trace")
    p.add_argument("policy", metavar="RUN_DIR_OR_CHECKPOINT_OR_POLICY", help="what relmogen eval takes")
    p.add_argument("--checkpoint", default="latest", help="which model of a run: latest, best or a folder name")
    p.add_argument("--episodes", type=_positive, default=10, help="episodes (default 10)")
    p.add_argument("--seed", type=int, default=100_000, help="seed of the first episode (default 100000)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="environment keyword argument, e.g. base_goal=nearest_reachable or arm_rrt=[100,4]")
    p.add_argument("--arm", action="append", default=[], metavar="KEY=VALUE",
                   help="ArmConfig setting, e.g. plan_attempts=6 (relmogen.analysis.arm)")
    p.add_argument("--stochastic", action="store_true", help="sample actions instead of the greedy policy")
    p.add_argument("--out", default=None, help="also write one JSON line per episode here")
    _json_flag(p)
    p.set_defaults(func=cmd_episodes)

    p = topics.add_parser("arm-settings", help="random subgoal-r steps' cost or oracle figures under ArmConfig settings")
    p.add_argument("mode", choices=("random", "oracle"), help="random steps (cost) or the task oracle (figures)")
    p.add_argument("settings", nargs="+", metavar="NAME[=key:value,...]", help="settings to compare")
    p.add_argument("--tasks", nargs="+", default=["PushDoorNav", "ButtonDoorNav"], help="tasks (default PushDoorNav "
                                                                                         "ButtonDoorNav)")
    p.add_argument("--episodes", type=_positive, default=None, help="episodes per task (random 20, oracle 50)")
    p.add_argument("--image-size", type=_positive, default=64, help="random: camera resolution (default 64)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="random: environment keyword argument, e.g. base_goal=nearest_free")
    _json_flag(p)
    p.set_defaults(func=cmd_arm_settings)

    p = topics.add_parser("collision-backends", help="the arm's collision backends on the same random configurations")
    p.add_argument("--tasks", nargs="+", default=None, help="tasks (default: the six with arm subgoals)")
    p.add_argument("--configurations", type=_positive, default=600, help="arm configurations per task and seed")
    p.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2], help="episode seeds (default 0 1 2)")
    _json_flag(p)
    p.set_defaults(func=cmd_collision_backends)

    p = topics.add_parser("door-front", help="plan rate of arm subgoals before PushDoorNav's door per ArmConfig setting")
    p.add_argument("settings", nargs="+", metavar="NAME[=key:value,...]", help="settings to compare")
    p.add_argument("--trials", type=_positive, default=80, help="arm subgoals (default 80)")
    _json_flag(p)
    p.set_defaults(func=cmd_door_front)

    p = topics.add_parser("ik-contacts", help="what an unchecked IK solution touches where every checked one collided")
    p.add_argument("policy", metavar="RUN_DIR_OR_CHECKPOINT_OR_POLICY", help="what relmogen eval takes")
    p.add_argument("--checkpoint", default="latest", help="which model of a run: latest, best or a folder name")
    p.add_argument("--seeds", nargs="+", type=int, required=True, help="episode seeds")
    _json_flag(p)
    p.set_defaults(func=cmd_ik_contacts)

    p = topics.add_parser("reach", help="arm plans found by distance from the first arm joint")
    p.add_argument("--robot", default="fetch", help="robot (default fetch)")
    p.add_argument("--tasks", nargs="+", default=["TabletopReachM", "PushDoorNav", "ArrangeKitchenMM"], help="tasks")
    p.add_argument("--episodes", type=_positive, default=4, help="episodes per task (default 4)")
    p.add_argument("--per-state", type=_positive, default=20, help="pixels per state (default 20)")
    p.add_argument("--seed", type=int, default=2000, help="seed of the first episode (default 2000)")
    p.add_argument("--image-size", type=_positive, default=64, help="camera resolution (default 64)")
    p.add_argument("--arm-collision", choices=("on", "off"), default="on", help="arm collision checking (default on)")
    p.add_argument("--base-moves", type=int, default=0, help="random base subgoals before sampling (default 0)")
    p.add_argument("--out", default=None, help="also write the table and every sample to this JSON file")
    _json_flag(p)
    p.set_defaults(func=cmd_reach)

    p = topics.add_parser("reach-mask", help="arm cells the sphere mask allows: IK solved, in the measured map")
    p.add_argument("--task", default="ArrangeKitchenMM", help="task (default ArrangeKitchenMM)")
    p.add_argument("--episodes", type=_positive, default=8, help="episodes (default 8)")
    p.add_argument("--cells", type=_positive, default=40, help="cells per state (default 40)")
    _json_flag(p)
    p.set_defaults(func=cmd_reach_mask)

    p = topics.add_parser("button-presses", help="which SGP-D pushes around ButtonDoorNav's button press it")
    p.add_argument("--episodes", type=_positive, default=4, help="episodes (default 4)")
    p.add_argument("--stand-off", type=float, default=0.65, help="metres in front of the button (default 0.65)")
    p.add_argument("--radius", type=int, default=1, help="cells around the button's cell (default 1: 3 x 3)")
    _json_flag(p)
    p.set_defaults(func=cmd_button_presses)

    p = topics.add_parser("goal-pixels", help="a TabletopReachM relmogen-r policy's first arm pixel against the goal's")
    p.add_argument("run", metavar="RUN_DIR_OR_CHECKPOINT", help="a TabletopReachM relmogen-r run or checkpoint folder")
    p.add_argument("--checkpoint", default="latest", help="which model of a run: latest, best or a folder name")
    p.add_argument("--episodes", type=_positive, default=40, help="episodes (default 40)")
    p.add_argument("--seed", type=int, default=100_000, help="seed of the first episode (default 100000)")
    _json_flag(p)
    p.set_defaults(func=cmd_goal_pixels)

    p = topics.add_parser("qvalues", help="a relmogen-d checkpoint's Q maps at oracle states or along greedy episodes")
    p.add_argument("mode", choices=("oracle", "greedy"), help="states before the oracle's pushes, or greedy episodes")
    p.add_argument("run", metavar="RUN_DIR_OR_CHECKPOINT", help="a relmogen-d run or checkpoint folder")
    p.add_argument("--checkpoint", default="latest", help="which model of a run: latest, best or a folder name")
    p.add_argument("--states", type=_positive, default=16, help="oracle: states (default 16)")
    p.add_argument("--button-only", action="store_true", help="oracle: one state per episode, before its first press")
    p.add_argument("--episodes", type=_positive, default=10, help="greedy: episodes (default 10)")
    p.add_argument("--seed", type=int, default=100_000, help="seed of the first episode (default 100000)")
    p.add_argument("--out", default=None, help="also write summary and rows to this JSON file")
    _json_flag(p)
    p.set_defaults(func=cmd_qvalues)

    p = topics.add_parser("oracle-cells", help="the oracle cell's Q-map percentile per stage and task (viz qmap JSONs)")
    p.add_argument("stages", nargs="+", metavar="STAGE_DIR", help="folders of <task>__relmogen-d__.../oracle_cells.json")
    _json_flag(p)
    p.set_defaults(func=cmd_oracle_cells)

    p = topics.add_parser("replay", help="what relmogen-d runs' saved replays hold")
    p.add_argument("mode", choices=("pushes", "rewards"), help="button-cap pushes, or rewards per action")
    p.add_argument("runs", nargs="+", metavar="RUN_DIR", help="run directories with a saved replay")
    p.add_argument("--action", action="append", default=[], metavar="BIN,I,J", help="rewards: an arm action to report")
    _json_flag(p)
    p.set_defaults(func=cmd_replay)

    p = topics.add_parser("offline-updates", help="more relmogen-d updates from a run's own replay, no new data")
    p.add_argument("run", metavar="RUN_DIR", help="a relmogen-d run with a checkpoint and a saved replay")
    p.add_argument("--updates", type=_positive, required=True, help="gradient steps")
    p.add_argument("--out", required=True, help="the new run folder (must not exist)")
    p.add_argument("--conservative-weight", type=float, default=None, help="algo.conservative_weight for these updates")
    p.add_argument("--from-scratch", action="store_true", help="a freshly initialised network on the same replay")
    p.add_argument("--set", action="append", default=[], metavar="algo.KEY=VALUE",
                   help="with --from-scratch: the new network's settings (repeatable)")
    p.set_defaults(func=cmd_offline_updates)

    p = topics.add_parser("average-checkpoints", help="average the weights of a run's kept checkpoints")
    p.add_argument("run", metavar="RUN_DIR", help="the run")
    p.add_argument("checkpoints", nargs="+", metavar="CHECKPOINT", help="folder names in RUN/checkpoints/")
    p.add_argument("--name", required=True, help="folder name of the averaged checkpoint")
    p.set_defaults(func=cmd_average_checkpoints)
