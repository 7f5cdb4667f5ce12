"""``relmogen eval``: a trained policy, deterministic, with the task metrics and MG statistics.

``stochastic=True`` samples SGP-R / SAC actions from the policy instead, and makes SGP-D
epsilon-greedy at its final training epsilon (the usual DQN evaluation, e.g. epsilon 0.05 on
Atari): a deterministic subgoal policy whose subgoal finds no plan sees the same observation
again (the step was a no-op) and repeats it until the episode ends, so both figures are worth
reporting. Action sampling is seeded from ``seed``.

``skip_no_ops=True`` (SGP-D and SGP-R; ours) adds a test-time rule after a subgoal that left the
view unchanged (``relmogen.agents.addons.skip_no_ops``): SGP-D does not choose it again until the
view changes; SGP-R samples its next subgoal instead of taking the mean. It is reported as its own
policy (``deterministic-skip-no-ops``), never as the paper's greedy figure.

``critic_select=K`` (SGP-R and the SAC family; ours) takes, of the actor's mean and K - 1 fixed
samples around it, the action the critics value highest (``relmogen.agents.addons.critic_select``),
reported as ``deterministic-critic-select-K``.

SGP-D evaluations of a task with an oracle also report ``oracle_agreement``: the share of the
policy's subgoals that were the oracle's choice in the same state (``OracleAgreement``), a
measure of imitation on the states the policy itself reaches, which demonstrations do not cover.

The planners, arm collision checking and scene can differ from training: that is how the
paper's planner-swap (Table II) and scene-transfer results are measured.

A run is evaluated from its latest checkpoint, its best one (``checkpoints/best``, the best
periodic evaluation during training), a checkpoint folder or an exported actor's folder
(``relmogen export``), loaded by ``loading.load_trained`` as ``relmogen.load`` loads it. The
result names the checkpoint (``checkpoint``: its folder name, ``checkpoint_episode``), the
evaluation's episode seeds (``eval_seed`` up to ``eval_seed + episodes - 1``) and the run's
``training_seed``; its file in ``RUN/eval/`` is named after the setting, the checkpoint and
``eval_seed``, so evaluations of other checkpoints or seeds sit beside it (an exported actor's
results are only returned: its folder may be inside the installed package). ``video`` records the first episode
(``relmogen.experiments.video``).
"""

from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Iterator

import numpy as np
import torch as th

from relmogen.agents.demonstrations import OracleAgreement
from relmogen.agents.oracles import ORACLES
from relmogen.experiments.shipped import SHIPPABLE_ALGOS
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.config import EnvConfig, TrainConfig
from relmogen.experiments.loading import load_checkpoint, load_policy, resolve_checkpoint  # noqa: F401 (re-exported)
from relmogen.experiments.loading import load_trained, policy_act
from relmogen.experiments.rollout import aggregate, run_episodes
from relmogen.tasks import task_class
from relmogen.experiments.environments import env_kwargs, motion_generator_kwargs
from relmogen.experiments.video import VIDEO_FPS, AnnotatedRecorder
from relmogen.simulation.views import check_animation_path, write_animation


@contextlib.contextmanager
def seeded_action_sampling(seed: int) -> Iterator[None]:
    """Seeds the generators actions are sampled from (numpy: SGP-D's epsilon coin; torch: SAC's
    samples) and restores them afterwards, so an evaluation during training leaves the
    training's exploration stream as it was."""
    numpy_state = np.random.get_state()
    with th.random.fork_rng(devices=[]):
        np.random.seed(seed)
        th.manual_seed(seed)
        try:
            yield
        finally:
            np.random.set_state(numpy_state)


