"""``relmogen viz exploration``: the paper's Fig. 6 (a)-(c) for two or more runs.

Each run (relmogen-r, relmogen-d, sac or oac; its latest checkpoint by default) acts in its
own task for ``episodes`` episodes, sampling its actions as during training (SGP-D:
epsilon-greedy at the checkpoint's epsilon; ``stochastic=False`` for the greedy policy), with arm
collision checking as during its training. One PNG, a row per run:

(a) the first two principal components (numpy SVD, per run) of the policy's own state
    embedding (the SAC actor's features extractor output; SGP-D's two convolutional branches,
    concatenated) along the first ``pca_episodes`` episodes, consecutive states joined: small
    steps in joint space, jumps between states a motion plan links in subgoal space;
(b) the base positions visited, top-down over the scene's floor plan (every simulated tick
    while a subgoal executes, every 0.1 s step of joint control), one line per episode;
(c) the interactions lasting at least ``INTERACTION_MIN_S`` of simulated time: a body other than
    the floor touched by any robot link (the gripper included) at every sample for 1 s or
    more (``InteractionTracker``), drawn where it was touched, sized by duration.

``exploration.json`` beside it keeps the numbers: per run the PCA points, explained variance and
the median step between consecutive embeddings relative to their spread
(``median_relative_step``), the positions and the area of 0.25 m cells they cover
(``coverage_m2``), and every interaction (body, episode, start, duration, position).

Samples come from the environment's ``frame_hook`` (called as simulated time advances while a
subgoal executes) and after every step.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pybullet as p  # noqa: E402
import torch as th  # noqa: E402

from relmogen.experiments.rollout import FrameRecorder  # noqa: E402
from relmogen.simulation.contacts import robot_touches  # noqa: E402
from relmogen.visualisation.policy_runs import PolicyRun, open_policy_run  # noqa: E402
from relmogen.visualisation.scene_map import draw_floor_plan, task_door, zoom_to  # noqa: E402

INTERACTION_MIN_S = 1.0  # paper Fig. 6 (c)
PCA_EPISODES = 10  # paper Fig. 6 (a)
COVERAGE_CELL_M = 0.25
POSITION_TOLERANCE_M = 1e-3  # a sample this close to the previous one is not kept again
EPISODE_COLOURS = plt.get_cmap("tab10").colors


def state_embedding(model, algo: str):
    """``obs -> 1-D array``: the policy's own features of an observation."""
    policy = model.policy
    if algo == "relmogen-d":
        net = policy.q_net.net

        def features(obs):
            return th.cat([net.image_branch(net.image_tensor(obs)), net.map_branch(net.map_tensor(obs))], dim=1)
    else:
        actor = policy.actor

        def features(obs):
            return actor.extract_features(obs, actor.features_extractor)

    def embed(obs: dict) -> np.ndarray:
        tensor, _ = policy.obs_to_tensor(obs)
        with th.no_grad():
            return features(tensor)[0].flatten().cpu().numpy().astype(np.float64)

    return embed


@dataclass
class _Contact:
    first_s: float
    last_s: float
    positions: list = field(default_factory=list)


class InteractionTracker:
    """Contacts that persist: ``update(time, touches)`` with the bodies touched at a sample
    (``robot_touches``); a body touched at every sample from ``first_s`` to ``last_s`` with
    ``last_s - first_s >= min_duration_s`` is one interaction, reported when the contact ends
    (``update`` without it, or ``close_all`` at the end of an episode) as (body, first_s,
    duration_s, mean touched position)."""

    def __init__(self, min_duration_s: float = INTERACTION_MIN_S):
        self.min_duration_s = min_duration_s
        self.open: dict[int, _Contact] = {}

    def update(self, time_s: float, touches: dict[int, tuple]) -> list[tuple[int, float, float, np.ndarray]]:
        ended = [self._close(body) for body in list(self.open) if body not in touches]
        for body, position in touches.items():
            contact = self.open.setdefault(body, _Contact(time_s, time_s))
            contact.last_s = time_s
            contact.positions.append(position)
        return [interaction for interaction in ended if interaction is not None]

    def close_all(self) -> list[tuple[int, float, float, np.ndarray]]:
        ended = [self._close(body) for body in list(self.open)]
        return [interaction for interaction in ended if interaction is not None]

    def _close(self, body: int):
        contact = self.open.pop(body)
        duration = contact.last_s - contact.first_s
        if duration < self.min_duration_s - 1e-9:
            return None
        return body, contact.first_s, duration, np.mean(np.asarray(contact.positions, dtype=float), axis=0)


