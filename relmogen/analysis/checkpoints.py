"""Average the weights of a run's kept checkpoints (stochastic weight averaging over the models
its periodic evaluations kept, ``run.keep_evaluated``) into one more checkpoint folder of the run.

Every floating-point tensor of the policy (actor, critics, encoder, target critics) is averaged;
the rest (the entropy coefficient, the optimiser state) is the last checkpoint's. Evaluate it with
``relmogen eval RUN --checkpoint NAME``.

    relmogen analyse average-checkpoints RUN CHECKPOINT... --name NAME
"""

from __future__ import annotations

import json
from pathlib import Path

import torch as th

from relmogen.experiments.checkpoints import CHECKPOINTS
from relmogen.experiments.loading import load_checkpoint


def averaged_state(states: list[dict]) -> dict:
    """The element-wise mean of each floating-point tensor; other entries from the last state."""
    return {key: th.stack([s[key] for s in states]).mean(0) if value.is_floating_point() else value
            for key, value in states[-1].items()}


def average_checkpoints(run: Path, names: list[str], name: str) -> Path:
    """``RUN/checkpoints/<name>`` holding the average of the named checkpoint folders; its
    ``state.json`` is the last one's without its evaluation, with ``averaged`` listing the names."""
    run = Path(run)
    if len(names) < 1:
        raise ValueError("name at least one checkpoint folder to average")
    folders = [run / CHECKPOINTS / checkpoint for checkpoint in names]
    missing = [str(folder) for folder in folders if not (folder / "model.zip").is_file()]
    if missing:
        raise ValueError(f"no model.zip in {', '.join(missing)}")
    out = run / CHECKPOINTS / name
    if out.exists():
        raise ValueError(f"{out} exists; choose another --name")
    models = [load_checkpoint(folder, run, device="cpu")[0] for folder in folders]
    last = models[-1]
    last.policy.load_state_dict(averaged_state([model.policy.state_dict() for model in models]))
    out.mkdir()
    last.save(out / "model.zip")
    state_file = folders[-1] / "state.json"
    state = json.loads(state_file.read_text()) if state_file.is_file() else {}
    state.pop("evaluation", None)
    state["averaged"] = list(names)
    (out / "state.json").write_text(json.dumps(state))
    if (folders[-1] / "config.yaml").is_file():
        (out / "config.yaml").write_text((folders[-1] / "config.yaml").read_text())
    return out
