"""Extra SGP-D updates from a run's own replay buffer, without new experience: does replaying
the stored transitions more often (a higher replay ratio) teach the arm Q map the rare
rewarded pushes? The copy gets a new checkpoint; look at it with ``relmogen viz qmap``.

    python results/sgpd-button/offline_replay_updates.py runs/sgpd-button/RUN --updates 20000 --out runs/sgpd-offline/RUN
    python results/sgpd-button/offline_replay_updates.py RUN --updates 4000 --conservative-weight 1 --out OUT
    relmogen viz qmap runs/sgpd-offline/RUN --drive oracle --states 16 --out DIR

``--from-scratch`` trains a freshly initialised network on the same replay instead (the
run's settings, changed by ``--set algo.KEY=VALUE``, e.g. ``algo.qmap_skip=true``): which
network can learn the stored presses at all, the data held fixed. The copy's ``config.yaml``
records what changed, so it can be resumed with ``relmogen train --resume``.

Target network: copied every ``target_update_interval / (n_envs * train_freq)`` updates, the
same number of updates between copies as in training.
"""

from __future__ import annotations

import argparse
import json
import shutil
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import torch as th
from rich.progress import Progress

from relmogen.agents.dqn import RelmogenDQN
from relmogen.agents.replay import stored_rows
from relmogen.experiments.config import read_config, save_config, with_overrides
from relmogen.experiments.train import build_dqn, latest_checkpoint, latest_replay, write_checkpoint


class SpacesOnly(gym.Env):
    """Carries a saved model's spaces into ``build_dqn``; never reset or stepped."""

    def __init__(self, observation_space: gym.Space, action_space: gym.Space):
        self.observation_space, self.action_space = observation_space, action_space


def copy_run(run: Path, out: Path) -> None:
    shutil.copytree(run, out, ignore=shutil.ignore_patterns("eval", "checkpoints"))
    (out / "checkpoints").mkdir()


def rewarded_transitions(model: RelmogenDQN, threshold: float) -> int:
    rewards = model.replay_buffer.rewards[stored_rows(model.replay_buffer)]
    return int((rewards >= threshold).sum())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path)
    parser.add_argument("--updates", type=int, default=20000)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--conservative-weight", type=float, default=None,
                        help="weight of the conservative term during these updates (default: the run's own)")
    parser.add_argument("--from-scratch", action="store_true",
                        help="train a freshly initialised network on the run's replay instead of its own")
    parser.add_argument("--set", action="append", default=[], metavar="algo.KEY=VALUE",
                        help="with --from-scratch: change the new network's settings (repeatable)")
    parser.add_argument("--reward-threshold", type=float, default=5.0,
                        help="count stored transitions with at least this reward (default 5: a button press)")
    args = parser.parse_args()
    if args.updates < 1:
        parser.error("--updates must be positive")
    if args.conservative_weight is not None and args.conservative_weight < 0:
        parser.error("--conservative-weight must be at least 0")
    if args.set and not args.from_scratch:
        parser.error("--set needs --from-scratch (a checkpoint fixes its network)")
    if args.out.exists():
        parser.error(f"{args.out} exists; choose a new --out")
    config = read_config(args.run / "config.yaml")
    checkpoint = latest_checkpoint(args.run)
    if config.algo != "relmogen-d" or checkpoint is None:
        raise SystemExit(f"{args.run} is not a relmogen-d run with a checkpoint")
    th.set_num_threads(config.run.torch_threads)
    weight = [] if args.conservative_weight is None else [f"algo.conservative_weight={args.conservative_weight}"]
    config = with_overrides(config, [*args.set, *weight])
    model = RelmogenDQN.load(checkpoint / "model.zip", device="cpu",
                             conservative_weight=config.algo_params.conservative_weight or 0.0)
    if args.from_scratch:
        model = build_dqn(config.model_copy(update={"device": "cpu"}),
                          SpacesOnly(model.observation_space, model.action_space))
    model.load_replay_buffer(latest_replay(args.run))
    params = config.algo_params
    copy_every = max(params.target_update_interval // (config.env.n_envs * params.train_freq), 1)
    start, losses, gaps = time.time(), [], []
    model.policy.set_training_mode(True)
    with Progress() as progress:
        bar = progress.add_task("offline updates", total=args.updates)
        for update in range(1, args.updates + 1):
            step = model._gradient_step(model.replay_buffer.sample(params.batch_size))
            losses.append(step["loss"])
            gaps.append(step.get("conservative_gap", 0.0))
            if update % copy_every == 0:
                model.q_net_target.load_state_dict(model.q_net.state_dict())
            progress.advance(bar)
    copy_run(args.run, args.out)
    save_config(config, args.out / "config.yaml")
    state = json.loads((checkpoint / "state.json").read_text())
    write_checkpoint(args.out, model, dict(state, offline_updates=args.updates, from_scratch=args.from_scratch))
    summary = {"run": str(args.run), "updates": args.updates, "from_scratch": args.from_scratch,
               "settings": args.set, "batch_size": params.batch_size,
               "target_copy_every": copy_every,
               "stored_transitions": len(stored_rows(model.replay_buffer)) * model.replay_buffer.n_envs,
               "rewarded_transitions": rewarded_transitions(model, args.reward_threshold),
               "conservative_weight": model.conservative_weight,
               "loss_first_1000": float(np.mean(losses[:1000])), "loss_last_1000": float(np.mean(losses[-1000:])),
               "conservative_gap_first_1000": float(np.mean(gaps[:1000])),
               "conservative_gap_last_1000": float(np.mean(gaps[-1000:])),
               "seconds": round(time.time() - start, 1)}
    (args.out / "offline_updates.json").write_text(json.dumps(summary, indent=1))
    print(json.dumps(summary))


if __name__ == "__main__":
    main()