def body_labels(env) -> dict[int, str]:
    """Body id -> a readable name: the scene's element kinds, the task's door, else PyBullet's name."""
    labels = {body: kind for kind, ids in env.scene.body_ids.items() for body in ids}
    door = task_door(env.task)
    if door is not None:
        labels[door.body] = "door"
    return labels


class ExplorationLog(FrameRecorder):
    """Positions, embeddings (first ``embed_episodes`` episodes) and interactions of the episodes it
    watches (``run_episode``'s recorder); renders nothing."""

    def __init__(self, embed, embed_episodes: int = PCA_EPISODES, min_duration_s: float = INTERACTION_MIN_S):
        super().__init__()
        self.embed, self.embed_episodes = embed, embed_episodes
        self.tracker = InteractionTracker(min_duration_s)
        self.embeddings: list[list[np.ndarray]] = []
        self.positions: list[list[tuple[float, float]]] = []
        self.interactions: list[dict] = []
        self.labels: dict[int, str] = {}

    def start(self, env, obs: dict) -> None:
        self.env, env.frame_hook = env, self.during_step
        self.labels = body_labels(env)
        self.ignored = frozenset({env.scene.floor_body_id})
        self._record(self.tracker.close_all())
        self.positions.append([])
        self.embeddings.append([])
        self._embed(obs)
        self._sample(detect=True)

    def during_step(self) -> None:
        self._sample()

    def _sample(self, detect: bool = False) -> None:
        """The base position and the bodies touched now. ``detect`` first refreshes PyBullet's
        contacts, which only physics steps and collision checks update: after a reset or a step
        that moved the robot kinematically (the arm tucked after a push) they would be stale."""
        client = self.env.world.client
        if detect:
            p.performCollisionDetection(physicsClientId=client)
        x, y, _ = self.env.robot.base_pose()
        path = self.positions[-1]
        if not path or np.hypot(x - path[-1][0], y - path[-1][1]) > POSITION_TOLERANCE_M:
            path.append((float(x), float(y)))
        touches = robot_touches(client, self.env.robot.robot_id, self.ignored)
        self._record(self.tracker.update(self.env.sim_time, touches))

    def after_step(self, obs: dict, reward: float, info: dict) -> None:
        self._sample(detect=True)
        self._embed(obs)
        if "metrics" in info:
            self._record(self.tracker.close_all())

    def _embed(self, obs: dict) -> None:
        if len(self.embeddings) <= self.embed_episodes:
            self.embeddings[-1].append(self.embed(obs))

    def _record(self, ended) -> None:
        for body, start, duration, position in ended:
            name = self.labels.get(body) or p.getBodyInfo(body, physicsClientId=self.env.world.client)[1].decode()
            self.interactions.append({"episode": len(self.positions) - 1, "body": name or f"body {body}",
                                      "start_s": round(float(start), 3), "duration_s": round(float(duration), 3),
                                      "position": [round(float(v), 3) for v in position]})


def pca_2d(states: np.ndarray) -> tuple[np.ndarray, list[float]]:
    """(N, D) -> their first two principal components (N, 2) and the share of variance of each."""
    states = np.asarray(states, dtype=np.float64)
    centred = states - states.mean(axis=0)
    _, singular, components = np.linalg.svd(centred, full_matrices=False)
    projected = np.zeros((len(states), 2))
    kept = min(2, components.shape[0])
    projected[:, :kept] = centred @ components[:kept].T
    variance = singular ** 2
    total = float(variance.sum())
    ratios = [float(v / total) if total > 0 else 0.0 for v in variance[:2]]
    return projected, ratios + [0.0] * (2 - len(ratios))


