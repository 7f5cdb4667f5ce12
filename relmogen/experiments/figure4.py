"""The paper's Fig. 4 for our Table I cells: ``relmogen report --figure4 DIR [--out OUT]``.

``DIR`` is a Table I folder (``results/table1``): a cell per ``DIR/<Task>__<algo>/`` with its
report (``table.json``, found as ``relmogen report --table1`` finds them) and its run folders, one
per seed. Per task, ``OUT/figure4_<Task>.png`` draws the return of training episodes and the
task's Table I metric as logged per training episode (``success``, or ``closed_10`` for the
arrangement tasks) against training episodes, a line per algorithm: the mean over seeds of each
seed's rolling mean, with a band of one std over seeds. ``OUT/figure4.md`` lists each cell's
seeds, episodes and final rolling metric, with the images. Only reward-only cells are drawn.

A cell's runs are the run folders directly in it (the last stage's: their config and evaluation
are the cell's), or, in the layout ``relmogen reproduce --publish`` writes, the runs under
``runs/<stage>/`` that no other run there was initialised from. A run started with
``--init-from`` (``init_from.json``) is preceded by the run it names, found by folder name
elsewhere in the cell (``phase1/``), so its episodes follow that run's and the x axis counts all
the seed's training episodes; a stage continued in place is one run already. ``reruns/`` and the
cell's other folders (earlier attempts, settings) are not read.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from relmogen.experiments.config import read_config  # noqa: E402
from relmogen.experiments.finetune import read_init_from  # noqa: E402
from relmogen.experiments.report import (CURVES_DPI, markdown_grid, mean_and_std, read_curve,  # noqa: E402
                                         trailing_mean, training_of)
from relmogen.experiments.table1 import ALGORITHMS, TASKS, catalogue_position, metric_of, read_tables  # noqa: E402

FIGURE4_SMOOTHING = 100  # training episodes in each seed's rolling mean
ALGORITHM_COLOURS = dict(zip(ALGORITHMS, ("C0", "C1", "C2", "C3", "C4")))  # the same in every task's figure
OTHER_COLOUR = "C7"
TRAINING_COLUMN = {"success_rate": "success", "closed_10": "closed_10"}  # Table I metric -> episodes.csv column
SKIPPED_FOLDERS = ("reruns",)


@dataclass
class SeedCurve:
    """One seed of a cell: its stages' runs in training order and their episodes end to end."""

    seed: int
    runs: list[Path]
    stage_episodes: list[int]  # episodes of each stage (a stage not in the folder: its init_from.json count)
    curve: dict[str, np.ndarray]  # read_curve's columns, episodes numbered from the first stage's first

    @property
    def episodes(self) -> int:
        return int(sum(self.stage_episodes))

    @property
    def stage_starts(self) -> list[int]:
        """The episode after which each later stage starts."""
        return [int(x) for x in np.cumsum(self.stage_episodes)[:-1]]


@dataclass
class Cell:
    task: str
    algorithm: str
    folder: Path
    seeds: list[SeedCurve]


def _is_run(path: Path) -> bool:
    return path.is_dir() and (path / "episodes.csv").is_file() and (path / "config.yaml").is_file()


def final_runs(cell: Path) -> list[Path]:
    """The runs of the cell's last stage (see the module's docstring)."""
    top = [path for path in sorted(cell.iterdir()) if _is_run(path)]
    if top:
        return top
    published = [path for path in sorted(cell.glob("runs/*/*")) if _is_run(path)]
    sources = {Path(init["run"]).name for path in published if (init := read_init_from(path))}
    return [path for path in published if path.name not in sources]


def _stage_run(cell: Path, name: str, after: Path) -> Path | None:
    """The run folder called ``name`` in a subfolder of the cell (not ``reruns/``), other than ``after``."""
    found = [path for path in sorted([*cell.glob(f"*/{name}"), *cell.glob(f"runs/*/{name}")])
             if path.parts[len(cell.parts)] not in SKIPPED_FOLDERS and path != after and _is_run(path)]
    return found[0] if found else None


