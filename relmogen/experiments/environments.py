"""The environment factory of ``relmogen train``: the ``RelmogenEnv`` keyword arguments of a run
(also what evaluation, loading and export build), and its vector of training environments."""

from __future__ import annotations

from pathlib import Path

from stable_baselines3.common.monitor import Monitor
from stable_baselines3.common.vec_env import DummyVecEnv

from relmogen.agents.demonstrations import OracleLabels
from relmogen.envs.hrl4in_wrapper import RobotStateObservation
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.config import TrainConfig
from relmogen.experiments.env_workers import WORKER_ERRORS, GuardedSubprocVecEnv, WorkerErrorLog


def env_kwargs(config: TrainConfig, arm_collision: bool, base_planner: str | None = None,
               arm_planner: str | None = None, scene: str | None = None) -> dict:
    kwargs = {"task": config.task, "control": config.control, "image_size": config.env.image_size,
              "scene": scene or config.env.scene, "robot": config.env.robot, "obs_mode": config.env.obs_mode}
    if config.env.episode_steps is not None:
        kwargs["episode_steps"] = config.env.episode_steps
    if config.control != "joint":
        kwargs.update(motion_generator_kwargs(config, arm_collision, base_planner, arm_planner))
    if config.control in ("subgoal-r", "subgoal-d") and config.env.subgoal_feedback:
        kwargs["subgoal_feedback"] = True
    if config.control == "subgoal-d":
        kwargs.update(push_frame=config.env.push_frame, qmap_size=config.env.qmap_size,
                      reach_mask=config.env.reach_mask)
    return kwargs


def motion_generator_kwargs(config: TrainConfig, arm_collision: bool, base_planner: str | None = None,
                            arm_planner: str | None = None) -> dict:
    """A subgoal control's motion-generator settings (planners default to the config's)."""
    return dict(base_planner=base_planner or config.env.base_planner, arm_planner=arm_planner or config.env.arm_planner,
                arm_collision=arm_collision, base_goal=config.env.base_goal, noop_cost=config.env.noop_cost,
                arm_rrt=tuple(config.env.arm_rrt), base_goal_clearance=config.env.base_goal_clearance,
                arm_collision_backend=config.env.arm_collision_backend)


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
    oracle_labels = config.oracle_labels
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