def relative_steps(episodes: list[np.ndarray]) -> dict[str, float]:
    """Distances between consecutive states of each episode, over the states' RMS distance from
    their mean (near 0 for small steps, about 1.4 for jumps between independent states): the
    median of the steps that changed the embedding (a subgoal without a plan leaves the
    observation as it was) and the mean of all; ``unchanged_steps`` counts the others."""
    states = np.vstack(episodes)
    spread = float(np.sqrt(np.mean(np.sum((states - states.mean(axis=0)) ** 2, axis=1))))
    steps = np.concatenate([np.linalg.norm(np.diff(e, axis=0), axis=1) for e in episodes if len(e) > 1] or [[]])
    moved = steps[steps > 1e-9 * max(spread, 1e-12)]
    if not len(moved) or spread <= 0:
        return {"median_relative_step": 0.0, "mean_relative_step": 0.0, "unchanged_steps": int(len(steps))}
    return {"median_relative_step": float(np.median(moved) / spread), "mean_relative_step": float(np.mean(steps) / spread),
            "unchanged_steps": int(len(steps) - len(moved))}


def coverage_m2(positions: list[list[tuple[float, float]]], cell: float = COVERAGE_CELL_M) -> float:
    """Area of the ``cell`` x ``cell`` squares holding at least one visited position."""
    points = np.array([xy for path in positions for xy in path], dtype=float).reshape(-1, 2)
    return float(len(np.unique(np.floor(points / cell).astype(int), axis=0)) * cell * cell)


def exploration_result(run: PolicyRun, log: ExplorationLog, episodes: int, seed: int) -> dict:
    embedded = [np.array(e) for e in log.embeddings if e]
    projected, ratios = pca_2d(np.vstack(embedded))
    bounds = np.cumsum([0] + [len(e) for e in embedded])
    return {**run.describe(), "label": run.label, "episodes": episodes, "seed": seed,
            "pca": {"episodes": len(embedded), "states": int(bounds[-1]), "embedding_size": int(embedded[0].shape[1]),
                    "explained_variance_ratio": ratios, **relative_steps(embedded),
                    "points": [np.round(projected[a:b], 4).tolist() for a, b in zip(bounds[:-1], bounds[1:])]},
            "positions": [np.round(np.array(path).reshape(-1, 2), 3).tolist() for path in log.positions],
            "position_samples": sum(len(path) for path in log.positions), "coverage_m2": coverage_m2(log.positions),
            "interaction_count": len(log.interactions), "interactions": log.interactions}


def _pca_panel(axis, result: dict) -> None:
    pca = result["pca"]
    for index, points in enumerate(pca["points"]):
        points = np.array(points)
        colour = EPISODE_COLOURS[index % len(EPISODE_COLOURS)]
        axis.plot(points[:, 0], points[:, 1], "--", color=colour, lw=0.6, alpha=0.7)
        axis.scatter(points[:, 0], points[:, 1], s=6, color=colour, zorder=3)
    ratios = pca["explained_variance_ratio"]
    axis.set_xlabel(f"PC 1 ({100 * ratios[0]:.0f}% of variance)", fontsize=8)
    axis.set_ylabel(f"PC 2 ({100 * ratios[1]:.0f}%)", fontsize=8)
    axis.tick_params(labelsize=7)
    axis.set_title(f"(a) state embeddings, {pca['episodes']} episodes, {pca['states']} states\n"
                   f"median step / spread {pca['median_relative_step']:.2f} "
                   f"({pca['unchanged_steps']} steps left it unchanged)", fontsize=9)


