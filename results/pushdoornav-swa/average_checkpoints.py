"""Average the weights of a run's kept checkpoints (stochastic weight averaging over the periodic
evaluations' models) and save the result as one more checkpoint folder of that run.

    python results/pushdoornav-swa/average_checkpoints.py RUN evaluated_0000200 evaluated_0000300 ... --name swa_200_500

Floating-point tensors of the whole policy (actor, critics, encoder, target critics) are averaged;
the entropy coefficient and the optimiser state are the last checkpoint's. Evaluate with
``relmogen eval RUN --checkpoint swa_200_500``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch as th

from relmogen.experiments.evaluate import load_checkpoint
from relmogen.experiments.train import CHECKPOINTS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path)
    parser.add_argument("checkpoints", nargs="+", help="names of folders in RUN/checkpoints/")
    parser.add_argument("--name", required=True, help="folder name of the averaged checkpoint")
    args = parser.parse_args()
    folders = [args.run / CHECKPOINTS / name for name in args.checkpoints]
    models = [load_checkpoint(folder, args.run, device="cpu")[0] for folder in folders]
    states = [model.policy.state_dict() for model in models]
    averaged = {key: (th.stack([s[key] for s in states]).mean(0) if value.is_floating_point() else value)
                for key, value in states[-1].items()}
    last = models[-1]
    last.policy.load_state_dict(averaged)
    out = args.run / CHECKPOINTS / args.name
    out.mkdir(exist_ok=True)
    last.save(out / "model.zip")
    state = json.loads((folders[-1] / "state.json").read_text())
    state.pop("evaluation", None)
    state["averaged"] = args.checkpoints
    (out / "state.json").write_text(json.dumps(state))
    print(out)


if __name__ == "__main__":
    main()
