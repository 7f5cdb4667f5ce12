"""``relmogen train``: SB3 training with progress, TensorBoard, checkpoints and resume.

A run directory ``{task}__{algo}__{seed}__{time}`` holds ``config.yaml`` (the resolved
configuration), ``episodes.csv`` (one row per finished training episode), TensorBoard events
(x-axis: environment episodes, as the paper plots), and ``checkpoints/`` with the model and,
in its own folder, the replay buffer. The model is saved every ``run.checkpoint_every_episodes``
and the replay (gigabytes for SGP-R) every ``run.replay_every_episodes``; both at every end of
training. Each is written to a fresh folder and published by atomically replacing
``checkpoints/latest`` / ``checkpoints/latest_replay``, so ``kill -9`` at any moment leaves the previous ones intact;
``--resume RUN_DIR`` continues from them: at most one model interval of learning is lost, and
the transitions collected since the last replay save. A stop asked for (Ctrl-C: SIGINT, or
SIGTERM) ends the run after the current environment step and writes both, so nothing is lost,
then raises ``TrainingStopped`` (a second signal interrupts at once, without saving). ``checkpoints/best`` names, the same way,
a copy of the model (no replay) at the best periodic evaluation so far; its ``state.json`` holds
that evaluation.
"""

from __future__ import annotations

import csv
import difflib
import json
import shutil
import signal
import sys
import threading
import time
from pathlib import Path

import numpy as np
import psutil
import torch as th
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from stable_baselines3.common.callbacks import BaseCallback
from torch.utils.tensorboard import SummaryWriter

from relmogen.agents.demonstrations import add_demonstrations
from relmogen.agents.replay import resize_replay_buffer
from relmogen.envs.relmogen_env import RelmogenEnv
# The model factory, environment factory and checkpoint store live in their own modules; their
# public names stay importable from here.
from relmogen.experiments.checkpoints import (  # noqa: F401
    BEST, CHECKPOINTS, LATEST, LATEST_REPLAY, REPLAY_FILE, best_checkpoint, best_evaluation, checkpoint_state,
    evaluation_rank, latest_checkpoint, latest_replay, run_config_file, write_best_checkpoint, write_checkpoint,
    write_evaluated_checkpoint)
from relmogen.experiments.config import TrainConfig, override_config, read_config, save_config
from relmogen.experiments.env_workers import EnvWorkerError
from relmogen.experiments.environments import (  # noqa: F401
    env_kwargs, make_training_env, training_env_kwargs, vec_env_of, worker_env)
from relmogen.experiments.finetune import INIT_LOG, init_source, initialise_from, read_init_from
from relmogen.experiments.models import build_dqn, build_model, model_class, require_device, resolve_device  # noqa: F401

EPISODE_FIELDS = ["episode", "timesteps", "wall_time_s", "return", "length", "success",
                  "base_fraction", "subgoal_success",  # subgoal controls only
                  "closed_10"]  # tasks that count closed items (ArrangeKitchenMM)
SUCCESS_WINDOW = 20




def process_tree_cpu_seconds() -> float:
    """User + system CPU seconds of this process and its live children since they started."""
    me = psutil.Process()
    total = 0.0
    for process in [me, *me.children(recursive=True)]:
        try:
            times = process.cpu_times()
        except psutil.NoSuchProcess:
            continue
        total += times.user + times.system
    return total


# --------------------------------------------------------------------------- callback
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


def hms(seconds: float) -> str:
    """``H:MM:SS``, as rich's elapsed-time column shows it."""
    minutes, secs = divmod(int(round(seconds)), 60)
    return f"{minutes // 60}:{minutes % 60:02d}:{secs:02d}"


BUDGETS = ("episodes", "max_hours", "max_cpu_hours")


def spent_budgets(config: TrainConfig, spent: dict) -> list[str]:
    """Which of ``BUDGETS`` the counters ``spent`` (``episodes``, ``wall_time_s``, ``cpu_time_s``,
    as a checkpoint's ``state.json`` holds them) have reached, in that order."""
    reached = {"episodes": spent["episodes"] >= config.episodes,
               "max_hours": config.max_hours is not None and spent["wall_time_s"] >= config.max_hours * 3600,
               "max_cpu_hours": (config.max_cpu_hours is not None
                                 and spent.get("cpu_time_s", 0.0) >= config.max_cpu_hours * 3600)}
    return [budget for budget in BUDGETS if reached[budget]]