def evaluate_model(model, config: TrainConfig, episodes: int, seed: int = 0, base_planner: str | None = None,
                   arm_planner: str | None = None, arm_collision: bool = True, scene: str | None = None,
                   quiet: bool = False, stochastic: bool = False, skip_no_ops: bool = False,
                   video: Path | None = None, robot: str | None = None, base_goal: str | None = None,
                   base_goal_clearance: float | None = None, critic_select: int = 0) -> dict:
    """``episodes`` episodes with seeds ``seed, seed + 1, ...``: the settings and the aggregated
    metrics; ``video`` (a .gif or .mp4 path) records the first one with overlays. ``robot``
    evaluates on another embodiment than the run's (its spaces must be the policy's),
    ``base_goal`` / ``base_goal_clearance`` with another rule for base goals the robot cannot
    reach or must not park at (``EnvConfig.base_goal``, ``EnvConfig.base_goal_clearance``)."""
    config = with_robot(config, robot)
    if base_goal is not None:
        config = with_env(config, base_goal=base_goal)
    if base_goal_clearance is not None:
        config = with_env(config, base_goal_clearance=base_goal_clearance)
    if skip_no_ops and config.algo not in ("relmogen-d", "relmogen-r"):
        raise ValueError(f"--skip-no-ops changes a subgoal policy's choice after a subgoal that changed nothing; it "
                         f"needs relmogen-d or relmogen-r, not {config.algo}")
    if skip_no_ops and stochastic and config.algo == "relmogen-r":
        raise ValueError("--skip-no-ops makes relmogen-r sample only after a no-op; --stochastic samples at every "
                         "step already, so use one of them")
    if critic_select and (stochastic or skip_no_ops or config.algo not in SHIPPABLE_ALGOS):
        raise ValueError(f"--critic-select chooses among a SAC-family actor's samples by its critic (relmogen-r, sac, "
                         f"oac), without --stochastic or --skip-no-ops; got {config.algo}"
                         f"{' with --stochastic' if stochastic else ''}{' with --skip-no-ops' if skip_no_ops else ''}")
    if scene is not None and scene in ("A", "B"):  # a layout letter: the task's kind of scene
        scene = f"{task_class(config.task).scene_kind}_{scene}"
    env = RelmogenEnv(**env_kwargs(config, arm_collision, base_planner, arm_planner, scene))
    act, agreement = policy_act(model, config, env, stochastic, skip_no_ops, critic_select, seed), None
    if config.algo == "relmogen-d" and config.task in ORACLES:
        act = agreement = OracleAgreement(act, env)
    on_reset = act.reset
    recorder = AnnotatedRecorder() if video is not None else None
    try:
        with seeded_action_sampling(seed):
            records = run_episodes(env, act, episodes, seed, quiet, on_reset=on_reset,
                                   description=f"eval {config.task}", first_recorder=recorder)
    finally:
        env.close()
    policy = (("stochastic" if stochastic else "deterministic") + ("-skip-no-ops" if skip_no_ops else "")
              + (f"-critic-select-{critic_select}" if critic_select else ""))
    settings = {"task": config.task, "algo": config.algo, "training_seed": config.seed, "eval_seed": seed,
                "scene": env.scene.name, "robot": config.env.robot, "policy": policy}
    if stochastic and config.algo == "relmogen-d":
        settings["epsilon"] = float(model.exploration_rate)
    if config.control != "joint":
        settings.update(motion_generator_kwargs(config, arm_collision, base_planner, arm_planner))
    if config.control in ("subgoal-r", "subgoal-d"):
        settings["subgoal_feedback"] = config.env.subgoal_feedback
    result = {**settings, **aggregate(records)}
    if agreement is not None:
        result["oracle_agreement"] = float(np.mean(agreement.matches))
    if recorder is not None:
        result["video"] = str(write_animation(recorder.frames, video, fps=VIDEO_FPS))
    return result


def with_robot(config: TrainConfig, robot: str | None) -> TrainConfig:
    """``config`` with ``env.robot`` replaced (validated: an unknown robot is a clear error)."""
    from relmogen.robots.spec import load_spec

    if robot is None or robot == config.env.robot:
        return config
    load_spec(robot)  # an unknown name: ValueError listing the robots
    return with_env(config, robot=robot)


