"""``relmogen viz qmap``: what an SGP-D policy values, pixel by pixel (like the paper's Fig. A.2).

For a few states of greedy evaluation episodes, one PNG with two panels:

* the robot's RGB frame with the arm Q map (max over the K push directions, min-max
  normalised, upsampled from Q x Q to the image) overlaid;
* the local occupancy map (robot at the centre, forward up, left to the left; white free,
  grey unknown, black occupied; the goal/waypoint channel in green when the task has one)
  with the base Q map (max over the L yaw bins, only on cells the policy may choose, i.e.
  free for the base footprint) overlaid.

The chosen action (masked greedy, as at evaluation) is marked with a star and an arrow: the
push direction (robot frame, drawn as seen from above) for arm actions, the final heading for
base actions. Each Q map has a colour bar of its Q values and its panel title its highest
value (the higher of the two decides between base and arm); a legend below the panels says
what the local map's colours and the marks mean. The figure's title names the task, the
policy, its training episodes and the step shown.

Which states: ``drive="greedy"`` follows the policy itself and draws every ``stride``-th state.
A young policy rarely reaches the button or a cabinet, so ``drive="oracle"`` lets the task's
scripted oracle drive instead and draws the state before each of its pushes, with the cell the
oracle reaches for outlined in cyan; ``oracle_cells.json`` then records where that cell ranks
in the learned arm Q map (percentile among the allowed cells), and where the 3 x 3 cells
around it rank among all such squares: does the policy value the button or the cabinet front
where it matters, or at least its surroundings?
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch as th  # noqa: E402
from matplotlib import patheffects  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from relmogen.agents.dqn import info_masks, without_arm_mask  # noqa: E402
from relmogen.envs.relmogen_env import RelmogenEnv  # noqa: E402
from relmogen.envs.subgoal_controls import PUSH_BINS, YAW_BINS  # noqa: E402
from relmogen.experiments.oracle import oracle_arm_pushes  # noqa: E402

OVERLAY_ALPHA = 0.45
Q_COLOURMAP = "jet"
ROBOT_COLOUR = "orange"
FIGURE_DPI = 110
ARROW_CELLS = 2.5  # arrow length in Q-map cells
DRIVERS = ("greedy", "oracle")
ORACLE_EPISODES = 20  # give up when the oracle has not pushed in this many episodes


@dataclass
class QMapState:
    """Everything one figure shows: observation, Q maps, the cell masks and the greedy choice."""

    rgb: np.ndarray  # (S, S, 3) uint8
    local_map: np.ndarray  # (S, S, C) uint8, row = robot x (forward), column = robot y (left)
    q_maps: np.ndarray  # (L + K, Q, Q)
    masks: np.ndarray  # (2, Q, Q) bool: cells the policy may choose, base then arm
    parts: tuple[str, ...]
    choice: tuple[str, int, int, int]  # (part, bin, i, j)
    step: int
    choice_heading: float | None = None  # robot-frame heading of the chosen push
    marked_cell: tuple[int, int] | None = None  # (i, j) the oracle reaches for, outlined in cyan

    @property
    def cell_pixels(self) -> int:
        """Image pixels per Q-map cell, a side."""
        return self.rgb.shape[0] // self.q_maps.shape[-1]

    def arm_values(self) -> np.ndarray:
        """(Q, Q) arm Q value (max over push directions) of allowed cells, NaN elsewhere."""
        return np.where(self.masks[1], self.q_maps[YAW_BINS:].max(axis=0), np.nan)

    def arm_percentile(self, cell: tuple[int, int]) -> float | None:
        """Share (0-100) of allowed arm cells valued below ``cell``; None if ``cell`` is masked."""
        return self.arm_area_percentile(cell, radius=0)

    def arm_area_percentile(self, cell: tuple[int, int], radius: int = 1) -> float | None:
        """Like ``arm_percentile`` for the mean over the allowed cells of the (2 radius + 1)^2
        square around ``cell``, ranked among the same squares around every allowed cell: does
        the map value the object's surroundings, where pushes that brush it start?"""
        values = self.arm_values()
        allowed = np.isfinite(values)
        if not allowed[cell]:
            return None
        side = 2 * radius + 1
        sums = np.lib.stride_tricks.sliding_window_view(np.pad(np.where(allowed, values, 0.0), radius), (side, side))
        counts = np.lib.stride_tricks.sliding_window_view(np.pad(allowed, radius), (side, side)).sum(axis=(-2, -1))
        means = np.divide(sums.sum(axis=(-2, -1)), counts, out=np.full(counts.shape, np.nan), where=counts > 0)
        return float(100.0 * np.mean(means[allowed] < means[cell]))

