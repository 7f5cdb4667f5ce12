"""The ``relmogen`` command line.

    relmogen demo  [--episodes N] [--seed S] [--out DIR] [--json]
    relmogen bench env [--task T] [--samples N] [--image-size PX] [--json]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np


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
        table.add_row(key, f"{value:.3f}" if isinstance(value, float) else str(value))
    Console().print(table)


def cmd_demo(args: argparse.Namespace) -> int:
    from relmogen.experiments.demo import run_demo

    metrics = run_demo(episodes=args.episodes, seed=args.seed, out_dir=Path(args.out), quiet=args.json)
    _print_metrics(metrics, args.json, "PointNav demo (waypoint follower on joint velocities)")
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    if args.what == "env":
        from relmogen.bench.env_bench import bench_env

        result = bench_env(task=args.task, samples=args.samples, image_size=args.image_size)
    else:  # argparse restricts the choices
        raise AssertionError(args.what)
    _print_metrics(result, args.json, f"bench {args.what}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="relmogen", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)

    demo = sub.add_parser("demo", help="run a short episode, print its metrics and write a GIF")
    demo.add_argument("--episodes", type=_positive_int, default=1)
    demo.add_argument("--seed", type=int, default=0)
    demo.add_argument("--out", default="out/demo", help="folder for the GIF (default out/demo)")
    demo.add_argument("--json", action="store_true", help="print the metrics as one JSON object")
    demo.set_defaults(func=cmd_demo)

    bench = sub.add_parser("bench", help="speed benchmarks")
    bench.add_argument("what", choices=["env"])
    bench.add_argument("--task", default="PointNav")
    bench.add_argument("--samples", type=_positive_int, default=200)
    bench.add_argument("--image-size", type=_positive_int, default=128)
    bench.add_argument("--json", action="store_true")
    bench.set_defaults(func=cmd_bench)
    return parser


def _positive_int(text: str) -> int:
    value = int(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


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
