"""``relmogen train``: SB3 training with progress, TensorBoard, checkpoints and resume.

A run directory ``{task}__{algo}__{seed}__{time}`` holds ``config.yaml`` (the resolved
configuration), ``episodes.csv`` (one row per finished training episode), TensorBoard events
(x-axis: environment episodes, as the paper plots), and ``checkpoints/`` with the model and,
in its own folder, the replay buffer. The model is saved every ``run.checkpoint_every_episodes``
and the replay (gigabytes for SGP-R) every ``run.replay_every_episodes``. Each is written to a
fresh folder and published by atomically replacing ``checkpoints/latest`` /
``checkpoints/latest_replay``, so ``kill -9`` at any moment leaves the previous ones intact;
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
import os
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
from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv
from torch.utils.tensorboard import SummaryWriter

from relmogen.agents.demonstrations import OracleLabels, add_demonstrations
from relmogen.agents.dqn import RelmogenDQN
from relmogen.agents.hrl4in import HRL4IN, build_hrl4in
from relmogen.agents.networks import SGPREncoder
from relmogen.agents.replay import CompactDictReplayBuffer, resize_replay_buffer
from relmogen.agents.sac import OAC, SharedEncoderSAC
from relmogen.envs.hrl4in_wrapper import RobotStateObservation
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.config import TrainConfig, override_config, read_config, save_config
from relmogen.experiments.finetune import INIT_LOG, init_source, initialise_from, read_init_from
from relmogen.experiments.env_workers import WORKER_ERRORS, EnvWorkerError, GuardedSubprocVecEnv, WorkerErrorLog

CHECKPOINTS = "checkpoints"
LATEST = "latest"  # a file naming the newest complete model checkpoint folder
LATEST_REPLAY = "latest_replay"  # a file naming the newest complete replay folder
BEST = "best"  # a file naming the model folder of the best periodic evaluation so far
REPLAY_FILE = "replay_buffer.pkl"
EPISODE_FIELDS = ["episode", "timesteps", "wall_time_s", "return", "length", "success",
                  "base_fraction", "subgoal_success",  # subgoal controls only
                  "closed_10"]  # tasks that count closed items (ArrangeKitchenMM)
SUCCESS_WINDOW = 20


def resolve_device(device: str) -> str:
    if device == "auto":
        return "cuda" if th.cuda.is_available() else "cpu"
    return device


def require_device(device: str) -> str:
    """``device`` when this machine has it: ``auto``, ``cpu``, ``cuda[:N]`` with CUDA, ``mps`` with
    MPS. An accelerator that is missing is an error, not a silent run on the CPU."""
    if device == "auto":
        return device
    try:
        kind = th.device(device).type
    except RuntimeError as error:
        raise ValueError(f"unknown device {device!r}; use auto, cpu or cuda") from error
    available = {"cpu": True, "cuda": th.cuda.is_available(), "mps": th.backends.mps.is_available()}
    if not available.get(kind, False):
        raise ValueError(f"device {device!r} is not available on this machine; use --device cpu or --device auto")
    return device


def env_kwargs(config: TrainConfig, arm_collision: bool, base_planner: str | None = None,
               arm_planner: str | None = None, scene: str | None = None) -> dict:
    kwargs = {"task": config.task, "control": config.control, "image_size": config.env.image_size,
              "scene": scene or config.env.scene, "robot": config.env.robot, "obs_mode": config.env.obs_mode}
    if config.env.episode_steps is not None:
        kwargs["episode_steps"] = config.env.episode_steps
    if config.control != "joint":
        kwargs.update(base_planner=base_planner or config.env.base_planner,
                      arm_planner=arm_planner or config.env.arm_planner, arm_collision=arm_collision,
                      base_goal=config.env.base_goal, noop_cost=config.env.noop_cost,
                      arm_rrt=tuple(config.env.arm_rrt), base_goal_clearance=config.env.base_goal_clearance)
    if config.control == "subgoal-r" and config.env.subgoal_feedback:
        kwargs["subgoal_feedback"] = True
    if config.control == "subgoal-d":
        kwargs.update(push_frame=config.env.push_frame, qmap_size=config.env.qmap_size,
                      reach_mask=config.env.reach_mask)
    return kwargs


def training_env_kwargs(config: TrainConfig) -> list[dict]:
    """Each training environment's ``RelmogenEnv`` keyword arguments: the last
    ``config.env.second_scene_envs`` of them in ``env.second_scene`` (the paper's fine-tuning to
    a new scene swaps half of the training environments), the others in ``env.scene``."""
    kwargs = env_kwargs(config, arm_collision=config.env.arm_collision_train)
    first = config.env.n_envs - config.env.second_scene_envs
    return [kwargs if rank < first else dict(kwargs, scene=config.env.second_scene)
            for rank in range(config.env.n_envs)]


def vec_env_of(per_env: list[dict], seed: int, vec_env_cls, vec_env_kwargs: dict | None = None,
               wrapper_class=None, wrapper_kwargs: dict | None = None):
    """SB3's ``make_vec_env`` for ``RelmogenEnv``s that each have their own keyword arguments, with
    its steps: environment ``rank``'s action space seeded with ``seed + rank``, ``Monitor``, then
    ``wrapper_class``; the vector environment seeded for its first reset."""
    def make(rank: int, kwargs: dict):
        def init():
            env = RelmogenEnv(**kwargs)
            env.action_space.seed(seed + rank)
            env = Monitor(env)
            return env if wrapper_class is None else wrapper_class(env, **(wrapper_kwargs or {}))
        return init

    vec_env = vec_env_cls([make(rank, kwargs) for rank, kwargs in enumerate(per_env)], **(vec_env_kwargs or {}))
    vec_env.seed(seed)
    return vec_env


def make_training_env(config: TrainConfig, run_dir: Path | None = None):
    """The training environments: in-process for one, else one worker process each
    (``GuardedSubprocVecEnv``: a dead or stuck worker raises ``EnvWorkerError`` instead of hanging;
    with ``run_dir``, a worker's exception is logged to ``run_dir/worker_errors.log``)."""
    per_env = training_env_kwargs(config)
    oracle_labels = config.algo_params.oracle_labels
    if config.env.n_envs == 1:
        return vec_env_of(per_env, seed=config.seed, vec_env_cls=DummyVecEnv,
                          wrapper_class=OracleLabels if oracle_labels else
                          (RobotStateObservation if config.algo == "hrl4in" else None))
    error_log = str(Path(run_dir) / WORKER_ERRORS) if run_dir is not None else None
    return vec_env_of(per_env, seed=config.seed, vec_env_cls=GuardedSubprocVecEnv,
                      vec_env_kwargs={"timeout_s": config.run.worker_timeout_s, "error_log": error_log},
                      wrapper_class=worker_env, wrapper_kwargs={"oracle_labels": oracle_labels,
                                                                "robot_state": config.algo == "hrl4in",
                                                                "error_log": error_log})


def worker_env(env, oracle_labels: bool = False, error_log: str | None = None, robot_state: bool = False):
    """A worker's environment: ``OracleLabels`` when asked, inside ``WorkerErrorLog``."""
    if robot_state:  # hrl4in: the robot's world state travels with the observation
        env = RobotStateObservation(env)
    return WorkerErrorLog(OracleLabels(env) if oracle_labels else env, error_log)


def build_model(config: TrainConfig, env):
    th.set_num_threads(config.run.torch_threads)
    if config.algo == "relmogen-d":
        return build_dqn(config, env)
    if config.algo == "hrl4in":  # two SAC levels and their own collection loop (agents/hrl4in.py)
        return build_hrl4in(config, env, resolve_device(config.device))
    params = config.algo_params
    # fused Adam: one kernel per step instead of one per tensor (updates 72 -> 69 ms of CPU, batch 64)
    policy_kwargs = dict(net_arch=params.net_arch, optimizer_kwargs={"fused": True})
    if config.env.obs_mode == "rgbd":  # state: SB3's CombinedExtractor flattens the vector
        policy_kwargs.update(features_extractor_class=SGPREncoder, normalize_images=False,
                             features_extractor_kwargs={"image_shift": params.image_shift})
    common = dict(env=env, learning_rate=params.learning_rate, buffer_size=params.buffer_size,
                  batch_size=params.batch_size, tau=params.tau, gamma=params.gamma,
                  learning_starts=params.learning_starts, train_freq=params.train_freq,
                  gradient_steps=params.gradient_steps, ent_coef=f"auto_{params.ent_coef_init}",
                  ent_coef_min=params.ent_coef_min,
                  target_entropy="auto" if params.target_entropy is None else params.target_entropy,
                  policy_kwargs=policy_kwargs, replay_buffer_class=CompactDictReplayBuffer, seed=config.seed,
                  device=resolve_device(config.device), verbose=0)
    if config.algo == "oac":
        return OAC(beta_ub=params.beta_ub or 4.66, delta=params.delta or 23.53, **common)
    return SharedEncoderSAC(**common)


def build_dqn(config: TrainConfig, env) -> RelmogenDQN:
    from relmogen.tasks import task_class

    params = config.algo_params
    policy_kwargs = {key: value for key, value in
                     (("widths", params.qmap_widths), ("head_width", params.qmap_head_width),
                      ("skip", params.qmap_skip), ("bf16", params.qmap_bf16), ("unet", params.qmap_unet),
                      ("head_kernel", params.qmap_head_kernel))
                     if value is not None}
    optional = {key: getattr(params, key) for key in
                ("target_update_interval", "max_grad_norm", "exploration_initial_eps", "exploration_final_eps",
                 "exploration_steps", "conservative_weight", "mask_arm", "n_step_returns", "oracle_labels",
                 "exploration_temperature", "priority_alpha", "priority_beta", "shift_cells")
                if getattr(params, key) is not None}
    return RelmogenDQN(env=env, learning_rate=params.learning_rate, buffer_size=params.buffer_size,
                       demo_margin_weight=params.demo_margin_weight,
                       replay_buffer_kwargs={"keep_demonstrations": params.demo_keep},
                       batch_size=params.batch_size, gamma=params.gamma, learning_starts=params.learning_starts,
                       train_freq=params.train_freq, gradient_steps=params.gradient_steps, tau=params.tau,
                       subgoal_parts=task_class(config.task).subgoal_parts, policy_kwargs=policy_kwargs,
                       seed=config.seed, device=resolve_device(config.device), verbose=0, **optional)


def model_class(config: TrainConfig):
    return {"oac": OAC, "relmogen-d": RelmogenDQN, "hrl4in": HRL4IN}.get(config.algo, SharedEncoderSAC)


# ------------------------------------------------------------------------ checkpoints
def latest_checkpoint(run_dir: Path) -> Path | None:
    return _pointed_checkpoint(run_dir, LATEST)


def best_checkpoint(run_dir: Path) -> Path | None:
    """The model of the best periodic evaluation so far (``TrainingMonitor.evaluate``), or None."""
    return _pointed_checkpoint(run_dir, BEST)


def _pointed_checkpoint(run_dir: Path, pointer_name: str) -> Path | None:
    pointer = Path(run_dir) / CHECKPOINTS / pointer_name
    if not pointer.is_file():
        return None
    folder = pointer.parent / pointer.read_text().strip()
    return folder if (folder / "model.zip").is_file() else None


def best_evaluation(run_dir: Path) -> dict | None:
    """The periodic evaluation recorded with ``checkpoints/best``, or None before the first one."""
    checkpoint = best_checkpoint(run_dir)
    return json.loads((checkpoint / "state.json").read_text()).get("evaluation") if checkpoint else None


def evaluation_rank(evaluation: dict) -> tuple[float, float, float]:
    """Orders evaluations, best last: success rate, then items closed (``closed_10``), then mean
    return, so ties and tasks that never succeed are decided by the next figure."""
    return (evaluation.get("success_rate", 0.0), evaluation.get("closed_10", 0.0),
            evaluation.get("mean_return", -np.inf))


def latest_replay(run_dir: Path) -> Path | None:
    """The newest saved replay buffer file: its own folder (``latest_replay``), or inside the
    model checkpoint for runs saved before the two were split."""
    root = Path(run_dir) / CHECKPOINTS
    pointer = root / LATEST_REPLAY
    if pointer.is_file() and (root / pointer.read_text().strip() / REPLAY_FILE).is_file():
        return root / pointer.read_text().strip() / REPLAY_FILE
    checkpoint = latest_checkpoint(run_dir)
    return checkpoint / REPLAY_FILE if checkpoint is not None and (checkpoint / REPLAY_FILE).is_file() else None


def checkpoint_state(folder: Path) -> dict:
    """The ``state.json`` of a checkpoint folder (episodes, timesteps, ...); {} if it has none."""
    path = Path(folder) / "state.json"
    return json.loads(path.read_text()) if path.is_file() else {}


def write_checkpoint(run_dir: Path, model, state: dict, with_replay: bool = True) -> Path:
    """The model (and, when asked, the replay buffer in its own folder) published atomically;
    older folders of the same kind are removed once the new one is in place."""
    root = Path(run_dir) / CHECKPOINTS
    if with_replay:
        _write_folder(root, f"replay_{state['episodes']:07d}", LATEST_REPLAY,
                      lambda folder: model.save_replay_buffer(folder / REPLAY_FILE), state)
    return _write_folder(root, f"episode_{state['episodes']:07d}", LATEST,
                         lambda folder: model.save(folder / "model.zip"), state)


def write_best_checkpoint(run_dir: Path, model, state: dict) -> Path:
    """The model alone (no replay) as ``checkpoints/best_<episode>``, published atomically through
    ``checkpoints/best``; ``state["evaluation"]`` is the evaluation that made it the best."""
    return _write_folder(Path(run_dir) / CHECKPOINTS, f"best_{state['episodes']:07d}", BEST,
                         lambda folder: model.save(folder / "model.zip"), state)


def write_evaluated_checkpoint(run_dir: Path, model, state: dict) -> Path:
    """The model alone as ``checkpoints/evaluated_<episode>`` (``run.keep_evaluated``); earlier
    ones are kept, ``checkpoints/evaluated`` names the newest."""
    return _write_folder(Path(run_dir) / CHECKPOINTS, f"evaluated_{state['episodes']:07d}", "evaluated",
                         lambda folder: model.save(folder / "model.zip"), state, prune=False)


def _write_folder(root: Path, name: str, pointer: str, write, state: dict, prune: bool = True) -> Path:
    folder, staging = root / name, root / f".staging_{os.getpid()}"
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir(parents=True)
    write(staging)
    (staging / "state.json").write_text(json.dumps(state))
    if (staging / "model.zip").is_file() and (root.parent / "config.yaml").is_file():
        shutil.copy(root.parent / "config.yaml", staging)  # a model carries its settings (loading.py)
    shutil.rmtree(folder, ignore_errors=True)
    os.replace(staging, folder)
    _publish(root, folder.name, pointer)
    if prune:
        for old in root.glob(name.split("_")[0] + "_*"):
            if old.name != folder.name:
                shutil.rmtree(old, ignore_errors=True)
    return folder


def _publish(root: Path, name: str, pointer: str) -> None:
    tmp = root / f".{pointer}.tmp"
    tmp.write_text(name)
    os.replace(tmp, root / pointer)


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
        hours, cpu_hours = self.config.max_hours, self.config.max_cpu_hours
        return (self.state["episodes"] >= self.config.episodes or (hours is not None and self.wall_time >= hours * 3600)
                or (cpu_hours is not None and self.cpu_time >= cpu_hours * 3600))

    def stop_reason(self) -> str:
        """One line naming what ended the run: a signal, or the first budget spent."""
        episodes, budget = self.state["episodes"], self.config.episodes
        at = f"at episode {episodes} of {budget}"
        if self.stop_request.requested:
            return f"stopped by {self.stop_request.signal_name} {at}"
        hours, cpu_hours = self.config.max_hours, self.config.max_cpu_hours
        if episodes >= budget:
            return f"stopped by the episode budget: {episodes} of {budget} episodes in {hms(self.wall_time)}"
        if hours is not None and self.wall_time >= hours * 3600:
            return f"stopped by the time limit (--max-hours {hours:g}) {at}, after {hms(self.wall_time)}"
        if cpu_hours is not None and self.cpu_time >= cpu_hours * 3600:
            return (f"stopped by the CPU-time limit (max_cpu_hours {cpu_hours:g}) {at}, "
                    f"after {self.cpu_time / 3600:.2f} CPU h")
        return f"stopped {at}"

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


def run_config_file(run_dir: Path) -> Path:
    """``run_dir/config.yaml``; a ValueError when ``run_dir`` is not a run directory."""
    path = Path(run_dir) / "config.yaml"
    if not path.is_file():
        raise ValueError(f"{run_dir} is not a run directory (no config.yaml); give a folder made by relmogen train")
    return path


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


def resume(run_dir: Path, quiet: bool = False, episodes: int | None = None,
           max_hours: float | None = None, overrides: list[str] = ()) -> Path:
    """Continue a run from its latest checkpoint, optionally with a new episode budget, a new
    total wall-clock budget (hours counted from the run's start, across resumes; a total CPU
    budget through ``max_cpu_hours=H`` in ``overrides``) or changed learning parameters (``overrides``, ``--set`` syntax, see ``override_config``). Every
    change is appended to ``resumes.jsonl`` with the episode it took effect at."""
    run_dir = Path(run_dir)
    config, changed = override_config(read_config(run_config_file(run_dir)), list(overrides))
    (run_dir / "done.json").unlink(missing_ok=True)  # running again: not done until _learn returns
    updates = {key: value for key, value in (("episodes", episodes), ("max_hours", max_hours)) if value is not None}
    config = config.model_copy(update=updates)
    checkpoint = latest_checkpoint(run_dir)
    state = json.loads((checkpoint / "state.json").read_text()) if checkpoint else None
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
        th.set_num_threads(config.run.torch_threads)  # as build_model does: extra threads thrash a busy CPU
        model = model_class(config).load(checkpoint / "model.zip", env=env, device=resolve_device(config.device),
                                         **changed)  # SB3 rebuilds schedules and buffer from these
        replay = latest_replay(run_dir)
        if replay is not None:
            model.load_replay_buffer(replay)
        else:  # killed before its first save, or carried to another machine without it
            refill_before_learning(run_dir, model, config, state)
        resize_replay_buffer(model.replay_buffer, config.algo_params.buffer_size)
    add_missing_demonstrations(run_dir, config, model, state, quiet)
    _truncate_episode_log(run_dir / "episodes.csv", state["episodes"])
    return _learn(run_dir, config, model, state, quiet)


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
            monitor.checkpoint(with_replay=stopped)  # a stop asked for keeps the replay too
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
    (run_dir / "done.json").write_text(json.dumps(dict(state, stop_reason=monitor.stop_reason())))
    return run_dir


def stop_reason(run_dir: Path) -> str | None:
    """The line naming what ended a finished run (``done.json``), or None for runs without one."""
    done = Path(run_dir) / "done.json"
    return json.loads(done.read_text()).get("stop_reason") if done.is_file() else None
