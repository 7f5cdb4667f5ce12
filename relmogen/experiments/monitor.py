"""The SB3 callback of a training session (``TrainingMonitor``): it counts episodes, logs them to
``episodes.csv`` and TensorBoard, shows the progress bar, writes checkpoints, runs the periodic
evaluations (``eval_during_training.jsonl``, ``checkpoints/best``) and stops training when a budget
is spent or a stop is asked for (``StopRequest``: SIGINT, SIGTERM)."""

from __future__ import annotations

import csv
import json
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from stable_baselines3.common.callbacks import BaseCallback
from torch.utils.tensorboard import SummaryWriter

from relmogen.agents.replay import finish_stopped_step
from relmogen.experiments.budgets import budget_stop_reason, hms, process_tree_cpu_seconds, spent_budgets
from relmogen.experiments.checkpoints import (best_evaluation, evaluation_rank, write_best_checkpoint, write_checkpoint,
                                              write_evaluated_checkpoint)
from relmogen.experiments.config import TrainConfig

EPISODE_FIELDS = ["episode", "timesteps", "wall_time_s", "return", "length", "success",
                  "base_fraction", "subgoal_success",  # subgoal controls only
                  "closed_10"]  # tasks that count closed items (ArrangeKitchenMM)
SUCCESS_WINDOW = 20
PERIODIC_EVALUATIONS = "eval_during_training.jsonl"


def latest_periodic_evaluation(run_dir: Path) -> dict | None:
    """The newest line of the run's periodic evaluations, or None before the first."""
    path = Path(run_dir) / PERIODIC_EVALUATIONS
    lines = path.read_text().splitlines() if path.is_file() else []
    return json.loads(lines[-1]) if lines else None


def progress_console() -> Console:
    """Rich's console on stderr; 160 columns when stderr is a file or a pipe, where rich's 80
    would cut the progress line's final state short."""
    return Console(stderr=True, width=None if sys.stderr.isatty() else 160)


def progress_bar(quiet: bool) -> Progress:
    """Episodes done of the budget, elapsed and estimated time left, and the ``_stats`` line."""
    return Progress(TextColumn("{task.description}"), BarColumn(bar_width=20), MofNCompleteColumn(),
                    TextColumn("episodes"), TimeElapsedColumn(), TextColumn("{task.fields[remaining]}"),
                    TextColumn("{task.fields[stats]}"), console=progress_console(), disable=quiet)


def open_episode_log(path: Path):
    """``episodes.csv`` opened for appending, and its writer (the header written into a new file)."""
    handle = open(path, "a", newline="")
    writer = csv.DictWriter(handle, fieldnames=EPISODE_FIELDS, extrasaction="ignore")
    if handle.tell() == 0:
        writer.writeheader()
    return handle, writer