def budget_stop_reason(config: TrainConfig, spent: dict) -> str:
    """``done.json``'s line for a run that ended on its own: the first budget spent."""
    episodes, budget = spent["episodes"], config.episodes
    at = f"at episode {episodes} of {budget}"
    reached = spent_budgets(config, spent)
    if "episodes" in reached:
        return f"stopped by the episode budget: {episodes} of {budget} episodes in {hms(spent['wall_time_s'])}"
    if "max_hours" in reached:
        return f"stopped by the time limit (--max-hours {config.max_hours:g}) {at}, after {hms(spent['wall_time_s'])}"
    if "max_cpu_hours" in reached:
        return (f"stopped by the CPU-time limit (max_cpu_hours {config.max_cpu_hours:g}) {at}, "
                f"after {spent['cpu_time_s'] / 3600:.2f} CPU h")
    return f"stopped {at}"


def spent_budget_note(run_dir: Path, config: TrainConfig, spent: dict) -> str | None:
    """None while ``config`` leaves the run budget to train; else one line naming each budget
    ``spent`` has reached and the option that raises it."""
    reached = [_budget_and_its_option(budget, config, spent) for budget in spent_budgets(config, spent)]
    if not reached:
        return None
    return (f"the run already reached {' and '.join(what for what, _ in reached)}; nothing trained; "
            f"to continue: relmogen train --resume {run_dir} {' '.join(option for _, option in reached)}")


def _budget_and_its_option(budget: str, config: TrainConfig, spent: dict) -> tuple[str, str]:
    """A reached budget in words, and the option that raises it."""
    if budget == "episodes":
        return (f"its episode budget ({spent['episodes']} of {config.episodes} episodes)",
                f"--episodes N (N > {spent['episodes']})")
    if budget == "max_hours":
        hours = spent["wall_time_s"] / 3600
        return (f"its time limit (--max-hours {config.max_hours:g}; {hms(spent['wall_time_s'])} spent)",
                f"--max-hours H (H > {hours:.3g}, a total from the run's start)")
    cpu_hours = spent.get("cpu_time_s", 0.0) / 3600
    return (f"its CPU-time limit (max_cpu_hours {config.max_cpu_hours:g}; {cpu_hours:.3g} CPU h spent)",
            f"--set max_cpu_hours=H (H > {cpu_hours:.3g}, a total from the run's start)")


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
        self.run_dir, self.config, self.state, self.quiet = Path(run_dir), config, state, quiet
        self.writer = SummaryWriter(str(self.run_dir / "tb"))
        self.successes: list[float] = []
        self.session_start = time.time()
        self.wall_before_session = state["wall_time_s"]
        self.cpu_before_session = state.get("cpu_time_s", 0.0)
        self.steps_at_start = state["timesteps"]
        self.csv_file = open(self.run_dir / "episodes.csv", "a", newline="")
        self.csv = csv.DictWriter(self.csv_file, fieldnames=EPISODE_FIELDS, extrasaction="ignore")
        if self.csv_file.tell() == 0:
            self.csv.writeheader()
        self.subgoals: dict[int, list[tuple[bool, bool]]] = {}  # env index -> (is base, plan found) per step
        self.term_sums: dict[int, dict[str, float]] = {}  # env index -> reward terms summed over the episode
        self.progress = Progress(TextColumn("{task.description}"), BarColumn(bar_width=20), MofNCompleteColumn(),
                                 TextColumn("episodes"), TimeElapsedColumn(), TextColumn("{task.fields[remaining]}"),
                                 TextColumn("{task.fields[stats]}"), console=progress_console(), disable=quiet)
        self.bar = None
        self.stop_request = StopRequest()
        self.episodes_at_start = state["episodes"]
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
        return not (self._budget_spent() or self.stop_request.requested)

    def _budget_spent(self) -> bool:
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
        episode, success = self.state["episodes"], float(info.get("is_success", False))
        self.successes = (self.successes + [success])[-SUCCESS_WINDOW:]
        sps = (self.model.num_timesteps - self.steps_at_start) / max(time.time() - self.session_start, 1e-9)
        row = {"episode": episode, "timesteps": self.model.num_timesteps, "wall_time_s": round(self.wall_time, 2),
               "return": info["episode"]["r"], "length": info["episode"]["l"], "success": success}
        if subgoals:
            row["base_fraction"] = round(float(np.mean([base for base, _ in subgoals])), 4)
            row["subgoal_success"] = round(float(np.mean([found for _, found in subgoals])), 4)
        if "closed_10" in info.get("metrics", {}):
            row["closed_10"] = info["metrics"]["closed_10"]
        self.csv.writerow(row)
        self.csv_file.flush()
        self._log_scalars(episode, row, sps)
        for term, total in term_sums.items():  # which reward terms the policy collects (door, button, ...)
            self.writer.add_scalar(f"reward_terms/{term}", total, episode)
        if episode % self.config.run.checkpoint_every_episodes == 0:
            self.checkpoint(with_replay=episode % self.config.run.replay_every_episodes == 0)
        if episode % self.config.run.eval_every_episodes == 0:
            self.evaluate(episode)
        remaining = self.remaining_seconds()
        self.progress.update(self.bar, completed=episode, stats=self._stats(sps),
                             remaining="" if remaining is None else f"~{hms(remaining)} left")

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

    def _log_scalars(self, episode: int, row: dict, sps: float) -> None:
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

    def checkpoint(self, with_replay: bool = True) -> None:
        write_checkpoint(self.run_dir, self.model, self._bookkept_state(), with_replay)

    def _bookkept_state(self) -> dict:
        """A copy of the run's state with its budget counters brought up to now."""
        self.state["wall_time_s"] = self.wall_time
        self.state["cpu_time_s"] = self.cpu_time
        self.state["timesteps"] = self.model.num_timesteps
        return dict(self.state)

    def close(self) -> None:
        self.writer.close()
        self.csv_file.close()


