"""A run's budgets: episodes, wall-clock hours and CPU hours (``TrainConfig.episodes``,
``max_hours``, ``max_cpu_hours``), which of them a run has spent, and the line that says what
stopped it (``done.json``'s ``stop_reason``)."""

from __future__ import annotations

import json
from pathlib import Path

import psutil

from relmogen.experiments.config import TrainConfig

BUDGETS = ("episodes", "max_hours", "max_cpu_hours")
DONE = "done.json"


def process_tree_cpu_seconds() -> float:
    """User + system CPU seconds of this process and its live children since they started."""
    me = psutil.Process()
    total = 0.0
    for process in [me, *me.children(recursive=True)]:
        try:
            times = process.cpu_times()
        except psutil.NoSuchProcess:
            continue
        total += times.user + times.system
    return total


def hms(seconds: float) -> str:
    """``H:MM:SS``, as rich's elapsed-time column shows it."""
    minutes, secs = divmod(int(round(seconds)), 60)
    return f"{minutes // 60}:{minutes % 60:02d}:{secs:02d}"


def spent_budgets(config: TrainConfig, spent: dict) -> list[str]:
    """Which of ``BUDGETS`` the counters ``spent`` (``episodes``, ``wall_time_s``, ``cpu_time_s``,
    as a checkpoint's ``state.json`` holds them) have reached, in that order."""
    reached = {"episodes": spent["episodes"] >= config.episodes,
               "max_hours": config.max_hours is not None and spent["wall_time_s"] >= config.max_hours * 3600,
               "max_cpu_hours": (config.max_cpu_hours is not None
                                 and spent.get("cpu_time_s", 0.0) >= config.max_cpu_hours * 3600)}
    return [budget for budget in BUDGETS if reached[budget]]


def budget_stop_reason(config: TrainConfig, spent: dict) -> str:
    """``done.json``'s line for a run that ended on its own: the first budget spent."""
    episodes, budget = spent["episodes"], config.episodes
    at = f"at episode {episodes} of {budget}"
    reached = spent_budgets(config, spent)
    if "episodes" in reached:
        return f"stopped by the episode budget: {episodes} of {budget} episodes in {hms(spent['wall_time_s'])}"
    if "max_hours" in reached:
        return f"stopped by the time limit (--max-hours {config.max_hours:g}) {at}, after {hms(spent['wall_time_s'])}"
    if "max_cpu_hours" in reached:
        return (f"stopped by the CPU-time limit (max_cpu_hours {config.max_cpu_hours:g}) {at}, "
                f"after {spent['cpu_time_s'] / 3600:.2f} CPU h")
    return f"stopped {at}"


def spent_budget_note(run_dir: Path, config: TrainConfig, spent: dict) -> str | None:
    """None while ``config`` leaves the run budget to train; else one line naming each budget
    ``spent`` has reached and the option that raises it."""
    reached = [_budget_and_its_option(budget, config, spent) for budget in spent_budgets(config, spent)]
    if not reached:
        return None
    return (f"the run already reached {' and '.join(what for what, _ in reached)}; nothing trained; "
            f"to continue: relmogen train --resume {run_dir} {' '.join(option for _, option in reached)}")


def _budget_and_its_option(budget: str, config: TrainConfig, spent: dict) -> tuple[str, str]:
    """A reached budget in words, and the option that raises it."""
    if budget == "episodes":
        return (f"its episode budget ({spent['episodes']} of {config.episodes} episodes)",
                f"--episodes N (N > {spent['episodes']})")
    if budget == "max_hours":
        hours = spent["wall_time_s"] / 3600
        return (f"its time limit (--max-hours {config.max_hours:g}; {hms(spent['wall_time_s'])} spent)",
                f"--max-hours H (H > {hours:.3g}, a total from the run's start)")
    cpu_hours = spent.get("cpu_time_s", 0.0) / 3600
    return (f"its CPU-time limit (max_cpu_hours {config.max_cpu_hours:g}; {cpu_hours:.3g} CPU h spent)",
            f"--set max_cpu_hours=H (H > {cpu_hours:.3g}, a total from the run's start)")


def write_done(run_dir: Path, state: dict, reason: str, keep: bool = False) -> None:
    """``done.json``: the budget spent and what stopped the run (an existing one stays with ``keep``)."""
    done = Path(run_dir) / DONE
    if not (keep and done.is_file()):
        done.write_text(json.dumps(dict(state, stop_reason=reason)))


def stop_reason(run_dir: Path) -> str | None:
    """The line naming what ended a finished run (``done.json``), or None for runs without one."""
    done = Path(run_dir) / DONE
    return json.loads(done.read_text()).get("stop_reason") if done.is_file() else None


def gradient_updates(config: TrainConfig, state: dict) -> tuple[int | None, bool]:
    """A run's gradient steps (``state.json``/``done.json``) and whether they were counted (True)
    or, for a run older than the count (2026-12-08), derived from its schedule (False; None for
    HRL4IN, whose high level updates once per subgoal)."""
    if "gradient_updates" in state:
        return int(state["gradient_updates"]), True
    if config.algo == "hrl4in" or "timesteps" not in state:
        return None, False
    return scheduled_gradient_updates(config, int(state["timesteps"])), False


def scheduled_gradient_updates(config: TrainConfig, timesteps: int) -> int:
    """The gradient steps SB3's off-policy loop takes in ``timesteps`` transitions of one
    uninterrupted run: ``gradient_steps`` after each rollout of ``train_freq`` steps of every
    environment that ends past ``learning_starts``. A stop and a resume can each move the
    count by one rollout's steps."""
    params = config.algo_params
    rollout = params.train_freq * config.env.n_envs
    rollouts_after_start = timesteps // rollout - params.learning_starts // rollout
    return max(rollouts_after_start, 0) * params.gradient_steps