def _positions_panel(axis, env, result: dict) -> None:
    draw_floor_plan(axis, env)
    for index, path in enumerate(result["positions"]):
        path = np.array(path).reshape(-1, 2)
        colour = EPISODE_COLOURS[index % len(EPISODE_COLOURS)]
        axis.plot(path[:, 0], path[:, 1], color=colour, lw=0.8, alpha=0.8, zorder=4)
        axis.scatter(path[:1, 0], path[:1, 1], marker="s", s=16, color=colour, edgecolors="black", lw=0.4, zorder=5)
    axis.set_title(f"(b) base positions, {result['episodes']} episodes: {result['coverage_m2']:.1f} m$^2$ "
                   f"of {COVERAGE_CELL_M} m cells", fontsize=9)


def _interactions_panel(axis, env, result: dict) -> None:
    draw_floor_plan(axis, env)
    interactions = result["interactions"]
    names = sorted({i["body"] for i in interactions})
    colours = plt.get_cmap("Set1").colors
    for index, name in enumerate(names):
        chosen = [i for i in interactions if i["body"] == name]
        xy = np.array([i["position"][:2] for i in chosen])
        sizes = 20 + 25 * np.array([i["duration_s"] for i in chosen])
        axis.scatter(xy[:, 0], xy[:, 1], s=sizes, color=colours[index % len(colours)], edgecolors="black", lw=0.4,
                     alpha=0.8, label=f"{name} ({len(chosen)})", zorder=6)
    if names:
        axis.legend(fontsize=6, loc="best", framealpha=0.8)
    axis.set_title(f"(c) interactions >= {INTERACTION_MIN_S:g} s: {len(interactions)}", fontsize=9)


def draw_exploration(runs: list[PolicyRun], results: list[dict], path: Path) -> Path:
    figure, axes = plt.subplots(len(runs), 3, figsize=(16.0, 4.2 * len(runs)), squeeze=False,
                                gridspec_kw={"width_ratios": (1.0, 1.5, 1.5)})
    same_scene = len({run.env.scene.name for run in runs}) == 1
    everywhere = [xy for result in results for path_ in result["positions"] for xy in path_]
    for row, (run, result) in enumerate(zip(runs, results)):
        _pca_panel(axes[row, 0], result)
        _positions_panel(axes[row, 1], run.env, result)
        _interactions_panel(axes[row, 2], run.env, result)
        shown = everywhere if same_scene else [xy for path_ in result["positions"] for xy in path_]
        for axis in axes[row, 1:]:
            zoom_to(axis, run.env, shown, margin=1.0)
        axes[row, 0].annotate(f"{run.run_dir.name}\n{run.label}", xy=(-0.22, 0.5), xycoords="axes fraction",
                              rotation=90, ha="center", va="center", fontsize=9)
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


def exploration_figure(paths: list[Path], out_dir: Path, episodes: int = 10, seed: int = 0,
                       pca_episodes: int = PCA_EPISODES, checkpoint: str = "latest", device: str = "auto",
                       stochastic: bool = True) -> dict:
    """``relmogen viz exploration``: ``out_dir/exploration.png`` and ``out_dir/exploration.json``;
    returns what the JSON holds."""
    if not paths:
        raise ValueError("exploration figures need at least one run")
    if episodes < 1 or pca_episodes < 1:
        raise ValueError(f"episodes and pca_episodes must be positive, got {episodes} and {pca_episodes}")
    out_dir = Path(out_dir)
    runs, results = [], []
    try:
        for path in paths:
            run = open_policy_run(Path(path), checkpoint, device, stochastic, arm_collision=None)
            runs.append(run)
            log = ExplorationLog(state_embedding(run.model, run.config.algo), min(pca_episodes, episodes))
            run.record(log, episodes, seed)
            results.append(exploration_result(run, log, episodes, seed))
        figure = draw_exploration(runs, results, out_dir / "exploration.png")
    finally:
        for run in runs:
            run.close()
    summary = {"figure": str(figure), "interaction_min_s": INTERACTION_MIN_S, "coverage_cell_m": COVERAGE_CELL_M,
               "runs": results}
    (out_dir / "exploration.json").write_text(json.dumps(summary))
    return summary