# ------------------------------------------------------------------------------ train
def known_name(value: str, valid, what: str) -> str:
    """``value`` when it is one of ``valid``; else a ValueError that suggests the nearest valid
    name (the same letters in another case first) and lists them all."""
    valid = sorted(valid)
    if value in valid:
        return value
    close = [name for name in valid if name.lower() == value.lower()] or difflib.get_close_matches(value, valid, n=1)
    suggestion = f"did you mean {close[0]}? " if close else ""
    raise ValueError(f"unknown {what} {value!r}; {suggestion}valid: {', '.join(valid)}")


def check_trainable(config: TrainConfig) -> None:
    """Refuses, before anything is written, what would only fail once the run started: an
    unknown task, scene or planner, or a device this machine does not have."""
    from relmogen.motion_generation.planners import BACKENDS
    from relmogen.scenes import available_scenes
    from relmogen.tasks import TASKS

    known_name(config.task, TASKS, "task")
    require_device(config.device)
    kind = TASKS[config.task].scene_kind
    for key in ("scene", "second_scene"):
        if getattr(config.env, key) is not None:
            known_name(getattr(config.env, key), [s for s in available_scenes() if s.startswith(kind)],
                       f"{kind} scene (env.{key})")
    if config.control != "joint":
        for key in ("base_planner", "arm_planner"):
            known_name(getattr(config.env, key), BACKENDS, f"env.{key}")


def new_run_dir(out: Path, config: TrainConfig) -> Path:
    stamp = time.strftime("%Y%m%d-%H%M%S")
    run_dir = Path(out) / f"{config.task}__{config.algo}__{config.seed}__{stamp}"
    run_dir.mkdir(parents=True, exist_ok=False)
    save_config(config, run_dir / "config.yaml")
    return run_dir


def train(config: TrainConfig, out: Path = Path("runs"), quiet: bool = False, init_from: Path | None = None,
          init_replay: bool = False) -> Path:
    """A new run. ``init_from`` (a run directory: its latest checkpoint, or a checkpoint folder)
    starts it from that model's weights and, with ``init_replay``, that run's replay buffer:
    fine-tuning to another scene or robot (``initialise_from``, recorded in ``init_from.json``)."""
    check_trainable(config)
    if init_replay and init_from is None:
        raise ValueError("--init-replay loads the replay buffer of the --init-from run; give --init-from too")
    source = init_source(config, init_from) if init_from is not None else None
    run_dir = new_run_dir(out, config)
    state = {"episodes": 0, "timesteps": 0, "wall_time_s": 0.0}
    env = make_training_env(config, run_dir)
    model = build_model(config, env)
    if source is not None:
        try:
            record = initialise_from(model, config, *source, with_replay=init_replay)
        except ValueError:  # the spaces or the replay layout do not match: leave nothing behind
            env.close()
            shutil.rmtree(run_dir, ignore_errors=True)
            raise
        (run_dir / INIT_LOG).write_text(json.dumps(dict(record, given=str(init_from)), indent=1))
    add_missing_demonstrations(run_dir, config, model, state, quiet)
    return _learn(run_dir, config, model, state, quiet)


