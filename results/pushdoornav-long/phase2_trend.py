"""Phase-2 trend of PushDoorNav relmogen-r runs: per block of episodes, the training success
(sampled subgoals), episode length, success and door reward, and the SAC critic's value estimate
(minus the actor loss) and temperature from TensorBoard.

    python results/pushdoornav-long/phase2_trend.py RUN_DIR... [--block 100]
"""

import argparse
import csv
import glob
from pathlib import Path

import numpy as np
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator


def scalars(run: Path, tag: str) -> tuple[np.ndarray, np.ndarray]:
    files = sorted(glob.glob(str(run / "tb" / "**" / "events*"), recursive=True))
    steps, values = [], []
    for f in files:
        events = EventAccumulator(f, size_guidance={"scalars": 0})
        events.Reload()
        if tag in events.Tags()["scalars"]:
            steps += [e.step for e in events.Scalars(tag)]
            values += [e.value for e in events.Scalars(tag)]
    return np.asarray(steps), np.asarray(values)


def block_mean(steps: np.ndarray, values: np.ndarray, start: int, stop: int) -> float:
    """Mean of the values logged at episodes [start, stop) (TensorBoard steps are episodes)."""
    inside = (steps >= start) & (steps < stop)
    return float(values[inside].mean()) if inside.any() else float("nan")


def trend(run: Path, block: int) -> list[dict]:
    episodes = list(csv.DictReader(open(run / "episodes.csv")))
    q_steps, actor = scalars(run, "losses/actor_loss")
    t_steps, temperature = scalars(run, "losses/ent_coef")
    s_steps, success_reward = scalars(run, "reward_terms/success")
    rows = []
    for start in range(0, len(episodes), block):
        chunk = episodes[start:start + block]
        mean = lambda key: float(np.mean([float(e[key] or 0) for e in chunk]))
        rows.append({"episodes": f"{start}-{start + len(chunk)}", "train_success": mean("success"),
                     "length": mean("length"), "arm_share": 1 - mean("base_fraction"),
                     "value_estimate": -block_mean(q_steps, actor, start, start + block),
                     "temperature": block_mean(t_steps, temperature, start, start + block)})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--block", type=int, default=100)
    args = parser.parse_args()
    for run in args.runs:
        print(f"\n{run.name}\n| episodes | training success | length | arm share | value estimate | temperature |\n|---|---|---|---|---|---|")
        for r in trend(run, args.block):
            print(f"| {r['episodes']} | {r['train_success']:.2f} | {r['length']:.1f} | {r['arm_share']:.2f} | "
                  f"{r['value_estimate']:.1f} | {r['temperature']:.3f} |")


if __name__ == "__main__":
    main()
