"""One training session of a run, new (``train``) or resumed (``resume``): the oracle
demonstrations the replay still lacks, then SB3's ``learn`` under ``TrainingMonitor`` until a
budget is spent or a stop is asked for. Every end writes a checkpoint with the replay, so
``--resume`` loses nothing: a stop asked for (Ctrl-C: SIGINT, or SIGTERM) ends the session after
the current environment step and raises ``TrainingStopped``; a dead or stuck environment worker
re-raises its ``EnvWorkerError``; a spent budget writes ``done.json``."""

from __future__ import annotations

import json
from pathlib import Path

from relmogen.agents.demonstrations import add_demonstrations
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.budgets import write_done
from relmogen.experiments.config import TrainConfig
from relmogen.experiments.env_workers import EnvWorkerError
from relmogen.experiments.environments import env_kwargs
from relmogen.experiments.monitor import TrainingMonitor

DEMO_LOG = "demonstrations.jsonl"
# Demonstrations of run seed s use episode seeds 50,000 + 1,000 s + n: apart from the final
# evaluations' 100,000 and up for run seeds below 50 and up to 1,000 demonstrations.
DEMO_SEED = 50_000


class TrainingStopped(Exception):
    """Training stopped on request (SIGINT, or SIGTERM through the CLI) after writing a checkpoint
    with the replay at ``episodes``."""

    def __init__(self, run_dir: Path, episodes: int, reason: str | None = None):
        super().__init__(run_dir, episodes, reason)
        self.run_dir, self.episodes = run_dir, episodes
        self.reason = reason or f"stopped at episode {episodes}"

    def __str__(self) -> str:
        return f"{self.reason}; model and replay saved; continue with: relmogen train --resume {self.run_dir}"


def learn(run_dir: Path, config: TrainConfig, model, state: dict, quiet: bool,
          monitor_class: type[TrainingMonitor] = TrainingMonitor) -> Path:
    """Train ``model`` on from ``state`` (the run's counters, updated in place) as the module says."""
    add_missing_demonstrations(run_dir, config, model, state, quiet)
    monitor = monitor_class(run_dir, config, state, quiet)
    try:
        if not monitor.budget_spent():  # else the latest checkpoint already holds everything
            with monitor.stop_request:
                model.learn(total_timesteps=10**12, callback=monitor, reset_num_timesteps=state["timesteps"] == 0,
                            progress_bar=False)
            stopped = monitor.stop_request.requested
            monitor.checkpoint(with_replay=True)
            if stopped:
                raise TrainingStopped(run_dir, state["episodes"], monitor.stop_reason())
        reason = monitor.stop_reason()  # while the environment workers live: their CPU time counts
    except EnvWorkerError as error:  # keep what was learned, then report it
        monitor.progress.stop()
        monitor.checkpoint(with_replay=True)
        error.run_dir, error.episodes = run_dir, state["episodes"]
        raise
    finally:
        monitor.close()
        model.get_env().close()
    write_done(run_dir, state, reason)
    return run_dir


def add_missing_demonstrations(run_dir: Path, config: TrainConfig, model, state: dict, quiet: bool) -> None:
    """Bring the oracle episodes in the replay up to ``algo.demo_episodes`` (a resume with a
    larger value adds the difference); each batch is logged to ``demonstrations.jsonl``."""
    added = state.get("demo_episodes", 0)
    missing = config.algo_params.demo_episodes - added
    if missing <= 0:
        return
    kwargs = env_kwargs(config, arm_collision=config.env.arm_collision_train)
    result = add_demonstrations(model, lambda: RelmogenEnv(**kwargs), missing,
                                seed=DEMO_SEED + 1000 * config.seed + added, quiet=quiet)
    state["demo_episodes"] = added + result["episodes"]
    with open(run_dir / DEMO_LOG, "a") as handle:
        handle.write(json.dumps({"at_episode": state["episodes"], **result}) + "\n")
