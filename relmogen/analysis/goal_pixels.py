"""Does a TabletopReachM relmogen-r policy reach for the goal marker it sees?

For each episode (seeds ``seed``, ``seed`` + 1, ...): reset, project the task's goal point (a
world point on the table) into the camera image (continuous pixel: ``u`` the column, ``v`` the
row, as ``CameraIntrinsics.project`` gives them), take the policy's deterministic first action,
decode the pixel it reaches for (``SubgoalRControl.arm_pixel``: integer row and column), step
once and record whether that first subgoal succeeded (``info["is_success"]`` or termination
``success``).

``pixel_statistics`` turns the chosen and goal pixels into the figures: the mean |column error|
and |row error| in pixels; the spread (population std) of the goal's column and row over the
episodes, which is about what a policy ignoring the image would be off by (a constant policy's
error is the mean absolute deviation of the goal pixels from its constant, at least the one from
their median); the chosen pixels' spread; the Pearson correlation of chosen with goal column (and
row), None where either side is constant (a policy that always picks the same pixel has no
correlation to measure; so has a single episode); and the first-subgoal success rate.

    relmogen analyse goal-pixels RUN_OR_CHECKPOINT [--checkpoint latest|best] [--episodes 40] [--seed 100000] [--json]
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from relmogen.experiments.loading import load_trained

TASK = "TabletopReachM"
CONTROL = "subgoal-r"


def correlation(a, b) -> float | None:
    """Pearson correlation of two equal-length sequences; None when either is constant."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if a.size < 2 or np.ptp(a) == 0.0 or np.ptp(b) == 0.0:
        return None
    return float(np.corrcoef(a, b)[0, 1])


def pixel_statistics(chosen_rows, chosen_cols, goal_rows, goal_cols, successes) -> dict:
    """Per axis (``column``, ``row``): mean |chosen - goal| in pixels, the goal's and the chosen
    pixel's std over the episodes, their Pearson correlation (None when either is constant); and
    the episodes and first-subgoal success rate. Pure arithmetic on equal-length arrays."""
    arrays = [np.asarray(x, dtype=np.float64) for x in (chosen_rows, chosen_cols, goal_rows, goal_cols, successes)]
    if len({a.shape for a in arrays}) != 1 or arrays[0].ndim != 1 or arrays[0].size == 0:
        raise ValueError("pixel_statistics takes non-empty 1-D arrays of one length each")
    chosen_rows, chosen_cols, goal_rows, goal_cols, successes = arrays

    def axis(chosen: np.ndarray, goal: np.ndarray) -> dict:
        return {"mean_abs_error_px": float(np.abs(chosen - goal).mean()), "goal_std_px": float(goal.std()),
                "chosen_std_px": float(chosen.std()), "correlation": correlation(chosen, goal)}

    return {"episodes": int(successes.size), "column": axis(chosen_cols, goal_cols),
            "row": axis(chosen_rows, goal_rows), "first_subgoal_success": float(successes.mean())}


def require_tabletop_subgoal_r(config) -> None:
    """A one-line ValueError unless the run is TabletopReachM with the ``subgoal-r`` control."""
    if config.task != TASK or config.control != CONTROL:
        raise ValueError(f"goal-pixels needs a {TASK} run with the {CONTROL} control (algo relmogen-r); this one is "
                         f"{config.task} with {config.control} ({config.algo}): give a {TASK} relmogen-r run")


def goal_pixel_samples(policy: Path, checkpoint: str = "latest", episodes: int = 40, seed: int = 100_000,
                       device: str = "cpu") -> tuple[list[dict], tuple[int, int]]:
    """One row per episode (seed, goal column / row, chosen column / row, first-subgoal success)
    and the image's (height, width)."""
    trained = load_trained(Path(policy), checkpoint, device=device)
    require_tabletop_subgoal_r(trained.config)
    env = trained.make_env().unwrapped
    rows = []
    try:
        for episode in range(episodes):
            obs, _ = env.reset(seed=seed + episode)
            pos, rot = env.robot.camera_pose()
            goal_u, goal_v, _ = env.camera.intrinsics.project(rot.T @ (np.asarray(env.task.goal) - pos))
            action, _ = trained.model.predict(obs, deterministic=True)
            row, col = env.control.arm_pixel(np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0))
            size = tuple(int(n) for n in env.last_frame.depth.shape)
            _, _, _, _, info = env.step(action)
            success = bool(info.get("is_success")) or info.get("termination") == "success"
            rows.append({"seed": seed + episode, "goal_col": goal_u, "goal_row": goal_v, "chosen_col": int(col),
                         "chosen_row": int(row), "first_subgoal_success": success})
    finally:
        env.close()
    return rows, size


def goal_pixels(policy: Path, checkpoint: str = "latest", episodes: int = 40, seed: int = 100_000,
                device: str = "cpu") -> dict:
    """``pixel_statistics`` of ``goal_pixel_samples``, with the image's height and width."""
    rows, (height, width) = goal_pixel_samples(policy, checkpoint, episodes, seed, device)
    stats = pixel_statistics(*([r[key] for r in rows] for key in
                               ("chosen_row", "chosen_col", "goal_row", "goal_col", "first_subgoal_success")))
    return {"image_height": height, "image_width": width, **stats}
