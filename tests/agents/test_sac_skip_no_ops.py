"""relmogen-r's test-time rule ``--skip-no-ops`` (``sample_after_no_ops`` in
``relmogen/agents/addons/skip_no_ops.py``): the mean, except right after an unchanged view."""

import numpy as np

from relmogen.agents.addons.skip_no_ops import sample_after_no_ops


class RecordingModel:
    """Stands in for an SB3 model: records whether each call was deterministic."""

    def __init__(self):
        self.calls: list[bool] = []

    def predict(self, obs, deterministic=False):
        self.calls.append(deterministic)
        return np.zeros(2), None


def observation(value: int) -> dict:
    return {"rgb": np.full((3, 4, 4), value, dtype=np.uint8), "task_obs": np.zeros(3, dtype=np.float32)}


def test_samples_only_right_after_a_step_that_left_the_view_unchanged():
    model = RecordingModel()
    act = sample_after_no_ops(model)
    for value in (0, 0, 0, 1, 2, 2):
        act(observation(value))
    assert model.calls == [True, False, False, True, True, False]


def test_reset_forgets_the_previous_view():
    model = RecordingModel()
    act = sample_after_no_ops(model)
    act(observation(0))
    act.reset()
    act(observation(0))
    assert model.calls == [True, True]


def test_only_the_view_counts_not_the_task_vector():
    model = RecordingModel()
    act = sample_after_no_ops(model)
    first, second = observation(0), observation(0)
    second["task_obs"] += 1.0
    act(first)
    act(second)
    assert model.calls == [True, False]
