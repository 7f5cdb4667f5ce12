"""``relmogen eval``: a trained policy, deterministic, with the task metrics and MG statistics.

``stochastic=True`` samples SGP-R / SAC actions from the policy instead, and makes SGP-D
epsilon-greedy at its final training epsilon (the usual DQN evaluation, e.g. epsilon 0.05 on
Atari): a deterministic subgoal policy whose subgoal finds no plan sees the same observation
again (the step was a no-op) and repeats it until the episode ends, so both figures are worth
reporting. Action sampling is seeded from ``seed``.

``skip_no_ops=True`` (SGP-D only; ours) adds a test-time rule, ``relmogen.agents.dqn.NoOpMemory``:
a subgoal after which the view did not change is not chosen again until it does. It is reported
as its own policy (``deterministic-skip-no-ops``), never as the paper's greedy figure.

SGP-D evaluations of a task with an oracle also report ``oracle_agreement``: the share of the
policy's subgoals that were the oracle's choice in the same state (``OracleAgreement``), a
measure of imitation on the states the policy itself reaches, which demonstrations do not cover.

The planners, arm collision checking and scene can differ from training: that is how the
paper's planner-swap (Table II) and scene-transfer results are measured.
"""

from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Iterator

import numpy as np
import torch as th

from relmogen.agents.demonstrations import OracleAgreement
from relmogen.agents.dqn import env_policy
from relmogen.agents.oracles import ORACLES
from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.config import TrainConfig, read_config
from relmogen.experiments.rollout import aggregate, run_episodes
from relmogen.tasks import task_class
from relmogen.experiments.train import env_kwargs, latest_checkpoint, model_class, resolve_device


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
                   quiet: bool = False, stochastic: bool = False, skip_no_ops: bool = False) -> dict:
    if skip_no_ops and config.algo != "relmogen-d":
        raise ValueError(f"--skip-no-ops excludes a discrete subgoal that changed nothing; it needs relmogen-d, "
                         f"not {config.algo}")
    if scene is not None and scene in ("A", "B"):  # a layout letter: the task's kind of scene
        scene = f"{task_class(config.task).scene_kind}_{scene}"
    env = RelmogenEnv(**env_kwargs(config, arm_collision, base_planner, arm_planner, scene))
    agreement = None
    if config.algo == "relmogen-d":  # over the free base cells only
        act = env_policy(model, env, deterministic=not stochastic, skip_no_ops=skip_no_ops)
        if config.task in ORACLES:
            act = agreement = OracleAgreement(act, env)
        on_reset = act.reset
    else:
        act, on_reset = (lambda obs: model.predict(obs, deterministic=not stochastic)[0]), None
    try:
        with seeded_action_sampling(seed):
            records = run_episodes(env, act, episodes, seed, quiet, on_reset=on_reset,
                                   description=f"eval {config.task}")
    finally:
        env.close()
    policy = ("stochastic" if stochastic else "deterministic") + ("-skip-no-ops" if skip_no_ops else "")
    settings = {"task": config.task, "algo": config.algo, "seed": config.seed, "scene": env.scene.name,
                "policy": policy}
    if stochastic and config.algo == "relmogen-d":
        settings["epsilon"] = float(model.exploration_rate)
    if config.control != "joint":
        settings.update(base_planner=base_planner or config.env.base_planner,
                        arm_planner=arm_planner or config.env.arm_planner, arm_collision=arm_collision,
                        base_goal=config.env.base_goal, noop_cost=config.env.noop_cost)
    result = {**settings, **aggregate(records)}
    if agreement is not None:
        result["oracle_agreement"] = float(np.mean(agreement.matches))
    return result


def load_policy(path: Path, device: str = "auto"):
    """A run directory (its latest checkpoint) or a checkpoint folder -> (model, config)."""
    path = Path(path)
    if (path / "model.zip").is_file():
        checkpoint, run_dir = path, path.parent.parent
    else:
        checkpoint, run_dir = latest_checkpoint(path), path
        if checkpoint is None:
            raise ValueError(f"{path} has no checkpoint (expected {path}/checkpoints/latest)")
    config = read_config(run_dir / "config.yaml")
    th.set_num_threads(config.run.torch_threads)  # one thread per process unless the config says otherwise
    model = model_class(config).load(checkpoint / "model.zip", device=resolve_device(device))
    return model, config, run_dir


def evaluate_path(path: Path, episodes: int, seed: int = 0, base_planner: str | None = None,
                  arm_planner: str | None = None, arm_collision: bool = True, scene: str | None = None,
                  device: str = "auto", quiet: bool = False, save: bool = True, stochastic: bool = False,
                  skip_no_ops: bool = False) -> dict:
    model, config, run_dir = load_policy(path, device)
    result = evaluate_model(model, config, episodes, seed, base_planner, arm_planner, arm_collision, scene, quiet,
                            stochastic, skip_no_ops)
    if save:
        name = f"eval_{result.get('scene')}_{result.get('base_planner', 'na')}_{result.get('arm_planner', 'na')}_" \
               f"collision-{'on' if arm_collision else 'off'}_{episodes}ep" \
               f"{'_stochastic' if stochastic else ''}{'_skip_no_ops' if skip_no_ops else ''}.json"
        (run_dir / "eval").mkdir(exist_ok=True)
        (run_dir / "eval" / name).write_text(json.dumps(result, indent=1))
    return result
