"""The command line itself: version, help on every flag, the task list, and one clear line per error."""

import argparse
import importlib.metadata
import json
import re
import subprocess
import sys

import pytest
import torch as th

from relmogen import __version__
from relmogen.cli import build_parser, main
from relmogen.experiments.config import resolve_config, save_config


def run_cli(*args, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "relmogen.cli", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=300)


def test_version_is_the_package_version_and_no_pybullet_banner_is_printed():
    done = run_cli("--version")
    assert done.returncode == 0 and done.stdout == f"relmogen {__version__}\n"
    assert "pybullet build time" not in done.stdout + done.stderr
    assert __version__ == importlib.metadata.version("relmogen")


def parsers(parser: argparse.ArgumentParser, name: str = "relmogen"):
    """Every parser of the command line with its command path."""
    yield name, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for command, subparser in action.choices.items():
                yield from parsers(subparser, f"{name} {command}")


def test_every_option_of_every_command_has_help():
    missing = []
    for name, parser in parsers(build_parser()):
        for action in parser._actions:
            if isinstance(action, argparse._HelpAction):
                continue
            if isinstance(action, argparse._SubParsersAction):
                missing += [f"{name} {choice.dest}" for choice in action._choices_actions if not choice.help]
            if not action.help or action.help == argparse.SUPPRESS:
                missing.append(f"{name} {'/'.join(action.option_strings) or action.dest}")
    assert not missing


def test_tasks_lists_every_task_with_its_metrics_and_episode_lengths(capsys):
    assert main(["tasks", "--json"]) == 0
    rows = {row["task"]: row for row in json.loads(capsys.readouterr().out)}
    assert {"PointNav", "TabletopReachM", "ArrangeKitchenMM"} <= set(rows)
    assert rows["PointNav"]["scene"] == "office" and "spl" in rows["PointNav"]["metrics"]
    assert "closed_10" not in rows["PointNav"]["metrics"] and "spl" not in rows["ArrangeKitchenMM"]["metrics"]
    assert rows["TabletopReachM"]["episode_steps"] == {"joint": 750, "subgoal-r": 5, "subgoal-d": 5}
    assert rows["PointNav"]["id"] == "relmogen/PointNav-v0"
    assert main(["tasks"]) == 0
    table = capsys.readouterr().out
    assert "ArrangeChairMM" in table and "750 / 25 / 25" in table and "750 / 5 / 5" in table


@pytest.fixture
def fake_run(tmp_path):
    """A run directory with only its config: no checkpoint, no evaluation."""
    run = tmp_path / "PointNav__sac__0__fake"
    run.mkdir()
    save_config(resolve_config("PointNav", "sac", preset="tiny"), run / "config.yaml")
    return run


ERRORS = {
    "report of a missing run": (["report", "/nonexistent", "--out", "x"], "not a run directory"),
    "report without --out": (["report", "{run}"], "--out DIR"),
    "curves only without --out": (["report", "{run}", "--curves-only"], "--out DIR"),
    "curves only of Table I": (["report", "--table1", ".", "--curves-only"], "not with --table1"),
    "task name in the wrong case": (["train", "--task", "pointnav", "--algo", "sac", "--preset", "tiny", "--out",
                                     "runs"], "did you mean PointNav?"),
    "missing preset file": (["train", "--task", "PointNav", "--algo", "sac", "--preset", "missing.yaml", "--out",
                             "runs"], "missing.yaml does not exist"),
    "CUDA without CUDA": (["train", "--task", "PointNav", "--algo", "sac", "--preset", "tiny", "--device", "cuda",
                           "--out", "runs"], "use --device cpu"),
    "resume of a missing run": (["train", "--resume", "nowhere"], "not a run directory"),
    "eval of a missing run": (["eval", "nowhere"], "not a run directory"),
    "eval of a run without a best checkpoint": (["eval", "{run}", "--checkpoint", "best"], "no best checkpoint"),
    "eval to a video format it cannot write": (["eval", "{run}", "--video", "out.avi"], ".gif or .mp4"),
    "misspelt algorithm block in a preset": (["train", "--task", "PointNav", "--algo", "relmogen-r", "--preset",
                                              "{typo_preset}", "--out", "runs"],
                                             "unknown algorithm block 'relmogen_r' under algos; did you mean relmogen-r?"),
    "misspelt algo key in --set": (["train", "--task", "PointNav", "--algo", "sac", "--preset", "tiny", "--out", "runs",
                                    "--set", "algo.batchsize=32"], "did you mean algo.batch_size?"),
    "misspelt env key in --set": (["train", "--task", "PointNav", "--algo", "sac", "--preset", "tiny", "--out", "runs",
                                   "--set", "env.imagesize=64"], "did you mean env.image_size?"),
    "misspelt run key in --set": (["train", "--task", "PointNav", "--algo", "sac", "--preset", "tiny", "--out", "runs",
                                   "--set", "run.evl_every=1"], "did you mean run.eval_every_episodes?"),
    "misspelt key on resume": (["train", "--resume", "{run}", "--set", "algo.batchsize=32"],
                               "did you mean algo.batch_size?"),
    "another algorithm's key in --set": (["train", "--task", "PointNav", "--algo", "relmogen-r", "--preset", "tiny",
                                         "--out", "runs", "--set", "algo.qmap_widths=[8,8,8,8]"],
                                        "--set algo.qmap_widths=[8,8,8,8]: algo.qmap_widths: relmogen-d only, "
                                        "not relmogen-r"),
    "another algorithm's key on resume": (["train", "--resume", "{run}", "--set", "algo.hrl4in_k=5"],
                                          "algo.hrl4in_k: hrl4in only, not sac"),
    "no CPUs per run": (["sweep", "--tasks", "PointNav", "--algos", "sac", "--seeds", "0", "--out", "runs",
                         "--cpus-per-run", "0"], "--cpus-per-run: must be a positive number, got 0"),
    "invalid value": (["train", "--task", "PointNav", "--algo", "sac", "--preset", "tiny", "--out", "runs",
                       "--set", "algo.gamma=2"], "invalid configuration: algo.gamma: Input should be less than"),
}


