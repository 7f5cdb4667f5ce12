"""End to end: train a few hundred steps on the tiny preset, checkpoint, resume, evaluate."""

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from relmogen.experiments.config import resolve_config
from relmogen.experiments.evaluate import evaluate_path
from relmogen.experiments.train import latest_checkpoint, resume, train


def episodes_in(run_dir: Path) -> list[int]:
    with open(run_dir / "episodes.csv", newline="") as handle:
        return [int(row["episode"]) for row in csv.DictReader(handle)]


@pytest.mark.parametrize("algo,episodes", [("sac", 20), ("oac", 20), ("relmogen-r", 3), ("relmogen-d", 3)])
def test_train_checkpoint_resume_evaluate(tmp_path, algo, episodes):
    config = resolve_config("PointNav", algo, seed=0, preset="tiny", episodes=episodes)
    run_dir = train(config, tmp_path, quiet=True)
    assert (run_dir / "config.yaml").is_file() and list((run_dir / "tb").iterdir())
    assert episodes_in(run_dir) == list(range(1, episodes + 1))
    state = json.loads((latest_checkpoint(run_dir) / "state.json").read_text())
    assert state["episodes"] == episodes and state["timesteps"] >= episodes
    assert (latest_checkpoint(run_dir) / "replay_buffer.pkl").is_file()
    # resume with a larger budget: continues from the checkpoint, keeps the replay buffer
    resume(run_dir, quiet=True, episodes=episodes + 2)
    assert episodes_in(run_dir) == list(range(1, episodes + 3))
    result = evaluate_path(run_dir, episodes=1, quiet=True)
    assert result["episodes"] == 1 and 0.0 <= result["success_rate"] <= 1.0
    assert list((run_dir / "eval").glob("*.json"))


def test_resume_after_kill_9_loses_at_most_one_checkpoint_interval(tmp_path):
    cmd = [sys.executable, "-m", "relmogen.cli", "train", "--task", "PointNav", "--algo", "sac", "--preset", "tiny",
           "--episodes", "1000", "--out", str(tmp_path), "--quiet", "--set", "run.eval_every_episodes=1000"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    deadline = time.time() + 240
    run_dir = None
    while time.time() < deadline:
        runs = list(tmp_path.glob("PointNav__sac__*"))
        if runs and latest_checkpoint(runs[0]) is not None and len(episodes_in(runs[0])) >= 4:
            run_dir = runs[0]
            break
        time.sleep(0.2)
    assert run_dir is not None, "no checkpoint appeared"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    saved = json.loads((latest_checkpoint(run_dir) / "state.json").read_text())["episodes"]
    logged = len(episodes_in(run_dir))
    assert logged - saved <= 1  # checkpoint every episode in the tiny preset
    resume(run_dir, quiet=True, episodes=saved + 3)
    assert episodes_in(run_dir) == list(range(1, saved + 4))
