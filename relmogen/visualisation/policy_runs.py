"""A trained run's policy acting in its task, for figures drawn from its episodes."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from relmogen.envs.relmogen_env import RelmogenEnv
from relmogen.experiments.config import TrainConfig
from relmogen.experiments.rollout import FrameRecorder, run_episode


@dataclass
class PolicyRun:
    """A checkpoint's model, its run's config, and an environment of its task it acts in
    (``act``: ``obs -> action`` with ``reset``, see ``evaluate.policy_act``)."""

    model: object
    config: TrainConfig
    run_dir: Path
    checkpoint: Path
    env: RelmogenEnv
    act: object
    stochastic: bool

    @property
    def checkpoint_episode(self) -> int | None:
        from relmogen.experiments.checkpoints import checkpoint_state

        return checkpoint_state(self.checkpoint).get("episodes")

    @property
    def label(self) -> str:
        episode = self.checkpoint_episode
        return (f"{self.config.algo} on {self.config.task}, {self.config.env.robot}"
                + (f" (episode {episode})" if episode is not None else ""))

    def describe(self) -> dict:
        """The fields every figure's JSON starts with."""
        return {"run": str(self.run_dir), "task": self.config.task, "algo": self.config.algo,
                "robot": self.config.env.robot,
                "checkpoint": self.checkpoint.name, "checkpoint_episode": self.checkpoint_episode,
                "policy": "stochastic" if self.stochastic else "deterministic"}

    def record(self, recorder: FrameRecorder, episodes: int, seed: int) -> None:
        """``episodes`` episodes with seeds ``seed, seed + 1, ...``, each seen by ``recorder``;
        sampled actions are seeded from ``seed`` (``seeded_action_sampling``)."""
        from relmogen.experiments.evaluate import seeded_action_sampling

        with seeded_action_sampling(seed):
            for episode in range(episodes):
                run_episode(self.env, self.act, seed + episode, on_reset=getattr(self.act, "reset", None),
                            recorder=recorder)

    def close(self) -> None:
        self.env.close()


def open_policy_run(path: Path, checkpoint: str = "latest", device: str = "auto", stochastic: bool = False,
                    arm_collision: bool | None = True, robot: str | None = None) -> PolicyRun:
    """A run directory (its ``checkpoint``: latest, best or a folder) or a checkpoint folder
    acting in its own task; ``arm_collision=None`` checks arm plans as during its training;
    ``robot`` puts the policy on another embodiment (``evaluate.with_robot``)."""
    from relmogen.experiments.evaluate import load_checkpoint, policy_act, resolve_checkpoint, with_robot
    from relmogen.experiments.environments import env_kwargs

    folder, run_dir = resolve_checkpoint(Path(path), checkpoint)
    model, config = load_checkpoint(folder, run_dir, device)
    config = with_robot(config, robot)
    if arm_collision is None:
        arm_collision = config.env.arm_collision_train
    env = RelmogenEnv(**env_kwargs(config, arm_collision=arm_collision))
    return PolicyRun(model, config, run_dir, folder, env, policy_act(model, config, env, stochastic), stochastic)


@dataclass
class ExportedPolicyRun(PolicyRun):
    """An exported actor (``relmogen export``; the ones shipped in ``relmogen/policies/``) acting
    greedily in its task: ``run_dir`` and ``checkpoint`` are its folder, ``provenance`` says which
    run and checkpoint it came from; no model object (``open_shipped`` keeps it inside ``act``)."""

    provenance: dict = field(default_factory=dict)

    @property
    def checkpoint_episode(self) -> int | None:
        return self.provenance.get("episodes")

    @property
    def label(self) -> str:
        return f"{super().label}, exported from {self.provenance.get('checkpoint')} of seed {self.config.seed}"

    def describe(self) -> dict:
        return {**super().describe(), "checkpoint": self.provenance.get("checkpoint"),
                "exported_from": self.provenance.get("run")}


def open_exported_run(folder: Path, checkpoint: str = "latest", device: str = "auto", stochastic: bool = False,
                      robot: str | None = None) -> ExportedPolicyRun:
    """An exported actor's folder (``shipped.is_exported_policy``) loaded by ``open_shipped``, as
    ``relmogen demo`` does, arm collision checking on; it holds one greedy model on its own robot,
    so another ``checkpoint``, ``stochastic`` or ``robot`` is refused."""
    from relmogen.experiments.shipped import open_shipped
    from relmogen.experiments.models import resolve_device

    given = {"--checkpoint": checkpoint != "latest", "--stochastic": stochastic, "--robot": robot is not None}
    refused = [option for option, is_given in given.items() if is_given]
    if refused:
        raise ValueError(f"{folder} is an exported actor (one greedy model on its own robot): it takes no "
                         f"{', '.join(refused)}")
    env, policy = open_shipped(Path(folder), device=resolve_device(device))
    return ExportedPolicyRun(None, policy.config, Path(folder), Path(folder), env, policy.act, False,
                             policy.provenance)