def stage_chain(cell: Path, run: Path) -> tuple[list[Path], int]:
    """The runs behind ``run`` in training order (``init_from.json`` back to a run from scratch),
    and the episodes of an earliest stage not in the folder (0 when all are)."""
    chain, missing = [run], 0
    while (init := read_init_from(chain[0])) is not None:
        source = _stage_run(cell, Path(init["run"]).name, chain[0])
        if source is None or source in chain:
            missing = int(init.get("initial_episodes", init.get("checkpoint_episode", 0)) or 0)
            break
        chain.insert(0, source)
    return chain, missing


def seed_curve(cell: Path, run: Path) -> SeedCurve:
    """The seed's curve: its stages' ``episodes.csv`` end to end, the last stage's config's seed."""
    chain, missing = stage_chain(cell, run)
    curves = [read_curve(path / "episodes.csv") for path in chain]
    counts = [int(np.nanmax(curve["episode"], initial=0)) for curve in curves]
    offsets = np.cumsum([missing, *counts[:-1]])
    joined = {key: np.concatenate([curve[key] for curve in curves]) for key in curves[0]}
    joined["episode"] = np.concatenate([curve["episode"] + offset for curve, offset in zip(curves, offsets)])
    joined["wall_time_s"] = np.concatenate([curve["wall_time_s"] + sum(
        np.nanmax(c["wall_time_s"], initial=0) for c in curves[:i]) for i, curve in enumerate(curves)])
    return SeedCurve(read_config(run / "config.yaml").seed, chain, ([missing] if missing else []) + counts, joined)


def read_cells(folder: Path) -> list[Cell]:
    """Every reward-only cell of the Table I folder (``table.json`` says which), in the paper's order."""
    cells = []
    for name, table in read_tables(Path(folder)):
        references = [row for row in table["rows"] if row["reference"]] or table["rows"]
        if not references or any(training_of(row) == "assisted" for row in references):
            continue
        cell = Path(folder) / name
        seeds = sorted((seed_curve(cell, run) for run in final_runs(cell)), key=lambda s: s.seed)
        if seeds:
            cells.append(Cell(references[0]["task"], references[0]["algorithm"], cell, seeds))
    return sorted(cells, key=lambda c: (catalogue_position(TASKS, c.task), c.task,
                                        catalogue_position(ALGORITHMS, c.algorithm), c.algorithm))


def metric_column(task: str) -> tuple[str, str]:
    """The ``episodes.csv`` column of the task's Table I metric and its axis label."""
    metric, label = metric_of(task)
    column = TRAINING_COLUMN[metric]
    if column == "success":
        return column, "success rate of training episodes"
    return column, f"items closed per training episode\n(within {label.removeprefix('closed (').rstrip(')')})"


def colour_of(algorithm: str) -> str:
    return ALGORITHM_COLOURS.get(algorithm, OTHER_COLOUR)


def _draw(ax, cell: Cell, key: str) -> None:
    runs = [{"curve": seed.curve} for seed in cell.seeds]
    grid, mean, std = mean_and_std(runs, key, "episode", FIGURE4_SMOOTHING)
    count = len(cell.seeds)
    colour = colour_of(cell.algorithm)
    ax.plot(grid, mean, color=colour, label=f"{cell.algorithm} ({count} seed{'s' if count != 1 else ''})")
    if count > 1:
        ax.fill_between(grid, mean - std, mean + std, color=colour, alpha=0.2, linewidth=0)
    for start in sorted({start for seed in cell.seeds for start in seed.stage_starts}):
        ax.axvline(start, color=colour, linestyle=":", linewidth=0.8)


def task_figure(task: str, cells: list[Cell]):
    """The task's Fig. 4: return (left) and the Table I metric (right) of training episodes."""
    column, label = metric_column(task)
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    rolling = f"rolling mean of {FIGURE4_SMOOTHING} episodes"
    for ax, key, ylabel in ((left, "return", f"episode return\n({rolling})"), (right, column, f"{label}\n({rolling})")):
        for cell in cells:
            _draw(ax, cell, key)
        ax.set_xlabel("training episodes")
        ax.set_ylabel(ylabel)
        ax.grid(alpha=0.3)
    staged = any(seed.stage_starts for cell in cells for seed in cell.seeds)
    left.legend(fontsize=8, title="mean ± std over seeds" + ("\n(dotted: a stage starts)" if staged else ""),
                title_fontsize=8)
    fig.suptitle(f"{task}: training curves (reward only)")
    return fig


