"""``relmogen viz subgoals``: where a trained ReLMoGen policy sends the base and the arm.

Runs evaluation episodes of a relmogen-r or relmogen-d policy (deterministic unless asked,
arm collision checking on, as ``relmogen eval``) and draws one PNG with three panels:

* base subgoals, top-down over the scene's floor plan (``scene_map``): where the base was when
  each base subgoal finished (green: planned and executed, red: no plan, so it stayed), a thin
  line from where it started, and a cross at the commanded goal; the goals of the episodes and
  the door when the task has them;
* arm subgoals on the camera: the pixel of every arm subgoal (the push direction as an arrow
  where it projects) over one representative camera image (the view of the first arm subgoal
  that found a plan);
* arm subgoals top-down: the 3D point seen at each of those pixels, coloured by height
  (tasks without arm subgoals, e.g. PointNav, get the base panel only).

Beside the PNG, ``<name>.json`` keeps the raw points so figures can be compared: per base
subgoal its start, commanded goal and end pose (world x, y, yaw), whether a plan was found and,
for tasks with a door, the end's ``door_distance`` and ``door_offset`` (``scene_map.door_distances``:
e.g. how far from the door a robot stops); per arm subgoal its pixel, world point (None when the
pixel had no depth), push end pixel and outcome; per episode its start, goal and success.
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from relmogen.experiments.shipped import is_exported_policy  # noqa: E402
from relmogen.experiments.rollout import FrameRecorder  # noqa: E402
from relmogen.visualisation.policy_runs import PolicyRun, open_exported_run, open_policy_run  # noqa: E402
from relmogen.visualisation.scene_map import (door_distances, draw_floor_plan, draw_goals, task_goal,  # noqa: E402
                                              zoom_to)
from relmogen.experiments.video import chosen_subgoal  # noqa: E402

SUBGOAL_ALGOS = ("relmogen-r", "relmogen-d")
FOUND_COLOUR, NO_PLAN_COLOUR = "tab:green", "tab:red"
_OUTCOMES = ((True, FOUND_COLOUR, "plan found"), (False, NO_PLAN_COLOUR, "no plan"))


def _pose(env) -> list[float]:
    return [float(v) for v in env.robot.base_pose()]


def _point(values) -> list[float] | None:
    return None if values is None else [float(v) for v in values]


def _pixel(values) -> list[int] | None:
    return None if values is None else [int(v) for v in values]


class SubgoalLog(FrameRecorder):
    """Records every subgoal of the episodes it watches (``run_episode``'s recorder); renders nothing."""

    def __init__(self) -> None:
        super().__init__()
        self.base: list[dict] = []
        self.arm: list[dict] = []
        self.episodes: list[dict] = []
        self.arm_images: list[np.ndarray] = []  # the camera image each arm subgoal was chosen on
        self.first_image: np.ndarray | None = None
        self.subgoal, self.start_pose, self.rgb, self.step = None, None, None, 0

    def start(self, env, obs: dict) -> None:
        self.env, self.step = env, 0
        self.episodes.append({"episode": len(self.episodes), "start": _pose(env), "goal": task_goal(env.task)})
        if self.first_image is None:
            self.first_image = obs["rgb"]

    def before_step(self, obs: dict, action) -> None:
        self.subgoal, self.start_pose, self.rgb = chosen_subgoal(self.env, action), _pose(self.env), obs["rgb"]

    def after_step(self, obs: dict, reward: float, info: dict) -> None:
        episode, self.step = self.episodes[-1], self.step + 1
        if "metrics" in info:
            episode.update(success=bool(info["metrics"].get("success")), steps=self.step)
        if self.subgoal is None:  # joint velocities
            return
        record = {"episode": episode["episode"], "step": self.step - 1, "plan_found": bool(info.get("plan_found")),
                  "reason": info.get("reason"), "reward": float(reward)}
        part = info.get("subgoal_type", self.subgoal.part)
        if part == "base":
            end = _pose(self.env)
            self.base.append({**record, "start": self.start_pose, "goal": _point(self.subgoal.base_goal), "end": end,
                              **door_distances(self.env.task, end[:2])})
        else:
            self.arm.append({**record, "pixel": _pixel(self.subgoal.pixel),
                             "point": _point(self.subgoal.arm_point), "push_end_pixel": _point(self.subgoal.push_end),
                             "base_pose": self.start_pose})
            self.arm_images.append(self.rgb)

    def representative_image(self) -> tuple[np.ndarray | None, int | None]:
        """(image, index of its arm subgoal): the first arm subgoal that found a plan, else the
        first one, else the first observation (index None)."""
        found = [i for i, record in enumerate(self.arm) if record["plan_found"]]
        if found or self.arm:
            index = (found or [0])[0]
            return self.arm_images[index], index
        return self.first_image, None

    def summary(self) -> dict:
        def rate(records):
            return float(np.mean([r["plan_found"] for r in records])) if records else None

        summary = {"base_subgoals": len(self.base), "arm_subgoals": len(self.arm), "base_plan_rate": rate(self.base),
                   "arm_plan_rate": rate(self.arm),
                   "success_rate": float(np.mean([e.get("success", False) for e in self.episodes]))}
        distances = [r["door_distance"] for r in self.base if "door_distance" in r]
        if distances:
            summary.update(mean_door_distance=float(np.mean(distances)),
                           min_door_distance=float(np.min(distances)))
        return summary


def _base_panel(axis, env, log: SubgoalLog) -> None:
    draw_floor_plan(axis, env)
    draw_goals(axis, [e["goal"] for e in log.episodes])
    starts = np.array([e["start"][:2] for e in log.episodes]).reshape(-1, 2)
    axis.scatter(starts[:, 0], starts[:, 1], marker="s", s=30, color="tab:blue", edgecolors="black", lw=0.5,
                 label="episode start", zorder=4)
    for record in log.base:
        (x0, y0), (x1, y1) = record["start"][:2], record["end"][:2]
        axis.plot([x0, x1], [y0, y1], color="tab:blue", lw=0.6, alpha=0.5, zorder=4)
    for found, colour, label in _OUTCOMES[::-1]:
        ends = np.array([r["end"][:2] for r in log.base if r["plan_found"] == found]).reshape(-1, 2)
        if len(ends):
            axis.scatter(ends[:, 0], ends[:, 1], s=22, color=colour, edgecolors="black", lw=0.4,
                         label=f"end, {label} ({len(ends)})", zorder=6)
    goals = np.array([r["goal"][:2] for r in log.base]).reshape(-1, 2)
    if len(goals):
        axis.scatter(goals[:, 0], goals[:, 1], marker="x", s=14, color="black", lw=0.7, alpha=0.6,
                     label="commanded goal", zorder=5)
    ends = np.array([r["end"][:2] for r in log.base]).reshape(-1, 2)
    task_goals = np.array([e["goal"] for e in log.episodes if e["goal"] is not None]).reshape(-1, 2)
    zoom_to(axis, env, np.vstack([ends, starts, goals, task_goals]))
    axis.set_title(f"base subgoals: {len(log.base)} ends", fontsize=9)
    axis.legend(fontsize=6, loc="best", framealpha=0.8)


def _camera_panel(axis, log: SubgoalLog) -> None:
    image, index = log.representative_image()
    if image is not None:
        axis.imshow(image)
    for record in log.arm:
        if record["pixel"] is not None and record["push_end_pixel"] is not None:
            (row, col), (end_row, end_col) = record["pixel"], record["push_end_pixel"]
            axis.annotate("", xy=(end_col, end_row), xytext=(col, row),
                          arrowprops=dict(arrowstyle="-|>", lw=0.8, alpha=0.7,
                                          color=FOUND_COLOUR if record["plan_found"] else NO_PLAN_COLOUR))
    for found, colour, label in _OUTCOMES[::-1]:  # plans found drawn on top
        pixels = np.array([r["pixel"] for r in log.arm if r["pixel"] is not None and r["plan_found"] == found])
        if len(pixels):
            axis.scatter(pixels[:, 1], pixels[:, 0], s=24, color=colour, edgecolors="black", lw=0.4,
                         label=f"{label} ({len(pixels)})", zorder=5)
    if log.arm:
        axis.legend(fontsize=6, loc="lower left", framealpha=0.8)
    shown = "no arm subgoals" if not log.arm else \
        f"arm subgoal pixels and pushes: {len(log.arm)} (image of arm subgoal {index})"
    axis.set_title(shown, fontsize=9)
    axis.set_axis_off()


def _arm_points_panel(axis, figure, env, log: SubgoalLog) -> None:
    draw_floor_plan(axis, env)
    points = np.array([r["point"] for r in log.arm if r["point"] is not None]).reshape(-1, 3)
    bases = np.array([r["base_pose"][:2] for r in log.arm]).reshape(-1, 2)
    if len(bases):
        axis.scatter(bases[:, 0], bases[:, 1], marker="s", s=18, color="tab:blue", edgecolors="black", lw=0.4,
                     label="base at arm subgoal", zorder=4)
    if len(points):
        found = np.array([r["plan_found"] for r in log.arm if r["point"] is not None])
        heights = dict(vmin=points[:, 2].min(), vmax=points[:, 2].max(), cmap="viridis")
        for outcome, colour, label in _OUTCOMES[::-1]:
            chosen = points[found == outcome]
            if len(chosen):
                scatter = axis.scatter(chosen[:, 0], chosen[:, 1], c=chosen[:, 2], s=26, edgecolors=colour, lw=1.2,
                                       label=f"point, {label} ({len(chosen)})", zorder=6, **heights)
        colourbar = figure.colorbar(scatter, ax=axis, fraction=0.046, pad=0.04)
        colourbar.set_label("point height z (m)", fontsize=8)
        colourbar.ax.tick_params(labelsize=7)
    zoom_to(axis, env, np.vstack([points[:, :2], bases]), margin=1.0)
    without = sum(r["point"] is None for r in log.arm)
    axis.set_title(f"arm subgoal points: {len(points)}" + (f" ({without} pixels without depth)" if without else ""),
                   fontsize=9)
    if len(bases):
        axis.legend(fontsize=6, loc="best", framealpha=0.8)
    if len(points):
        axis.text(0.01, 0.01, "fill: height; edge: outcome", transform=axis.transAxes, fontsize=6, va="bottom")


def subgoals_figure(run: PolicyRun, log: SubgoalLog, title: str):
    """The three panels; the base one alone for tasks without arm subgoals (PointNav)."""
    arm = "arm" in run.env.task.subgoal_parts or bool(log.arm)
    size = (15.0, 5.8) if arm else (8.0, 5.8)
    figure, axes = plt.subplots(1, 3 if arm else 1, figsize=size, layout="constrained")  # room for every label
    axes = np.atleast_1d(axes)
    _base_panel(axes[0], run.env, log)
    if arm:
        _camera_panel(axes[1], log)
        _arm_points_panel(axes[2], figure, run.env, log)
    else:
        title += f"\n({run.config.task} uses base subgoals only)"
    figure.suptitle(title, fontsize=10)
    return figure


def draw_subgoals(run: PolicyRun, log: SubgoalLog, path: Path, title: str) -> Path:
    figure = subgoals_figure(run, log, title)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110, bbox_inches="tight")  # tall map panels can still reach the edge
    plt.close(figure)
    return path


