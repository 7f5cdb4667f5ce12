"""``relmogen analyse average-checkpoints``: the weights of kept checkpoints, averaged."""

import json
import shutil

import pytest
import torch as th

from relmogen.analysis.checkpoints import average_checkpoints, averaged_state
from relmogen.cli import main
from relmogen.experiments.checkpoints import latest_checkpoint
from relmogen.experiments.loading import load_checkpoint


def test_floating_point_entries_are_averaged_and_the_rest_is_the_last_one_s():
    states = [{"w": th.tensor([1.0, 2.0]), "n": th.tensor(3)}, {"w": th.tensor([3.0, 6.0]), "n": th.tensor(5)}]
    averaged = averaged_state(states)
    assert th.equal(averaged["w"], th.tensor([2.0, 4.0])) and averaged["n"].item() == 5


def test_two_kept_checkpoints_average_into_a_new_folder_of_the_run(tiny_sac_run, capsys):
    source = latest_checkpoint(tiny_sac_run)
    checkpoints = tiny_sac_run / "checkpoints"
    shutil.copytree(source, checkpoints / "evaluated_a")
    model, _ = load_checkpoint(source, tiny_sac_run, device="cpu")
    shifted = {key: value + 2.0 if value.is_floating_point() else value for key, value in model.policy.state_dict().items()}
    model.policy.load_state_dict(shifted)
    shutil.copytree(source, checkpoints / "evaluated_b")
    model.save(checkpoints / "evaluated_b" / "model.zip")
    assert main(["analyse", "average-checkpoints", str(tiny_sac_run), "evaluated_a", "evaluated_b",
                 "--name", "swa"]) == 0
    out = checkpoints / "swa"
    assert capsys.readouterr().out.strip() == str(out)
    averaged, _ = load_checkpoint(out, tiny_sac_run, device="cpu")
    original, _ = load_checkpoint(checkpoints / "evaluated_a", tiny_sac_run, device="cpu")
    for key, value in averaged.policy.state_dict().items():
        if value.is_floating_point():
            assert th.allclose(value, original.policy.state_dict()[key] + 1.0, atol=1e-5), key
    assert json.loads((out / "state.json").read_text())["averaged"] == ["evaluated_a", "evaluated_b"]
    with pytest.raises(ValueError, match="exists"):
        average_checkpoints(tiny_sac_run, ["evaluated_a"], "swa")
    with pytest.raises(ValueError, match="no model.zip"):
        average_checkpoints(tiny_sac_run, ["missing"], "other")