def q_map_state(model, env: RelmogenEnv, obs: dict, step: int) -> QMapState:
    control = env.unwrapped.control
    masks = info_masks(control.extra_info(), model.q)
    masks = masks if model.mask_arm else without_arm_mask(masks)
    tensor_obs, _ = model.policy.obs_to_tensor(obs)
    with th.no_grad():
        maps = model.policy.q_net.net.q_maps(tensor_obs)[0].cpu().numpy()
    action = int(model.predict(obs, deterministic=True, masks=masks)[0])
    choice = control.decode(action)
    heading = control.push_heading(*choice[1:]) if choice[0] == "arm" else None
    sensed_map = obs["local_map"][..., :control.map_channels]  # without ``subgoal_feedback``'s channels
    return QMapState(obs["rgb"], sensed_map, maps, masks, tuple(model.subgoal_parts), choice, step, heading)


def _value_range(values: np.ndarray) -> tuple[float, float] | None:
    """(lowest, highest) finite value, widened a little when they are equal; None without any."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return None
    low, high = float(finite.min()), float(finite.max())
    return (low, high) if high > low else (low - 0.5, high + 0.5)


def _to_display(grid: np.ndarray) -> np.ndarray:
    """Row = forward, column = left -> an image with forward up and left on the left."""
    return grid[::-1, ::-1]


def _arrow(axis, row: float, col: float, angle: float, length: float) -> None:
    """Arrow at a display position for a robot-frame heading (forward up, left to the left)."""
    arrow = axis.annotate("", xy=(col - length * np.sin(angle), row - length * np.cos(angle)), xytext=(col, row),
                          arrowprops=dict(arrowstyle="-|>", color="white", lw=2.0))
    arrow.arrow_patch.set_path_effects([patheffects.withStroke(linewidth=3.5, foreground="black")])  # seen on white


def _mark_choice(axis, row: float, col: float) -> None:
    axis.plot(col, row, marker="*", markersize=16, color="white", markeredgecolor="black")


def _q_overlay(figure, axis, values: np.ndarray, size: int, label: str) -> None:
    """``values`` (Q x Q, NaN where not allowed) over the panel, with a colour bar of Q values."""
    value_range = _value_range(values)
    if value_range is None:
        return
    image = axis.imshow(values, cmap=Q_COLOURMAP, alpha=OVERLAY_ALPHA, vmin=value_range[0], vmax=value_range[1],
                        extent=(-0.5, size - 0.5, size - 0.5, -0.5), interpolation="nearest")
    colour_bar = figure.colorbar(image, ax=axis, fraction=0.046, pad=0.02)
    colour_bar.solids.set_alpha(1.0)  # the bar shows the colours, not the see-through overlay
    colour_bar.set_label(label, fontsize=8)
    colour_bar.ax.tick_params(labelsize=7)


def _arm_panel(figure, axis, state: QMapState) -> None:
    size = state.rgb.shape[0]
    axis.imshow(state.rgb)
    if "arm" in state.parts:
        arm = state.arm_values()
        _q_overlay(figure, axis, arm, size, "arm Q value")
        axis.set_title(f"Arm: value of pushing from each image cell\n(best of {PUSH_BINS} directions; "
                       f"highest {np.nanmax(arm) if np.isfinite(arm).any() else float('nan'):.2f})", fontsize=9)
    else:
        axis.set_title("Arm: not used by this task", fontsize=9)
    part, bin_, i, j = state.choice
    c = state.cell_pixels
    if part == "arm":
        row, col = c * i + c // 2, c * j + c // 2
        _mark_choice(axis, row, col)
        if state.choice_heading is not None:
            _arrow(axis, row, col, state.choice_heading, ARROW_CELLS * c)
    if state.marked_cell is not None:
        i, j = state.marked_cell
        axis.add_patch(plt.Rectangle((c * j - 0.5, c * i - 0.5), c, c, fill=False, edgecolor="cyan", lw=2.0))
    axis.set_axis_off()


def _base_panel(figure, axis, state: QMapState) -> None:
    grid = state.local_map[..., 0].astype(float)
    size, q = grid.shape[0], state.masks.shape[-1]
    axis.imshow(_to_display(grid), cmap="gray_r", vmin=0, vmax=255)
    if state.local_map.shape[-1] > 1:
        marks = np.ma.masked_equal(_to_display(state.local_map[..., 1].astype(float)), 0)
        axis.imshow(marks, cmap="Greens", vmin=0, vmax=255, alpha=0.9)
    scale = size / q
    if "base" in state.parts:
        base = np.where(state.masks[0], state.q_maps[:YAW_BINS].max(axis=0), np.nan)
        _q_overlay(figure, axis, _to_display(base), size, "base Q value")
        axis.set_title(f"Base: value of driving to each free cell\n(best of {YAW_BINS} headings; "
                       f"highest {np.nanmax(base) if np.isfinite(base).any() else float('nan'):.2f})", fontsize=9)
    else:
        axis.set_title("Base: not used by this task", fontsize=9)
    centre = size / 2 - 0.5
    axis.plot(centre, centre, marker="o", markersize=7, color=ROBOT_COLOUR, markeredgecolor="black")
    part, bin_, i, j = state.choice
    if part == "base":
        row, col = (q - 1 - i + 0.5) * scale - 0.5, (q - 1 - j + 0.5) * scale - 0.5
        _mark_choice(axis, row, col)
        _arrow(axis, row, col, -np.pi + bin_ * 2 * np.pi / YAW_BINS, ARROW_CELLS * scale)
    axis.set_axis_off()


def legend_handles(state: QMapState) -> list:
    """What the marks and the local map's colours mean."""
    handles = [Patch(facecolor="white", edgecolor="black", label="local map: free"),
               Patch(facecolor="grey", edgecolor="black", label="local map: not seen yet"),
               Patch(facecolor="black", edgecolor="black", label="local map: occupied"),
               Line2D([], [], marker="o", linestyle="", color=ROBOT_COLOUR, markeredgecolor="black",
                      label="robot (map centre, facing up)"),
               Line2D([], [], marker="*", linestyle="", markersize=12, color="white", markeredgecolor="black",
                      label="the policy's choice (arrow: push direction or final heading)"),
               Patch(facecolor="none", edgecolor="lightgrey", label="no colour: a cell the policy may not choose")]
    if state.local_map.shape[-1] > 1:
        handles.insert(3, Patch(facecolor="tab:green", label="goal and path to it"))
    if state.marked_cell is not None:
        handles.append(Patch(facecolor="none", edgecolor="cyan", lw=2.0, label="cell the scripted oracle pushes"))
    return handles


