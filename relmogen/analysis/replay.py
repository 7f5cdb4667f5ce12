"""What a relmogen-d run's saved replay holds, and what more updates on it alone do.

``button_pushes``: for every stored arm push of a ButtonDoorNav replay, was the red button cap
in the RGB frame it was chosen on, did the pushed Q-map cell hold cap pixels, and was it
rewarded by a press (reward >= 5: the +5 button term, or +10 success).

``action_rewards``: the mean reward per step, overall, per part and for given arm actions, and
the most frequent actions with their mean reward (a Q value at discount gamma is about
1 / (1 - gamma) times the reward per step the policy earns).

``offline_updates``: more relmogen-d updates from a run's own latest replay and checkpoint (or a
freshly initialised network, ``from_scratch``), no new experience; the target network copied as
often, in updates, as in training. The copy is a new run folder with the new checkpoint (look at
it with ``relmogen viz qmap``; resume it with ``relmogen train --resume``).

    relmogen analyse replay pushes RUN... [--json]
    relmogen analyse replay rewards RUN [--action BIN,I,J ...] [--json]
    relmogen analyse offline-updates RUN --updates N --out NEW_RUN [--conservative-weight W] [--from-scratch]
                                     [--set algo.KEY=VALUE ...]
"""

from __future__ import annotations

import json
import shutil
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

from relmogen.agents.replay import stored_rows
from relmogen.envs.subgoal_controls import decode_indices, qmap_size_for
from relmogen.experiments.checkpoints import latest_checkpoint, latest_replay

PRESS_REWARD = 5.0


def load_replay(run: Path):
    """(the run's latest saved replay buffer, its Q-map side Q from the run's settings)."""
    from relmogen.experiments.checkpoints import read_replay_file
    from relmogen.experiments.config import read_config

    path = latest_replay(Path(run))
    if path is None:
        raise ValueError(f"{run} has no saved replay buffer")
    env = read_config(Path(run) / "config.yaml").env
    return read_replay_file(path), qmap_size_for(env.image_size, env.qmap_size)


def transitions(buffer) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(stored rows, actions, rewards) flattened over the environments, oldest first."""
    rows = stored_rows(buffer)
    return rows, buffer.actions[rows].reshape(-1).astype(np.int64), buffer.rewards[rows].reshape(-1)


def button_pushes(buffer, q: int) -> dict[str, int]:
    """Counts over the stored transitions of a buffer of Q x Q maps: arm pushes, with the cap in
    view, on the cap, on the cap and rewarded, elsewhere and rewarded."""
    from relmogen.tasks.button_door_nav import button_cap_cells

    rows, actions, rewards = transitions(buffer)
    rgb = buffer.observations["rgb"][rows]
    rgb = rgb.reshape(-1, *rgb.shape[2:])
    size = max(rgb.shape[1], rgb.shape[2])  # channels first or last
    cells = button_cap_cells(rgb, size // q)
    arm, _, i, j = decode_indices(actions, q)
    on_cap = arm & cells[np.arange(len(actions)), i, j]
    pressed = rewards >= PRESS_REWARD
    return {"transitions": len(actions), "arm_pushes": int(arm.sum()),
            "cap_in_view": int((arm & cells.any(axis=(1, 2))).sum()), "on_the_cap": int(on_cap.sum()),
            "on_the_cap_rewarded": int((on_cap & pressed).sum()),
            "elsewhere_rewarded": int((arm & ~on_cap & pressed).sum())}


def action_rewards(buffer, q: int, arm_actions: list[tuple[int, int, int]] = (), top: int = 8) -> dict:
    """Mean reward per step overall, for arm and base steps, for the given (bin, i, j) arm actions,
    and for the ``top`` most frequent actions (with their share of rewards above 0.5)."""
    _, actions, rewards = transitions(buffer)
    arm, bins, rows_i, cols_j = decode_indices(actions, q)

    def mean(mask) -> float | None:
        return round(float(rewards[mask].mean()), 4) if mask.any() else None

    given = [{"action": ["arm", *action], "times": int(chosen.sum()), "mean_reward": mean(chosen)}
             for action in arm_actions
             for chosen in [arm & (bins == action[0]) & (rows_i == action[1]) & (cols_j == action[2])]]
    values, counts = np.unique(actions, return_counts=True)
    frequent = []
    for value, count in sorted(zip(values.tolist(), counts.tolist()), key=lambda vc: -vc[1])[:top]:
        chosen = actions == value
        is_arm, bin_, i, j = (int(x) for x in decode_indices(value, q))
        frequent.append({"action": ["arm" if is_arm else "base", bin_, i, j], "times": count,
                         "mean_reward": mean(chosen), "rewards_above_0.5": round(float((rewards[chosen] > 0.5).mean()), 3)})
    return {"transitions": int(actions.size), "mean_reward": mean(np.ones_like(arm)), "arm_mean_reward": mean(arm),
            "base_mean_reward": mean(~arm), "arm_share": round(float(arm.mean()), 3) if arm.size else None,
            "rewards_above_0.5": int((rewards > 0.5).sum()), "given": given, "most_frequent": frequent}


class SpacesOnly(gym.Env):
    """Carries a saved model's spaces into ``build_dqn``; never reset or stepped."""

    def __init__(self, observation_space: gym.Space, action_space: gym.Space):
        self.observation_space, self.action_space = observation_space, action_space