def final_metric(seed: SeedCurve, column: str) -> float:
    """The seed's rolling mean of ``column`` at its last episode."""
    values = trailing_mean(seed.curve[column], FIGURE4_SMOOTHING)
    return float(values[-1]) if len(values) else float("nan")


def _number(value: float) -> str:
    return "-" if not np.isfinite(value) else f"{value:.2f}"


def _episodes_cell(seed: SeedCurve) -> str:
    parts = " + ".join(str(count) for count in seed.stage_episodes)
    return f"{seed.episodes} ({parts})" if len(seed.stage_episodes) > 1 else str(seed.episodes)


HEADER = f"""# Fig. 4 for our runs: training curves of the Table I cells (reward only)

`relmogen report --figure4 DIR` draws, per task, the return of training episodes (left) and the
task's Table I metric as logged per training episode (right: success, or items closed within
10 deg / 10 cm) against training episodes, like the paper's Fig. 4. A line per algorithm: the mean
over seeds of each seed's rolling mean of {FIGURE4_SMOOTHING} training episodes (sampled actions, as trained),
with a band of one std over seeds; where seeds ran different numbers of episodes, the end of a line
averages the seeds still running. A seed's stages are drawn end to end: a run initialised from an
earlier stage's (`init_from.json`) follows that run's episodes (dotted lines: where a stage
starts); a stage continued in place is one run. These are training episodes, not the Table I
evaluations (greedy, on other seeds)."""


def task_table(cells: list[Cell]) -> str:
    column, _ = metric_column(cells[0].task)
    label = metric_of(cells[0].task)[1]
    header = ["algorithm", "folder", "seeds", "episodes per seed (stages)",
              f"final {label} per seed (last {FIGURE4_SMOOTHING} episodes)", "mean"]
    lines = []
    for cell in cells:
        finals = [final_metric(seed, column) for seed in cell.seeds]
        known = [value for value in finals if np.isfinite(value)]
        lines.append([cell.algorithm, cell.folder.name, ", ".join(str(seed.seed) for seed in cell.seeds),
                      ", ".join(_episodes_cell(seed) for seed in cell.seeds),
                      ", ".join(_number(value) for value in finals),
                      _number(float(np.mean(known))) if known else "-"])
    return markdown_grid(header, lines)


def figure4_markdown(by_task: dict[str, list[Cell]], images: dict[str, str]) -> str:
    parts = [HEADER]
    for task, cells in by_task.items():
        parts += [f"## {task}", f"![{task}: training curves]({images[task]})", task_table(cells)]
    return "\n\n".join(parts) + "\n"


def write_figure4(folder: Path, out: Path | None = None) -> dict[str, Path]:
    """Writes ``out/figure4_<Task>.png`` per task with a reward-only cell and ``out/figure4.md``
    (``out`` defaults to ``folder/figure4``); returns the paths, by task and ``markdown``."""
    cells = read_cells(Path(folder))
    if not cells:
        raise ValueError(f"no reward-only cell with runs under {folder}")
    out = Path(out) if out is not None else Path(folder) / "figure4"
    out.mkdir(parents=True, exist_ok=True)
    by_task: dict[str, list[Cell]] = {}
    for cell in cells:
        by_task.setdefault(cell.task, []).append(cell)
    paths: dict[str, Path] = {}
    for task, task_cells in by_task.items():
        fig = task_figure(task, task_cells)
        paths[task] = out / f"figure4_{task}.png"
        fig.savefig(paths[task], dpi=CURVES_DPI)
        plt.close(fig)
    paths["markdown"] = out / "figure4.md"
    paths["markdown"].write_text(figure4_markdown(by_task, {task: paths[task].name for task in by_task}))
    return paths