def choice_text(state: QMapState) -> str:
    part = state.choice[0]
    return "push with the arm" if part == "arm" else "drive the base"


def q_map_figure(state: QMapState, title: str):
    """The three panels, a colour bar per Q map, and a legend of the marks below them."""
    figure, axes = plt.subplots(1, 3, figsize=(13.0, 5.3), layout="constrained")
    axes[0].imshow(state.rgb)
    axes[0].set_title("Robot camera (RGB)", fontsize=9)
    axes[0].set_axis_off()
    _arm_panel(figure, axes[1], state)
    _base_panel(figure, axes[2], state)
    driver = "the scripted oracle" if state.marked_cell is not None else "the policy"
    figure.suptitle(f"{title}\nstep {state.step} of an episode driven by {driver}: the greedy policy would "
                    f"{choice_text(state)} (the higher of the two best values wins)", fontsize=10)
    figure.legend(handles=legend_handles(state), loc="outside lower center", ncol=4, fontsize=8, frameon=False)
    return figure


def draw_q_map_state(state: QMapState, path: Path, title: str) -> Path:
    figure = q_map_figure(state, title)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=FIGURE_DPI)
    plt.close(figure)
    return path


def q_map_figures(model, env: RelmogenEnv, out_dir: Path, states: int = 4, seed: int = 0,
                  stride: int = 3, title: str = "", drive: str = "greedy") -> list[Path]:
    """Draw ``states`` figures over episodes with seeds ``seed, seed + 1, ...``: every
    ``stride``-th state of greedy episodes, or (``drive="oracle"``) the state before each push of
    the task's oracle."""
    if states < 1 or stride < 1:
        raise ValueError(f"states and stride must be positive, got {states} and {stride}")
    if drive not in DRIVERS:
        raise ValueError(f"unknown drive {drive!r}; valid: {', '.join(DRIVERS)}")
    if drive == "oracle":
        return _oracle_figures(model, env, Path(out_dir), states, seed, title)
    paths: list[Path] = []
    episode = 0
    while len(paths) < states:
        obs, _ = env.reset(seed=seed + episode)
        done, step = False, 0
        while not done and len(paths) < states:
            state = q_map_state(model, env, obs, step)
            if step % stride == 0:
                paths.append(draw_q_map_state(state, _figure_path(out_dir, env, episode, step),
                                              title or env.unwrapped.task.name))
            part, bin_, i, j = state.choice
            obs, _, terminated, truncated, _ = env.step(env.unwrapped.control.encode(part, bin_, i, j))
            done, step = terminated or truncated, step + 1
        episode += 1
    return paths