def offline_updates(run: Path, out: Path, updates: int, conservative_weight: float | None = None,
                    from_scratch: bool = False, settings: list[str] = (), reward_threshold: float = PRESS_REWARD) -> dict:
    """See the module docstring; returns (and writes to ``out/offline_updates.json``) a summary:
    stored and rewarded transitions, the target copy interval, the mean loss (and conservative
    gap) over the first and the last 1,000 updates, seconds."""
    import torch as th
    from stable_baselines3.common.logger import Logger

    from relmogen.agents.dqn import RelmogenDQN
    from relmogen.experiments.checkpoints import load_replay as load_replay_into, write_checkpoint
    from relmogen.experiments.config import read_config, save_config, with_overrides
    from relmogen.experiments.models import build_dqn

    run, out = Path(run), Path(out)
    if updates < 1:
        raise ValueError("updates must be positive")
    if settings and not from_scratch:
        raise ValueError("--set needs --from-scratch (a checkpoint fixes its network)")
    if out.exists():
        raise ValueError(f"{out} exists; choose a new output folder")
    config = read_config(run / "config.yaml")
    checkpoint = latest_checkpoint(run)
    if config.algo != "relmogen-d" or checkpoint is None:
        raise ValueError(f"{run} is not a relmogen-d run with a checkpoint")
    weight = [] if conservative_weight is None else [f"algo.conservative_weight={conservative_weight}"]
    config = with_overrides(config, [*settings, *weight])
    th.set_num_threads(config.run.torch_threads)
    model = RelmogenDQN.load(checkpoint / "model.zip", device="cpu",
                             conservative_weight=config.algo_params.conservative_weight or 0.0)
    if from_scratch:
        model = build_dqn(config.model_copy(update={"device": "cpu"}),
                          SpacesOnly(model.observation_space, model.action_space))
    load_replay_into(model, latest_replay(run))
    logger = Logger(folder=None, output_formats=[])
    model.set_logger(logger)
    params = config.algo_params
    copy_every = max(params.target_update_interval // (config.env.n_envs * params.train_freq), 1)
    start, chunks, done = time.time(), [], 0
    while done < updates:
        k = min(copy_every - done % copy_every, updates - done)
        model.train(gradient_steps=k, batch_size=params.batch_size)
        chunks.append((done, k, logger.name_to_value["train/loss"], logger.name_to_value.get("train/conservative_gap", 0.0)))
        logger.dump()
        done += k
        if done % copy_every == 0:
            model.q_net_target.load_state_dict(model.q_net.state_dict())

    def mean_over(first: bool, column: int) -> float:
        window = min(1000, updates)
        inside = [(c[1], c[column]) for c in chunks if (c[0] < window if first else c[0] + c[1] > updates - window)]
        return float(np.average([v for _, v in inside], weights=[w for w, _ in inside]))

    shutil.copytree(run, out, ignore=shutil.ignore_patterns("eval", "checkpoints"))
    (out / "checkpoints").mkdir()
    save_config(config, out / "config.yaml")
    state = json.loads((checkpoint / "state.json").read_text())
    write_checkpoint(out, model, dict(state, offline_updates=updates, from_scratch=from_scratch))
    _, _, rewards = transitions(model.replay_buffer)
    summary = {"run": str(run), "updates": updates, "from_scratch": from_scratch, "settings": list(settings),
               "batch_size": params.batch_size, "target_copy_every": copy_every, "stored_transitions": int(rewards.size),
               "rewarded_transitions": int((rewards >= reward_threshold).sum()),
               "conservative_weight": model.conservative_weight,
               "loss_first_1000": mean_over(True, 2), "loss_last_1000": mean_over(False, 2),
               "conservative_gap_first_1000": mean_over(True, 3), "conservative_gap_last_1000": mean_over(False, 3),
               "seconds": round(time.time() - start, 1)}
    (out / "offline_updates.json").write_text(json.dumps(summary, indent=1))
    return summary