def with_env(config: TrainConfig, **fields) -> TrainConfig:
    """``config`` with these ``env`` fields replaced, validated by ``EnvConfig``."""
    return config.model_copy(update={"env": EnvConfig.model_validate({**config.env.model_dump(), **fields})})


def evaluate_path(path: Path, episodes: int, seed: int = 0, base_planner: str | None = None,
                  arm_planner: str | None = None, arm_collision: bool = True, scene: str | None = None,
                  device: str = "auto", quiet: bool = False, save: bool = True, stochastic: bool = False,
                  skip_no_ops: bool = False, checkpoint: str = "latest", video: Path | None = None,
                  robot: str | None = None, base_goal: str | None = None,
                  base_goal_clearance: float | None = None, critic_select: int = 0) -> dict:
    """``evaluate_model`` on what ``load_trained`` loads from ``path`` (a run's checkpoint, see
    ``resolve_checkpoint``, or an exported actor), saved in ``RUN/eval/`` under
    ``evaluation_file_name`` (an exported actor has no run: its results are only returned)."""
    if video is not None:
        check_animation_path(video)
    trained = load_trained(path, checkpoint, device)
    if critic_select and trained.run_dir is None:
        raise ValueError(f"--critic-select needs the critics; {path} is an exported actor, without them")
    result = evaluate_model(trained.model, trained.config, episodes, seed, base_planner, arm_planner, arm_collision,
                            scene, quiet, stochastic, skip_no_ops, video, robot, base_goal, base_goal_clearance,
                            critic_select)
    result = {**result, "checkpoint": trained.checkpoint_name, "checkpoint_episode": trained.checkpoint_episode}
    if save and trained.run_dir is not None:
        save_evaluation(result, trained.run_dir, trained.config, arm_collision)
    return result


def save_evaluation(result: dict, run_dir: Path, config: TrainConfig, arm_collision: bool) -> Path:
    """``result`` as ``RUN/eval/<evaluation_file_name>``."""
    (run_dir / "eval").mkdir(exist_ok=True)
    name = evaluation_file_name(result, arm_collision, trained_base_goal=config.env.base_goal,
                                trained_goal_clearance=config.env.base_goal_clearance)
    path = run_dir / "eval" / name
    path.write_text(json.dumps(result, indent=1))
    return path


def evaluation_file_name(result: dict, arm_collision: bool, trained_base_goal: str | None = None,
                         trained_goal_clearance: float = 0.0) -> str:
    """``eval_<scene>[_<robot>]_<base planner>_<arm planner>[_goal-<base goal>][_clearance-<m>]_collision-<on|off>
    _<N>ep[_stochastic][_skip_no_ops][_critic_select<K>]_<checkpoint folder>_seed<eval seed>.json``; ``na`` for the
    planners of joint control; the robot only when it is not Fetch, the base goal rule and its
    clearance only when they are not the ones the run trained with."""
    policy = result["policy"]
    robot = "" if result.get("robot", "fetch") == "fetch" else f"_{result['robot']}"
    goal = result.get("base_goal")
    goal = f"_goal-{goal}" if goal is not None and trained_base_goal is not None and goal != trained_base_goal else ""
    clearance = result.get("base_goal_clearance")
    if clearance is not None and clearance != trained_goal_clearance:
        goal += f"_clearance-{clearance:.2f}"
    return (f"eval_{result.get('scene')}{robot}_{result.get('base_planner', 'na')}_{result.get('arm_planner', 'na')}"
            f"{goal}_collision-{'on' if arm_collision else 'off'}_{result['episodes']}ep"
            f"{'_stochastic' if policy.startswith('stochastic') else ''}"
            f"{'_skip_no_ops' if policy.endswith('skip-no-ops') else ''}"
            f"{'_critic_select' + policy.rsplit('-', 1)[1] if '-critic-select-' in policy else ''}"
            f"_{result['checkpoint']}_seed{result['eval_seed']}.json")