class StopRequest:
    """While entered (in the main thread), SIGINT and SIGTERM ask training to stop: the first
    sets ``requested``, which ``TrainingMonitor`` turns into a stop after the current environment
    step; a second raises ``KeyboardInterrupt`` at once. The previous handlers come back on exit."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.requested = False
        self.signal_name: str | None = None
        self._previous: dict = {}

    def __enter__(self) -> StopRequest:
        if threading.current_thread() is threading.main_thread():  # signal handlers live there only
            self._previous = {signum: signal.signal(signum, self._handle) for signum in self.SIGNALS}
        return self

    def __exit__(self, *exc_info) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        self._previous = {}

    def _handle(self, signum, frame) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested, self.signal_name = True, signal.Signals(signum).name


class TrainingMonitor(BaseCallback):
    """Counts episodes; logs, checkpoints, evaluates and stops on the episode/time budget."""

    def __init__(self, run_dir: Path, config: TrainConfig, state: dict, quiet: bool = False):
        super().__init__()
        self.run_dir, self.config, self.state = Path(run_dir), config, state
        self.session_start = time.time()
        self.wall_before_session = state["wall_time_s"]
        self.cpu_before_session = state.get("cpu_time_s", 0.0)
        self.steps_at_start, self.episodes_at_start = state["timesteps"], state["episodes"]
        self.updates_before_session, self.updates_at_start = state.get("gradient_updates", 0), None
        self.writer = SummaryWriter(str(self.run_dir / "tb"))
        self.csv_file, self.csv = open_episode_log(self.run_dir / "episodes.csv")
        self.successes: list[float] = []
        self.subgoals: dict[int, list[tuple[bool, bool]]] = {}  # env index -> (is base, plan found) per step
        self.term_sums: dict[int, dict[str, float]] = {}  # env index -> reward terms summed over the episode
        self.progress, self.bar = progress_bar(quiet), None
        self.stop_request = StopRequest()
        self.latest_evaluation = latest_periodic_evaluation(self.run_dir)

    @property
    def wall_time(self) -> float:
        return self.wall_before_session + (time.time() - self.session_start)

    @property
    def cpu_time(self) -> float:
        """CPU seconds of this run so far (trainer plus its environment workers): the fair
        budget measure when several runs share a machine."""
        return self.cpu_before_session + process_tree_cpu_seconds()

    def _on_training_start(self) -> None:
        self.updates_at_start = self.model._n_updates  # a fine-tuned model arrives with its source's count
        self.progress.start()
        self.bar = self.progress.add_task(f"{self.config.task} {self.config.algo}", total=self.config.episodes,
                                          completed=self.state["episodes"], remaining="", stats=self._stats(0.0))

    def _on_training_end(self) -> None:
        self.progress.stop()

    def _on_step(self) -> bool:
        for index, (info, done) in enumerate(zip(self.locals["infos"], self.locals["dones"])):
            if "subgoal_type" in info:
                self.subgoals.setdefault(index, []).append((info["subgoal_type"] == "base", bool(info["plan_found"])))
            sums = self.term_sums.setdefault(index, {})
            for term, value in info.get("reward_terms", {}).items():
                sums[term] = sums.get(term, 0.0) + value
            if done and "episode" in info:
                self._record_episode(info, self.subgoals.pop(index, []), self.term_sums.pop(index))
        if self.budget_spent() or self.stop_request.requested:
            finish_stopped_step(self.model, self.locals)  # SB3 returns before storing this step
            return False
        return True

    def budget_spent(self) -> bool:
        return bool(spent_budgets(self.config, self._spent()))

    def _spent(self) -> dict:
        """The budget counters now (CPU time measured only when a CPU budget is set: it walks the process tree)."""
        cpu_s = self.cpu_time if self.config.max_cpu_hours is not None else 0.0
        return {"episodes": self.state["episodes"], "wall_time_s": self.wall_time, "cpu_time_s": cpu_s}

    def stop_reason(self) -> str:
        """One line naming what ended the run: a signal, or the first budget spent."""
        if self.stop_request.requested:
            return f"stopped by {self.stop_request.signal_name} at episode {self.state['episodes']} of {self.config.episodes}"
        return budget_stop_reason(self.config, self._spent())

    def remaining_seconds(self) -> float | None:
        """Wall seconds left: the episodes still to run at this session's rate, or the time or
        CPU-time limit if that comes first; None before this session's first episode."""
        session_s = time.time() - self.session_start
        done = self.state["episodes"] - self.episodes_at_start
        if done <= 0 or session_s <= 0:
            return None
        left = [(self.config.episodes - self.state["episodes"]) * session_s / done]
        if self.config.max_hours is not None:
            left.append(self.config.max_hours * 3600 - self.wall_time)
        if self.config.max_cpu_hours is not None:
            session_cpu_s = max(self.cpu_time - self.cpu_before_session, 1e-9)
            left.append((self.config.max_cpu_hours * 3600 - self.cpu_time) * session_s / session_cpu_s)
        return max(min(left), 0.0)

    def _stats(self, sps: float) -> str:
        training = f"SR {np.mean(self.successes):.2f} (last {len(self.successes)})" if self.successes else "SR -"
        evaluation = self.latest_evaluation
        periodic = (f"eval SR {evaluation['success_rate']:.2f} (episode {evaluation['episode']})"
                    if evaluation else "eval SR -")
        return f"{training}  {periodic}  {sps:.1f} steps/s"

    def _record_episode(self, info: dict, subgoals: list[tuple[bool, bool]], term_sums: dict[str, float]) -> None:
        self.state["episodes"] += 1
        self.state["timesteps"] = self.model.num_timesteps
        episode = self.state["episodes"]
        row = self._episode_row(episode, info, subgoals)
        self.successes = (self.successes + [row["success"]])[-SUCCESS_WINDOW:]
        sps = (self.model.num_timesteps - self.steps_at_start) / max(time.time() - self.session_start, 1e-9)
        self.csv.writerow(row)
        self.csv_file.flush()
        self._log_scalars(episode, row, sps, term_sums)
        if episode % self.config.run.checkpoint_every_episodes == 0:
            self.checkpoint(with_replay=episode % self.config.run.replay_every_episodes == 0)
        if episode % self.config.run.eval_every_episodes == 0:
            self.evaluate(episode)
        remaining = self.remaining_seconds()
        self.progress.update(self.bar, completed=episode, stats=self._stats(sps),
                             remaining="" if remaining is None else f"~{hms(remaining)} left")

    def _episode_row(self, episode: int, info: dict, subgoals: list[tuple[bool, bool]]) -> dict:
        """The episode's line of ``episodes.csv`` (``EPISODE_FIELDS``)."""
        row = {"episode": episode, "timesteps": self.model.num_timesteps, "wall_time_s": round(self.wall_time, 2),
               "return": info["episode"]["r"], "length": info["episode"]["l"],
               "success": float(info.get("is_success", False))}
        if subgoals:
            row["base_fraction"] = round(float(np.mean([base for base, _ in subgoals])), 4)
            row["subgoal_success"] = round(float(np.mean([found for _, found in subgoals])), 4)
        if "closed_10" in info.get("metrics", {}):
            row["closed_10"] = info["metrics"]["closed_10"]
        return row

    def evaluate(self, episode: int) -> None:
        """Deterministic policy on a separate environment (arm collision checking on), logged to
        TensorBoard and ``eval_during_training.jsonl``. An evaluation that ranks above every
        earlier one (``evaluation_rank``) makes the model ``checkpoints/best``."""
        from relmogen.experiments.evaluate import evaluate_model

        seed = self.config.run.eval_seed
        result = evaluate_model(self.model, self.config, self.config.run.eval_episodes,
                                seed=10_000 + episode if seed is None else seed, quiet=True)
        for key in ("success_rate", "spl", "closed_10", "mean_return"):
            self.writer.add_scalar(f"eval/{key}", result[key], episode)
        evaluation = {"episode": episode, "wall_time_s": round(self.wall_time, 2), **result}
        with open(self.run_dir / PERIODIC_EVALUATIONS, "a") as handle:
            handle.write(json.dumps(evaluation) + "\n")
        self.latest_evaluation = evaluation
        if self.config.run.keep_evaluated:
            write_evaluated_checkpoint(self.run_dir, self.model, dict(self._bookkept_state(), evaluation=evaluation))
        best = best_evaluation(self.run_dir)
        if best is None or evaluation_rank(evaluation) > evaluation_rank(best):
            write_best_checkpoint(self.run_dir, self.model, dict(self._bookkept_state(), evaluation=evaluation))

    def _log_scalars(self, episode: int, row: dict, sps: float, term_sums: dict[str, float]) -> None:
        self.writer.add_scalar("charts/episodic_return", row["return"], episode)
        self.writer.add_scalar("charts/episodic_length", row["length"], episode)
        self.writer.add_scalar("charts/success_rate", float(np.mean(self.successes)), episode)
        self.writer.add_scalar("charts/SPS", sps, episode)
        self.writer.add_scalar("charts/global_step", self.model.num_timesteps, episode)
        if hasattr(self.model, "exploration_rate"):  # DQN's epsilon
            self.writer.add_scalar("charts/epsilon", self.model.exploration_rate, episode)
        for key in ("base_fraction", "subgoal_success", "closed_10"):
            if key in row:
                self.writer.add_scalar(f"charts/{key}", row[key], episode)
        for key, value in self.model.logger.name_to_value.items():
            if key.startswith("train/"):
                self.writer.add_scalar(f"losses/{key.split('/', 1)[1]}", value, episode)
            elif key == "rollout/oracle_agreement":  # algo.oracle_labels
                self.writer.add_scalar("charts/oracle_agreement", value, episode)
        for term, total in term_sums.items():  # which reward terms the policy collects (door, button, ...)
            self.writer.add_scalar(f"reward_terms/{term}", total, episode)

    def checkpoint(self, with_replay: bool = True) -> None:
        write_checkpoint(self.run_dir, self.model, self._bookkept_state(), with_replay)

    def _bookkept_state(self) -> dict:
        """A copy of the run's state with its budget counters brought up to now."""
        self.state["wall_time_s"] = self.wall_time
        self.state["cpu_time_s"] = self.cpu_time
        self.state["timesteps"] = self.model.num_timesteps
        self.state["gradient_updates"] = self.gradient_updates
        return dict(self.state)

    @property
    def gradient_updates(self) -> int:
        """Gradient steps this run has taken (every session, not those behind ``--init-from`` weights)."""
        updates_at_start = self.model._n_updates if self.updates_at_start is None else self.updates_at_start
        return int(self.updates_before_session + self.model._n_updates - updates_at_start)

    def close(self) -> None:
        self.writer.close()
        self.csv_file.close()