@pytest.fixture
def typo_preset(tmp_path):
    """A preset file whose relmogen-r block is misspelt ``relmogen_r``."""
    path = tmp_path / "typo.yaml"
    path.write_text("env:\n  image_size: 64\nalgos:\n  relmogen_r:\n    batch_size: 32\n")
    return path


def run_main(args, capfd) -> subprocess.CompletedProcess:
    """``main(args)`` in this process (no ~3 s torch import per case), its stdout and stderr as a
    finished ``relmogen`` process would give them (``capfd``: also what C code prints)."""
    capfd.readouterr()
    try:
        code = main(list(args))
    except SystemExit as exit_:
        code = exit_.code
    out, err = capfd.readouterr()
    return subprocess.CompletedProcess(["relmogen", *args], code, out, err)


# every case runs in this process; these also as a fresh ``python -m relmogen.cli`` (import-time noise)
IN_A_FRESH_PROCESS = ["invalid value", "eval of a run without a best checkpoint"]


@pytest.mark.parametrize("case, fresh", [pytest.param(case, False, id=case) for case in ERRORS] +
                         [pytest.param(case, True, id=f"{case}-subprocess") for case in IN_A_FRESH_PROCESS])
def test_errors_are_one_line_naming_the_fix_with_exit_code_2_and_create_nothing(case, fresh, tmp_path, fake_run,
                                                                                 typo_preset, capfd, monkeypatch):
    args, message = ERRORS[case]
    if case == "CUDA without CUDA" and th.cuda.is_available():
        pytest.skip("this machine has CUDA")
    before = sorted(tmp_path.rglob("*"))
    args = [arg.format(run=fake_run, typo_preset=typo_preset) for arg in args]
    monkeypatch.chdir(tmp_path)
    done = run_cli(*args, cwd=tmp_path) if fresh else run_main(args, capfd)
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2, done.stderr
    assert len(lines) == 1 and lines[0].startswith("relmogen: error: ") and message in lines[0], done.stderr
    assert done.stdout == "" and sorted(tmp_path.rglob("*")) == before


TINY_RUN = "--task PointNav --algo relmogen-r --preset tiny --episodes 2 --set run.eval_every_episodes=1000"
CLI = f"{sys.executable} -m relmogen.cli"


def test_the_quick_start_captures_the_run_directory_and_evaluates_it(tmp_path):
    # the README's form, twice for the same seed: each RUN is one directory, never a glob of both
    script = (f'for i in 1 2; do RUN=$({CLI} train {TINY_RUN} --out runs --quiet 2>>train.err); echo "$RUN"; done\n'
              f'{CLI} eval "$RUN" --episodes 1 --seed 5 --json')
    done = subprocess.run(["bash", "-c", script], capture_output=True, text=True, cwd=tmp_path, timeout=600)
    assert done.returncode == 0, done.stderr
    first, second, metrics = done.stdout.splitlines()
    assert first != second and all((tmp_path / run / "config.yaml").is_file() for run in (first, second))
    assert json.loads(metrics)["episodes"] == 1
    reasons = (tmp_path / "train.err").read_text().splitlines()
    assert len(reasons) == 2 and all(re.fullmatch(r"relmogen: stopped by the episode budget: 2 of 2 episodes in "
                                                  r"0:\d\d:\d\d", reason) for reason in reasons), reasons


def test_train_json_is_the_only_stdout_and_progress_goes_to_stderr(tmp_path, capfd, monkeypatch):
    monkeypatch.chdir(tmp_path)  # in this process: the quick start above runs ``relmogen train`` as one
    done = run_main(["train", *TINY_RUN.split(), "--out", str(tmp_path), "--json"], capfd)
    assert done.returncode == 0, done.stderr
    (line,) = done.stdout.splitlines()
    result = json.loads(line)
    assert result["episodes"] == 2 and (tmp_path / result["run_dir"] / "done.json").is_file()
    assert result["stop_reason"].startswith("stopped by the episode budget: 2 of 2 episodes")
    assert "2/2 episodes" in done.stderr and done.stderr.splitlines()[-1] == f"relmogen: {result['stop_reason']}"