def subgoal_figure(path: Path, out: Path, episodes: int = 10, seed: int = 100_000, checkpoint: str = "latest",
                   device: str = "auto", stochastic: bool = False, robot: str | None = None) -> dict:
    """``relmogen viz subgoals``: the figure at ``out`` (a .png) and its points at ``out`` with
    suffix .json; returns what the JSON holds. ``path`` is a run, a checkpoint or an exported
    actor's folder (``relmogen/policies/PushDoorNav-relmogen-r``). ``robot`` evaluates on another
    embodiment than the run's (e.g. movo for a Fetch run: where does it stop in front of the door?)."""
    out = Path(out)
    if out.suffix.lower() != ".png":
        raise ValueError(f"--out must name a .png file, got {out}")
    if episodes < 1:
        raise ValueError(f"episodes must be positive, got {episodes}")
    opener = open_exported_run if is_exported_policy(path) else open_policy_run
    run = opener(Path(path), checkpoint, device, stochastic, robot=robot)
    try:
        if run.config.algo not in SUBGOAL_ALGOS:
            raise ValueError(f"subgoal figures need a {' or '.join(SUBGOAL_ALGOS)} run; {run.run_dir} is "
                             f"{run.config.algo!r}")
        log = SubgoalLog()
        run.record(log, episodes, seed)
        summary = log.summary()
        title = (f"{run.run_dir.name}\n{run.label}, {episodes} episodes from seed {seed} "
                 f"({'stochastic' if stochastic else 'deterministic'}), success {summary['success_rate']:.2f}")
        draw_subgoals(run, log, out, title)
        _, image_index = log.representative_image()
        result = {**run.describe(), "episodes": episodes, "seed": seed, "figure": str(out), **summary,
                  "camera_image_arm_subgoal": image_index, "episode_records": log.episodes,
                  "base": log.base, "arm": log.arm}
    finally:
        run.close()
    out.with_suffix(".json").write_text(json.dumps(result, indent=1))
    return result