def resumed_config(run_dir: Path, episodes: int | None = None, max_hours: float | None = None,
                   overrides: list[str] = ()) -> tuple[TrainConfig, dict, dict]:
    """The run's configuration with a resume's changes: the config, the changed algorithm
    parameters (``override_config``) and the new budgets given as arguments."""
    config, changed = override_config(read_config(run_config_file(run_dir)), list(overrides))
    updates = {key: value for key, value in (("episodes", episodes), ("max_hours", max_hours)) if value is not None}
    return config.model_copy(update=updates), changed, updates


def resume_budget_note(run_dir: Path, episodes: int | None = None, max_hours: float | None = None,
                       overrides: list[str] = ()) -> str | None:
    """What ``resume`` with these arguments would say instead of training: one line naming the
    budgets the run already reached and how to raise them; None when it would train."""
    checkpoint = latest_checkpoint(Path(run_dir))
    if checkpoint is None:
        return None
    state = checkpoint_state(checkpoint)
    return spent_budget_note(Path(run_dir), resumed_config(Path(run_dir), episodes, max_hours, overrides)[0], state)


def resume(run_dir: Path, quiet: bool = False, episodes: int | None = None,
           max_hours: float | None = None, overrides: list[str] = ()) -> Path:
    """Continue a run from its latest checkpoint, optionally with a new episode budget, a new
    total wall-clock budget (hours counted from the run's start, across resumes; a total CPU
    budget through ``max_cpu_hours=H`` in ``overrides``) or changed learning parameters
    (``overrides``, ``--set`` syntax, see ``override_config``). Every change is appended to
    ``resumes.jsonl`` with the episode it took effect at. A run whose latest checkpoint already
    reached the (new) budget is left as it is (``resume_budget_note`` says why); its ``done.json``
    is written if a kill came between that checkpoint and it."""
    run_dir = Path(run_dir)
    config, changed, updates = resumed_config(run_dir, episodes, max_hours, overrides)
    checkpoint = latest_checkpoint(run_dir)
    state = checkpoint_state(checkpoint) if checkpoint else None
    if state is not None and spent_budgets(config, state):
        _write_done(run_dir, state, budget_stop_reason(config, state), keep=True)
        return run_dir
    (run_dir / "done.json").unlink(missing_ok=True)  # running again: not done until _learn returns
    if updates or overrides:
        save_config(config, run_dir / "config.yaml")
        _log_resume(run_dir, state, updates, list(overrides))
    env = make_training_env(config, run_dir)
    if checkpoint is None:  # killed before the first checkpoint: start over in place
        state, model = {"episodes": 0, "timesteps": 0, "wall_time_s": 0.0}, build_model(config, env)
        init = read_init_from(run_dir)
        if init is not None:  # from the same weights (and replay) as the first start
            initialise_from(model, config, Path(init["checkpoint"]), Path(init["run"]), init["replay"] is not None)
    else:
        model = _resumed_model(run_dir, config, checkpoint, changed, env, state)
    add_missing_demonstrations(run_dir, config, model, state, quiet)
    _truncate_episode_log(run_dir / "episodes.csv", state["episodes"])
    return _learn(run_dir, config, model, state, quiet)


def _resumed_model(run_dir: Path, config: TrainConfig, checkpoint: Path, changed: dict, env, state: dict):
    """The checkpoint's model on ``env`` with the changed parameters, and the run's latest replay."""
    th.set_num_threads(config.run.torch_threads)  # as build_model does: extra threads thrash a busy CPU
    model = model_class(config).load(checkpoint / "model.zip", env=env, device=resolve_device(config.device),
                                     **changed)  # SB3 rebuilds schedules and buffer from these
    replay = latest_replay(run_dir)
    if replay is not None:
        model.load_replay_buffer(replay)
    else:  # killed before its first save, or carried to another machine without it
        refill_before_learning(run_dir, model, config, state)
    resize_replay_buffer(model.replay_buffer, config.algo_params.buffer_size)
    return model


