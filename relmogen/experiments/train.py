"""``relmogen train``: a new run, from scratch or from another run's weights (``--init-from``).

A run directory ``{task}__{algo}__{seed}__{time}`` holds ``config.yaml`` (the resolved
configuration), ``episodes.csv`` (one row per finished training episode), TensorBoard events
(x-axis: environment episodes, as the paper plots), and ``checkpoints/`` with the model and,
in its own folder, the replay buffer (``checkpoints.py``). The jobs of a run live in their own
modules: ``session.py`` trains (``monitor.py``'s callback counts, logs, checkpoints, evaluates
and stops it; ``budgets.py`` says when and why), ``resume.py`` continues a run, ``models.py`` and
``environments.py`` build what it trains.
"""

from __future__ import annotations

import difflib
import json
import shutil
import time
from pathlib import Path

from relmogen.experiments.config import TrainConfig, save_config
from relmogen.experiments.environments import make_training_env
from relmogen.experiments.finetune import INIT_LOG, init_source, initialise_from
from relmogen.experiments.models import build_model, require_device
from relmogen.experiments.session import learn


def known_name(value: str, valid, what: str) -> str:
    """``value`` when it is one of ``valid``; else a ValueError that suggests the nearest valid
    name (the same letters in another case first) and lists them all."""
    valid = sorted(valid)
    if value in valid:
        return value
    close = [name for name in valid if name.lower() == value.lower()] or difflib.get_close_matches(value, valid, n=1)
    suggestion = f"did you mean {close[0]}? " if close else ""
    raise ValueError(f"unknown {what} {value!r}; {suggestion}valid: {', '.join(valid)}")


def check_trainable(config: TrainConfig) -> None:
    """Refuses, before anything is written, what would only fail once the run started: an
    unknown task, scene or planner, or a device this machine does not have."""
    from relmogen.motion_generation.planners import BACKENDS
    from relmogen.scenes import available_scenes
    from relmogen.tasks import TASKS

    known_name(config.task, TASKS, "task")
    require_device(config.device)
    kind = TASKS[config.task].scene_kind
    for key in ("scene", "second_scene"):
        if getattr(config.env, key) is not None:
            known_name(getattr(config.env, key), [s for s in available_scenes() if s.startswith(kind)],
                       f"{kind} scene (env.{key})")
    if config.control != "joint":
        for key in ("base_planner", "arm_planner"):
            known_name(getattr(config.env, key), BACKENDS, f"env.{key}")


def new_run_dir(out: Path, config: TrainConfig) -> Path:
    stamp = time.strftime("%Y%m%d-%H%M%S")
    run_dir = Path(out) / f"{config.task}__{config.algo}__{config.seed}__{stamp}"
    run_dir.mkdir(parents=True, exist_ok=False)
    save_config(config, run_dir / "config.yaml")
    return run_dir


def train(config: TrainConfig, out: Path = Path("runs"), quiet: bool = False, init_from: Path | None = None,
          init_replay: bool = False) -> Path:
    """A new run. ``init_from`` (a run directory: its latest checkpoint, or a checkpoint folder)
    starts it from that model's weights and, with ``init_replay``, that run's replay buffer:
    fine-tuning to another scene or robot (``initialise_from``, recorded in ``init_from.json``)."""
    check_trainable(config)
    if init_replay and init_from is None:
        raise ValueError("--init-replay loads the replay buffer of the --init-from run; give --init-from too")
    source = init_source(config, init_from) if init_from is not None else None
    run_dir = new_run_dir(out, config)
    env = make_training_env(config, run_dir)
    model = build_model(config, env)
    if source is not None:
        try:
            record = initialise_from(model, config, *source, with_replay=init_replay)
        except ValueError:  # the spaces or the replay layout do not match: leave nothing behind
            env.close()
            shutil.rmtree(run_dir, ignore_errors=True)
            raise
        (run_dir / INIT_LOG).write_text(json.dumps(dict(record, given=str(init_from)), indent=1))
    return learn(run_dir, config, model, {"episodes": 0, "timesteps": 0, "wall_time_s": 0.0}, quiet)
