"""Saved evaluations of one checkpoint, as ``relmogen export`` records them in provenance.json."""

import json

from relmogen.experiments.evaluate import checkpoint_evaluations


def save_evaluation(run, name: str, checkpoint: str, episodes: int, success_rate: float) -> None:
    (run / "eval" / name).write_text(json.dumps({"checkpoint": checkpoint, "episodes": episodes,
                                                 "success_rate": success_rate}))


def test_only_the_checkpoints_own_evaluations_most_episodes_first(tmp_path):
    (tmp_path / "eval").mkdir()
    save_evaluation(tmp_path, "a.json", "best_0000500", 50, 0.70)
    save_evaluation(tmp_path, "b.json", "best_0000500", 100, 0.78)
    save_evaluation(tmp_path, "c.json", "episode_0001000", 100, 0.18)
    found = checkpoint_evaluations(tmp_path, "best_0000500")
    assert [(e["episodes"], e["success_rate"]) for e in found] == [(100, 0.78), (50, 0.70)]


def test_a_run_never_evaluated_has_none(tmp_path):
    assert checkpoint_evaluations(tmp_path, "episode_0000020") == []