def _write_done(run_dir: Path, state: dict, reason: str, keep: bool = False) -> None:
    """``done.json``: the budget spent and what stopped the run (an existing one stays with ``keep``)."""
    done = Path(run_dir) / "done.json"
    if not (keep and done.is_file()):
        done.write_text(json.dumps(dict(state, stop_reason=reason)))


DEMO_LOG = "demonstrations.jsonl"
# Demonstrations of run seed s use episode seeds 50,000 + 1,000 s + n: apart from the final
# evaluations' 100,000 and up for run seeds below 50 and up to 1,000 demonstrations.
DEMO_SEED = 50_000


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


RESUME_LOG = "resumes.jsonl"


def refill_before_learning(run_dir: Path, model, config: TrainConfig, state: dict) -> None:
    """A run resumed without a replay buffer first collects ``learning_starts`` transitions, as a
    new run does (with random actions), instead of fitting batches drawn from its first few; the
    refill is logged to ``resumes.jsonl``."""
    if model.num_timesteps == 0:
        return
    model.learning_starts = model.num_timesteps + config.algo_params.learning_starts
    print(f"{run_dir}: no saved replay buffer; collecting {config.algo_params.learning_starts} transitions "
          "before learning resumes", file=sys.stderr)
    with open(run_dir / RESUME_LOG, "a") as handle:
        handle.write(json.dumps({"from_episode": state["episodes"], "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
                                 "replay": "empty", "learning_starts": model.learning_starts}) + "\n")


def _log_resume(run_dir: Path, state: dict | None, updates: dict, overrides: list[str]) -> None:
    entry = {"from_episode": state["episodes"] if state else 0, "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
             **updates, "set": overrides}
    with open(run_dir / RESUME_LOG, "a") as handle:
        handle.write(json.dumps(entry) + "\n")


def read_resume_log(run_dir: Path) -> list[dict]:
    """The run's resumes, oldest first (empty for a run never resumed with changes)."""
    log = Path(run_dir) / RESUME_LOG
    return [json.loads(line) for line in log.read_text().splitlines()] if log.is_file() else []


def _truncate_episode_log(path: Path, episodes: int) -> None:
    """Drop rows written after the checkpoint we resume from (they will be replayed); the file
    is rewritten with the current columns (a run logged by an older version gains the new
    ones, empty in its old rows)."""
    if not path.is_file():
        return
    with open(path, newline="") as handle:
        rows = [row for row in csv.DictReader(handle) if int(row["episode"]) <= episodes]
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=EPISODE_FIELDS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)


class TrainingStopped(Exception):
    """Training stopped on request (SIGINT, or SIGTERM through the CLI) after writing a checkpoint
    with the replay at ``episodes``."""

    def __init__(self, run_dir: Path, episodes: int, reason: str | None = None):
        super().__init__(run_dir, episodes, reason)
        self.run_dir, self.episodes = run_dir, episodes
        self.reason = reason or f"stopped at episode {episodes}"

    def __str__(self) -> str:
        return f"{self.reason}; model and replay saved; continue with: relmogen train --resume {self.run_dir}"


def _learn(run_dir: Path, config: TrainConfig, model, state: dict, quiet: bool) -> Path:
    monitor = TrainingMonitor(run_dir, config, state, quiet)
    try:
        if not monitor._budget_spent():  # else the latest checkpoint already holds everything
            with monitor.stop_request:
                model.learn(total_timesteps=10**12, callback=monitor, reset_num_timesteps=state["timesteps"] == 0,
                            progress_bar=False)
            stopped = monitor.stop_request.requested
            monitor.checkpoint(with_replay=True)  # every end keeps the replay: --resume loses nothing
            if stopped:
                raise TrainingStopped(run_dir, state["episodes"], monitor.stop_reason())
    except EnvWorkerError as error:  # a worker died or hung: keep what was learned, then report it
        monitor.progress.stop()
        monitor.checkpoint(with_replay=True)
        error.run_dir, error.episodes = run_dir, state["episodes"]
        raise
    finally:
        monitor.close()
        model.get_env().close()
    _write_done(run_dir, state, monitor.stop_reason())
    return run_dir


def stop_reason(run_dir: Path) -> str | None:
    """The line naming what ended a finished run (``done.json``), or None for runs without one."""
    done = Path(run_dir) / "done.json"
    return json.loads(done.read_text()).get("stop_reason") if done.is_file() else None