def _figure_path(out_dir: Path, env: RelmogenEnv, episode: int, step: int) -> Path:
    return Path(out_dir) / f"qmap_{env.unwrapped.task.name}_ep{episode}_step{step:02d}.png"


def _oracle_figures(model, env: RelmogenEnv, out_dir: Path, states: int, seed: int, title: str) -> list[Path]:
    """The states before the oracle's arm pushes (``oracle_arm_pushes``), its cell outlined."""
    unwrapped = env.unwrapped
    paths, records = [], []
    for episode, step, obs, action in oracle_arm_pushes(env, ORACLE_EPISODES, seed):
        row, col = unwrapped.control.arm_pixel(action)
        state = q_map_state(model, env, obs, step)
        state.marked_cell = unwrapped.control.pixel_cell(row, col)
        records.append(_oracle_record(state, episode))
        paths.append(draw_q_map_state(state, _figure_path(out_dir, env, episode, step), title or unwrapped.task.name))
        if len(paths) >= states:
            break
    if not paths:
        raise RuntimeError(f"the {unwrapped.task.name} oracle made no arm subgoal in {ORACLE_EPISODES} episodes")
    _write_oracle_summary(out_dir / "oracle_cells.json", records)
    return paths


def _oracle_record(state: QMapState, episode: int) -> dict:
    part, _, i, j = state.choice
    return {"episode": episode, "step": state.step, "oracle_cell": list(state.marked_cell),
            "oracle_cell_allowed": bool(state.masks[1][state.marked_cell]),
            "oracle_cell_percentile": state.arm_percentile(state.marked_cell),
            "oracle_area_percentile": state.arm_area_percentile(state.marked_cell),
            "greedy_part": part, "greedy_is_oracle_cell": part == "arm" and (i, j) == state.marked_cell}


def _write_oracle_summary(path: Path, records: list[dict]) -> None:
    def mean_of(key: str) -> float | None:
        values = [r[key] for r in records if r[key] is not None]
        return float(np.mean(values)) if values else None

    summary = {"pushes": len(records), "oracle_cell_allowed": sum(r["oracle_cell_allowed"] for r in records),
               "mean_percentile": mean_of("oracle_cell_percentile"),
               "mean_area_percentile": mean_of("oracle_area_percentile"),
               "greedy_arm": sum(r["greedy_part"] == "arm" for r in records),
               "greedy_is_oracle_cell": sum(r["greedy_is_oracle_cell"] for r in records), "states": records}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(summary, indent=1))


def figure_title(config, episodes: int | None, trained_task: str) -> str:
    """Task, policy and training episodes, e.g. "ButtonDoorNav: Q maps of relmogen-d (seed 0) after
    2,019 training episodes"."""
    trained = f" after {episodes:,} training episodes" if episodes is not None else ""
    elsewhere = f" on {trained_task}" if trained_task != config.task else ""
    return f"{config.task}: Q maps of {config.algo} (seed {config.seed}){elsewhere}{trained}"


def q_map_figures_for_checkpoint(path: Path, out_dir: Path, task: str | None = None, states: int = 4,
                                 seed: int = 0, stride: int = 3, device: str = "auto",
                                 drive: str = "greedy") -> list[Path]:
    """``relmogen viz qmap``: load a relmogen-d run or checkpoint and draw its Q maps on ``task``
    (default: the task it was trained on), arm collision checking on as at evaluation."""
    from relmogen.experiments.evaluate import load_checkpoint, resolve_checkpoint
    from relmogen.experiments.checkpoints import checkpoint_state
    from relmogen.experiments.environments import env_kwargs

    folder, run_dir = resolve_checkpoint(Path(path))
    model, config = load_checkpoint(folder, run_dir, device)
    if config.algo != "relmogen-d":
        raise ValueError(f"Q maps exist only for relmogen-d policies; {run_dir} is {config.algo!r}")
    trained_task = config.task
    if task is not None:
        config = config.model_copy(update={"task": task})
    env = RelmogenEnv(**env_kwargs(config, arm_collision=True))
    try:
        if min(env.observation_space["local_map"].shape) != min(model.observation_space["local_map"].shape):
            raise ValueError(f"{config.task}'s local map has a different number of channels than the "
                             f"task {run_dir.name} was trained on")
        title = figure_title(config, checkpoint_state(folder).get("episodes"), trained_task)
        return q_map_figures(model, env, out_dir, states, seed, stride, title=title, drive=drive)
    finally:
        env.close()
